//! The example files at the repository root parse, and say what they are meant to say.

use slate_model::Context;
use slate_plans::{ActionKind, ExprKind, File, PlanDecl, PlanRef, QuantifierKind, parse};

const GSR: &str = include_str!("../../../../examples/gsr.slate");

fn gsr() -> File {
    parse(GSR).unwrap_or_else(|errors| panic!("{}", errors.render("examples/gsr.slate", GSR)))
}

/// The plan `name` of `file`.
fn plan<'f>(file: &'f File, name: &str) -> &'f PlanDecl {
    file.plans()
        .find(|p| p.name.name == name)
        .unwrap_or_else(|| panic!("no plan {name}"))
}

#[test]
fn gsr_declares_the_paper_classes_under_thing() {
    let file = gsr();
    let classes: Vec<_> = file
        .classes()
        .map(|c| (c.name.name.as_str(), c.parent.is_none()))
        .collect();
    assert_eq!(
        classes,
        [
            ("Vehicle", true),
            ("Sensor", true),
            ("Obstacle", true),
            ("Target", true)
        ]
    );
}

#[test]
fn gsr_derives_obstacle_positions_from_vehicle_pose_and_relative_range_and_bearing() {
    let file = gsr();
    let obstacle = file
        .classes()
        .find(|c| c.name.name == "Obstacle")
        .expect("Obstacle");
    let position = obstacle
        .attributes
        .iter()
        .find(|a| a.name.name == "position")
        .expect("position");
    let derived = position.derived.as_ref().expect("derived");
    assert_eq!(
        derived.value.to_string(),
        "(self.observer.position + polar(self.range, (self.observer.heading + self.bearing)))"
    );
    assert!(derived.accuracy.is_some() && derived.confidence.is_some());
}

#[test]
fn gsr_objects_are_the_robot_and_its_sensors_in_self_context() {
    let file = gsr();
    let objects: Vec<_> = file
        .objects()
        .map(|o| {
            (
                o.name.name.as_str(),
                o.class.name.as_str(),
                o.context.map(|c| c.context),
            )
        })
        .collect();
    assert_eq!(
        objects,
        [
            ("gsr", "Vehicle", Some(Context::Self_)),
            ("nav", "Sensor", Some(Context::Self_)),
            ("prox", "Sensor", Some(Context::Self_)),
            ("vision", "Sensor", Some(Context::Self_)),
        ]
    );
    let rules: Vec<_> = file
        .rules()
        .map(|f| {
            format!(
                "{}.{}",
                f.owner.as_ref().map_or("", |o| &o.name),
                f.attribute.name
            )
        })
        .collect();
    assert_eq!(rules, ["nav.status", "Obstacle.range"]);
}

#[test]
fn gsr_plans_cover_the_cooperations_of_the_paper() {
    let file = gsr();
    let plans: Vec<_> = file.plans().map(|p| p.name.name.as_str()).collect();
    assert_eq!(
        plans,
        [
            "share_pose_with_proximity",
            "hand_target_to_vision",
            "report_located_target",
            "stop_near_obstacle",
            "resume_when_clear",
            "forget_stale_obstacles",
            "seed_intruder",
        ]
    );
}

#[test]
fn gsr_proximity_hands_targets_to_vision_with_a_narrowing_plan() {
    let file = gsr();
    let hand = plan(&file, "hand_target_to_vision");
    let sent = hand.action.iter().find_map(|a| match &a.kind {
        ActionKind::Send {
            plan: PlanRef::Inline(plan),
            to,
        } => Some((plan, to)),
        _ => None,
    });
    let (narrow, to) = sent.expect("an inline plan sent");
    assert_eq!(
        (narrow.name.name.as_str(), to.value.as_str()),
        ("narrow_vision_search", "team/r1/vision")
    );
    assert!(narrow.every.is_some());
    let ActionKind::Set(assignments) = &narrow.action[0].kind else {
        panic!("{narrow:?}")
    };
    let targets: Vec<_> = assignments.iter().map(|a| a.target.to_string()).collect();
    assert_eq!(targets, ["vision.search_bearing", "vision.search_width"]);
}

#[test]
fn gsr_stops_near_the_nearest_obstacle() {
    let file = gsr();
    let stop = plan(&file, "stop_near_obstacle");
    let Some(ExprKind::Quantifier(nearest)) = stop.trigger.as_ref().map(|t| &t.kind) else {
        panic!("{stop:?}")
    };
    assert_eq!(
        (nearest.kind, nearest.var.name.as_str()),
        (QuantifierKind::Any, "o")
    );
    let order = nearest.order.as_ref().expect("ordered by distance");
    assert_eq!(
        (order.key.to_string(), order.descending),
        ("distance(o.position, gsr.position)".to_owned(), false)
    );
    assert!(matches!(stop.action[0].kind, ActionKind::Set(_)));
}

const LANGUAGE_DOC: &str = include_str!("../../../../docs/language.md");

/// Whether `example`, a whole file or a fragment of one, parses in some context.
fn parses_somewhere(example: &str) -> bool {
    let whole = [
        example.to_owned(),
        format!("plan p {{ action {{\n{example}\n}} }}"),
        format!("plan p {{\n{example}\naction {{}} }}"),
    ];
    let line_by_line = || {
        example
            .lines()
            .all(|line| parse(&format!("plan p {{\n{line}\naction {{}} }}")).is_ok())
    };
    whole.iter().any(|source| parse(source).is_ok()) || line_by_line()
}

#[test]
fn every_example_of_the_language_reference_parses() {
    let examples: Vec<&str> = LANGUAGE_DOC
        .split("```slate\n")
        .skip(1)
        .map(|block| block.split("```").next().unwrap_or_default())
        .collect();
    assert!(examples.len() >= 10, "{}", examples.len());
    for example in examples {
        assert!(parses_somewhere(example), "does not parse:\n{example}");
    }
}
