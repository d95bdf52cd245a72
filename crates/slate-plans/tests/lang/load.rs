//! Loading is all-or-nothing: a file with any error applies nothing, and every error
//! carries the position of what is wrong.

use slate_plans::LoadError;

use crate::support::{engine, loaded, refused_after};

/// The (line, column, message) of each diagnostic.
fn positions(e: &LoadError) -> Vec<(u32, u32, String)> {
    e.diagnostics
        .iter()
        .map(|d| (d.span.line, d.span.col, d.message.clone()))
        .collect()
}

#[test]
fn a_failed_load_applies_nothing() {
    let (board, engine) = engine();
    let bad = "class A { x: real in 0 .. 1; }\nobject o : A { x = 5.0; }";
    let e = engine.load("w.slate", bad).unwrap_err();
    assert!(board.class_def("A").is_none(), "{e}");
    assert!(board.info("o").is_none(), "{e}");
    let good = "class A { x: real in 0 .. 1; }\nobject o : A { x = 0.5; }";
    engine.load("w.slate", good).unwrap();
    assert_eq!(board.read("o", "x").unwrap().value.as_f64(), Some(0.5));
}

#[test]
fn an_out_of_bounds_initial_value_is_reported_at_the_value() {
    let (_board, engine) = engine();
    let bad = "class A { x: real in 0 .. 1; }\nobject o : A { x = 5.0; }";
    let e = engine.load("w.slate", bad).unwrap_err();
    let p = positions(&e);
    assert_eq!(p.len(), 1, "{p:?}");
    assert_eq!((p[0].0, p[0].1), (2, 20), "{p:?}");
    assert!(p[0].2.contains("outside the declared bounds"), "{p:?}");
    assert!(
        e.rendered.starts_with("w.slate:2:20: error: "),
        "{}",
        e.rendered
    );
}

#[test]
fn a_bad_confidence_or_accuracy_is_reported_at_its_expression() {
    let (board, engine) = engine();
    let cases = [
        ("confidence 2.0", 35, "confidence 2 must be between 0 and 1"),
        ("accuracy -1", 33, "accuracy -1 must be finite and >= 0"),
    ];
    for (quality, column, says) in cases {
        let bad = format!("class A {{ x: real; }}\nobject o : A {{ x = 1.0 {quality}; }}");
        let p = positions(&engine.load("w.slate", &bad).unwrap_err());
        assert_eq!((p[0].0, p[0].1), (2, column), "{p:?}");
        assert!(p[0].2.contains(says), "{p:?}");
    }
    assert!(board.class_def("A").is_none());
}

#[test]
fn a_computed_initial_value_that_fails_rolls_the_whole_load_back() {
    let (board, engine) = loaded("base.slate", "class B { y: real = 5.0; }\nobject b : B;");
    let bad = "class A { x: real in 0 .. 1; }\nobject o : A { x = b.y; }\n\
               on write B.y { set b.y = 1.0; }\nplan p { trigger: o.x > 0.5; action { set o.x = 0.0; } }";
    let e = engine.load("w.slate", bad).unwrap_err();
    let p = positions(&e);
    assert_eq!((p[0].0, p[0].1), (2, 20), "{p:?}");
    assert!(board.class_def("A").is_none(), "{e}");
    assert!(board.info("o").is_none(), "{e}");
    assert!(board.info("p").is_none(), "{e}");
    assert!(engine.status("p").is_none());
    // The rule on the class that existed before is not left attached.
    board.write("b", "y", 2.0).unwrap();
    assert_eq!(board.read("b", "y").unwrap().value.as_f64(), Some(2.0));
}

#[test]
fn a_default_outside_its_bounds_is_reported_at_the_default() {
    let (board, engine) = engine();
    let e = engine
        .load("w.slate", "class A { x: real in 0 .. 1 = 5.0; }")
        .unwrap_err();
    let p = positions(&e);
    assert_eq!((p[0].0, p[0].1), (1, 31), "{p:?}");
    assert!(p[0].2.contains("outside the declared bounds"), "{p:?}");
    assert!(board.class_def("A").is_none());
}

#[test]
fn a_plan_named_like_an_existing_object_is_reported_at_its_name() {
    let (board, _engine, e) = refused_after(
        "class A { x: real; }\nobject o : A;",
        "object n : A;\nplan o { trigger: true; action { set n.x = 1.0; } }",
    );
    let p = positions(&e);
    assert_eq!((p[0].0, p[0].1), (2, 6), "{p:?}");
    assert!(board.info("n").is_none(), "{e}");
}

#[test]
fn redefining_a_builtin_class_says_it_is_built_in() {
    let (_board, engine) = engine();
    for (src, name) in [
        ("class Thing { x: real; }", "Thing"),
        ("class Module { y: real; }", "Module"),
    ] {
        let e = engine.load("w.slate", src).unwrap_err();
        let p = positions(&e);
        assert_eq!((p[0].0, p[0].1), (1, 7), "{p:?}");
        assert!(
            p[0].2.contains(&format!("{name} is a built-in class")),
            "{p:?}"
        );
        assert!(!p[0].2.contains("  "), "{p:?}");
    }
}
