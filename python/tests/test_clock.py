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
