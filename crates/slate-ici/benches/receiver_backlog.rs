//! A receiver behind a gap: what each message costs it as the backlog above the gap
//! grows (issue 16, finding 8). Not a test: it prints figures for docs/performance.md.
//!
//! `cargo bench -p slate-ici --bench receiver_backlog`
//!
//! Two modules of two robots on the simulator (`t/r1/w` writes, `t/r2/r` receives; the
//! team link clean, 100 µs, so that batches arrive in little virtual time). For each backlog B, a fresh pair: the writer's next report is lost at the
//! receiver (a gap), then it writes B + 5000 updates of one attribute, delivered in
//! batches of 1000; the figure is the median of the wall times the last five batches
//! took to deliver (the simulator delivering them, the receiver decoding, ordering and
//! merging each), per message. The receiver's `gap_grace` is an hour, so no catch-up closes the gap
//! while it is measured. The baseline, in the same run, is the same stream with no
//! loss (`in order`).

use std::sync::Arc;
use std::time::{Duration, Instant};

use slate_ici::{ClassSet, Ici, IciConfig, LinkConfig, LinkKind, MsgKind, SimConfig, SimNet};
use slate_model::{Address, AttrDecl, Board, ClassDef, ValueType};

/// Messages per delivery batch, and in the measured batch.
const BATCH: u64 = 1000;

/// Batches measured (the median is reported).
const MEASURED: usize = 5;

/// Virtual time each batch is given to arrive (well within `gap_grace`).
const DELIVER: Duration = Duration::from_millis(5);

fn main() {
    println!("receiver cost per message behind an open gap (simulator, team link)");
    println!("{:>10} {:>14} {:>12}", "backlog", "ns/message", "in order");
    for backlog in [1_000, 10_000, 100_000] {
        let baseline = cost_per_message(backlog, false);
        let gapped = cost_per_message(backlog, true);
        println!("{backlog:>10} {gapped:>14.0} {baseline:>12.0}");
    }
}

/// Wall nanoseconds per message of the last batch after `backlog` messages, with the
/// first message lost (`gap`) or not.
fn cost_per_message(backlog: u64, gap: bool) -> f64 {
    let fast = SimConfig {
        team: LinkConfig::clean().delay(Duration::from_micros(100)),
        ..SimConfig::default()
    };
    let net = SimNet::with_config(1, fast);
    let (w, r) = (address("t/r1/w"), address("t/r2/r"));
    let open = IciConfig::default().export(ClassSet::all());
    let writer = module(&net, &w, open.clone());
    let patient = IciConfig {
        gap_grace: Duration::from_secs(3600),
        ..open
    };
    let receiver = module(&net, &r, patient);
    writer.board().create("Cell", "c").expect("create");
    writer.board().write("c", "v", 0_i64).expect("write");
    net.run_for(Duration::from_secs(2));
    let asked = receiver.stats().catch_up.requested;
    if gap {
        net.drop_next_publish(&w, std::slice::from_ref(&r));
    }
    let mut v = 1_i64;
    let mut deliver = |n: u64| {
        for _ in 0..n {
            writer.board().write("c", "v", v).expect("write");
            v += 1;
        }
        let start = Instant::now();
        net.run_for(DELIVER);
        start.elapsed()
    };
    deliver(1);
    (0..backlog / BATCH).for_each(|_| {
        deliver(BATCH);
    });
    let mut took: Vec<Duration> = (0..MEASURED).map(|_| deliver(BATCH)).collect();
    took.sort();
    let stats = receiver.stats();
    let reports = stats.traffic[&(LinkKind::Team, MsgKind::Report)].recv_msgs;
    let sent = 1 + backlog + MEASURED as u64 * BATCH;
    assert_eq!(
        reports,
        sent - u64::from(gap),
        "the one lost report is the gap"
    );
    assert_eq!(
        stats.catch_up.requested, asked,
        "no catch-up closed the gap"
    );
    assert_eq!(
        receiver.board().read("c", "v").map(|p| p.value),
        Ok((v - 1).into())
    );
    took[took.len() / 2].as_nanos() as f64 / BATCH as f64
}

fn module(net: &SimNet, address: &Address, config: IciConfig) -> Ici {
    let board = Board::builder()
        .clock(net.clock())
        .address(address.clone())
        .build();
    board
        .define(ClassDef::new("Cell").attr(AttrDecl::new("v", ValueType::Int)))
        .expect("define");
    Ici::new(Arc::new(board), net.join(address), config).expect("ici")
}

fn address(text: &str) -> Address {
    Address::new(text).expect("address")
}
