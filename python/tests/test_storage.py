"""On disk: a node's board kept across a restart (`state=`), a node recording its board
(`record=`), and `slate.Recording` reading the file back as packets and events."""

from __future__ import annotations

from pathlib import Path

import pytest

import slate

from .conftest import free_endpoint

WORLD = """
class Vehicle {
    speed: real [m/s] in 0 .. 10 = 0.0;
    mode: string = "auto";
}
"""


def nav_board() -> slate.Board:
    board = slate.Board(address="t/r1/nav")
    board.load(WORLD + "object gsr : Vehicle context self;")
    return board


def test_a_node_with_state_comes_back_with_its_board(tmp_path: Path) -> None:
    state = tmp_path / "nav-state"
    board = nav_board()
    with slate.Node("t/r1/nav", board, listen=[free_endpoint()], state=state) as node:
        assert node.restored == {"objects": 0, "packets": 0, "refused": 0}
        board.create("Vehicle", "probe")
        board.write("probe", "speed", 4.5, accuracy=0.25)
        board.write("gsr", "mode", "manual")
    written = board.read("probe", "speed")

    again = nav_board()
    with slate.Node("t/r1/nav", again, listen=[free_endpoint()], state=str(state)) as node:
        assert node.restored == {"objects": 1, "packets": 2, "refused": 0}
        back = again.read("probe", "speed")
        assert (back.value, back.accuracy, back.stamp, back.source) == (
            4.5,
            written.accuracy,
            written.stamp,
            "t/r1/nav",
        )
        assert again.read("gsr", "mode").value == "manual"


def test_a_node_without_state_says_nothing_was_restored() -> None:
    with slate.Node("t/r1/nav", nav_board(), listen=[free_endpoint()]) as node:
        assert node.restored is None


def test_a_damaged_state_directory_is_a_node_error_naming_it(tmp_path: Path) -> None:
    state = tmp_path / "damaged"
    state.mkdir()
    (state / "board.redb").write_bytes(b"\x5a" * 4096)
    with pytest.raises(slate.NodeError) as e:
        slate.Node("t/r1/nav", nav_board(), listen=[free_endpoint()], state=state)
    assert str(state) in str(e.value)
    assert "--reset-state" in str(e.value)


def test_a_recording_reads_back_as_packets_and_events(tmp_path: Path) -> None:
    path = tmp_path / "nav.mcap"
    board = nav_board()
    with slate.Node("t/r1/nav", board, listen=[free_endpoint()], record=path):
        board.create("Vehicle", "probe")
        board.write("probe", "speed", 4.5, accuracy=0.25)
        board.write("probe", "speed", 5.5)
    recording = slate.Recording(path)
    assert recording.complete
    assert recording.address == "t/r1/nav"
    assert len(recording) == len(list(recording))

    speeds = [p for p in recording.packets() if p.object == "probe" and p.attr == "speed"]
    assert [p.value for p in speeds] == [4.5, 5.5]
    first = speeds[0]
    assert (first.accuracy, first.source) == (0.25, "t/r1/nav")
    assert first.stamp < speeds[1].stamp
    assert first.time > 0.0 and first.timestamp > 0.0

    events = list(recording.events())
    assert all(isinstance(e, slate.RecordedEvent) for e in events)
    created = [e.data for e in events if e.kind == "objects" and e.data["op"] == "create"]
    assert {"op": "create", "object": "probe", "class": "Vehicle"}.items() <= created[0].items()
    classes = [e.data["name"] for e in events if e.kind == "classes"]
    assert "Vehicle" in classes
    assert {e.kind for e in events} <= {
        "objects",
        "classes",
        "plans",
        "circuits",
        "liveliness",
        "events",
        "links",
        "recorder",
    }


def test_a_recording_that_cannot_be_read_says_why(tmp_path: Path) -> None:
    with pytest.raises(OSError):
        slate.Recording(tmp_path / "missing.mcap")
    text = tmp_path / "notes.mcap"
    text.write_text("not a recording")
    with pytest.raises(ValueError, match="not an MCAP recording"):
        slate.Recording(text)
