//! Parser unit tests: expression grouping, error recovery and the nesting cap. Each construct's
//! syntax tree is tested through the public API in `tests/lang`.

use super::{MAX_NESTING, MAX_PLAN_NESTING, parse};
use crate::ast::{Expr, Item};
use crate::diagnostic::{Diagnostic, Span, Stage};

/// The `trigger:` expression of `source` put in a plan, or the errors.
fn trigger(source: &str) -> Result<Expr, Vec<Diagnostic>> {
    let file = parse(&format!("plan p {{ trigger: {source}; action {{}} }}")).map_err(|d| d.0)?;
    match file.items.into_iter().next() {
        Some(Item::Plan(plan)) => plan.trigger.ok_or_else(Vec::new),
        other => panic!("not a plan: {other:?}"),
    }
}

/// Each source groups as its expected text.
fn assert_grouped(cases: &[(&str, &str)]) {
    for (source, expected) in cases {
        assert_eq!(grouped(source), *expected, "{source}");
    }
}

fn grouped(source: &str) -> String {
    match trigger(source) {
        Ok(expr) => expr.to_string(),
        Err(errors) => panic!("{source}: {errors:?}"),
    }
}

/// The messages of the errors of `source` (a whole file).
fn messages(source: &str) -> Vec<String> {
    match parse(source) {
        Ok(file) => panic!("parsed: {file:?}"),
        Err(errors) => errors.into_iter().map(|d| d.message).collect(),
    }
}

fn trigger_messages(source: &str) -> Vec<String> {
    match trigger(source) {
        Ok(expr) => panic!("parsed: {expr}"),
        Err(errors) => errors.into_iter().map(|d| d.message).collect(),
    }
}

#[test]
fn binary_operators_group_by_precedence() {
    let cases = [
        ("a or b and c", "(a or (b and c))"),
        ("a and b or c", "((a and b) or c)"),
        ("a == b and c != d", "((a == b) and (c != d))"),
        ("a < b + c", "(a < (b + c))"),
        ("a + b * c", "(a + (b * c))"),
        ("a * b + c % d", "((a * b) + (c % d))"),
        ("-a * b", "((-a) * b)"),
        ("a * -b.c", "(a * (-b.c))"),
        ("(a + b) * c", "((a + b) * c)"),
        ("a <= b or c >= d", "((a <= b) or (c >= d))"),
    ];
    assert_grouped(&cases);
}

#[test]
fn same_precedence_operators_associate_to_the_left() {
    assert_grouped(&[
        ("a - b - c", "((a - b) - c)"),
        ("a / b * c % d", "(((a / b) * c) % d)"),
        ("a or b or c", "((a or b) or c)"),
        ("a and b and c", "((a and b) and c)"),
    ]);
}

#[test]
fn not_binds_looser_than_comparison_and_tighter_than_and() {
    assert_grouped(&[
        ("not a == b", "(not (a == b))"),
        ("not a and b", "((not a) and b)"),
        ("a or not b and c", "(a or ((not b) and c))"),
        ("not not a", "(not (not a))"),
        ("- - a", "(-(-a))"),
        ("a == (not b)", "(a == (not b))"),
    ]);
}

#[test]
fn not_inside_a_comparison_must_be_parenthesized() {
    assert_eq!(
        trigger_messages("a == not b"),
        ["`not` applies to a whole comparison; parenthesize it to use it here, as in `(not ...)`"]
    );
}

#[test]
fn comparisons_do_not_chain() {
    for source in ["a < b < c", "a == b == c", "a < b >= c", "1 + 2 != 3 == x"] {
        let errors = trigger_messages(source);
        assert_eq!(errors.len(), 1, "{source}: {errors:?}");
        assert!(
            errors[0].starts_with("comparison operators cannot be chained"),
            "{errors:?}"
        );
    }
    assert_eq!(grouped("(a < b) == c"), "((a < b) == c)");
}

#[test]
fn postfix_fields_bind_tightest_and_chain() {
    assert_eq!(
        grouped("o.observer.position.accuracy"),
        "o.observer.position.accuracy"
    );
    assert_eq!(grouped("-x.speed"), "(-x.speed)");
    assert_eq!(grouped("age(x.pos).y"), "age(x.pos).y");
    assert_eq!(
        grouped("x.count + x.in + self.all"),
        "((x.count + x.in) + self.all)"
    );
}

#[test]
fn methods_are_rejected_with_a_hint() {
    assert_eq!(
        trigger_messages("x.speed.abs()"),
        ["`.abs(...)`: there are no methods; call functions by name, as in `abs(x)`"]
    );
}

#[test]
fn a_quantifier_condition_extends_to_the_right() {
    assert_eq!(
        grouped("x and any o: A where p or q"),
        "(x and (any o: A where (p or q)))"
    );
    assert_eq!(grouped("not any o: A where p"), "(not (any o: A where p))");
    assert_eq!(
        grouped("(count o: A where o.r < 5) > 2"),
        "((count o: A where (o.r < 5)) > 2)"
    );
    assert_eq!(grouped("1 + count o: A"), "(1 + (count o: A))");
}

#[test]
fn a_comparison_after_a_quantifier_condition_asks_for_parentheses() {
    let errors = trigger_messages("count o: Obstacle where o.range < 5 > 2");
    assert_eq!(
        errors,
        [
            "comparison operators cannot be chained: a quantifier's condition extends as far right \
         as it can, so parenthesize the quantifier to compare its result, as in \
         `(count o: Obstacle where ...) > ...`"
        ]
    );
    let inside_parentheses = trigger_messages("any o: A where (a < b < c)");
    assert!(
        inside_parentheses[0].contains("combine them with `and`"),
        "{inside_parentheses:?}"
    );
}

#[test]
fn an_operator_after_a_bare_quantifier_asks_for_parentheses() {
    assert_eq!(
        trigger_messages("count o: Obstacle > 2"),
        [
            "a quantifier must be parenthesized to be used as an operand, as in \
         `(count o: Obstacle ...) > ...`"
        ]
    );
    assert_eq!(
        trigger_messages("any o: A by o.r desc and x"),
        [
            "a quantifier must be parenthesized to be used as an operand, as in `(any o: A ...) and ...`"
        ]
    );
    assert_eq!(
        trigger_messages("any o: A.x"),
        [
            "a quantifier must be parenthesized to be used as an operand, as in `(any o: A ...).field`"
        ]
    );
}

#[test]
fn quantifier_forms_are_checked() {
    assert_eq!(
        trigger_messages("all o: A"),
        ["expected `where` and a condition after `all o: A`, found `;`"]
    );
    assert_eq!(
        trigger_messages("count o: A by o.x"),
        ["`by` orders the matches of `any` only, not of `count o: A`"]
    );
    assert_eq!(
        trigger_messages("any by: A"),
        ["expected a variable name after `any`, found keyword `by`"]
    );
}

fn nested_parentheses(levels: usize) -> String {
    format!("{}x{}", "(".repeat(levels), ")".repeat(levels))
}

#[test]
fn nesting_up_to_the_cap_parses() {
    assert_eq!(grouped(&nested_parentheses(MAX_NESTING)), "x");
    let negations = format!("{}x", "-".repeat(MAX_NESTING));
    assert!(trigger(&negations).is_ok());
}

#[test]
fn nesting_past_the_cap_is_one_error_not_a_crash() {
    let message = super::too_deep_expression();
    for source in [
        nested_parentheses(MAX_NESTING + 1),
        nested_parentheses(100_000),
        "[".repeat(100_000),
        "not ".repeat(100_000),
        "f(".repeat(100_000),
        "any o: A where ".repeat(10_000),
    ] {
        assert_eq!(trigger_messages(&source), [message.as_str()]);
    }
}

#[test]
fn plans_sent_inside_plans_are_capped_too() {
    let inline = |levels: usize| {
        let mut source = "plan p0 { action { report x; } }".to_owned();
        for level in 1..=levels {
            source = format!("plan p{level} {{ action {{ send {source} to \"m\"; }} }}");
        }
        source
    };
    assert!(parse(&inline(MAX_PLAN_NESTING - 1)).is_ok());
    let errors = messages(&inline(MAX_PLAN_NESTING));
    assert_eq!(errors, [super::too_deep_plans()]);
    assert_eq!(messages(&inline(5_000)).len(), 1);
}

#[test]
fn a_missing_semicolon_at_line_end_points_after_the_last_token() {
    let errors = parse("class A {\n    speed: real [m/s]\n}").unwrap_err();
    let error = &errors.0[0];
    assert_eq!(
        error.message,
        "expected `;` after attribute declaration, found `}`"
    );
    assert_eq!(error.span, Span::new(31, 31, 2, 22));
}

#[test]
fn a_missing_semicolon_at_line_end_does_not_swallow_the_next_line() {
    let errors = messages("class A {\n  a: int\n  b: real = 1 2;\n  c: bool\n}");
    assert_eq!(
        errors,
        [
            "expected `;` after attribute declaration, found `b`",
            "expected `;` after attribute declaration, found `2`",
            "expected `;` after attribute declaration, found `}`",
        ]
    );
}

#[test]
fn a_lexical_error_is_not_reported_again_by_the_parser() {
    let errors = parse("plan p { action { set x = 1 @ 2; } }").unwrap_err();
    assert_eq!(errors.len(), 1);
    assert_eq!(errors.0[0].stage, Stage::Lex);
}

#[test]
fn a_missing_brace_is_reported_once_for_all_open_blocks() {
    let errors = messages("plan p {\n  action {\n    report x;\n");
    assert_eq!(
        errors,
        ["expected `}` to close the `action` block, found end of file"]
    );
    let errors = messages("class A {\n  x: int;\nplan b { action {} }\nclass C { y: int = ; }");
    assert_eq!(
        errors,
        [
            "expected `}` to close class `A`, found `plan`",
            "expected an expression, found `;`"
        ]
    );
}

#[test]
fn recovery_skips_a_broken_statement_and_its_braces() {
    let source =
        "plan p { action {\n create A a context nowhere { x = 1; }\n delete a; report b c; } }";
    assert_eq!(
        messages(source),
        [
            "expected a context (`self`, `surroundings` or `system`), found `nowhere`",
            "expected `,`, `to` or `;` after the reported targets, found `c`",
        ]
    );
}

#[test]
fn a_broken_item_header_skips_to_the_next_item() {
    let source = "class { on write x { report y; } a: int; }\nobject o : A;\nfoo bar;\nplan q { }";
    assert_eq!(
        messages(source),
        [
            "expected a class name, found `{`",
            "expected `class`, `object`, `plan`, `on` or `link`, found `foo`",
            "plan `q` has no `action { ... }` block",
        ]
    );
}

#[test]
fn empty_and_blank_sources_parse_to_no_items() {
    for source in ["", "  \n\t", "// only a comment", ";;"] {
        assert_eq!(parse(source).map(|f| f.items.len()), Ok(0));
    }
}

#[test]
fn a_duplicate_clause_is_reported_even_when_the_first_is_broken() {
    assert_eq!(
        messages("plan p { trigger: a < ; trigger: b; action {} }"),
        [
            "expected an expression, found `;`",
            "duplicate `trigger` clause in plan `p`",
        ]
    );
}

#[test]
fn an_action_block_without_braces_is_one_error() {
    assert_eq!(
        messages("plan p { action set x = 1; }"),
        ["expected `{` to open the `action` block, found `set`"]
    );
}

#[test]
fn keywords_that_start_items_can_still_name_attributes() {
    let source = "class A { plan: string; on: bool; class: int; on write plan { } }\n\
                  object o : A { plan = \"x\"; on = true; }";
    let file = parse(source).unwrap_or_else(|e| panic!("{e}"));
    let Some(Item::Class(class)) = file.items.first() else {
        panic!("{file:?}")
    };
    let names: Vec<_> = class
        .attributes
        .iter()
        .map(|a| a.name.name.as_str())
        .collect();
    assert_eq!(names, ["plan", "on", "class"]);
    assert_eq!(class.rules[0].attribute.name, "plan");
    let Some(Item::Object(object)) = file.items.get(1) else {
        panic!("{file:?}")
    };
    assert_eq!(object.values.len(), 2);
}

#[test]
fn regression_item_keyword_named_member_in_an_action_block_looped_forever() {
    assert_eq!(
        messages("plan p { action { on = 1; plan: x; report y; } }"),
        [
            "expected an action (`set`, `report`, `send`, `create` or `delete`), found `on`",
            "expected an action (`set`, `report`, `send`, `create` or `delete`), found `plan`",
        ]
    );
}

#[test]
fn parsing_stops_after_too_many_errors() {
    let source = "class A {\n".to_owned() + &"  x: nosuchtype;\n".repeat(1000) + "}";
    let errors = messages(&source);
    assert_eq!(errors.len(), super::MAX_ERRORS + 1);
    assert_eq!(
        errors.last().map(String::as_str),
        Some("too many errors (256); stopping here")
    );
}

#[test]
fn a_missing_brace_at_line_end_is_assumed_and_reported_once() {
    let source = "plan p {\n  action\n    set x = 1;\n    report x;\n  }\n}\nplan q { action {} }";
    assert_eq!(
        messages(source),
        ["expected `{` to open the `action` block, found `set`"]
    );
    let source = "plan p { action {\n  create A a context self\n    x = 1;\n  }\n} }";
    assert_eq!(
        messages(source),
        ["expected `{` to open the values of `a`, found `x`"]
    );
}

/// `x OP 1 OP 1 ...` with `terms` operands: a left-deep tree, built by a loop, not by recursion.
fn chain(terms: usize, op: &str) -> String {
    format!("x{}", format!(" {op} 1").repeat(terms - 1))
}

/// The one error of `source` (a whole file), which must mention the nesting limit.
fn the_nesting_error(source: &str) -> Diagnostic {
    let errors = parse(source).map(|_| ()).unwrap_err().0;
    assert_eq!(errors.len(), 1, "{errors:?}");
    let limit = format!("at most {MAX_NESTING} levels");
    assert!(errors[0].message.contains(&limit), "{}", errors[0].message);
    errors.into_iter().next().unwrap_or_else(|| unreachable!())
}

#[test]
fn a_deep_operator_chain_is_refused_not_a_crash() {
    for terms in [MAX_NESTING + 2, 4_000, 100_000] {
        for op in ["+", "-", "*", "/", "%", "and", "or"] {
            let source = format!(
                "plan p {{\n  action {{}}\n  trigger: {};\n}}",
                chain(terms, op)
            );
            assert_eq!(the_nesting_error(&source).span.line, 3, "{op} x{terms}");
        }
    }
}

#[test]
fn an_operator_chain_up_to_the_cap_parses() {
    let expr = trigger(&chain(MAX_NESTING + 1, "+")).unwrap_or_else(|e| panic!("{e:?}"));
    assert_eq!(expr.depth(), MAX_NESTING);
    assert_eq!(trigger("x").map(|e| e.depth()), Ok(0));
}

#[test]
fn a_deep_member_access_is_refused_not_a_crash() {
    for fields in [MAX_NESTING + 1, 100_000] {
        let source = format!(
            "plan p {{ trigger: x{}; action {{}} }}",
            ".a".repeat(fields)
        );
        the_nesting_error(&source);
    }
    let deepest = format!("x{}", ".a".repeat(MAX_NESTING));
    assert_eq!(trigger(&deepest).map(|e| e.depth()), Ok(MAX_NESTING));
}

#[test]
fn parentheses_and_chains_add_up_to_one_cap() {
    // 40 levels of parentheses around chains of 40 operators: each count is under the cap,
    // the tree they make together is 1 600 levels deep.
    let mut source = chain(40, "+");
    for _ in 0..40 {
        source = format!("{} + ({source})", chain(40, "+"));
    }
    the_nesting_error(&format!("plan p {{ trigger: {source}; action {{}} }}"));
}

#[test]
fn deep_chains_are_refused_wherever_an_expression_goes() {
    let deep = chain(100_000, "+");
    for source in [
        format!("class A {{ x: real = {deep}; }}"),
        format!("class A {{ x: real in 0 .. {deep}; }}"),
        format!("object o : A {{ x = {deep}; }}"),
        format!("plan p {{ action {{ set o.x = 1 accuracy {deep}; }} }}"),
        format!("plan p {{ action {{ delete {deep}; }} }}"),
        format!("plan p {{ every {deep}; action {{}} }}"),
        format!("plan p {{ trigger: f({deep}); action {{}} }}"),
        format!("plan p {{ trigger: [1, {deep}]; action {{}} }}"),
        format!("plan p {{ trigger: any o: A where {deep}; action {{}} }}"),
        format!("link team {{ heartbeat {deep}; }}"),
    ] {
        the_nesting_error(&source);
    }
}
