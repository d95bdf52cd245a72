"""Atomic batches: all of it or none of it, and one change for watchers."""

from __future__ import annotations

import threading

import pytest

import slate

from .conftest import run_with_timeout


def test_batch_commits_when_the_block_ends(board: slate.Board) -> None:
    watch = board.watch("gsr", timeout=0.5)
    with board.batch() as tx:
        tx.write("gsr", "speed", 2.0)
        tx.write("gsr", "mode", "moving")
        assert len(tx) == 2
        assert board.read("gsr", "speed").value == 0.0  # not applied yet
    assert tx.revision == board.revision
    assert board.read("gsr", "speed").value == 2.0
    change = watch.get()
    assert change is not None and change.revision == tx.revision
    assert [(i.kind, i.attr) for i in change.items] == [("write", "speed"), ("write", "mode")]
    assert watch.get(timeout=0.05) is None


def test_exception_leaving_the_block_applies_nothing(board: slate.Board) -> None:
    before = board.revision
    with pytest.raises(RuntimeError, match="abort"):
        with board.batch() as tx:
            tx.write("gsr", "speed", 2.0)
            tx.create("Obstacle", "rock")
            raise RuntimeError("abort")
    assert board.revision == before
    assert board.read("gsr", "speed").value == 0.0
    assert "rock" not in board


def test_failing_operation_raises_its_error_with_index_and_applies_nothing(
    board: slate.Board,
) -> None:
    before = board.revision
    with pytest.raises(slate.ValueTypeError, match="batch operation 2") as caught:
        with board.batch() as tx:
            tx.create("Obstacle", "rock")
            tx.write("rock", "range", 3.0)
            tx.write("gsr", "speed", "fast")
    assert caught.value.index == 2  # type: ignore[attr-defined]
    assert board.revision == before
    assert "rock" not in board
    with pytest.raises(slate.UnknownObjectError) as missing:
        with board.batch() as tx:
            tx.write("gsr", "speed", 1.0)
            tx.write("ghost", "speed", 1.0)
    assert missing.value.index == 1  # type: ignore[attr-defined]
    assert board.read("gsr", "speed").value == 0.0


def test_batch_converts_ints_for_objects_it_creates(board: slate.Board) -> None:
    with board.batch() as tx:
        tx.create("Obstacle", "rock", context="surroundings")
        tx.write("rock", "range", 3)
        tx.write("Obstacle", "clearance", 2)
        tx.write("gsr", "count", 4)
    assert board.read("rock", "range").value == 3.0
    assert board.read("rock", "clearance").value == 2.0
    assert board.read("gsr", "count").value == 4


def test_batch_without_with_and_after_commit(board: slate.Board) -> None:
    tx = board.batch()
    tx.write("gsr", "speed", 1.0)
    tx.delete("r2")
    rev = tx.commit()
    assert rev == board.revision and "r2" not in board
    with pytest.raises(slate.SlateError, match="batch is over"):
        tx.write("gsr", "speed", 2.0)
    with pytest.raises(slate.SlateError, match="batch is over"):
        tx.commit()
    discarded = board.batch()
    discarded.write("gsr", "speed", 3.0)
    discarded.discard()
    assert board.read("gsr", "speed").value == 1.0


def test_concurrent_batches_from_threads_each_arrive_whole(board: slate.Board) -> None:
    watch = board.watch("gsr", timeout=1.0)

    def writer(offset: int) -> None:
        for i in range(100):
            with board.batch() as tx:
                tx.write("gsr", "speed", float((offset + i) % 10))
                tx.write("gsr", "count", (offset + i) % 10)

    def both() -> None:
        threads = [threading.Thread(target=writer, args=(k,)) for k in (0, 5)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()

    run_with_timeout(both)
    changes = watch.drain()
    assert len(changes) == 200
    for change in changes:
        speed, count = (i.packet.value for i in change.items if i.packet is not None)
        assert speed == count
