//! Expression forms: literals, names and paths, calls, vectors, quantifiers.

use slate_plans::{BinaryOp, Expr, ExprKind, Item, Literal, Quantifier, QuantifierKind, Span};

use crate::support::parse_ok;

/// The `trigger:` expression of a plan.
fn expr(source: &str) -> Expr {
    let file = parse_ok(&format!("plan p {{ trigger: {source}; action {{}} }}"));
    match file.items.into_iter().next() {
        Some(Item::Plan(plan)) => plan.trigger.expect("trigger"),
        other => panic!("{other:?}"),
    }
}

fn literal(source: &str) -> Literal {
    match expr(source).kind {
        ExprKind::Literal(literal) => literal,
        other => panic!("{source}: {other:?}"),
    }
}

fn quantifier(source: &str) -> Quantifier {
    match expr(source).kind {
        ExprKind::Quantifier(quantifier) => *quantifier,
        other => panic!("{source}: {other:?}"),
    }
}

#[test]
fn literals_keep_their_values() {
    let cases = [
        ("42", Literal::Int(42)),
        ("2.5", Literal::Real(2.5)),
        ("1e-3", Literal::Real(0.001)),
        ("250ms", Literal::Duration(0.25)),
        ("2s", Literal::Duration(2.0)),
        ("1.5s", Literal::Duration(1.5)),
        ("3min", Literal::Duration(180.0)),
        ("1h", Literal::Duration(3600.0)),
        (
            r#""a \"q\" \\ \n""#,
            Literal::Str("a \"q\" \\ \n".to_owned()),
        ),
        ("true", Literal::Bool(true)),
        ("false", Literal::Bool(false)),
        ("none", Literal::None),
    ];
    for (source, expected) in cases {
        assert_eq!(literal(source), expected, "{source}");
    }
    assert_eq!(literal("10us"), Literal::Duration(10.0 * 1e-6));
}

#[test]
fn paths_are_a_name_then_field_accesses() {
    let path = expr("gsr.speed.accuracy");
    let ExprKind::Field(base, accuracy) = &path.kind else {
        panic!("{path:?}")
    };
    let ExprKind::Field(root, speed) = &base.kind else {
        panic!("{base:?}")
    };
    let ExprKind::Name(gsr) = &root.kind else {
        panic!("{root:?}")
    };
    assert_eq!(
        [&gsr.name, &speed.name, &accuracy.name],
        ["gsr", "speed", "accuracy"]
    );
    assert_eq!(accuracy.span, Span::new(28, 36, 1, 29));
    assert_eq!(path.span, Span::new(18, 36, 1, 19));
}

#[test]
fn self_is_a_name() {
    let ExprKind::Field(root, range) = expr("self.range").kind else {
        panic!()
    };
    assert_eq!(
        root.kind,
        ExprKind::Name(slate_plans::Ident {
            name: "self".to_owned(),
            span: Span::new(18, 22, 1, 19)
        })
    );
    assert_eq!(range.name, "range");
}

#[test]
fn contextual_keywords_are_field_names_after_a_dot() {
    for field in [
        "accuracy",
        "confidence",
        "timestamp",
        "source",
        "count",
        "action",
    ] {
        let ExprKind::Field(_, name) = expr(&format!("x.speed.{field}")).kind else {
            panic!()
        };
        assert_eq!(name.name, field);
    }
}

#[test]
fn calls_take_any_name_and_arguments() {
    let cases = [
        ("now()", "now", 0),
        ("age(x.pos)", "age", 1),
        ("changed(x, 0.5)", "changed", 2),
        ("polar(r, theta,)", "polar", 2),
        ("whatever(1, 2, 3)", "whatever", 3),
    ];
    for (source, name, arity) in cases {
        let ExprKind::Call(callee, args) = expr(source).kind else {
            panic!("{source}")
        };
        assert_eq!((callee.name.as_str(), args.len()), (name, arity));
    }
}

#[test]
fn vectors_hold_expressions() {
    let ExprKind::Vector(items) = expr("[1.0, -2.0, x.y]").kind else {
        panic!()
    };
    let items: Vec<_> = items.iter().map(ToString::to_string).collect();
    assert_eq!(items, ["1.0", "(-2.0)", "x.y"]);
    assert_eq!(expr("[]").kind, ExprKind::Vector(Vec::new()));
}

#[test]
fn binary_expressions_span_both_operands() {
    let sum = expr("a + b * c");
    let ExprKind::Binary(BinaryOp::Add, lhs, rhs) = &sum.kind else {
        panic!()
    };
    assert_eq!(
        (lhs.to_string(), rhs.to_string()),
        ("a".to_owned(), "(b * c)".to_owned())
    );
    assert_eq!(sum.span, Span::new(18, 27, 1, 19));
}

#[test]
fn any_with_where_by_and_desc() {
    let nearest = quantifier("any o: Obstacle where o.range < 5.0 by o.range desc");
    assert_eq!(nearest.kind, QuantifierKind::Any);
    assert_eq!(
        (nearest.var.name.as_str(), nearest.class.name.as_str()),
        ("o", "Obstacle")
    );
    assert_eq!(
        nearest.filter.map(|f| f.to_string()).as_deref(),
        Some("(o.range < 5.0)")
    );
    let order = nearest.order.expect("order");
    assert_eq!(
        (order.key.to_string(), order.descending),
        ("o.range".to_owned(), true)
    );
}

#[test]
fn any_without_where_and_ascending_order() {
    let first = quantifier("any t: Target by age(t.position)");
    assert!(first.filter.is_none());
    let order = first.order.expect("order");
    assert_eq!(
        (order.key.to_string(), order.descending),
        ("age(t.position)".to_owned(), false)
    );
    assert!(quantifier("any t: Target").order.is_none());
}

#[test]
fn all_requires_where() {
    let every = quantifier("all v: Vehicle where v.alive and v.speed < 1.0");
    assert_eq!(every.kind, QuantifierKind::All);
    assert_eq!(
        every.filter.map(|f| f.to_string()).as_deref(),
        Some("(v.alive and (v.speed < 1.0))")
    );
    assert!(every.order.is_none());
}

#[test]
fn count_with_and_without_where() {
    let near = quantifier("count o: Obstacle where o.range < 5");
    assert_eq!(
        (near.kind, near.filter.is_some()),
        (QuantifierKind::Count, true)
    );
    let all = quantifier("count o: Obstacle");
    assert_eq!(
        (all.kind, all.filter.is_none()),
        (QuantifierKind::Count, true)
    );
}

#[test]
fn a_parenthesized_quantifier_is_an_operand() {
    let compared = expr("(count o: Obstacle where o.range < 5) > 2");
    let ExprKind::Binary(BinaryOp::Gt, lhs, _) = &compared.kind else {
        panic!("{compared:?}")
    };
    assert!(matches!(lhs.kind, ExprKind::Quantifier(_)));
}
