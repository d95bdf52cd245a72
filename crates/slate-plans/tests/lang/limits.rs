//! Nesting limits (docs/language.md, "Limits"): input nested deeper than [`MAX_NESTING`] is
//! refused with an error naming the limit and the line, never a crash; the deepest input
//! accepted is parsed, checked, run, printed and dropped on a small stack.

use std::sync::Arc;

use slate_model::{Board, Clock, Value};
use slate_plans::{Engine, Item, MAX_NESTING, MAX_PLAN_NESTING, Outgoing, parse};

/// The cells the deep expressions read: `c.next` refers back to `c`, so a chain of `.next`
/// can be as long as the cap allows.
const WORLD: &str = r#"
    class Cell { v: real = 1.0; on: bool = false; next: ref; }
    object c : Cell { next = c; }
    object log : Cell;
"#;

/// `x + 1 + 1 ...` with `terms` operands, on line 3 of a plan.
fn chained_plan(terms: usize) -> String {
    let chain = format!("c.v{}", " + 1.0".repeat(terms - 1));
    format!("plan p {{\n  action {{}}\n  trigger: {chain} > 0.0;\n}}")
}

#[test]
fn a_deep_operator_chain_is_refused_by_the_engine_not_a_crash() {
    for terms in [4_000, 100_000] {
        let (_, engine) = engine_with_world();
        let error = engine.load("deep.slate", &chained_plan(terms)).unwrap_err();
        let limit = format!("at most {MAX_NESTING} levels");
        assert!(error.rendered.starts_with("deep.slate:3:"), "{error}");
        assert!(error.rendered.contains(&limit), "{error}");
        assert!(
            engine.status("p").is_none(),
            "nothing of the file is applied"
        );
    }
}

/// Boolean expressions exactly [`MAX_NESTING`] levels deep, one per kind of nesting, each
/// true on [`WORLD`] once `c.on` is.
fn deepest_conditions() -> Vec<(&'static str, String)> {
    let levels = MAX_NESTING - 2; // `(... ) > 0.0` and `c.v` take one level each
    let numeric = |open: &str, close: &str| {
        format!(
            "{}c.v{} > 0.0 and c.on",
            open.repeat(levels - 1),
            close.repeat(levels - 1)
        )
    };
    vec![
        (
            "left-deep chain",
            format!("c.v{} > 0.0 and c.on", " + 1.0".repeat(levels - 1)),
        ),
        ("right-deep chain", numeric("1.0 + (", ")")),
        (
            "negations",
            format!("{}c.v < 0.0 and c.on", "-".repeat(levels - 1)),
        ),
        ("calls", numeric("abs(", ")")),
        (
            "references",
            format!("c{}.v > 0.0 and c.on", ".next".repeat(levels - 1)),
        ),
        (
            "nots",
            format!("{}(c.on and c.on)", "not not ".repeat(levels / 2)),
        ),
        (
            "quantifiers",
            (1..MAX_NESTING).fold("c.on".to_owned(), |inner, level| {
                format!("any q{level}: Cell where {inner}")
            }),
        ),
    ]
}

/// A plan `p0` whose trigger is `condition`, sent inside plans `MAX_PLAN_NESTING - 1` deep.
fn deepest_plans(condition: &str) -> String {
    let mut text = format!("plan p0 {{ trigger: {condition}; action {{ set log.v = 2.0; }} }}");
    for level in 1..MAX_PLAN_NESTING {
        text =
            format!("plan p{level} {{ trigger: c.on; action {{ send {text} to \"t/r2/x\"; }} }}");
    }
    text
}

/// The stack the deepest accepted input is shown to fit in, in the test (unoptimized) build:
/// half the 2 MiB of a Rust thread or a Tokio worker (Zenoh's receive threads are Tokio
/// workers). Measured: the deepest expressions need more than 640 KiB and at most 768 KiB
/// (the parser on a right-deep chain), 16 plans in plans around the deepest expression
/// more than 512 KiB and at most 768 KiB (docs/language.md, "Limits"); an optimized build
/// needs less.
const SMALL_STACK: usize = 1024 * 1024;

/// Runs `work` on a thread with [`SMALL_STACK`] bytes of stack; a stack overflow aborts the
/// test binary, so this passing is the measurement.
fn on_a_small_stack(work: impl FnOnce() + Send + 'static) {
    on_a_stack(SMALL_STACK, work);
}

fn on_a_stack(bytes: usize, work: impl FnOnce() + Send + 'static) {
    let thread = std::thread::Builder::new().stack_size(bytes);
    let handle = thread.spawn(work).unwrap_or_else(|e| panic!("spawn: {e}"));
    handle
        .join()
        .unwrap_or_else(|_| panic!("the work panicked"));
}

/// `text` without parentheses and blanks: what printing an expression keeps of its source.
fn bare(text: &str) -> String {
    text.chars().filter(|c| !"() ".contains(*c)).collect()
}

fn engine_with_world() -> (Arc<Board>, Engine) {
    let board = Arc::new(Board::builder().clock(Clock::manual()).build());
    let engine = Engine::new(&board);
    engine
        .load("world.slate", WORLD)
        .unwrap_or_else(|e| panic!("{e}"));
    (board, engine)
}

#[test]
fn the_deepest_accepted_expressions_run_on_a_small_stack() {
    for (kind, condition) in deepest_conditions() {
        on_a_small_stack(move || {
            let text = format!("plan p {{ trigger: {condition}; action {{ set log.v = 2.0; }} }}");
            let file = parse(&text).unwrap_or_else(|e| panic!("{kind}: {e}"));
            let Some(Item::Plan(plan)) = file.items.first() else {
                panic!("{kind}")
            };
            let trigger = plan.trigger.as_ref().unwrap_or_else(|| panic!("{kind}"));
            assert_eq!(trigger.depth(), MAX_NESTING, "{kind}");
            assert_eq!(
                bare(&trigger.to_string()),
                bare(&condition),
                "printed, {kind}"
            );
            let (board, engine) = engine_with_world();
            engine
                .load("deep.slate", &text)
                .unwrap_or_else(|e| panic!("{kind}: {e}"));
            board
                .write("c", "on", true)
                .unwrap_or_else(|e| panic!("{e}"));
            let fired = board.read("log", "v").map(|p| p.value);
            assert_eq!(fired.ok(), Some(Value::Real(2.0)), "{kind}");
        });
    }
}

#[test]
fn the_deepest_accepted_plans_in_plans_run_on_a_small_stack() {
    let (_, condition) = deepest_conditions().swap_remove(1); // the right-deep chain: the worst
    on_a_small_stack(move || {
        let (board, engine) = engine_with_world();
        let text = deepest_plans(&condition);
        let outgoing = engine.outgoing();
        engine
            .load("deep.slate", &text)
            .unwrap_or_else(|e| panic!("{e}"));
        board
            .write("c", "on", true)
            .unwrap_or_else(|e| panic!("{e}"));
        let sent: Vec<Outgoing> = outgoing.try_iter().collect();
        let [Outgoing::Plan(plan)] = sent.as_slice() else {
            panic!("{sent:?}")
        };
        let (_receiver_board, receiver) = engine_with_world();
        receiver
            .load("sent.slate", &plan.text)
            .unwrap_or_else(|e| panic!("{e}"));
    });
}

/// A class whose attribute `a{i}` is derived from `a{i-1}`, `attributes` long, one object of
/// it, and a plan reading the last one.
fn derived_chain(attributes: usize) -> String {
    let mut class = "class Chain {\n  a0: real = 1.0;\n".to_owned();
    for i in 1..attributes {
        class += &format!("  a{i}: real derived = self.a{} + 1.0;\n", i - 1);
    }
    let last = attributes - 1;
    format!("{class}}}\nobject k : Chain;\nplan p {{ trigger: k.a{last} > 0.0; action {{}} }}\n")
}

#[test]
fn a_long_chain_of_derived_attributes_is_refused_not_a_crash() {
    for attributes in [MAX_NESTING + 2, 10_000] {
        let (_board, engine) = engine_with_world();
        let error = engine
            .load("chain.slate", &derived_chain(attributes))
            .unwrap_err();
        let limit = format!("more than {MAX_NESTING} deep");
        assert!(
            error.rendered.contains(&limit),
            "{}",
            &error.rendered[..2_000.min(error.rendered.len())]
        );
        assert!(engine.status("p").is_none());
    }
    let (_board, engine) = engine_with_world();
    engine
        .load("chain.slate", &derived_chain(MAX_NESTING + 1))
        .unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn a_source_with_thousands_of_errors_reports_the_first_256() {
    // 32 KiB of `set a.b = 1;` (no object a), on one line: 2 500 errors, each quoting it.
    let actions = "set a.b = 1; ".repeat(2_500);
    let text = format!("plan many {{ trigger: c.on; action {{ {actions}}} }}");
    let (_board, engine) = engine_with_world();
    let error = engine.load("many.slate", &text).unwrap_err();
    let messages: Vec<&str> = error
        .diagnostics
        .iter()
        .map(|d| d.message.as_str())
        .collect();
    assert_eq!(messages.len(), 257, "{:?}", &messages[..3]);
    assert_eq!(
        messages[256],
        "too many errors (2500); the first 256 are shown"
    );
    assert!(
        error.rendered.len() < 256 * 400,
        "{} bytes",
        error.rendered.len()
    );
}

/// A class whose `a{i}` is derived from `a{i-1}` inside an expression [`MAX_NESTING`] deep,
/// `attributes` long, and one object `k` of it.
fn deep_derived_chain(attributes: usize) -> String {
    let deep = |inner: String| {
        let levels = MAX_NESTING - 2; // `self.a` and the outermost `+` take one level each
        format!("{}{inner}{}", "1.0 + (".repeat(levels), ")".repeat(levels))
    };
    let mut class = "class D {\n  a0: real = 1.0;\n".to_owned();
    for i in 1..attributes {
        class += &format!(
            "  a{i}: real derived = {};\n",
            deep(format!("self.a{}", i - 1))
        );
    }
    format!("{class}}}\nobject k : D;\n")
}

#[test]
fn the_deepest_derived_chain_a_board_evaluates_fits_in_two_mib() {
    // A read runs one active function per derived attribute inside one another, as deep as
    // the board allows (DEFAULT_MAX_DEPTH + 1 of them here), each evaluating an expression
    // at the cap: measured unoptimized, 1 MiB is not enough, 2 MiB (a Rust thread's, a
    // Tokio worker's) is.
    let attributes = slate_model::DEFAULT_MAX_DEPTH + 2;
    on_a_stack(2 * 1024 * 1024, move || {
        let (board, engine) = engine_with_world();
        let source = deep_derived_chain(attributes + 1);
        engine
            .load("d.slate", &source)
            .unwrap_or_else(|e| panic!("{e}"));
        let deepest = board
            .read("k", &format!("a{}", attributes - 1))
            .map(|p| p.value);
        let expected = 1.0 + (attributes - 1) as f64 * (MAX_NESTING - 2) as f64;
        assert_eq!(deepest.ok(), Some(Value::Real(expected)));
        let cut = board.read("k", &format!("a{attributes}")).map(|p| p.value);
        assert_eq!(
            cut.ok(),
            Some(Value::None),
            "one more is cut by the board, not a crash"
        );
    });
}
