//! The plan engine: the truth table of initiation, trigger and termination (docs/language.md,
//! "What a plan does"), repetition, quantifiers with bindings, time, actions and their failures.

use std::sync::Arc;
use std::time::Duration;

use slate_model::{Board, Clock, Value};
use slate_plans::{Engine, Outgoing, PlanEvent, PlanState};

use crate::support::{engine, loaded, refused_after};

pub const SIGNALS: &str = r#"
    class Signal { on: bool = false; level: real = 0.0; }
    class Log { n: int = 0; }
    object init : Signal;
    object trig : Signal;
    object term : Signal;
    object log : Log;
"#;

/// A board with the signals and one plan `p` (`every` optional) that counts in log.n.
pub fn world(every: &str) -> (Arc<Board>, Engine) {
    world_with(&format!(
        "initiation: init.on; trigger: trig.on; termination: term.on; {every}"
    ))
}

/// A board with the signals and one plan `p` with these conditions, counting in log.n
/// (and writing nothing its conditions read).
fn world_with(conditions: &str) -> (Arc<Board>, Engine) {
    let (board, engine) = engine();
    let plan = format!(
        "{SIGNALS}
        plan p {{
            {conditions}
            action {{ set log.n = log.n + 1; }}
        }}"
    );
    engine
        .load("t.slate", &plan)
        .unwrap_or_else(|e| panic!("{e}"));
    (board, engine)
}

fn set(b: &Board, signal: &str, on: bool) {
    b.write(signal, "on", on).unwrap();
}

fn fired(b: &Board, e: &Engine) -> i64 {
    let n = e.status("p").unwrap().fired as i64;
    assert_eq!(
        b.read("log", "n").unwrap().value,
        Value::Int(n),
        "log.n follows the plan's fired count"
    );
    n
}

#[test]
fn plan_fires_when_trigger_follows_initiation() {
    let (b, e) = world("");
    set(&b, "trig", false);
    set(&b, "init", true);
    assert_eq!(fired(&b, &e), 0);
    set(&b, "trig", true);
    assert_eq!(fired(&b, &e), 1);
    set(&b, "trig", true); // still true: no new edge
    assert_eq!(fired(&b, &e), 1);
    set(&b, "trig", false);
    set(&b, "trig", true);
    assert_eq!(fired(&b, &e), 2, "each rising edge fires");
}

#[test]
fn plan_with_trigger_before_initiation_fires_once_initiation_happens() {
    let (b, e) = world("");
    set(&b, "trig", true);
    assert_eq!(fired(&b, &e), 0, "not active yet");
    set(&b, "init", true);
    assert_eq!(
        fired(&b, &e),
        1,
        "a trigger already true when the plan initiates fires at once"
    );
}

#[test]
fn initiation_is_latched() {
    let (b, e) = world("");
    set(&b, "init", true);
    set(&b, "init", false);
    set(&b, "trig", true);
    assert_eq!(fired(&b, &e), 1);
    assert_eq!(e.status("p").unwrap().state, PlanState::Active);
}

#[test]
fn plan_never_fires_when_termination_precedes_initiation() {
    let (b, e) = world("");
    set(&b, "term", true);
    set(&b, "term", false); // latched: turning it off changes nothing
    set(&b, "init", true);
    set(&b, "trig", true);
    assert_eq!(fired(&b, &e), 0);
    assert_eq!(e.status("p").unwrap().state, PlanState::Terminated);
}

#[test]
fn plan_never_fires_when_termination_and_initiation_come_in_the_same_evaluation() {
    let (b, e) = world("");
    set(&b, "trig", true);
    let mut batch = b.batch();
    batch.write("init", "on", true).write("term", "on", true);
    batch.commit().unwrap();
    assert_eq!(fired(&b, &e), 0);
    assert_eq!(e.status("p").unwrap().state, PlanState::Terminated);
}

#[test]
fn plan_never_fires_again_after_termination() {
    let (b, e) = world("");
    set(&b, "init", true);
    set(&b, "trig", true);
    assert_eq!(fired(&b, &e), 1);
    set(&b, "term", true);
    set(&b, "trig", false);
    set(&b, "trig", true);
    assert_eq!(fired(&b, &e), 1);
    assert_eq!(
        b.read("p", "state").unwrap().value,
        Value::from("terminated")
    );
}

#[test]
fn every_repeats_while_the_trigger_holds_and_stops_at_termination() {
    let (b, e) = world("every 1s;");
    let clock = b.clock().clone();
    let advance = |ms| clock.advance(Duration::from_millis(ms)).unwrap();
    set(&b, "init", true);
    set(&b, "trig", true);
    assert_eq!(fired(&b, &e), 1, "fires at the edge");
    advance(999);
    assert_eq!(fired(&b, &e), 1);
    advance(1);
    assert_eq!(fired(&b, &e), 2, "then every second");
    advance(1000);
    assert_eq!(fired(&b, &e), 3);
    set(&b, "trig", false);
    advance(3000);
    assert_eq!(fired(&b, &e), 3, "not while the trigger is false");
    set(&b, "trig", true);
    assert_eq!(fired(&b, &e), 4, "a new edge fires at once");
    set(&b, "term", true);
    advance(5000);
    assert_eq!(fired(&b, &e), 4, "never after termination");
}

/// A plan triggered by `changed(trig.level, 0.5)`, optionally `or` something else.
fn follower(or: &str) -> (Arc<Board>, Engine) {
    world_with(&format!("trigger: changed(trig.level, 0.5){or};"))
}

#[test]
fn changed_fires_on_every_move_beyond_the_deadband() {
    let (b, e) = follower("");
    let level = |x: f64| b.write("trig", "level", x).unwrap();
    assert_eq!(fired(&b, &e), 1, "true as soon as the value exists");
    level(2.0);
    assert_eq!(
        fired(&b, &e),
        2,
        "a jump fires although no evaluation read false"
    );
    level(5.0);
    assert_eq!(fired(&b, &e), 3);
    level(5.3);
    assert_eq!(fired(&b, &e), 3, "within the deadband of the last firing");
    level(5.6);
    assert_eq!(fired(&b, &e), 4, "0.6 from the last firing");
}

#[test]
fn changed_keeps_the_edge_of_the_rest_of_the_trigger() {
    let (b, e) = follower(" or init.on");
    set(&b, "init", true);
    let n = fired(&b, &e);
    b.write("trig", "level", 3.0).unwrap();
    b.write("trig", "level", 9.0).unwrap();
    assert_eq!(fired(&b, &e), n, "the trigger never left true: no new edge");
}

#[test]
fn cancelled_plans_never_fire() {
    let (b, e) = world("");
    set(&b, "init", true);
    assert!(e.cancel("p"));
    set(&b, "trig", true);
    assert_eq!(fired(&b, &e), 0);
    assert_eq!(
        b.read("p", "state").unwrap().value,
        Value::from("cancelled")
    );
    assert!(!e.cancel("nope"));
}

#[test]
fn the_plan_object_shows_progress_and_events_are_emitted() {
    let (b, e) = world("");
    let events = e.events();
    assert_eq!(b.read("p", "state").unwrap().value, Value::from("pending"));
    set(&b, "init", true);
    assert_eq!(b.read("p", "state").unwrap().value, Value::from("active"));
    set(&b, "trig", true);
    assert_eq!(b.read("p", "fired").unwrap().value, Value::Int(1));
    set(&b, "term", true);
    let got: Vec<PlanEvent> = events.try_iter().collect();
    let kinds: Vec<&str> = got
        .iter()
        .map(|e| match e {
            PlanEvent::Initiated { .. } => "initiated",
            PlanEvent::Triggered { error: None, .. } => "triggered",
            PlanEvent::Terminated { .. } => "terminated",
            _ => "other",
        })
        .collect();
    assert_eq!(kinds, ["initiated", "triggered", "terminated"]);
}

#[test]
fn a_write_evaluates_only_the_plans_that_read_what_changed() {
    let (b, e) = world("");
    let before = e.evaluations();
    b.write("log", "n", 5).unwrap();
    b.write("trig", "level", 2.0).unwrap();
    assert_eq!(e.evaluations(), before, "nothing the plan reads changed");
    // Pending, it reads its termination and initiation only: its last evaluation did
    // nothing, and evaluating it again on the same values would do nothing again.
    set(&b, "trig", true);
    assert_eq!(
        e.evaluations(),
        before,
        "its last evaluation did not read it"
    );
    set(&b, "init", true);
    assert_eq!(e.evaluations(), before + 1);
    let fired = e.status("p").unwrap().fired;
    assert_eq!(fired, 1, "initiated, it fires: the trigger holds");
}

#[test]
fn a_plan_is_evaluated_again_only_when_what_its_last_evaluation_read_changes() {
    let (b, e) = engine();
    let src = r#"
        class Gauge { a: real = 0.0; b: real = 0.0; }
        class Log { n: int = 0; }
        object g : Gauge;
        object log : Log;
        plan both { trigger: g.a > 1.0 and g.b > 1.0; action { set log.n = log.n + 1; } }
    "#;
    e.load("t.slate", src).unwrap_or_else(|e| panic!("{e}"));
    // Its first evaluation activated it (no initiation): it did something.
    b.write("g", "b", 4.0).unwrap();
    let before = e.evaluations();
    b.write("g", "b", 5.0).unwrap();
    assert_eq!(
        e.evaluations(),
        before,
        "`g.a > 1.0` was false: the last evaluation did not read g.b"
    );
    b.write("g", "a", 5.0).unwrap();
    assert_eq!(e.evaluations(), before + 1);
    assert_eq!(e.status("both").unwrap().fired, 1, "g.b's write is seen");
    b.write("g", "b", 0.0).unwrap();
    b.write("g", "b", 6.0).unwrap();
    assert_eq!(
        e.status("both").unwrap().fired,
        2,
        "read now: each write evaluates"
    );
}

#[test]
fn a_plan_reading_a_derived_attribute_sees_what_the_derived_value_read_change() {
    let (b, e) = engine();
    let src = r#"
        class Bot { speed: real = 0.0; limit: real = 5.0; fast: bool derived = self.speed > self.limit; }
        class Unit { up: bool = true; }
        class Log { n: int = 0; }
        object r1 : Bot;
        object log : Log;
        plan slow_down { trigger: r1.fast; action { set log.n = log.n + 1; } }
        plan count_down { trigger: any u: Unit where not u.up; action { set log.n = log.n + 10; } }
    "#;
    e.load("t.slate", src).unwrap_or_else(|e| panic!("{e}"));
    b.write("r1", "speed", 6.0).unwrap();
    assert_eq!(e.status("slow_down").unwrap().fired, 1);
    b.write("r1", "speed", 1.0).unwrap();
    b.write("r1", "limit", 0.5).unwrap();
    assert_eq!(
        e.status("slow_down").unwrap().fired,
        2,
        "through the derived value's other input"
    );
    // An object created: what a quantifier sees.
    b.create("Unit", "u0").unwrap();
    b.create("Unit", "u1").unwrap();
    b.write("u1", "up", false).unwrap();
    assert_eq!(e.status("count_down").unwrap().fired, 1);
}

#[test]
fn a_plan_reading_a_derived_attribute_sees_what_its_quantifier_variable_reads_change() {
    // Like the demo's `Robot.alive` (over the built-in `Module`): a quantifier variable inside the derived attribute reads
    // another class's attribute (`m.alive`). Writing that attribute evaluates the plan.
    let (b, e) = engine();
    let src = r#"
        class Part { address: string = ""; alive: bool = true; }
        class Robot {
            exec: string = "";
            alive: bool derived = not (any m: Part where m.address == self.exec and not m.alive);
        }
        class Log { n: int = 0; }
        object r1 : Robot { exec = "r1/exec"; }
        object m1 : Part { address = "r1/exec"; }
        object log : Log;
        plan mourn { trigger: not r1.alive; action { set log.n = log.n + 1; } }
    "#;
    e.load("t.slate", src).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(e.status("mourn").unwrap().fired, 0);
    b.write("m1", "alive", false).unwrap();
    assert_eq!(
        e.status("mourn").unwrap().fired,
        1,
        "the part's `alive`, read by the quantifier inside r1.alive, went false"
    );
    b.write("m1", "alive", true).unwrap();
    b.write("m1", "address", "elsewhere").unwrap();
    b.write("m1", "alive", false).unwrap();
    assert_eq!(
        e.status("mourn").unwrap().fired,
        1,
        "not r1's part any more"
    );
    b.write("m1", "address", "r1/exec").unwrap();
    assert_eq!(
        e.status("mourn").unwrap().fired,
        2,
        "the part's address, read by the quantifier, names r1's again"
    );
}

const VEHICLES: &str = r#"
    class Vehicle { position: vec<2> [m]; speed: real = 1.0; nearest: ref; mode: string = "auto"; }
    class Obstacle { position: vec<2> [m]; }
    object gsr : Vehicle;
"#;

fn vehicles(plans: &str) -> (Arc<Board>, Engine) {
    let (board, engine) = engine();
    engine
        .load("v.slate", &format!("{VEHICLES}\n{plans}"))
        .unwrap_or_else(|e| panic!("{e}"));
    (board, engine)
}

#[test]
fn the_nearest_obstacle_closer_than_5_m_stops_the_vehicle() {
    let (b, e) = vehicles(
        r#"plan stop_near_obstacle {
            trigger: any o: Obstacle where distance(o.position, gsr.position) < 5.0
                by distance(o.position, gsr.position);
            action { set gsr.speed = 0, gsr.nearest = o; }
        }"#,
    );
    b.write("gsr", "position", [0.0, 0.0]).unwrap();
    for (name, x) in [("far", 8.0), ("near", 4.0), ("nearer", 3.0)] {
        let mut batch = b.batch();
        batch
            .create("Obstacle", name)
            .write(name, "position", [x, 0.0]);
        batch.commit().unwrap();
    }
    // "near" at 4 m crossed the threshold first and stopped the vehicle.
    assert_eq!(e.status("stop_near_obstacle").unwrap().fired, 1);
    assert_eq!(b.read("gsr", "speed").unwrap().value, Value::Real(0.0));
    assert_eq!(
        b.read("gsr", "nearest").unwrap().value,
        Value::reference("near")
    );
    // Moving away and back picks the nearest of all matches.
    b.write("gsr", "position", [100.0, 0.0]).unwrap();
    b.write("gsr", "position", [1.0, 0.0]).unwrap();
    assert_eq!(
        b.read("gsr", "nearest").unwrap().value,
        Value::reference("nearer")
    );
}

/// The vehicles with `position_lost` (fires once `gsr.position` is older than 2 s), just
/// after a position was written; returns the board's clock too, to advance.
fn position_lost() -> (Arc<Board>, Engine, Clock) {
    let (b, e) = vehicles(
        r#"plan position_lost {
            trigger: age(gsr.position) > 2s;
            action { set gsr.mode = "lost"; }
        }"#,
    );
    let clock = b.clock().clone();
    b.write("gsr", "position", [0.0, 0.0]).unwrap();
    (b, e, clock)
}

fn lost_fired(e: &Engine) -> u64 {
    e.status("position_lost").unwrap().fired
}

#[test]
fn an_age_condition_fires_exactly_when_its_deadline_passes() {
    let (b, e, clock) = position_lost();
    clock.advance(Duration::from_millis(1999)).unwrap();
    assert_eq!(lost_fired(&e), 0);
    clock.advance(Duration::from_millis(2)).unwrap();
    assert_eq!(lost_fired(&e), 1, "the deadline was a timer, not a poll");
    assert_eq!(b.read("gsr", "mode").unwrap().value, Value::from("lost"));
    // A fresh position re-arms it: the next deadline is 2 s after the new write.
    b.write("gsr", "position", [1.0, 0.0]).unwrap();
    clock.advance(Duration::from_millis(2001)).unwrap();
    assert_eq!(lost_fired(&e), 2);
}

#[test]
fn a_derived_attribute_reading_its_own_name_through_a_reference_loads_and_tracks() {
    // Regression: `position` derived from `observer.position` made the dependency
    // expansion exponential (about 110 s to load one plan).
    let (board, engine) = engine();
    let src = r#"
        class Body { position: vec<2>; heading: real = 0.0; }
        class Seen {
            observer: ref; range: real = 1.0; bearing: real = 0.0;
            position: vec<2> derived = self.observer.position + polar(self.range, self.observer.heading + self.bearing);
        }
        class Log { n: int = 0; }
        object me : Body { position = [0.0, 0.0]; }
        object s1 : Seen { observer = me; range = 10.0; }
        object log : Log;
        plan close { trigger: any s: Seen where distance(s.position, me.position) < 5.0; action { set log.n = log.n + 1; } }
    "#;
    engine
        .load("d.slate", src)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(engine.status("close").unwrap().fired, 0);
    board.write("s1", "range", 2.0).unwrap();
    let fired = engine.status("close").unwrap().fired;
    assert_eq!(
        fired, 1,
        "a write read through the derived attribute re-evaluates the plan"
    );
}

#[test]
fn a_derived_value_is_kept_only_until_what_it_reads_changes() {
    // The board keeps a derived attribute's value (it is a pure function of what it
    // reads): every change of what it read, and the clock for `age`, must show.
    let (board, engine) = engine();
    let src = r#"
        class Unit { address: string = ""; up: bool = true; }
        class Bot {
            exec: string = "";
            alive: bool derived = not (any m: Unit where m.address == self.exec and not m.up);
        }
        class Fix { at: real = 0.0; stale: real derived = age(self.at); }
        object u1 : Unit { address = "a"; }
        object u2 : Unit { address = "b"; }
        object r1 : Bot { exec = "a"; }
        object f : Fix;
    "#;
    engine
        .load("d.slate", src)
        .unwrap_or_else(|e| panic!("{e}"));
    let alive = || board.read("r1", "alive").unwrap().value;
    assert_eq!((alive(), alive()), (Value::Bool(true), Value::Bool(true)));
    board.write("u1", "up", false).unwrap();
    assert_eq!(alive(), Value::Bool(false), "the module it names went down");
    board.write("u2", "up", false).unwrap();
    board.write("u1", "up", true).unwrap();
    assert_eq!(alive(), Value::Bool(true), "and came back");
    board.write("r1", "exec", "b").unwrap();
    assert_eq!(alive(), Value::Bool(false), "its own attribute");
    board.create("Unit", "u3").unwrap();
    board.write("r1", "exec", "c").unwrap();
    assert_eq!(alive(), Value::Bool(true));
    board.write("u3", "address", "c").unwrap();
    board.write("u3", "up", false).unwrap();
    assert_eq!(
        board.snapshot().read("r1", "alive").unwrap().value,
        Value::Bool(false),
        "a module that appeared, read through a snapshot"
    );
    board.delete("u3").unwrap();
    assert_eq!(alive(), Value::Bool(true), "and went away");
    board.write("f", "at", 1.0).unwrap();
    let stale = || board.read("f", "stale").unwrap().value.as_f64().unwrap();
    assert_eq!((stale(), stale()), (0.0, 0.0));
    board.clock().advance(Duration::from_millis(1500)).unwrap();
    assert_eq!(stale(), 1.5, "the clock moved: `age` reads it again");
}

#[test]
fn an_age_condition_fires_after_the_clock_stopped_exactly_on_its_deadline() {
    let (_b, e, clock) = position_lost();
    clock.advance(Duration::from_secs(2)).unwrap();
    assert_eq!(lost_fired(&e), 0, "at exactly 2 s, age > 2s is false");
    clock.advance(Duration::from_millis(1)).unwrap();
    assert_eq!(lost_fired(&e), 1, "just after, it fires without a write");
}

#[test]
fn a_failing_action_is_recorded_and_applies_nothing() {
    let (b, e) = vehicles(
        r#"plan bad {
            trigger: gsr.speed > 5.0;
            action { set gsr.mode = "fast", gsr.nearest.speed = 0.0; }
        }"#,
    );
    let events = e.events();
    // The reference dangles, so the second write of the action fails at run time.
    b.write("gsr", "nearest", Value::reference("ghost"))
        .unwrap();
    b.write("gsr", "speed", 6.0).unwrap();
    let status = e.status("bad").unwrap();
    assert_eq!(status.fired, 0, "fired counts the actions that committed");
    let error = status.last_error.expect("the failure is recorded");
    assert!(error.contains("ghost"), "{error}");
    assert_eq!(
        b.read("gsr", "mode").unwrap().value,
        Value::from("auto"),
        "the first write was not applied"
    );
    assert_eq!(
        b.read("bad", "last_error").unwrap().value,
        Value::from(error.as_str())
    );
    assert!(
        events
            .try_iter()
            .any(|ev| matches!(ev, PlanEvent::Triggered { error: Some(_), .. }))
    );
}

#[test]
fn report_and_send_actions_produce_messages_for_the_ici() {
    let (b, e) = vehicles(
        r#"plan tell {
            trigger: gsr.speed > 5.0;
            action {
                report gsr.speed to "team/r1/console";
                report gsr;
                send follow to "team/r2/exec";
                send plan inline { trigger: true; action { report gsr; } } to "team/r2/exec";
            }
        }
        plan follow { trigger: false; action { report gsr; } }"#,
    );
    let out = e.outgoing();
    b.write("gsr", "speed", 6.0).unwrap();
    let msgs: Vec<Outgoing> = out.try_iter().collect();
    assert_eq!(msgs.len(), 4, "{msgs:?}");
    let Outgoing::Report(r) = &msgs[0] else {
        panic!("{msgs:?}")
    };
    assert_eq!(
        (r.to.as_ref().map(|a| a.as_str()), r.items.len()),
        (Some("team/r1/console"), 1)
    );
    assert_eq!(r.items[0].packet.value, Value::Real(6.0));
    let Outgoing::Report(all) = &msgs[1] else {
        panic!()
    };
    assert!(all.to.is_none() && all.items.iter().any(|i| &*i.attr == "speed"));
    let Outgoing::Plan(p) = &msgs[2] else {
        panic!()
    };
    assert!(p.text.starts_with("plan follow {"), "{}", p.text);
    let Outgoing::Plan(p) = &msgs[3] else {
        panic!()
    };
    assert!(p.text.starts_with("plan inline {") && p.to.as_str() == "team/r2/exec");
}

#[test]
fn initial_values_from_a_file_claim_no_time_and_lose_to_any_packet_written_since() {
    let (board, _engine) = loaded("w.slate", "class A { x: real; } object o : A { x = 1.0; }");
    let initial = board.read("o", "x").unwrap();
    assert_eq!(initial.value, Value::Real(1.0));
    assert_eq!(initial.timestamp, slate_model::Timestamp::ZERO);
    // A packet the team wrote long ago (before a restart, say) still wins.
    let mut older = initial.clone();
    older.value = Value::Real(5.0);
    older.timestamp = slate_model::Timestamp::from_raw(1 << 12);
    older.source = slate_model::Address::new("t/r2/op").unwrap();
    board.merge("o", "x", older).unwrap();
    assert_eq!(board.read("o", "x").unwrap().value, Value::Real(5.0));
}

#[test]
fn a_plan_object_refuses_writes_from_anyone_but_its_engine() {
    let (b, e) = world("");
    set(&b, "init", true);
    for (attr, value) in [
        ("state", Value::from("terminated")),
        ("fired", Value::Int(7)),
    ] {
        let err = b.write("p", attr, value).unwrap_err();
        assert!(
            matches!(err, slate_model::WriteError::Guarded { .. }),
            "{attr}: {err}"
        );
        assert!(err.to_string().contains("plan engine"), "{err}");
    }
    let mut batch = b.batch();
    batch.write("p", "state", "cancelled");
    assert!(batch.commit().is_err());
    // The object still tells the truth, and the plan still acts.
    assert_eq!(b.read("p", "state").unwrap().value, Value::from("active"));
    set(&b, "trig", true);
    assert_eq!(fired(&b, &e), 1);
    assert_eq!(b.read("p", "fired").unwrap().value, Value::Int(1));
    // Cancelling goes through the engine, and the object says so.
    assert!(e.cancel("p"));
    assert_eq!(
        b.read("p", "state").unwrap().value,
        Value::from("cancelled")
    );
}

#[test]
fn a_plan_action_that_writes_a_plan_object_is_refused_by_the_checker() {
    let (_board, _engine, e) = refused_after(
        "plan q { trigger: false; action { } }",
        "plan r { trigger: true; action { set q.state = \"terminated\"; } }",
    );
    assert!(e.diagnostics.0[0].message.contains("plan engine"), "{e}");
    assert_eq!(
        (e.diagnostics.0[0].span.line, e.diagnostics.0[0].span.col),
        (1, 38)
    );
}

#[test]
fn a_failed_action_does_not_count_as_fired() {
    let (board, engine) = engine();
    engine
        .load(
            "t.slate",
            "class A { x: real in 0 .. 1; go: bool = false; }\nobject a : A;\n\
             plan p { trigger: a.go; action { set a.x = 5.0; } }",
        )
        .unwrap();
    board.write("a", "go", true).unwrap();
    let status = engine.status("p").unwrap();
    assert!(status.last_error.is_some(), "{status:?}");
    assert_eq!(status.fired, 0, "{status:?}");
    assert_eq!(board.read("p", "fired").unwrap().value, Value::Int(0));
    assert!(
        board
            .read("p", "last_error")
            .unwrap()
            .value
            .to_string()
            .contains("outside the declared bounds")
    );
}

/// A board with the signals written by `before`, then plan `p` (these conditions,
/// counting in log.n) loaded to take up at `progress`, as after a restart.
fn resumed(
    conditions: &str,
    before: impl FnOnce(&Board),
    progress: slate_plans::PlanProgress,
) -> (Arc<Board>, Engine) {
    let (board, engine) = engine();
    engine.load("signals.slate", SIGNALS).unwrap();
    before(&board);
    engine.resume("p", progress);
    let plan = format!("plan p {{ {conditions} action {{ set log.n = log.n + 1; }} }}");
    engine
        .load("p.slate", &plan)
        .unwrap_or_else(|e| panic!("{e}"));
    (board, engine)
}

fn logged(b: &Board) -> Value {
    b.read("log", "n").unwrap().value
}

#[test]
fn a_resumed_plan_whose_trigger_held_fires_only_on_its_next_rising_edge() {
    let progress = slate_plans::PlanProgress {
        state: PlanState::Active,
        fired: 3,
        trigger_held: true,
    };
    let (b, e) = resumed("trigger: trig.on;", |b| set(b, "trig", true), progress);
    let status = e.status("p").unwrap();
    assert_eq!((status.state, status.fired), (PlanState::Active, 3));
    assert_eq!(b.read("p", "fired").unwrap().value, Value::Int(3));
    assert_eq!(logged(&b), Value::Int(0), "it had fired for this state");
    set(&b, "trig", false);
    set(&b, "trig", true);
    assert_eq!(logged(&b), Value::Int(1));
    assert_eq!(e.status("p").unwrap().fired, 4);
}

#[test]
fn a_resumed_plan_whose_trigger_did_not_hold_fires_once_it_holds() {
    let progress = slate_plans::PlanProgress {
        state: PlanState::Active,
        fired: 1,
        trigger_held: false,
    };
    let conditions = "initiation: init.on; trigger: trig.on;";
    let (b, _e) = resumed(conditions, |b| set(b, "trig", true), progress);
    assert_eq!(logged(&b), Value::Int(1), "active (latched) and a new edge");
}

#[test]
fn a_resumed_plan_that_had_acted_takes_its_changed_references_from_the_board() {
    let progress = slate_plans::PlanProgress {
        state: PlanState::Active,
        fired: 1,
        trigger_held: false,
    };
    let level = |b: &Board, x: f64| {
        b.write("trig", "level", x).unwrap();
    };
    let conditions = "trigger: changed(trig.level, 0.5);";
    let (b, _e) = resumed(conditions, |b| level(b, 3.0), progress);
    assert_eq!(logged(&b), Value::Int(0), "nothing moved since the restart");
    level(&b, 3.2);
    assert_eq!(logged(&b), Value::Int(0));
    level(&b, 3.6);
    assert_eq!(logged(&b), Value::Int(1));
}

/// On the system clock the engine's timer thread sleeps until the next plan deadline:
/// once a plan's `every` timer has fired and the plan ended, nothing is due and the
/// thread wakes at most every 200 ms. It used to keep the passed deadline as its wake-up
/// time and loop on it, one core at 100 % for the life of the node.
#[test]
fn the_timer_thread_sleeps_once_nothing_is_due() {
    let board = Arc::new(Board::builder().build());
    let e = Engine::new(&board);
    e.load(
        "t.slate",
        &format!(
            "{SIGNALS}
            plan p {{ trigger: trig.on; termination: log.n >= 2; every 50ms;
                action {{ set log.n = log.n + 1; }} }}"
        ),
    )
    .unwrap();
    let _timers = e.run_timers();
    set(&board, "trig", true);
    let ended = |b: &Board| b.read("p", "state").unwrap().value == Value::from("terminated");
    let deadline = std::time::Instant::now() + Duration::from_secs(10);
    while !ended(&board) && std::time::Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(ended(&board), "the every timer fired the plan to its end");
    let before = e.timer_wakes();
    std::thread::sleep(Duration::from_millis(500));
    let wakes = e.timer_wakes() - before;
    assert!(wakes <= 5, "{wakes} wake-ups in 500 ms with nothing due");
}
