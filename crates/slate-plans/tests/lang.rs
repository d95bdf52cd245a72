//! Integration tests of the slate language front end, through the public API only: one test
//! binary, one module per area in `tests/lang/`.

#[path = "lang/checker.rs"]
mod checker;
#[path = "lang/errors.rs"]
mod errors;
#[path = "lang/examples.rs"]
mod examples;
#[path = "lang/expressions.rs"]
mod expressions;
#[path = "lang/fuzz.rs"]
mod fuzz;
#[path = "lang/gsr_run.rs"]
mod gsr_run;
#[path = "lang/items.rs"]
mod items;
#[path = "lang/load.rs"]
mod load;
#[path = "lang/plans.rs"]
mod plans;

use slate_plans::{Diagnostics, Expr, File, Item, parse};

/// Parses `source`, failing the test with the rendered diagnostics if it does not parse.
pub fn parse_ok(source: &str) -> File {
    parse(source).unwrap_or_else(|errors: Diagnostics| panic!("{}", errors.render("test", source)))
}

/// The messages of every diagnostic of `source`, failing the test if it parses.
pub fn messages(source: &str) -> Vec<String> {
    match parse(source) {
        Ok(file) => panic!("unexpectedly parsed: {file:?}"),
        Err(errors) => errors.into_iter().map(|d| d.message).collect(),
    }
}

/// The only item of `source`.
pub fn only_item(source: &str) -> Item {
    let mut items = parse_ok(source).items;
    assert_eq!(items.len(), 1, "{items:?}");
    items.remove(0)
}

/// An optional expression as fully parenthesized text.
pub fn text(expr: Option<&Expr>) -> Option<String> {
    expr.map(ToString::to_string)
}
