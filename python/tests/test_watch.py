"""Watching changes: filters, timeouts, iteration, threads."""

from __future__ import annotations

import threading
import time

import pytest

import slate

from .conftest import run_with_timeout


def test_watch_a_class_sees_its_instances_and_subclasses(board: slate.Board) -> None:
    watch = board.watch("Vehicle", timeout=0.2)
    board.write("gsr", "speed", 1.0)
    board.write("r2", "speed", 2.0)
    board.create("Obstacle", "rock")  # another class: not seen
    board.write("rock", "range", 3.0)
    changes = list(watch)  # stops after 0.2 s without a change
    assert [(c.items[0].object, c.items[0].attr) for c in changes] == [
        ("gsr", "speed"),
        ("r2", "speed"),
    ]
    item = changes[0].items[0]
    assert item.kind == "write" and item.packet is not None and item.packet.value == 1.0
    assert changes[0].revision < changes[1].revision


def test_watch_an_object_and_an_attribute(board: slate.Board) -> None:
    speed_of_gsr = board.watch("gsr", "speed", timeout=0.1)
    any_mode = board.watch(attr="mode", timeout=0.1)
    board.write("gsr", "speed", 1.0)
    board.write("gsr", "mode", "manual")
    board.write("r2", "mode", "manual")
    board.write("Vehicle", "speed", 3.0)  # class level: changes what gsr reads
    assert [(i.object, i.attr) for c in speed_of_gsr for i in c.items] == [
        ("gsr", "speed"),
        ("Vehicle", "speed"),
    ]
    assert [i.object for c in any_mode for i in c.items] == ["gsr", "r2"]


def test_creations_and_deletions_are_changes(board: slate.Board) -> None:
    watch = board.watch(timeout=0.1)
    board.create("Obstacle", "rock")
    board.delete("rock")
    items = [i for c in watch for i in c.items]
    assert [(i.kind, i.object, i.class_name, i.attr, i.packet) for i in items] == [
        ("create", "rock", "Obstacle", None, None),
        ("delete", "rock", "Obstacle", None, None),
    ]


def test_get_with_timeout_returns_none_when_nothing_comes(board: slate.Board) -> None:
    watch = board.watch("gsr")
    start = time.monotonic()
    assert watch.get(timeout=0.15) is None
    assert time.monotonic() - start >= 0.14
    assert watch.pending == 0
    board.write("gsr", "speed", 1.0)
    assert watch.pending == 1
    change = watch.get(timeout=0)
    assert change is not None and change.items[0].attr == "speed"


def test_a_backlog_is_taken_whole_in_order_then_the_watch_waits(board: slate.Board) -> None:
    """Changes already waiting are taken without waiting (nor letting go of the GIL),
    each once, in revision order, by iteration, `get` and `drain` alike; then the watch
    waits again for the next."""
    watch = board.watch("gsr", "speed", timeout=0.1)
    revisions = [board.write("gsr", "speed", i / 100) for i in range(1000)]
    assert watch.pending == 1000
    first = watch.get(timeout=0)
    assert first is not None
    middle = [next(watch) for _ in range(498)]
    rest = watch.drain()
    changes = [first, *middle, *rest]
    assert [c.revision for c in changes] == revisions
    packets = [c.items[0].packet for c in changes]
    assert [p.value if p is not None else None for p in packets] == [i / 100 for i in range(1000)]
    assert watch.pending == 0 and watch.get(timeout=0) is None
    board.write("gsr", "speed", 10.0)
    later = watch.get(timeout=1.0)
    assert later is not None
    packet = later.items[0].packet
    assert packet is not None and packet.value == 10.0


def test_a_blocked_watch_releases_the_gil_for_writers(board: slate.Board) -> None:
    """The main thread waits in the watch while another Python thread writes."""
    watch = board.watch("gsr", "speed", timeout=5.0)

    def writer() -> None:
        for i in range(5):
            time.sleep(0.01)
            board.write("gsr", "speed", float(i))

    def read_five() -> None:
        t = threading.Thread(target=writer)
        t.start()
        seen = []
        for change in watch:
            seen.append(change.items[0].packet.value if change.items[0].packet else None)
            if len(seen) == 5:
                break
        t.join()
        assert seen == [0.0, 1.0, 2.0, 3.0, 4.0]

    run_with_timeout(read_five)


def test_closing_a_watch_ends_iteration(board: slate.Board) -> None:
    with board.watch("gsr") as watch:
        board.write("gsr", "speed", 1.0)
    assert watch.get(timeout=0.01) is None
    assert list(watch) == []
    assert watch.drain() == []


def test_closing_from_another_thread_wakes_the_iterator(board: slate.Board) -> None:
    watch = board.watch("gsr")  # no timeout: waits until closed

    def close_soon() -> None:
        time.sleep(0.05)
        watch.close()

    def iterate() -> None:
        threading.Thread(target=close_soon).start()
        assert list(watch) == []

    run_with_timeout(iterate)


def test_watching_unknown_names_raises(board: slate.Board) -> None:
    with pytest.raises(slate.UnknownObjectError):
        board.watch("ghost")
    with pytest.raises(slate.UnknownAttributeError):
        board.watch("gsr", "altitude")
