//! The checker: names, types, arities, quantifiers and cycles, with positions.

use std::sync::Arc;

use slate_model::{Board, Clock};
use slate_plans::{Engine, LoadError};

use crate::support::{engine, loaded, refused};

const WORLD: &str = r#"
class Vehicle { position: vec<2> [m]; speed: real = 0.0; mode: string = "auto"; target: ref; }
class Obstacle { position: vec<2> [m]; range: real; }
object gsr : Vehicle;
"#;

fn load(src: &str) -> Result<(), LoadError> {
    let (_board, engine) = engine();
    engine.load("w.slate", &format!("{WORLD}{src}")).map(|_| ())
}

fn errors(src: &str) -> Vec<String> {
    match load(src) {
        Ok(()) => panic!("loaded: {src}"),
        Err(e) => e.diagnostics.iter().map(|d| d.message.clone()).collect(),
    }
}

#[test]
fn unknown_names_attributes_and_functions() {
    let e = errors("plan p { trigger: ghost.speed > 1.0; action { set gsr.speed = 0; } }");
    assert_eq!(
        e,
        ["unknown name ghost: not an object, a class or a variable here"]
    );
    let e = errors("plan p { trigger: gsr.altitude > 1.0; action { set gsr.speed = 0; } }");
    assert_eq!(e, ["class Vehicle has no attribute altitude"]);
    let e = errors("plan p { trigger: teleport(gsr) ; action { set gsr.speed = 0; } }");
    assert!(e[0].starts_with("unknown function teleport()"), "{e:?}");
}

#[test]
fn type_errors_and_arity() {
    let e = errors(r#"plan p { trigger: gsr.speed > "fast"; action { set gsr.speed = 0; } }"#);
    assert_eq!(
        e,
        ["`>` needs two numbers (or two strings), found real and string"]
    );
    let e = errors(r#"plan p { trigger: gsr.speed; action { set gsr.speed = 0; } }"#);
    assert_eq!(e, ["a condition must be true or false, but this is real"]);
    let e = errors(r#"plan p { trigger: true; action { set gsr.speed = "stop"; } }"#);
    assert_eq!(e, ["gsr.speed is real, but this value is string"]);
    let e =
        errors("plan p { trigger: distance(gsr.position) > 1.0; action { set gsr.speed = 0; } }");
    assert_eq!(e, ["distance() takes 2 argument(s), got 1"]);
    let e = errors("plan p { trigger: age(3) > 1.0; action { set gsr.speed = 0; } }");
    assert_eq!(e, ["age() takes an attribute, like age(gsr.position)"]);
}

#[test]
fn quantifier_misuse() {
    let e = errors(
        "plan p { trigger: (count o: Obstacle where o.range < 1.0 by o.range) > 2; action { set gsr.speed = 0; } }",
    );
    assert_eq!(
        e,
        ["`by` orders the matches of `any` only, not of `count o: Obstacle`"]
    );
    let e = errors(
        "plan p { trigger: any o: Rock where o.range < 1.0; action { set gsr.speed = 0; } }",
    );
    assert!(e.contains(&"unknown class Rock".to_owned()), "{e:?}");
    let e =
        errors("plan p { trigger: any gsr: Obstacle where true; action { set gsr.speed = 0; } }");
    assert!(e[0].contains("already a name"), "{e:?}");
    // A variable is only visible inside its quantifier and, for `any` in the trigger, the action.
    let e = errors("plan p { initiation: any o: Obstacle where true; action { delete o; } }");
    assert_eq!(
        e,
        ["unknown name o: not an object, a class or a variable here"]
    );
}

#[test]
fn cyclic_derived_attributes_are_refused() {
    let e =
        errors("class Loop { a: real derived = self.b + 1.0; b: real derived = self.a * 2.0; }");
    assert_eq!(
        e,
        [
            "derived attribute a depends on itself",
            "derived attribute b depends on itself"
        ]
    );
}

#[test]
fn rules_cannot_create_or_delete() {
    let e = errors("on write gsr.speed { delete gsr; }");
    assert_eq!(
        e,
        ["create and delete are allowed in plans, not in `on write` rules"]
    );
}

#[test]
fn several_errors_are_all_reported_with_line_column_and_caret() {
    let src = "plan p {\n    trigger: gsr.speed > \"x\";\n    action { set gsr.sped = 1.0; }\n}";
    let err = load(src).unwrap_err();
    assert_eq!(err.diagnostics.len(), 2);
    let expected = "w.slate:6:14: error: `>` needs two numbers (or two strings), found real and string\n  \
        6 |     trigger: gsr.speed > \"x\";\n    |              ^^^^^^^^^^^^^^^\n\
        w.slate:7:22: error: class Vehicle has no attribute sped\n  \
        7 |     action { set gsr.sped = 1.0; }\n    |                      ^^^^";
    assert_eq!(err.rendered, expected);
}

#[test]
fn nothing_is_applied_when_a_file_has_an_error() {
    let (board, engine) = engine();
    let bad = "class Rover { speed: real; }\nobject r : Rover;\nplan p { trigger: r.spd > 1.0; action { set r.speed = 0; } }";
    assert!(engine.load("bad.slate", bad).is_err());
    assert!(board.class_def("Rover").is_none());
    assert!(board.info("r").is_none());
    assert!(engine.plans().is_empty());
}

#[test]
fn a_class_defined_differently_on_the_board_is_a_conflict() {
    let (_board, engine) = loaded("a.slate", "class Rover { speed: real; }");
    engine
        .load("again.slate", "class Rover { speed: real; }")
        .expect("identical is fine");
    let e = refused(&engine, "class Rover { speed: int; }");
    assert!(
        e.rendered
            .contains("class Rover is already defined differently"),
        "{}",
        e.rendered
    );
}

#[test]
fn the_builtin_classes_are_known_to_a_fresh_board_and_its_checker() {
    let board = Arc::new(Board::builder().clock(Clock::manual()).build());
    for class in ["Module", "Plan"] {
        assert!(board.class_def(class).is_some(), "{class}");
    }
    let engine = Engine::new(&board);
    engine
        .load(
            "w.slate",
            "plan watch { trigger: any m: Module where not m.alive; action { } }\n\
             plan quiet { trigger: all p: Plan where p.fired == 0; action { } }",
        )
        .unwrap();
}
