//! The paper's Ground Surveillance Robot (`examples/gsr.slate`) loaded and run.

use std::sync::Arc;

use slate_model::{Board, Clock, Value};
use slate_plans::{Engine, Outgoing};

const GSR: &str = include_str!("../../../../examples/gsr.slate");

fn gsr() -> (Arc<Board>, Engine) {
    let (b, e, _) = gsr_with_outbox();
    (b, e)
}

/// The GSR board, its engine, and what its plans sent from the start.
fn gsr_with_outbox() -> (Arc<Board>, Engine, crossbeam_channel::Receiver<Outgoing>) {
    let board = Arc::new(
        Board::builder()
            .clock(Clock::manual())
            .address("team/r1/exec".parse().unwrap())
            .build(),
    );
    let engine = Engine::new(&board);
    let out = engine.outgoing();
    engine
        .load("examples/gsr.slate", GSR)
        .unwrap_or_else(|e| panic!("{e}"));
    (board, engine, out)
}

#[test]
fn gsr_loads_with_its_classes_objects_and_plans() {
    let (b, e) = gsr();
    for class in ["Vehicle", "Sensor", "Obstacle", "Target", "Plan"] {
        assert!(b.class_def(class).is_some(), "{class}");
    }
    assert_eq!(
        b.read("prox", "mounted_on").unwrap().value,
        Value::reference("gsr")
    );
    let plans: Vec<String> = e.plans().into_iter().map(|p| p.name).collect();
    assert!(
        plans.contains(&"stop_near_obstacle".to_owned()),
        "{plans:?}"
    );
}

#[test]
fn navigation_and_proximity_give_obstacles_in_absolute_coordinates() {
    let (b, _) = gsr();
    b.write(
        "gsr",
        "position",
        slate_model::Update::new([10.0, 20.0])
            .accuracy(0.5)
            .confidence(0.9),
    )
    .unwrap();
    b.write("gsr", "heading", 0.0).unwrap();
    let mut batch = b.batch();
    batch
        .create("Obstacle", "rock")
        .write("rock", "observer", Value::reference("gsr"))
        .write(
            "rock",
            "range",
            slate_model::Update::new(30.0).accuracy(0.2).confidence(0.8),
        )
        .write("rock", "bearing", std::f64::consts::FRAC_PI_2);
    batch.commit().unwrap();
    let p = b.read("rock", "position").unwrap();
    let v = p.value.as_vector().unwrap();
    assert!(
        (v[0] - 10.0).abs() < 1e-6 && (v[1] - 50.0).abs() < 1e-6,
        "{v:?}"
    );
    assert!(
        (p.confidence - 0.72).abs() < 1e-9,
        "confidence multiplies: {}",
        p.confidence
    );
}

#[test]
fn a_close_obstacle_stops_the_vehicle_and_tells_the_console() {
    let (b, e) = gsr();
    let out = e.outgoing();
    b.write("gsr", "position", [0.0, 0.0]).unwrap();
    b.write("gsr", "speed", 2.0).unwrap();
    let mut batch = b.batch();
    batch
        .create("Obstacle", "rock")
        .write("rock", "observer", Value::reference("gsr"))
        .write("rock", "range", 2.5)
        .write("rock", "bearing", 0.0);
    batch.commit().unwrap();
    assert_eq!(e.status("stop_near_obstacle").unwrap().fired, 1);
    assert_eq!(b.read("gsr", "speed").unwrap().value, Value::Real(0.0));
    assert_eq!(b.read("gsr", "mode").unwrap().value, Value::from("stopped"));
    let sent: Vec<Outgoing> = out.try_iter().collect();
    assert!(
        sent.iter()
            .any(|m| matches!(m, Outgoing::Plan(p) if p.name == "resume_when_clear")),
        "{sent:?}"
    );
    assert!(sent.iter().any(|m| matches!(m, Outgoing::Report(r) if r.to.as_ref().is_some_and(|a| a.as_str() == "team/base/console"))));
}

#[test]
fn proximity_hands_an_out_of_range_target_to_vision_with_a_search_plan() {
    // seed_intruder creates a target 600 m out, beyond proximity's 30 m: at once, the
    // target goes to vision with a plan that narrows vision's search.
    let (_, e, out) = gsr_with_outbox();
    assert_eq!(e.status("seed_intruder").unwrap().fired, 1);
    assert_eq!(e.status("hand_target_to_vision").unwrap().fired, 1);
    let sent: Vec<Outgoing> = out.try_iter().collect();
    assert!(sent.iter().any(
        |m| matches!(m, Outgoing::Report(r) if r.items.iter().any(|i| &*i.object == "intruder"))
    ));
    let plan = sent.iter().find_map(|m| match m {
        Outgoing::Plan(p) if p.name == "narrow_vision_search" => Some(p.clone()),
        _ => None,
    });
    let plan = plan.expect("the search plan is sent to vision");
    assert_eq!(plan.to.as_str(), "team/r1/vision");
    // What travels is slate that vision's board (same world model) loads and runs.
    let (vision, ve) = gsr();
    ve.load("from-prox.slate", &plan.text)
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(ve.status("narrow_vision_search").unwrap().fired >= 1);
    let bearing = vision.read("vision", "search_bearing").unwrap().value;
    assert_eq!(
        bearing,
        Value::Real(0.2),
        "vision looks where proximity last saw the target"
    );
}
