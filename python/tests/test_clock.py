"""The manual and system clocks."""

from __future__ import annotations

import time

import pytest

import slate


def test_manual_clock_moves_only_when_told() -> None:
    clock = slate.Clock("manual")
    assert clock.is_manual
    start = clock.now()
    assert start == 1767225600.0  # 2026-01-01T00:00:00Z
    clock.advance(2.5)
    assert clock.now() == pytest.approx(start + 2.5)
    clock.set(start + 10)
    assert clock.now() == pytest.approx(start + 10)
    with pytest.raises(slate.ClockError):
        clock.set(start)  # never backwards
    with pytest.raises(slate.ClockError, match="only moves forward"):
        clock.advance(-1.0)


def test_system_clock_follows_wall_time_and_cannot_be_moved() -> None:
    clock = slate.Clock()
    assert not clock.is_manual
    assert abs(clock.now() - time.time()) < 5.0
    with pytest.raises(slate.ClockError):
        clock.advance(1.0)


def test_boards_can_share_a_clock() -> None:
    clock = slate.Clock("manual")
    a = slate.Board(clock=clock)
    b = slate.Board(clock=a.clock)
    clock.advance(3.0)
    assert a.clock.now() == b.clock.now() == clock.now()
    with pytest.raises(slate.ClockError, match="unknown clock"):
        slate.Board(clock="sundial")  # type: ignore[arg-type]


def test_writes_are_stamped_by_the_board_clock(board: slate.Board) -> None:
    board.clock.advance(1.0)
    board.write("gsr", "speed", 1.0)
    first = board.read("gsr", "speed").timestamp
    board.clock.advance(0.5)
    board.write("gsr", "speed", 2.0)
    assert board.read("gsr", "speed").timestamp == pytest.approx(first + 0.5)


def test_moving_the_clock_past_what_a_timestamp_holds_is_refused() -> None:
    clock = slate.Clock("manual")
    start = clock.now()
    with pytest.raises(slate.ClockError, match="2112"):
        clock.advance(5e9)
    with pytest.raises(slate.ClockError, match="2112"):
        clock.set(5e9)
    with pytest.raises(slate.ClockError):
        clock.set(1e300)
    assert clock.now() == start


def test_a_timestamp_past_what_a_stamp_holds_is_refused(board: slate.Board) -> None:
    with pytest.raises(slate.InvalidPacketError, match="2112"):
        board.write("gsr", "speed", 1.0, timestamp=5e9)
    with pytest.raises(slate.InvalidPacketError, match="2112"):
        slate.Packet(1.0, timestamp=5e9)
    assert board.read("gsr", "speed").value == 0.0


def test_stamps_order_writes_made_at_one_instant(board: slate.Board) -> None:
    stamps = []
    for v in range(5):
        board.write("gsr", "count", v)
        p = board.read("gsr", "count")
        assert p.timestamp == 1767225600.0  # the clock did not move
        stamps.append(p.stamp)
    assert stamps == sorted(stamps) and len(set(stamps)) == 5
    # The stamp holds the seconds too: microseconds in the high bits, a counter below.
    assert stamps[0] >> 12 == 1767225600 * 1_000_000
    board.clock.advance(0.5)
    board.write("gsr", "count", 9)
    assert board.read("gsr", "count").stamp > stamps[-1]
    assert board.read("r2", "count").stamp == 0  # never written
