//! Helpers the area modules share: parsing, and an engine on a fresh board.

use std::sync::Arc;

use slate_model::{Board, Clock};
use slate_plans::{Diagnostics, Engine, Expr, File, Item, LoadError, parse};

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

/// An engine on a fresh board with a manual clock, and the board.
pub fn engine() -> (Arc<Board>, Engine) {
    let board = Arc::new(Board::builder().clock(Clock::manual()).build());
    let engine = Engine::new(&board);
    (board, engine)
}

/// An engine on a fresh board that has loaded `source` as `file`, and the board.
pub fn loaded(file: &str, source: &str) -> (Arc<Board>, Engine) {
    let (board, engine) = engine();
    engine
        .load(file, source)
        .unwrap_or_else(|e| panic!("{file}: {e}"));
    (board, engine)
}

/// The error of loading `source` (as `b.slate`) on `engine`, which must refuse it.
pub fn refused(engine: &Engine, source: &str) -> LoadError {
    engine.load("b.slate", source).unwrap_err()
}

/// An engine that loaded `first` (as `a.slate`) and then refused `second` (as
/// `b.slate`): the board, the engine, and the error.
pub fn refused_after(first: &str, second: &str) -> (Arc<Board>, Engine, LoadError) {
    let (board, engine) = loaded("a.slate", first);
    let error = refused(&engine, second);
    (board, engine, error)
}
