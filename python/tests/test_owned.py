"""Writes every other board would refuse are refused where they are made."""

from __future__ import annotations

import pytest

import slate

WORLD = """
class Vehicle { heading: real merge owned; speed: real; }
object gsr : Vehicle owner "team/r1/nav";
"""


def board_at(address: str) -> slate.Board:
    board = slate.Board(clock="manual", address=address)
    board.load(WORLD)
    return board


def test_a_non_owner_write_to_an_owned_attribute_raises_and_stores_nothing() -> None:
    board = board_at("team/r2/nav")
    with pytest.raises(slate.WriteError, match=r"gsr.heading is owned by team/r1/nav"):
        board.write("gsr", "heading", 1.0)
    assert board.read("gsr", "heading").value is None
    board.write("gsr", "speed", 1.0)  # not owned: anyone may write it
    board_at("team/r1/nav").write("gsr", "heading", 1.0)


def test_a_non_owner_write_fails_a_whole_batch() -> None:
    board = board_at("team/r2/nav")
    with pytest.raises(slate.SlateError, match="owned by team/r1/nav"):
        with board.batch() as b:
            b.write("gsr", "speed", 1.0)
            b.write("gsr", "heading", 1.0)
    assert board.read("gsr", "speed").value is None


def test_an_own_write_older_than_the_stored_packet_raises() -> None:
    board = board_at("team/r1/nav")
    board.write("gsr", "speed", 1.0)
    old = board.clock.now() - 100.0
    with pytest.raises(slate.WriteError, match="older than the stored packet"):
        board.write("gsr", "speed", 2.0, timestamp=old)
    assert board.read("gsr", "speed").value == 1.0
