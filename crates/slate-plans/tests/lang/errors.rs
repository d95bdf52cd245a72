//! Errors: duplicates, several errors per file, and the exact rendered text of diagnostics.

use slate_plans::{Diagnostic, Span, Stage, parse};

use crate::support::messages;

/// Lines joined with newlines, so that expected renderings line up in the test source.
fn lines(lines: &[&str]) -> String {
    lines.join("\n")
}

/// The rendered diagnostics of `source` as `world.slate`.
fn rendered(source: &str) -> String {
    match parse(source) {
        Ok(file) => panic!("unexpectedly parsed: {file:?}"),
        Err(errors) => errors.render("world.slate", source),
    }
}

#[test]
fn duplicate_attribute_options_are_errors() {
    let cases = [
        ("x: real [m] [s];", "duplicate unit in attribute `x`"),
        (
            "x: int in 0 .. 1 in 2 .. 3;",
            "duplicate `in` bounds in attribute `x`",
        ),
        (
            "x: real step 1 step 2;",
            "duplicate `step` in attribute `x`",
        ),
        ("x: real = 1 = 2;", "duplicate default in attribute `x`"),
        (
            "x: real derived = 1 derived = 2;",
            "duplicate `derived` in attribute `x`",
        ),
        (
            "x: real merge latest merge fused;",
            "duplicate `merge` in attribute `x`",
        ),
        (
            "x: real report every 1s report heartbeat 2s;",
            "duplicate `report` in attribute `x`",
        ),
        (
            "x: real report every 1s every 2s;",
            "duplicate `every` in the `report` options of attribute `x`",
        ),
        (
            "x: real report on_accuracy deadband 1 on_accuracy;",
            "duplicate `on_accuracy` in the `report` options of attribute `x`",
        ),
        (
            "x: real = 1 accuracy 0.1 accuracy 0.2;",
            "duplicate `accuracy`",
        ),
        (
            "x: real derived = y confidence 1 confidence 1;",
            "duplicate `confidence`",
        ),
    ];
    assert_attribute_errors(&cases);
}

#[test]
fn duplicate_plan_clauses_are_errors() {
    let cases = [
        (
            "plan p { initiation: a; initiation: b; action {} }",
            "initiation",
        ),
        ("plan p { trigger: a; action {} trigger: b; }", "trigger"),
        (
            "plan p { termination: a; termination: b; action {} }",
            "termination",
        ),
        ("plan p { every 1s; every 2s; action {} }", "every"),
        ("plan p { action {} action { delete x; } }", "action"),
    ];
    for (source, clause) in cases {
        assert_eq!(
            messages(source),
            [format!("duplicate `{clause}` clause in plan `p`")]
        );
    }
}

#[test]
fn duplicate_object_options_are_errors() {
    assert_eq!(
        messages("object o : A context self context system;"),
        ["duplicate `context`"]
    );
    assert_eq!(
        messages(r#"object o : A owner "a" owner "b";"#),
        ["duplicate `owner`"]
    );
}

#[test]
fn attribute_shape_errors() {
    let cases = [
        (
            "x: real = 1 derived = 2;",
            "attribute `x` cannot have both a default value and `derived`: a derived value is \
             computed on every read",
        ),
        (
            "x: real accuracy 0.1;",
            "`accuracy` must follow a default value (`= ...`) or `derived = ...`",
        ),
        (
            "x: float;",
            "unknown type `float`: expected a type (`int`, `real`, `bool`, `string`, `ref` or \
             `vec<N>`)",
        ),
        (
            "x: vec<0>;",
            "vector length must be between 1 and 4294967295",
        ),
        ("x: vec<n>;", "expected a vector length, found `n`"),
        (
            "x: real [];",
            "empty unit: leave out the brackets for a quantity without unit",
        ),
        (
            "x: real report;",
            "expected `every`, `heartbeat`, `deadband` or `on_accuracy` after `report`, found `;`",
        ),
        (
            "Vehicle.max_speed = 3.0;",
            "a class body declares attributes (`name: type ...;`) and `on write` rules; write \
             values with an object or a `set` action",
        ),
    ];
    assert_attribute_errors(&cases);
}

#[test]
fn three_broken_attributes_give_three_diagnostics() {
    let source = "class A {\n    a: real = ;\n    b: flaot;\n    c: int in 0 .. ;\n    d: bool;\n}";
    let errors = parse(source).unwrap_err();
    let found: Vec<_> = errors
        .iter()
        .map(|d| (d.span.line, d.message.as_str()))
        .collect();
    assert_eq!(
        found,
        [
            (2, "expected an expression, found `;`"),
            (
                3,
                "unknown type `flaot`: expected a type (`int`, `real`, `bool`, `string`, `ref` or \
             `vec<N>`)"
            ),
            (4, "expected an expression, found `;`"),
        ]
    );
    assert!(errors.iter().all(|d| d.stage == Stage::Parse));
}

#[test]
fn errors_in_every_kind_of_item_are_all_reported() {
    let source = r#"
class A { x: real = "unterminated; }
object o : A { x = 1 }
on write o.x { set = 2; }
plan p { trigger: x < ; action { report; send q; create A; delete ; } }
plan ok { action { report o.x; } }
"#;
    let errors = parse(source).unwrap_err();
    let found: Vec<_> = errors
        .iter()
        .map(|d| (d.span.line, d.stage, d.message.as_str()))
        .collect();
    assert_eq!(
        found,
        [
            (2, Stage::Lex, "unterminated string: add a closing `\"`"),
            (
                3,
                Stage::Parse,
                "expected `;` after the attribute value, found `}`"
            ),
            (
                4,
                Stage::Parse,
                "expected an attribute to set, as in `gsr.speed`, found `=`"
            ),
            (5, Stage::Parse, "expected an expression, found `;`"),
            (
                5,
                Stage::Parse,
                "expected an object or attribute to report, found `;`"
            ),
            (
                5,
                Stage::Parse,
                "expected `to` and a destination address, found `;`"
            ),
            (
                5,
                Stage::Parse,
                "expected a name for the new object, found `;`"
            ),
            (5, Stage::Parse, "expected an expression, found `;`"),
        ]
    );
}

#[test]
fn renders_a_missing_semicolon_after_the_last_token() {
    let source = "class Vehicle {\n  // speed\n  speed: real [m/s]\n}\n";
    assert_eq!(
        rendered(source),
        lines(&[
            "world.slate:3:20: error: expected `;` after attribute declaration, found `}`",
            "  3 |   speed: real [m/s]",
            "    |                    ^",
        ])
    );
}

#[test]
fn renders_an_unterminated_string_under_its_opening_quote() {
    let source = "object gsr : Vehicle {\n    mode = \"auto;\n}";
    assert_eq!(
        rendered(source),
        lines(&[
            "world.slate:2:12: error: unterminated string: add a closing `\"`",
            "  2 |     mode = \"auto;",
            "    |            ^^^^^^",
        ])
    );
}

#[test]
fn renders_stray_characters() {
    let source = "plan p {\n  trigger: a && b;\n  action {}\n}";
    assert_eq!(
        rendered(source),
        lines(&[
            "world.slate:2:14: error: unexpected `&&`; use `and`",
            "  2 |   trigger: a && b;",
            "    |              ^^",
        ])
    );
}

#[test]
fn renders_a_chained_comparison() {
    let source = "plan p { trigger: 0 < x < 1; action {} }";
    assert_eq!(
        rendered(source),
        lines(&[
            "world.slate:1:25: error: comparison operators cannot be chained: combine them with \
         `and`, as in `a < b and b < c`",
            "  1 | plan p { trigger: 0 < x < 1; action {} }",
            "    |                         ^",
        ])
    );
}

#[test]
fn renders_a_duplicate_clause_under_its_keyword() {
    let source = "plan p {\n\ttrigger: a;\n\ttrigger: b;\n\taction {}\n}";
    assert_eq!(
        rendered(source),
        lines(&[
            "world.slate:3:2: error: duplicate `trigger` clause in plan `p`",
            "  3 | \ttrigger: b;",
            "    | \t^^^^^^^",
        ])
    );
}

#[test]
fn renders_an_unknown_type_and_a_too_large_integer_together() {
    let source = "class A {\n  n: integer;\n  m: int = 99999999999999999999;\n}";
    assert_eq!(
        rendered(source),
        lines(&[
            "world.slate:2:6: error: unknown type `integer`: expected a type (`int`, `real`, `bool`, \
         `string`, `ref` or `vec<N>`)",
            "  2 |   n: integer;",
            "    |      ^^^^^^^",
            "world.slate:3:12: error: integer literal `99999999999999999999` is too large (the \
         maximum is 9223372036854775807)",
            "  3 |   m: int = 99999999999999999999;",
            "    |            ^^^^^^^^^^^^^^^^^^^^",
        ])
    );
}

#[test]
fn renders_a_missing_closing_brace_at_end_of_file() {
    let source = "plan p {\n  action {\n    delete x;\n";
    assert_eq!(
        rendered(source),
        lines(&[
            "world.slate:3:14: error: expected `}` to close the `action` block, found end of file",
            "  3 |     delete x;",
            "    |              ^",
        ])
    );
}

#[test]
fn renders_a_quantifier_that_needs_parentheses() {
    let source = "plan p {\n  trigger: count o: Obstacle where o.range < 5 > 2;\n  action {}\n}";
    assert_eq!(
        rendered(source),
        lines(&[
            "world.slate:2:48: error: comparison operators cannot be chained: a quantifier's \
         condition extends as far right as it can, so parenthesize the quantifier to compare \
         its result, as in `(count o: Obstacle where ...) > ...`",
            "  2 |   trigger: count o: Obstacle where o.range < 5 > 2;",
            "    |                                                ^",
        ])
    );
}

#[test]
fn checker_diagnostics_render_the_same_way() {
    let source = "object o : Vehicel;";
    let span = Span::new(11, 18, 1, 12);
    let error = Diagnostic::error(Stage::Check, span, "unknown class `Vehicel`");
    assert_eq!(
        error.render("w.slate", source),
        lines(&[
            "w.slate:1:12: error: unknown class `Vehicel`",
            "  1 | object o : Vehicel;",
            "    |            ^^^^^^^",
        ])
    );
}

#[test]
fn diagnostics_are_a_std_error() {
    let errors = parse("class").unwrap_err();
    let boxed: Box<dyn std::error::Error> = Box::new(errors);
    assert_eq!(
        boxed.to_string(),
        "1:6: error: expected a class name, found end of file"
    );
}

/// Each attribute declaration, alone in a class, gives exactly its one message.
fn assert_attribute_errors(cases: &[(&str, &str)]) {
    for (attribute, message) in cases {
        assert_eq!(
            messages(&format!("class A {{ {attribute} }}")),
            [*message],
            "{attribute}"
        );
    }
}
