"""Loading .slate sources, plans, the manual clock's deadlines, and what plans send out."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

import slate

VEHICLES = """
class Vehicle {
    position: vec<2> [m];
    speed: real [m/s] = 0.0;
    mode: string = "auto";
}
class Obstacle { position: vec<2> [m]; }
object gsr : Vehicle context self;
"""


def vehicles(plans: str = "") -> slate.Board:
    b = slate.Board(clock="manual", address="team/r1/exec")
    b.load(VEHICLES + plans)
    return b


def test_load_a_path_a_pathlike_or_source_text(world_file: Path) -> None:
    by_path = slate.Board()
    loaded = by_path.load(str(world_file))
    assert loaded.classes == ["Vehicle", "Rover", "Obstacle"]
    assert loaded.objects == ["gsr", "r2"] and loaded.plans == [] and loaded.rules == 0
    by_pathlike = slate.Board()
    assert by_pathlike.load(world_file).objects == ["gsr", "r2"]
    by_text = slate.Board()
    assert by_text.load(world_file.read_text()).objects == ["gsr", "r2"]
    one_line = slate.Board()
    assert one_line.load("class A { x: real; }").classes == ["A"]


def test_a_missing_file_raises_file_not_found(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError) as e:
        slate.Board().load(tmp_path / "nowhere.slate")
    assert e.value.filename == str(tmp_path / "nowhere.slate")
    with pytest.raises(TypeError, match="source text"):
        slate.Board().load(42)  # type: ignore[arg-type]


def test_a_syntax_error_raises_load_error_with_line_and_column() -> None:
    b = slate.Board()
    source = "class Vehicle {\n    speed: real [m/s]\n}\n"
    with pytest.raises(slate.LoadError) as caught:
        b.load(source, name="world.slate")
    e = caught.value
    assert (e.file, e.line, e.column) == ("world.slate", 2, 22)
    assert str(e) == (
        "world.slate:2:22: error: expected `;` after attribute declaration, found `}`\n"
        "  2 |     speed: real [m/s]\n"
        "    |                      ^"
    )
    [d] = e.diagnostics
    assert (d.file, d.line, d.column, d.stage, d.severity) == (
        "world.slate", 2, 22, "parse", "error"
    )
    assert str(d).startswith("world.slate:2:22: error: expected `;`")
    assert b.info("Vehicle") is None  # nothing applied


def test_a_deep_operator_chain_is_refused_with_the_limit_not_a_crash() -> None:
    # Issue 17: a trigger of 100 000 additions aborted the process (a stack overflow).
    b = vehicles()
    chain = "gsr.speed" + " + 1.0" * 99_999
    with pytest.raises(slate.LoadError) as caught:
        b.load(f"plan p {{\n  trigger: {chain} > 0.0;\n  action {{ }}\n}}", name="deep.slate")
    e = caught.value
    assert (e.file, e.line) == ("deep.slate", 2)
    assert "at most 64 levels" in str(e)
    assert len(str(e)) < 2_000  # a window of the line is quoted, not all of it
    assert b.info("p") is None


def test_errors_in_a_file_are_all_reported_with_their_positions(world_file: Path) -> None:
    world_file.write_text("class A { x: real }\nclass B { y: int }\n")
    with pytest.raises(slate.LoadError) as caught:
        slate.Board().load(world_file)
    e = caught.value
    assert e.file == str(world_file)
    assert [(d.line, d.column) for d in e.diagnostics] == [(1, 19), (2, 18)]


def test_a_checker_error_names_the_unknown_thing() -> None:
    source = "plan p {\n  trigger: gsr.altitude > 1.0;\n  action { set gsr.mode = \"x\"; }\n}\n"
    with pytest.raises(slate.LoadError, match="Vehicle has no attribute altitude") as caught:
        vehicles(source)
    e = caught.value
    assert (e.line, e.column) == (VEHICLES.count("\n") + 2, 16)
    assert e.diagnostics[0].stage == "check"


def test_plan_status_follows_the_plan() -> None:
    b = vehicles(
        """
        plan slow_down {
            initiation: gsr.mode == "auto";
            trigger: gsr.speed > 5.0;
            termination: gsr.mode == "manual";
            action { set gsr.speed = 5.0; }
        }
        """
    )
    plan = b.plan("slow_down")
    assert (plan.name, plan.state, plan.fired, plan.last_error) == ("slow_down", "active", 0, None)
    b.write("gsr", "speed", 8)
    assert b.read("gsr", "speed").value == 5.0
    assert plan.fired == 1
    b.write("gsr", "mode", "manual")
    assert plan.state == "terminated"
    b.write("gsr", "speed", 9.0)
    assert plan.fired == 1 and b.read("gsr", "speed").value == 9.0
    assert [p.name for p in b.plans()] == ["slow_down"]
    assert b.read("slow_down", "state").value == "terminated"  # plans are objects
    with pytest.raises(slate.UnknownObjectError, match="no plan named nope"):
        b.plan("nope")


AGE_PLANS = """
plan position_lost {
    trigger: age(gsr.position) > 2s;
    action { set gsr.mode = "lost"; }
}
plan position_old {
    trigger: age(gsr.position) >= 2s;
    action { set gsr.speed = 0.0; }
}
"""


def test_an_age_plan_fires_exactly_when_its_deadline_passes() -> None:
    b = vehicles(AGE_PLANS)
    b.write("gsr", "speed", 3.0)
    b.write("gsr", "position", [0.0, 0.0])
    lost, old = b.plan("position_lost"), b.plan("position_old")
    b.clock.advance(1.999)
    assert (lost.fired, old.fired) == (0, 0)
    b.clock.advance(0.002)  # 2.001 s: the timer fired, nothing polled
    assert (lost.fired, old.fired) == (1, 1)
    assert b.read("gsr", "mode").value == "lost"
    assert b.read("gsr", "speed").value == 0.0
    # A fresh position re-arms it: the next deadline is 2 s after the new write.
    b.write("gsr", "position", [1.0, 0.0])
    b.clock.advance(1.5)
    assert lost.fired == 1
    b.clock.advance(0.501)
    assert lost.fired == 2


def test_at_exactly_the_deadline_ge_holds_and_gt_does_not_yet() -> None:
    b = vehicles(AGE_PLANS)
    b.write("gsr", "position", [0.0, 0.0])
    b.clock.advance(2.0)
    assert (b.plan("position_lost").fired, b.plan("position_old").fired) == (0, 1)


def test_a_gt_age_plan_fires_after_the_clock_stopped_exactly_on_its_deadline() -> None:
    b = vehicles(AGE_PLANS)
    b.write("gsr", "position", [0.0, 0.0])
    b.clock.advance(2.0)
    b.clock.advance(0.5)
    assert b.plan("position_lost").fired == 1


def test_plan_events_report_progress() -> None:
    b = slate.Board(clock="manual")
    events = b.plan_events()
    b.load(
        VEHICLES
        + """
        plan stop {
            initiation: gsr.mode == "auto";
            trigger: gsr.speed > 5.0;
            termination: gsr.mode == "manual";
            action { set gsr.speed = 0.0; }
        }
        """
    )
    b.write("gsr", "speed", 6.0)
    b.write("gsr", "mode", "manual")
    got = [(e.kind, e.plan, e.fired) for e in events.drain()]
    assert got == [
        ("installed", "stop", None),
        ("initiated", "stop", None),
        ("triggered", "stop", 1),
        ("terminated", "stop", None),
    ]


def test_a_failing_action_is_recorded_and_applies_nothing() -> None:
    b = slate.Board(clock="manual")
    b.load(
        """
        class Vehicle { speed: real = 0.0; mode: string = "auto"; nearest: ref; }
        object gsr : Vehicle;
        plan bad {
            trigger: gsr.speed > 5.0;
            action { set gsr.mode = "fast", gsr.nearest.speed = 0.0; }
        }
        """
    )
    b.write("gsr", "nearest", slate.Ref("ghost"))  # dangling: the action fails at run time
    b.write("gsr", "speed", 6.0)
    plan = b.plan("bad")
    assert plan.fired == 0  # fired counts the actions that committed
    assert plan.last_error is not None and "ghost" in plan.last_error
    assert b.read("gsr", "mode").value == "auto"


def test_reports_and_sent_plans_go_to_the_outbox() -> None:
    b = slate.Board(clock="manual", address="team/r1/exec")
    outbox = b.outgoing()
    b.load(
        VEHICLES
        + """
        plan stop_near_obstacle {
            trigger: any o: Obstacle where distance(o.position, gsr.position) < 5.0;
            action {
                set gsr.speed = 0.0;
                report gsr.speed to "team/base/console";
                report o;
                send plan resume { trigger: gsr.mode == "auto"; action { set gsr.speed = 1.0; } }
                    to "team/r1/loco";
            }
        }
        """
    )
    b.write("gsr", "position", [0.0, 0.0])
    b.create("Obstacle", "rock")
    b.write("rock", "position", [3, 3])
    first, second, third = outbox.drain()
    assert isinstance(first, slate.Report) and first.origin == "stop_near_obstacle"
    assert first.to == "team/base/console"
    [item] = first.items
    assert (item.object, item.attr, item.packet.value) == ("gsr", "speed", 0.0)
    assert isinstance(second, slate.Report) and second.to is None
    assert [(i.object, i.attr, i.packet.value) for i in second.items] == [
        ("rock", "position", (3.0, 3.0))
    ]
    assert isinstance(third, slate.PlanMessage)
    assert (third.name, third.to, third.origin) == ("resume", "team/r1/loco", "stop_near_obstacle")
    assert third.text.startswith("plan resume")
    assert outbox.get(timeout=0.01) is None


def test_cancel_stops_a_plan() -> None:
    b = vehicles("plan p { trigger: gsr.speed > 1.0; action { set gsr.mode = \"fast\"; } }")
    plan = b.plan("p")
    assert plan.cancel()
    assert plan.state == "cancelled"
    b.write("gsr", "speed", 2.0)
    assert plan.fired == 0


def test_loading_a_conflicting_class_changes_nothing() -> None:
    b = vehicles()
    with pytest.raises(slate.LoadError, match="already defined differently"):
        b.load("class Vehicle { speed: int; }\nobject other : Vehicle;")
    assert "other" not in b


def test_rules_written_in_slate_and_python_functions_work_together() -> None:
    b = vehicles("on write gsr.speed { set gsr.mode = \"moving\"; }")
    seen: list[object] = []
    b.on_write("Vehicle", "mode", lambda call: seen.append(call.packet.value))
    b.write("gsr", "speed", 1.0)
    assert b.read("gsr", "mode").value == "moving"
    assert seen == ["moving"]


def test_on_the_system_clock_deadlines_fire_by_themselves() -> None:
    b = slate.Board()  # system clock: the engine runs a timer thread
    b.load(VEHICLES + 'plan lost { trigger: age(gsr.position) > 0.05s; action { set gsr.mode = "lost"; } }')
    b.write("gsr", "position", [0.0, 0.0])
    plan = b.plan("lost")
    deadline = time.monotonic() + 10.0
    while plan.fired == 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert plan.fired == 1
    assert b.read("gsr", "mode").value == "lost"
