"""Reading, writing, creating and querying a board; values and their conversion."""

from __future__ import annotations

import math

import pytest

import slate


def test_write_then_read_returns_the_packet(board: slate.Board) -> None:
    rev = board.write("gsr", "speed", 2.5, accuracy=0.1, confidence=0.9)
    p = board.read("gsr", "speed")
    assert (p.value, p.accuracy, p.confidence) == (2.5, 0.1, 0.9)
    assert p.source == "team/r1/nav"
    assert p.timestamp == pytest.approx(board.clock.now())
    assert rev == board.revision


def test_unwritten_attribute_reads_its_declared_default(board: slate.Board) -> None:
    p = board.read("gsr", "position")
    assert (p.value, p.accuracy, p.confidence) == ((0.0, 0.0), 100.0, 0.0)
    assert board.read("gsr", "target").value is None


def test_int_written_to_a_real_attribute_is_stored_as_a_float(board: slate.Board) -> None:
    board.write("gsr", "speed", 2)
    value = board.read("gsr", "speed").value
    assert value == 2.0 and isinstance(value, float)


def test_int_attribute_keeps_ints(board: slate.Board) -> None:
    board.write("gsr", "count", 7)
    value = board.read("gsr", "count").value
    assert value == 7 and isinstance(value, int)


def test_every_value_type_round_trips(board: slate.Board) -> None:
    board.write("gsr", "mode", "manual")
    board.write("gsr", "alive", False)
    board.write("gsr", "target", slate.Ref("r2"))
    board.write("gsr", "position", [1, 2.5])
    board.write("r2", "position", (3.0, 4.0))
    assert board.read("gsr", "mode").value == "manual"
    assert board.read("gsr", "alive").value is False
    assert board.read("gsr", "target").value == slate.Ref("r2")
    assert board.read("gsr", "position").value == (1.0, 2.5)
    assert board.read("r2", "position").value == (3.0, 4.0)


def test_ref_is_a_hashable_name() -> None:
    r = slate.Ref("gsr")
    assert r.name == "gsr" and str(r) == "gsr" and repr(r) == "Ref('gsr')"
    assert {r, slate.Ref("gsr")} == {r}
    assert r != slate.Ref("r2")


def test_explicit_timestamp_and_source_are_kept(board: slate.Board) -> None:
    t = board.clock.now() - 1.5
    board.write("gsr", "speed", 1.0, timestamp=t, source="team/r2/nav")
    p = board.read("gsr", "speed")
    assert p.timestamp == pytest.approx(t)
    assert p.source == "team/r2/nav"


def test_wrong_type_raises_value_type_error(board: slate.Board) -> None:
    with pytest.raises(slate.ValueTypeError, match=r"gsr.speed: expected a value of type real"):
        board.write("gsr", "speed", "fast")
    with pytest.raises(TypeError):  # ValueTypeError is also a TypeError
        board.write("gsr", "count", 1.5)
    with pytest.raises(slate.ValueTypeError, match="vec<2>"):
        board.write("gsr", "position", [1.0, 2.0, 3.0])
    assert board.read("gsr", "speed").value == 0.0


def test_values_python_cannot_store_raise_value_type_error(board: slate.Board) -> None:
    with pytest.raises(slate.ValueTypeError, match="cannot store a dict"):
        board.write("gsr", "speed", {"x": 1})  # type: ignore[arg-type]
    with pytest.raises(slate.ValueTypeError, match="holds numbers only"):
        board.write("gsr", "position", ["a", "b"])  # type: ignore[list-item]
    with pytest.raises(slate.ValueTypeError, match="64 bits"):
        board.write("gsr", "count", 2**70)


def test_unknown_object_attribute_and_class_raise(board: slate.Board) -> None:
    with pytest.raises(slate.UnknownObjectError, match="no object named ghost"):
        board.write("ghost", "speed", 1.0)
    with pytest.raises(slate.UnknownObjectError):
        board.read("ghost", "speed")
    with pytest.raises(LookupError):
        board.read("ghost", "speed")
    with pytest.raises(slate.UnknownAttributeError, match="gsr has no attribute altitude"):
        board.read("gsr", "altitude")
    with pytest.raises(slate.UnknownClassError, match="class Submarine is not defined"):
        board.create("Submarine", "u1")


def test_bad_confidence_and_accuracy_raise_and_store_nothing(board: slate.Board) -> None:
    with pytest.raises(slate.ConfidenceError, match=r"confidence 1.5 must be between 0 and 1"):
        board.write("gsr", "speed", 1.0, confidence=1.5)
    with pytest.raises(slate.AccuracyError, match=r"accuracy -0.1 must be finite and >= 0"):
        board.write("gsr", "speed", 1.0, accuracy=-0.1)
    with pytest.raises(ValueError):  # InvalidPacketError is also a ValueError
        board.write("gsr", "speed", 1.0, confidence=-0.5)
    assert board.read("gsr", "speed").timestamp == 0.0


def test_out_of_bounds_and_non_finite_values_raise(board: slate.Board) -> None:
    with pytest.raises(slate.OutOfBoundsError, match="outside the declared bounds"):
        board.write("gsr", "speed", 11.0)
    with pytest.raises(slate.InvalidPacketError, match="not finite"):
        board.write("gsr", "speed", math.nan)


def test_create_with_context_and_owner(board: slate.Board) -> None:
    board.create("Obstacle", "rock", context="surroundings", owner="team/r1/prox")
    info = board.info("rock")
    assert info is not None
    assert (info.name, info.class_name, info.is_class) == ("rock", "Obstacle", False)
    assert (info.context, info.owner) == ("surroundings", "team/r1/prox")
    assert "rock" in board and "boulder" not in board
    assert board.info("boulder") is None
    vehicle = board.info("Vehicle")
    assert vehicle is not None and vehicle.is_class


def test_create_refuses_taken_and_bad_names(board: slate.Board) -> None:
    with pytest.raises(slate.CreateError, match="gsr already exists"):
        board.create("Vehicle", "gsr")
    with pytest.raises(slate.CreateError, match="not a valid object name"):
        board.create("Vehicle", "2fast")
    with pytest.raises(ValueError, match="unknown context"):
        board.create("Vehicle", "v9", context="elsewhere")  # type: ignore[arg-type]
    with pytest.raises(slate.AddressError):
        board.create("Vehicle", "v9", owner="not an address")


def test_instances_include_subclasses_and_filter_by_context(board: slate.Board) -> None:
    assert board.instances("Vehicle") == ["gsr", "r2"]
    assert board.instances("Rover") == ["r2"]
    assert board.instances("Vehicle", context="system") == ["r2"]
    assert board.instances("Vehicle", owner="team/r1/nav") == ["gsr", "r2"]
    assert board.instances("Obstacle") == []
    with pytest.raises(slate.UnknownClassError):
        board.instances("Submarine")


def test_class_level_write_reaches_every_instance(board: slate.Board) -> None:
    board.create("Obstacle", "o1")
    board.create("Obstacle", "o2")
    board.write("o2", "clearance", 0.5)
    board.write("Obstacle", "clearance", 2)
    assert board.read("o1", "clearance").value == 2.0
    assert board.read("o2", "clearance").value == 0.5


def test_delete_leaves_references_dangling(board: slate.Board) -> None:
    board.write("gsr", "target", slate.Ref("r2"))
    board.delete("r2")
    assert "r2" not in board
    assert board.read("gsr", "target").value == slate.Ref("r2")
    with pytest.raises(slate.UnknownObjectError):
        board.delete("r2")
    with pytest.raises(slate.DeleteError, match="is a class"):
        board.delete("Vehicle")


def test_define_declares_a_class_from_python() -> None:
    b = slate.Board()
    b.define("Beacon", {"position": "vec<3>", "battery": "real", "id": "int"})
    b.define("Buoy", parent="Beacon")
    b.create("Buoy", "b1")
    b.write("b1", "battery", 1)
    assert b.read("b1", "battery").value == 1.0
    b.define("Beacon", {"position": "vec<3>", "battery": "real", "id": "int"})  # identical
    with pytest.raises(slate.DefineError, match="already defined differently"):
        b.define("Beacon", {"battery": "int"})
    with pytest.raises(slate.DefineError, match="unknown type"):
        b.define("Lamp", {"on": "boolean"})


def test_board_address_and_defaults() -> None:
    b = slate.Board()
    assert b.address == "local/robot/module"
    assert not b.clock.is_manual
    with pytest.raises(slate.AddressError, match="team/robot/module"):
        slate.Board(address="nav")
    with pytest.raises(TypeError):
        slate.Board(clock=3)  # type: ignore[arg-type]


def test_packets_made_in_python_are_checked() -> None:
    p = slate.Packet([1, 2], accuracy=0.5, confidence=0.25)
    assert (p.value, p.accuracy, p.confidence, p.timestamp) == ((1.0, 2.0), 0.5, 0.25, 0.0)
    assert p == slate.Packet((1.0, 2.0), 0.5, 0.25)
    with pytest.raises(slate.ConfidenceError):
        slate.Packet(1.0, confidence=2.0)
    with pytest.raises(slate.AccuracyError):
        slate.Packet(1.0, accuracy=math.inf)


def test_stats_and_dump(board: slate.Board) -> None:
    board.write("gsr", "speed", 1.0)
    s = board.stats()
    assert s["revision"] == board.revision and s["objects"] == 2
    assert s["function_failures"] == 0
    assert "object gsr" in board.dump()
    assert repr(board).startswith("Board(address='team/r1/nav'")


def test_delete_class_removes_an_unused_class(board: slate.Board) -> None:
    board.load("class Puppy : Vehicle { tail: real; }")
    board.create("Puppy", "rex")
    with pytest.raises(slate.SlateError, match="delete_class"):
        board.delete("Puppy")
    with pytest.raises(slate.SlateError, match="instance"):
        board.delete_class("Puppy")
    board.delete("rex")
    board.delete_class("Puppy")
    assert "Puppy" not in board
    with pytest.raises(slate.UnknownObjectError):
        board.delete_class("Puppy")
    with pytest.raises(slate.SlateError, match="subclass"):
        board.delete_class("Vehicle")  # Rover is its subclass
    with pytest.raises(slate.SlateError, match="delete"):
        board.delete_class("gsr")  # an object, not a class
    board.load("class Puppy { tail: int; }")  # the name is free again, for a new definition
    assert board.info("Puppy") is not None


@pytest.mark.parametrize("depth", [-1, 10**30, 129, "8", 2.5])
def test_a_bad_max_depth_is_a_value_error_that_says_what_to_give(depth: object) -> None:
    with pytest.raises((ValueError, TypeError), match="max_depth"):
        slate.Board(max_depth=depth)  # type: ignore[arg-type]


def test_max_depth_accepts_the_documented_range() -> None:
    assert slate.Board(max_depth=0) is not None
    assert slate.Board(max_depth=128) is not None
