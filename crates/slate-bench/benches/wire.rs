//! `cargo bench -p slate-bench --bench wire`: the time to encode the reports whose sizes
//! `slate bench wire` prints, from the same steady-state sender, under divan's harness.

use divan::Bencher;
use slate_bench::wire::{SEQ, SteadySender};
use slate_wire::Assertion;

fn main() {
    divan::main();
}

/// Encodes the first `n` of the sender's 100 updates as one report, repeatedly.
fn encode_updates(bencher: Bencher, n: usize) {
    encode_repeatedly(bencher, |sender| sender.updates[..n].to_vec());
}

/// Encodes the report `pick` takes from a new steady sender, repeatedly, each time with
/// the next sequence number.
fn encode_repeatedly(bencher: Bencher, pick: impl FnOnce(&SteadySender) -> Vec<Assertion>) {
    let mut sender = SteadySender::new().expect("steady sender");
    let items = pick(&sender);
    let mut seq = SEQ;
    bencher
        .with_inputs(|| items.clone())
        .bench_local_values(|items| {
            seq += 1;
            sender.encode(seq, items).expect("encodes")
        });
}

#[divan::bench]
fn encode_single_update(bencher: Bencher) {
    encode_updates(bencher, 1);
}

#[divan::bench]
fn encode_batch100(bencher: Bencher) {
    encode_updates(bencher, 100);
}

#[divan::bench]
fn encode_pose(bencher: Bencher) {
    encode_repeatedly(bencher, |sender| sender.pose.clone());
}
