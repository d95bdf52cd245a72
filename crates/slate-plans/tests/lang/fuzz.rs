//! The parser never panics, and every diagnostic points inside the source at the right line and
//! column: random bytes, random soups of the language's tokens, and mutated example files.

use std::sync::mpsc;
use std::thread;
use std::time::Duration;

use proptest::prelude::*;
use proptest::sample::{Index, select};
use slate_plans::{Diagnostics, parse};

const GSR: &str = include_str!("../../../../examples/gsr.slate");
const SMALL: &str = r#"class V : Thing { s: real [m/s] in 0 .. 5 = 1 report every 1s; on write s { report self; } }
object g : V context self owner "a/b/c" { s = 2 accuracy 0.1; }
plan p { trigger: any o: V where o.s > 1 by o.s desc; every 1s;
  action { set g.s = 0, g.t = [1.0, 2]; send plan q { action { delete o; } } to "x/y"; create V n { s = 1; } } }"#;

/// Token texts of the language, including broken ones.
const TOKENS: &[&str] = &[
    "class",
    "object",
    "plan",
    "on",
    "write",
    "read",
    "set",
    "report",
    "send",
    "create",
    "delete",
    "any",
    "all",
    "count",
    "where",
    "by",
    "desc",
    "and",
    "or",
    "not",
    "true",
    "false",
    "none",
    "in",
    "step",
    "derived",
    "merge",
    "every",
    "heartbeat",
    "deadband",
    "context",
    "owner",
    "accuracy",
    "confidence",
    "initiation",
    "trigger",
    "termination",
    "action",
    "to",
    "self",
    "on_accuracy",
    "surroundings",
    "system",
    "int",
    "real",
    "vec",
    "Vehicle",
    "x",
    "speed",
    "{",
    "}",
    "(",
    ")",
    "[",
    "]",
    ",",
    ";",
    ":",
    ".",
    "..",
    "=",
    "==",
    "!=",
    "<",
    "<=",
    ">",
    ">=",
    "+",
    "-",
    "*",
    "/",
    "%",
    "42",
    "2.5",
    "1e-3",
    "250ms",
    "3min",
    "99999999999999999999",
    "1e999",
    "5kg",
    "\"s\"",
    "\"a\\\"b\"",
    "\"open",
    "\"bad\\q\"",
    "[m/s]",
    "// note\n",
    "\n",
    "@",
    "é",
    "&&",
    "!",
    "\t",
];

/// Where token soups are put (at `$`), to exercise every kind of block and its recovery.
const CONTEXTS: &[&str] = &[
    "$",
    "class A { $ }",
    "object o : A { $ }",
    "plan p { $ }",
    "plan p { action { $ } }",
    "on write a.b { send plan q { $ } to \"m\"; }",
    "plan p { trigger: $; action {} }",
];

/// Checks that every diagnostic's span is inside `source` and matches its line and column.
fn check_spans(source: &str, errors: &Diagnostics) -> Result<(), TestCaseError> {
    prop_assert!(!errors.is_empty());
    for error in errors {
        let span = error.span;
        prop_assert!(
            span.start <= span.end && span.end <= source.len(),
            "{error:?}"
        );
        prop_assert!(source.is_char_boundary(span.start) && source.is_char_boundary(span.end));
        let before = &source[..span.start];
        let line = before.matches('\n').count() + 1;
        let col = before.rsplit('\n').next().unwrap_or("").chars().count() + 1;
        prop_assert_eq!(
            (span.line as usize, span.col as usize),
            (line, col),
            "{:?}",
            error
        );
        let rendered = error.render("f", source);
        prop_assert!(rendered.contains('^'), "{}", rendered);
    }
    Ok(())
}

/// Parses `source` on another thread, failing (rather than hanging) if it takes too long.
fn check(source: &str) -> Result<(), TestCaseError> {
    let (done, result) = mpsc::channel();
    let owned = source.to_owned();
    thread::spawn(move || done.send(parse(&owned).err()));
    match result.recv_timeout(Duration::from_secs(30)) {
        Ok(None) => Ok(()),
        Ok(Some(errors)) => check_spans(source, &errors),
        Err(_) => Err(TestCaseError::fail(format!(
            "parse hung or panicked on {source:?}"
        ))),
    }
}

/// `source` with its chars in `[from, from + len)` replaced by `insert`.
fn mutate(source: &str, from: Index, len: usize, insert: &str) -> String {
    let chars: Vec<char> = source.chars().collect();
    let start = from.index(chars.len() + 1);
    let end = (start + len).min(chars.len());
    chars[..start]
        .iter()
        .chain(insert.chars().collect::<Vec<_>>().iter())
        .chain(&chars[end..])
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
        check(&String::from_utf8_lossy(&bytes))?;
    }

    #[test]
    fn random_token_soups_never_panic(
        tokens in prop::collection::vec((select(TOKENS), select(&[" ", "", "\n"][..])), 0..80),
        context in select(CONTEXTS),
    ) {
        let soup: String = tokens.iter().flat_map(|(token, sep)| [*token, *sep]).collect();
        check(&context.replace('$', &soup))?;
    }

    #[test]
    fn mutated_examples_never_panic(
        edits in prop::collection::vec((any::<Index>(), 0..12usize, select(TOKENS)), 1..4),
        gsr in any::<bool>(),
    ) {
        let mut source = if gsr { GSR.to_owned() } else { SMALL.to_owned() };
        for (from, len, insert) in edits {
            source = mutate(&source, from, len, insert);
        }
        check(&source)?;
    }
}

#[test]
fn the_unmutated_fuzz_seeds_parse() {
    assert!(parse(SMALL).is_ok(), "{:?}", parse(SMALL).err());
    assert!(parse(GSR).is_ok());
}
