//! `slate bench plans`: the plan engine's costs. The baseline is the same write on a board
//! whose engine has no plan at all, measured in the same run.

use std::fmt::Write as _;
use std::hint::black_box;
use std::sync::Arc;
use std::time::Instant;

use slate_model::{Board, Clock, Key};
use slate_plans::Engine;

use crate::{Config, Figures, measure, median};

/// The classes every plan of the suite reads: `Cell` (`v`, `w`) and `Obstacle` (`range`).
pub const WORLD: &str =
    "class Cell { v: real = 0.0; w: real = 0.0; }\nclass Obstacle { range: real = 100.0; }\n";

/// A board on a manual clock with its plan engine, [`WORLD`] loaded.
pub fn engine() -> (Arc<Board>, Engine) {
    let board = Arc::new(Board::builder().clock(Clock::manual()).build());
    let engine = Engine::new(&board);
    engine.load("world.slate", WORLD).expect("world loads");
    (board, engine)
}

/// A plan on `x.v` whose trigger stays false over the suite's writes.
pub const DEPENDENT: &str = "plan dep { trigger: x.v > 1000000.0; action { set x.w = 1.0; } }";

/// [`engine`] with the object `x` and the plan `act`, which fires when `x.v` goes above
/// 0.5 and copies it to `x.w`; the key of `x.v`.
pub fn acting() -> (Arc<Board>, Engine, Key) {
    let (board, engine) = engine();
    engine
        .load(
            "a.slate",
            "object x : Cell;\nplan act { trigger: x.v > 0.5; action { set x.w = x.v; } }",
        )
        .expect("act");
    let key = board.key("x", "v").expect("key");
    (board, engine, key)
}

/// [`engine`] with 10 000 obstacles and the plan `crowd`, whose trigger counts them; the
/// key of `o5.range`, which the quantifier reads.
pub fn crowd() -> (Arc<Board>, Engine, Key) {
    let (board, engine) = engine();
    let mut batch = board.batch();
    for i in 0..10_000 {
        batch.create("Obstacle", &format!("o{i}"));
    }
    batch.commit().expect("10k obstacles");
    engine
        .load("q.slate", "object x : Cell;\nplan crowd { trigger: (count o: Obstacle where o.range < 5.0) > 20000; action { set x.w = 1.0; } }")
        .expect("crowd");
    let key = board.key("o5", "range").expect("key");
    (board, engine, key)
}

/// `n` cells and one plan per cell whose trigger never fires.
pub fn unrelated(n: usize) -> String {
    let mut s = String::new();
    for i in 0..n {
        let _ = writeln!(s, "object c{i} : Cell;");
        let _ = writeln!(
            s,
            "plan p{i} {{ trigger: c{i}.v > 1000000.0; action {{ set c{i}.w = 1.0; }} }}"
        );
    }
    s
}

/// Runs the suite; `progress` is told each step.
pub fn run(cfg: &Config, progress: &mut dyn FnMut(&str)) -> Figures {
    let mut r =
        Figures::new("slate bench plans: plan engine (write costs vs the same write with no plan)");
    progress("compiling 1000 plans");
    r.add("compile_1000_plans_ms", compile_1000(cfg));
    progress("writes");
    writes(cfg, &mut r);
    progress("write to action");
    write_to_action(cfg, &mut r);
    progress("quantifier over 10 000 objects");
    quantifier(cfg, &mut r);
    r
}

fn compile_1000(cfg: &Config) -> f64 {
    let source = format!("{WORLD}{}", unrelated(1000));
    let times: Vec<f64> = (0..cfg.samples.clamp(3, 7))
        .map(|_| {
            let board = Arc::new(Board::builder().clock(Clock::manual()).build());
            let engine = Engine::new(&board);
            let start = Instant::now();
            engine
                .load("bench.slate", &source)
                .expect("1000 plans load");
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    median(times)
}

fn write_loop(cfg: &Config, board: &Board, key: Key) -> f64 {
    let mut values = crate::Cycle::new(0.0, 100.0);
    measure(cfg, || {
        let v = values.next_value();
        drop(black_box(board.write_key(key, v)));
    })
}

fn writes(cfg: &Config, r: &mut Figures) {
    let (board, engine) = engine();
    engine.load("x.slate", "object x : Cell;").expect("x");
    let key = board.key("x", "v").expect("key");
    r.add("write_no_plans_ns", write_loop(cfg, &board, key));
    engine.load("dep.slate", DEPENDENT).expect("dep");
    r.compare(
        "write_1_dependent_ns",
        write_loop(cfg, &board, key),
        "write_no_plans_ns",
        None,
    );
    engine
        .load("many.slate", &unrelated(10_000))
        .expect("10k plans");
    let ns = write_loop(cfg, &board, key);
    r.compare(
        "write_1_dependent_10k_unrelated_ns",
        ns,
        "write_1_dependent_ns",
        Some(2.0),
    );
}

/// Write→action latency: a write that makes a trigger true, evaluates the plan and applies
/// its action (all synchronous, in the writer's thread). Measured as writes alternating
/// between firing and not firing, minus the writes that do not fire (same plan, values
/// that keep the trigger false).
fn write_to_action(cfg: &Config, r: &mut Figures) {
    let (board, engine, key) = acting();
    let mut on = false;
    let pair = measure(cfg, || {
        on = !on;
        drop(black_box(board.write_key(key, if on { 1.0 } else { 0.0 })));
    }) * 2.0;
    let fired = engine.status("act").expect("act").fired;
    assert!(fired > 0, "the action ran");
    let mut low = false;
    let quiet = measure(cfg, || {
        low = !low;
        drop(black_box(board.write_key(key, if low { 0.1 } else { 0.0 })));
    });
    assert_eq!(
        engine.status("act").expect("act").fired,
        fired,
        "the quiet writes did not fire"
    );
    r.add("write_no_action_ns", quiet);
    r.add("write_to_action_ns", pair - quiet);
}

fn quantifier(cfg: &Config, r: &mut Figures) {
    let (board, _engine, key) = crowd();
    let mut values = crate::Cycle::new(50.0, 90.0);
    let ns = measure(cfg, || {
        let v = values.next_value();
        drop(black_box(board.write_key(key, v)));
    });
    r.add("quantifier_10k_ns", ns);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plans_suite_reports_every_field() {
        let j = run(&crate::TINY, &mut |_| {}).json();
        crate::assert_fields(
            &j,
            &[
                "compile_1000_plans_ms",
                "write_no_plans_ns",
                "write_1_dependent_ns",
                "write_1_dependent_10k_unrelated_ns",
                "write_to_action_ns",
                "quantifier_10k_ns",
            ],
            f64::is_finite,
        );
    }
}
