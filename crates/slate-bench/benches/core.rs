//! `cargo bench -p slate-bench --bench core`: the operations `slate bench core` measures,
//! on the same board, under divan's harness.

use std::collections::HashMap;
use std::hint::black_box;

use divan::Bencher;
use slate_bench::Cycle;
use slate_bench::core::{packet, world};
use slate_model::{Board, Key, Packet, Update};

fn main() {
    divan::main();
}

/// The suite's board with its 10 000 obstacles; built once per benchmark.
fn board() -> Board {
    world(10_000)
}

fn key(b: &Board, object: &str, attr: &str) -> Key {
    b.key(object, attr).expect("key")
}

/// Writes the next of `values` to `key` per iteration.
fn write_cycle(bencher: Bencher, b: &Board, key: Key, mut values: Cycle) {
    bencher.bench_local(|| b.write_key(key, values.next_value()));
}

/// 10 objects of 8 attributes, as `(object, attr)` ids.
fn map() -> HashMap<(u32, u32), Packet> {
    (0..10u32)
        .flat_map(|o| (0..8u32).map(move |a| ((o, a), packet())))
        .collect()
}

#[divan::bench]
fn hashmap_get(bencher: Bencher) {
    let map = map();
    bencher.bench_local(|| map.get(black_box(&(3, 4))).cloned());
}

#[divan::bench]
fn hashmap_insert(bencher: Bencher) {
    let mut map = map();
    let p = packet();
    bencher.bench_local(|| map.insert(black_box((3, 4)), p.clone()));
}

#[divan::bench]
fn read(bencher: Bencher) {
    let b = board();
    let own = key(&b, "v0", "speed");
    bencher.bench_local(|| b.read_key(black_box(own)));
}

#[divan::bench]
fn read_inherited(bencher: Bencher) {
    let b = board();
    let inherited = key(&b, "v0", "mode");
    bencher.bench_local(|| b.read_key(black_box(inherited)));
}

#[divan::bench]
fn read_by_name(bencher: Bencher) {
    let b = board();
    bencher.bench_local(|| b.read(black_box("v0"), "speed"));
}

#[divan::bench]
fn write(bencher: Bencher) {
    let b = board();
    let own = key(&b, "v0", "speed");
    write_cycle(bencher, &b, own, Cycle::new(0.0, 49.0));
}

#[divan::bench]
fn write_full_packet(bencher: Bencher) {
    let b = board();
    let own = key(&b, "v0", "speed");
    let mut values = Cycle::new(0.0, 49.0);
    bencher.bench_local(|| {
        let v = values.next_value();
        b.write_key(own, Update::new(v).accuracy(0.1).confidence(0.9))
    });
}

#[divan::bench]
fn batch10(bencher: Bencher) {
    let b = board();
    let keys: Vec<Key> = (0..10).map(|i| key(&b, &format!("v{i}"), "x")).collect();
    let mut values = Cycle::new(0.0, 49.0);
    bencher.bench_local(|| {
        let v = values.next_value();
        let mut batch = b.batch();
        for k in &keys {
            batch.write_key(*k, v);
        }
        batch.commit()
    });
}

#[divan::bench]
fn write_active_fn(bencher: Bencher) {
    let b = board();
    b.on_write("v9", "heading", |_| Ok(())).expect("attach");
    let heading = key(&b, "v9", "heading");
    write_cycle(bencher, &b, heading, Cycle::new(0.0, 7.0));
}

#[divan::bench]
fn query_10k(bencher: Bencher) {
    let b = board();
    bencher.bench_local(|| b.instances(black_box("Obstacle")).expect("query"));
}

#[divan::bench]
fn clock_now(bencher: Bencher) {
    let b = board();
    let clock = b.clock().clone();
    bencher.bench_local(|| clock.now());
}
