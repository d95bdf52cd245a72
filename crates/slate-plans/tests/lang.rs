//! Integration tests of the slate language front end, through the public API only: one test
//! binary, one module per area in `tests/lang/`.

// The checker: names, types, arities, quantifiers and cycles, with positions.
#[path = "lang/checker.rs"]
mod checker;
// Errors: duplicates, several errors per file, and the exact rendered text of diagnostics.
#[path = "lang/errors.rs"]
mod errors;
// The example files at the repository root parse, and say what they are meant to say.
#[path = "lang/examples.rs"]
mod examples;
// Expression forms: literals, names and paths, calls, vectors, quantifiers.
#[path = "lang/expressions.rs"]
mod expressions;
// The parser never panics, and every diagnostic points inside the source.
#[path = "lang/fuzz.rs"]
mod fuzz;
// The paper's Ground Surveillance Robot (`examples/gsr.slate`) loaded and run.
#[path = "lang/gsr_run.rs"]
mod gsr_run;
// One test per construct: classes, attributes, objects, active functions, plans and actions.
#[path = "lang/items.rs"]
mod items;
// Nesting limits: deep input refused, never a crash; the deepest accepted runs on a small stack.
#[path = "lang/limits.rs"]
mod limits;
// Link policies: `link team { ... }` parsed, checked with positions, merged.
#[path = "lang/links.rs"]
mod links;
// Loading is all-or-nothing: a file with any error applies nothing.
#[path = "lang/load.rs"]
mod load;
// The plan engine: the truth table of initiation, trigger and termination.
#[path = "lang/plans.rs"]
mod plans;
// Helpers the area modules share: parsing, and an engine on a fresh board.
#[path = "lang/support.rs"]
mod support;
