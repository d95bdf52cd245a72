"""A plan's object tells the truth: only its engine writes it, and loads are all-or-nothing."""

from __future__ import annotations

import pytest

import slate

WORLD = """
class Vehicle { speed: real [m/s] = 0.0; mode: string = "auto"; }
object gsr : Vehicle context self;
plan q {
    trigger: gsr.speed > 5.0;
    action { set gsr.speed = 5.0; }
}
"""


def test_a_write_to_a_plan_objects_state_is_refused_and_the_plan_keeps_acting() -> None:
    b = slate.Board(clock="manual")
    b.load(WORLD)
    with pytest.raises(slate.WriteError, match="plan engine"):
        b.write("q", "state", "terminated")
    with pytest.raises(slate.WriteError, match="plan engine"):
        b.write("q", "fired", 3)
    assert b.read("q", "state").value == "active"
    b.write("gsr", "speed", 8.0)
    assert b.read("gsr", "speed").value == 5.0
    assert b.plan("q").fired == 1 and b.read("q", "fired").value == 1


def test_cancelling_goes_through_the_engine_and_the_object_says_so() -> None:
    b = slate.Board(clock="manual")
    b.load(WORLD)
    with pytest.raises(slate.WriteError):
        b.write("q", "state", "cancelled")
    assert b.plan("q").cancel()
    assert b.read("q", "state").value == "cancelled"
    b.write("gsr", "speed", 8.0)
    assert b.read("gsr", "speed").value == 8.0


def test_a_failed_load_applies_nothing_and_names_the_value() -> None:
    b = slate.Board(clock="manual")
    bad = "class A { x: real in 0 .. 1; }\nobject o : A { x = 5.0; }"
    with pytest.raises(slate.LoadError, match=r":2:20: error: x: value 5\.0 is outside"):
        b.load(bad)
    b.load("class A { x: real in 0 .. 1; }\nobject o : A { x = 0.5; }")
    assert b.read("o", "x").value == 0.5
