//! `cargo bench -p slate-bench --bench plans`: the operations `slate bench plans`
//! measures, on the same plans, under divan's harness.

use std::hint::black_box;
use std::sync::Arc;

use divan::Bencher;
use slate_bench::Cycle;
use slate_bench::plans::{DEPENDENT, WORLD, acting, crowd, engine, unrelated};
use slate_model::{Board, Clock, Key};
use slate_plans::Engine;

fn main() {
    divan::main();
}

/// Writes `x.v` on a board whose engine also holds `plans` (and the object `x`).
fn write_loop(bencher: Bencher, plans: &[&str]) {
    let (board, engine) = engine();
    engine.load("x.slate", "object x : Cell;").expect("x");
    for (i, source) in plans.iter().enumerate() {
        engine
            .load(&format!("p{i}.slate"), source)
            .expect("plans load");
    }
    let key: Key = board.key("x", "v").expect("key");
    write_cycle(bencher, &board, key, Cycle::new(0.0, 100.0));
}

/// Writes the next of `values` to `key` per iteration.
fn write_cycle(bencher: Bencher, board: &Board, key: Key, mut values: Cycle) {
    bencher.bench_local(|| board.write_key(key, values.next_value()));
}

#[divan::bench]
fn write_no_plans(bencher: Bencher) {
    write_loop(bencher, &[]);
}

#[divan::bench]
fn write_1_dependent(bencher: Bencher) {
    write_loop(bencher, &[DEPENDENT]);
}

#[divan::bench]
fn write_1_dependent_10k_unrelated(bencher: Bencher) {
    write_loop(bencher, &[DEPENDENT, &unrelated(10_000)]);
}

/// A pair of writes, one making `act`'s trigger true (the action runs) and one false.
#[divan::bench]
fn write_to_action_pair(bencher: Bencher) {
    let (board, _engine, key) = acting();
    bencher.bench_local(|| {
        drop(black_box(board.write_key(key, 1.0)));
        board.write_key(key, 0.0)
    });
}

#[divan::bench]
fn quantifier_10k(bencher: Bencher) {
    let (board, _engine, key) = crowd();
    write_cycle(bencher, &board, key, Cycle::new(50.0, 90.0));
}

/// Loading 1000 plans into a fresh engine (the board and engine are made untimed).
#[divan::bench(sample_count = 7, sample_size = 1)]
fn compile_1000_plans(bencher: Bencher) {
    let source = format!("{WORLD}{}", unrelated(1000));
    bencher
        .with_inputs(|| {
            let board = Arc::new(Board::builder().clock(Clock::manual()).build());
            (Engine::new(&board), board)
        })
        .bench_local_values(|(engine, board)| {
            engine
                .load("bench.slate", &source)
                .expect("1000 plans load");
            (engine, board)
        });
}
