//! One test per construct: classes, attributes, objects, active functions, plans and actions.

use slate_model::Context;
use slate_plans::{
    Action, ActionKind, AttributeDecl, ClassDecl, Item, ObjectDecl, PacketExpr, PlanDecl, PlanRef,
    RuleDecl, Span, Type,
};

use crate::support::{messages, only_item, parse_ok, text};

const VEHICLE: &str = r#"class Vehicle : Thing {
    speed: real [m/s] in 0 .. 50 step 0.01 = 0.0 accuracy 0.1 confidence 1.0 merge latest report every 200ms heartbeat 5s deadband 0.05;
    position: vec<2> [m];
    mode: string = "auto";
    target: ref;
    alive: bool = true;
    count: int in 0 .. 1000;
    abs_position: vec<2> [m] derived = self.observer.position + polar(self.range, self.observer.heading + self.bearing) accuracy self.range.accuracy + 0.5;
}"#;

/// The text of a packet's value, accuracy and confidence.
fn packet_texts(p: &PacketExpr) -> (String, Option<String>, Option<String>) {
    (
        p.value.to_string(),
        text(p.accuracy.as_ref()),
        text(p.confidence.as_ref()),
    )
}

fn class(source: &str) -> ClassDecl {
    match only_item(source) {
        Item::Class(class) => class,
        other => panic!("not a class: {other:?}"),
    }
}

fn object(source: &str) -> ObjectDecl {
    match only_item(source) {
        Item::Object(object) => object,
        other => panic!("not an object: {other:?}"),
    }
}

fn plan(source: &str) -> PlanDecl {
    match only_item(source) {
        Item::Plan(plan) => plan,
        other => panic!("not a plan: {other:?}"),
    }
}

/// The actions of a plan whose action block is `actions`.
fn actions(actions: &str) -> Vec<Action> {
    plan(&format!("plan p {{ action {{ {actions} }} }}")).action
}

fn names(attributes: &[AttributeDecl]) -> Vec<(&str, Type)> {
    attributes
        .iter()
        .map(|a| (a.name.name.as_str(), a.ty.ty))
        .collect()
}

#[test]
fn class_declares_attributes_with_types_and_parent() {
    let vehicle = class(VEHICLE);
    assert_eq!(vehicle.name.name, "Vehicle");
    assert_eq!(vehicle.parent.map(|p| p.name).as_deref(), Some("Thing"));
    assert_eq!(
        names(&vehicle.attributes),
        [
            ("speed", Type::Real),
            ("position", Type::Vec(2)),
            ("mode", Type::String),
            ("target", Type::Ref),
            ("alive", Type::Bool),
            ("count", Type::Int),
            ("abs_position", Type::Vec(2)),
        ]
    );
    assert!(vehicle.rules.is_empty());
    assert_eq!(vehicle.span, Span::new(0, VEHICLE.len(), 1, 1));
}

#[test]
fn attribute_options_are_all_kept() {
    let speed = class(VEHICLE).attributes.remove(0);
    assert_eq!(speed.unit.map(|u| u.text).as_deref(), Some("m/s"));
    let bounds = speed
        .bounds
        .as_ref()
        .map(|b| (b.min.to_string(), b.max.to_string()));
    assert_eq!(bounds, Some(("0".to_owned(), "50".to_owned())));
    assert_eq!(text(speed.step.as_ref()).as_deref(), Some("0.01"));
    let default = speed.default.as_ref().map(packet_texts);
    assert_eq!(
        default,
        Some(("0.0".into(), Some("0.1".into()), Some("1.0".into())))
    );
    assert_eq!(speed.merge.map(|m| m.name).as_deref(), Some("latest"));
    assert!(speed.derived.is_none());
    let report = speed.report.unwrap_or_default();
    assert_eq!(text(report.every.as_ref()).as_deref(), Some("0.2s"));
    assert_eq!(text(report.heartbeat.as_ref()).as_deref(), Some("5.0s"));
    assert_eq!(text(report.deadband.as_ref()).as_deref(), Some("0.05"));
    assert_eq!(report.on_accuracy, None);
    assert_eq!((speed.span.line, speed.span.col), (2, 5));
    assert_eq!(
        &VEHICLE[speed.span.start..speed.span.end],
        VEHICLE.lines().nth(1).unwrap().trim()
    );
}

#[test]
fn attribute_without_options_has_none() {
    let position = class(VEHICLE).attributes.remove(1);
    assert_eq!(position.unit.as_ref().map(|u| u.text.as_str()), Some("m"));
    assert!(position.bounds.is_none() && position.step.is_none() && position.default.is_none());
    assert!(position.derived.is_none() && position.merge.is_none() && position.report.is_none());
    let start = VEHICLE.find("vec<2> [m];").unwrap_or_default();
    assert_eq!(position.ty.span, Span::new(start, start + 6, 3, 15));
}

#[test]
fn derived_attribute_keeps_its_expression_and_accuracy() {
    let derived = class(VEHICLE)
        .attributes
        .remove(6)
        .derived
        .expect("derived");
    assert_eq!(
        derived.value.to_string(),
        "(self.observer.position + polar(self.range, (self.observer.heading + self.bearing)))"
    );
    assert_eq!(
        text(derived.accuracy.as_ref()).as_deref(),
        Some("(self.range.accuracy + 0.5)")
    );
    assert_eq!(derived.confidence, None);
}

#[test]
fn options_come_in_any_order_and_report_takes_on_accuracy() {
    let source = "class A { x: real report on_accuracy every 1s merge fused = 1 [deg] step 0.5; }";
    let x = class(source).attributes.remove(0);
    let report = x.report.unwrap_or_default();
    assert_eq!(report.on_accuracy.map(|s| s.col), Some(26));
    assert_eq!(text(report.every.as_ref()).as_deref(), Some("1.0s"));
    assert_eq!(
        (x.unit.map(|u| u.text), x.merge.map(|m| m.name)),
        (Some("deg".to_owned()), Some("fused".to_owned()))
    );
    assert_eq!(text(x.step.as_ref()).as_deref(), Some("0.5"));
}

#[test]
fn units_are_raw_text() {
    let source = "class A { g: real [m/s^2]; t: real [ °C ]; }";
    let units: Vec<_> = class(source)
        .attributes
        .into_iter()
        .filter_map(|a| a.unit)
        .collect();
    assert_eq!(
        units.iter().map(|u| u.text.as_str()).collect::<Vec<_>>(),
        ["m/s^2", "°C"]
    );
    assert_eq!(units[0].span, Span::new(18, 25, 1, 19));
}

#[test]
fn class_without_parent_and_with_a_write_rule() {
    let source = "class Sensor { status: string; on write status { report self.status; } }";
    let sensor = class(source);
    assert_eq!(sensor.parent, None);
    let rule = &sensor.rules[0];
    assert_eq!(
        (rule.owner.as_ref(), rule.attribute.name.as_str()),
        (None, "status")
    );
    let ActionKind::Report { targets, to } = &rule.actions[0].kind else {
        panic!("{rule:?}")
    };
    assert_eq!(
        (targets[0].to_string(), to),
        ("self.status".to_owned(), &None)
    );
}

#[test]
fn object_with_context_owner_and_values() {
    let gsr = object(
        r#"object gsr : Vehicle context self owner "team/r1/nav" { speed = 2.5 accuracy 0.1 confidence 0.9; mode = "auto"; }"#,
    );
    assert_eq!(
        (gsr.name.name.as_str(), gsr.class.name.as_str()),
        ("gsr", "Vehicle")
    );
    assert_eq!(gsr.context.map(|c| c.context), Some(Context::Self_));
    assert_eq!(gsr.owner.map(|o| o.value).as_deref(), Some("team/r1/nav"));
    let values: Vec<_> = gsr
        .values
        .iter()
        .map(|v| (v.name.name.as_str(), packet_texts(&v.packet)))
        .collect();
    let speed = (
        "2.5".to_owned(),
        Some("0.1".to_owned()),
        Some("0.9".to_owned()),
    );
    let mode = ("\"auto\"".to_owned(), None, None);
    assert_eq!(values, [("speed", speed), ("mode", mode)]);
}

#[test]
fn object_without_body_or_options() {
    let o2 = object("object o2 : Obstacle;");
    assert_eq!(
        (o2.name.name.as_str(), o2.class.name.as_str()),
        ("o2", "Obstacle")
    );
    assert!(o2.context.is_none() && o2.owner.is_none() && o2.values.is_empty());
    assert_eq!(o2.span, Span::new(0, 21, 1, 1));
    let swapped = object(r#"object t : Target owner "team/r2/vision" context system;"#);
    assert_eq!(swapped.context.map(|c| c.context), Some(Context::System));
}

fn top_rule(source: &str) -> RuleDecl {
    match only_item(source) {
        Item::Rule(rule) => rule,
        other => panic!("not an active function: {other:?}"),
    }
}

#[test]
fn top_level_write_rules_name_a_class_or_object_attribute() {
    for (source, owner) in [
        ("on write Vehicle.speed { report self.speed; }", "Vehicle"),
        ("on write gsr.speed { set gsr.mode = \"moving\"; }", "gsr"),
    ] {
        let rule = top_rule(source);
        assert_eq!(rule.owner.map(|o| o.name).as_deref(), Some(owner));
        assert_eq!(rule.attribute.name, "speed");
        assert_eq!(rule.actions.len(), 1);
        assert_eq!(rule.span, Span::new(0, source.len(), 1, 1));
    }
}

#[test]
fn on_read_and_bare_attributes_are_rejected_with_hints() {
    assert_eq!(
        messages("on read gsr.speed { }"),
        [
            "`on read` is not supported: declare a `derived` attribute to compute a value when it is read"
        ]
    );
    assert_eq!(
        messages("on write speed { }"),
        [
            "expected `.` and an attribute name after `speed`: at top level, `on write` names a class \
         or object attribute, as in `on write Vehicle.speed`"
        ]
    );
    assert_eq!(
        messages("class A { on write A.speed { } }"),
        ["inside a class, `on write` names an attribute of the class, as in `on write A`"]
    );
}

const STOP_NEAR_OBSTACLE: &str = r#"
plan stop_near_obstacle {
    initiation: gsr.mode == "auto";
    trigger: any o: Obstacle where distance(o.position, gsr.position) < 5.0 by distance(o.position, gsr.position);
    termination: gsr.mode == "manual" or age(gsr.position) > 10s;
    every 1s;
    action {
        set gsr.speed = 0.0 accuracy 0.0 confidence 1.0, gsr.goal = o.position;
        report o;
        report gsr.speed, gsr.position to "team/r2/loco";
        send plan follow { initiation: true; trigger: changed(gsr.position, 0.5); action { report gsr.position; } } to "team/r1/loco";
        send patrol to "team/r2/exec";      // a plan declared elsewhere in the file(s)
        create Obstacle seen1 context surroundings { range = 3.0; observer = gsr; }
        delete o;
    }
}
"#;

#[test]
fn plan_keeps_its_clauses() {
    let stop = plan(STOP_NEAR_OBSTACLE);
    assert_eq!(stop.name.name, "stop_near_obstacle");
    assert_eq!(
        text(stop.initiation.as_ref()).as_deref(),
        Some("(gsr.mode == \"auto\")")
    );
    assert_eq!(
        text(stop.trigger.as_ref()).as_deref(),
        Some(
            "(any o: Obstacle where (distance(o.position, gsr.position) < 5.0) by \
             distance(o.position, gsr.position))"
        )
    );
    assert_eq!(
        text(stop.termination.as_ref()).as_deref(),
        Some("((gsr.mode == \"manual\") or (age(gsr.position) > 10.0s))")
    );
    assert_eq!(text(stop.every.as_ref()).as_deref(), Some("1.0s"));
    assert_eq!(stop.action.len(), 7);
    assert_eq!((stop.span.line, stop.span.col), (2, 1));
}

#[test]
fn plan_clauses_are_optional_except_action() {
    let minimal = plan("plan p { action { } }");
    assert!(minimal.initiation.is_none() && minimal.trigger.is_none());
    assert!(minimal.termination.is_none() && minimal.every.is_none() && minimal.action.is_empty());
    assert_eq!(
        messages("plan p { trigger: x; }"),
        ["plan `p` has no `action { ... }` block"]
    );
}

#[test]
fn plan_clauses_come_in_any_order() {
    let p = plan(
        "plan p { action { delete x; } every 2s; termination: b; trigger: c; initiation: a; }",
    );
    let clauses = [&p.initiation, &p.trigger, &p.termination, &p.every].map(|c| text(c.as_ref()));
    assert_eq!(
        clauses,
        [Some("a"), Some("c"), Some("b"), Some("2.0s")].map(|c| c.map(String::from))
    );
    assert_eq!(p.action.len(), 1);
}

#[test]
fn set_action_writes_several_packets() {
    let action = actions("set gsr.speed = 0.0 accuracy 0.0 confidence 1.0, gsr.goal = o.position;");
    let ActionKind::Set(assignments) = &action[0].kind else {
        panic!("{action:?}")
    };
    let written: Vec<_> = assignments
        .iter()
        .map(|a| (a.target.to_string(), packet_texts(&a.packet)))
        .collect();
    let speed = (
        "0.0".to_owned(),
        Some("0.0".to_owned()),
        Some("1.0".to_owned()),
    );
    let goal = ("o.position".to_owned(), None, None);
    assert_eq!(
        written,
        [
            ("gsr.speed".to_owned(), speed),
            ("gsr.goal".to_owned(), goal)
        ]
    );
    assert_eq!(action[0].span.start, 18);
    assert_eq!(assignments[1].target.fields[0].name, "goal");
}

#[test]
fn report_action_has_targets_and_an_optional_destination() {
    let reports = actions(r#"report o; report gsr.speed, gsr.position to "team/r2/loco";"#);
    let summary: Vec<_> = reports
        .iter()
        .map(|a| match &a.kind {
            ActionKind::Report { targets, to } => (
                targets.iter().map(ToString::to_string).collect::<Vec<_>>(),
                to.as_ref().map(|t| t.value.clone()),
            ),
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(
        summary,
        [
            (vec!["o".to_owned()], None),
            (
                vec!["gsr.speed".to_owned(), "gsr.position".to_owned()],
                Some("team/r2/loco".to_owned())
            ),
        ]
    );
}

#[test]
fn send_action_carries_an_inline_plan() {
    let sent = actions(
        r#"send plan follow { initiation: true; trigger: changed(gsr.position, 0.5); action { report gsr.position; } } to "team/r1/loco";"#,
    );
    let ActionKind::Send {
        plan: PlanRef::Inline(follow),
        to,
    } = &sent[0].kind
    else {
        panic!("{sent:?}")
    };
    assert_eq!(follow.name.name, "follow");
    assert_eq!(text(follow.initiation.as_ref()).as_deref(), Some("true"));
    assert_eq!(
        text(follow.trigger.as_ref()).as_deref(),
        Some("changed(gsr.position, 0.5)")
    );
    assert_eq!(follow.action.len(), 1);
    assert_eq!(to.value, "team/r1/loco");
}

#[test]
fn send_action_names_a_plan_declared_elsewhere() {
    let sent = actions(r#"send patrol to "team/r2/exec";"#);
    let ActionKind::Send {
        plan: PlanRef::Named(name),
        to,
    } = &sent[0].kind
    else {
        panic!("{sent:?}")
    };
    assert_eq!(
        (name.name.as_str(), to.value.as_str()),
        ("patrol", "team/r2/exec")
    );
}

#[test]
fn create_action_with_context_and_values() {
    let created =
        actions("create Obstacle seen1 context surroundings { range = 3.0; observer = gsr; }");
    let ActionKind::Create {
        class,
        name,
        context,
        values,
    } = &created[0].kind
    else {
        panic!("{created:?}")
    };
    assert_eq!(
        (class.name.as_str(), name.name.as_str()),
        ("Obstacle", "seen1")
    );
    assert_eq!(context.map(|c| c.context), Some(Context::Surroundings));
    let values: Vec<_> = values
        .iter()
        .map(|v| (v.name.name.as_str(), v.packet.value.to_string()))
        .collect();
    assert_eq!(
        values,
        [("range", "3.0".to_owned()), ("observer", "gsr".to_owned())]
    );
}

#[test]
fn create_action_without_body_and_with_trailing_semicolon() {
    let created = actions("create Target t1; create Target t2 context system { x = 1; };");
    assert_eq!(created.len(), 2);
    let ActionKind::Create {
        values, context, ..
    } = &created[0].kind
    else {
        panic!()
    };
    assert!(values.is_empty() && context.is_none());
}

#[test]
fn delete_action_takes_an_expression() {
    let deleted = actions("delete o; delete gsr.target;");
    let targets: Vec<_> = deleted
        .iter()
        .map(|a| match &a.kind {
            ActionKind::Delete(target) => target.to_string(),
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(targets, ["o", "gsr.target"]);
}

#[test]
fn items_keep_source_order() {
    let file = parse_ok(
        "plan a { action {} }\nclass B {}\nobject c : B;\non write c.x { delete c; }\nlink team {}",
    );
    let kinds: Vec<_> = file
        .items
        .iter()
        .map(|item| match item {
            Item::Plan(_) => "plan",
            Item::Class(_) => "class",
            Item::Object(_) => "object",
            Item::Rule(_) => "on",
            Item::Link(_) => "link",
        })
        .collect();
    assert_eq!(kinds, ["plan", "class", "object", "on", "link"]);
    assert_eq!(file.items[2].span().line, 3);
    assert_eq!(
        (
            file.plans().count(),
            file.classes().count(),
            file.objects().count()
        ),
        (1, 1, 1)
    );
    assert_eq!(file.rules().count(), 1);
}
