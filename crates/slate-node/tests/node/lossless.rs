//! A lossless class (`IciConfig::lossless`) over real Zenoh sessions on 127.0.0.1: every
//! update reaches the receiver, in order, while the other classes' reports are dropped
//! and catch-ups close the gaps they leave.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use slate_ici::{ClassSet, Flow, IciConfig, MsgKind};
use slate_model::{Address, AttrDecl, ChangeItem, ClassDef, Filter, ValueType};
use slate_testing::{eventually, free_port};
use slate_transport::tap::Tapped;
use slate_zenoh::ZenohConfig;

use crate::support::ZenohModule;

fn classes() -> Vec<ClassDef> {
    vec![
        ClassDef::new("Event").attr(AttrDecl::new("seq", ValueType::Real)),
        ClassDef::new("Gauge").attr(AttrDecl::new("level", ValueType::Real)),
    ]
}

#[test]
fn every_event_arrives_in_order_while_catch_ups_close_the_gaps_of_the_other_class() {
    // The writer writes a gauge (best effort: one report in three is dropped, so the
    // receiver's stream has gaps and it asks for catch-ups) and an event (lossless),
    // while its ICI answers those catch-ups on Zenoh's threads. Two ways this lost
    // events, both fixed:
    // - an answer carries the board's current state: when it held writes not reported
    //   yet, their reports came after it and the receiver refused them as older (runs
    //   of events missing in mid-stream);
    // - the first report, which announces the names and the epoch every later report
    //   uses, was a gauge's, and was dropped: the events' reports could not be decoded
    //   until a catch-up brought the names (the first events missing).
    const EVENTS: u32 = 20_000;
    let port = free_port();
    let endpoint = vec![format!("tcp/127.0.0.1:{port}")];
    let open = IciConfig::default().export(ClassSet::all());
    let writer = ZenohModule::open(
        &Address::new("t/r1/writer").unwrap(),
        &classes(),
        &ZenohConfig {
            listen: endpoint.clone(),
            ..ZenohConfig::default()
        },
        open.clone().lossless(ClassSet::none().class("Event")),
        |zenoh| {
            // One report in three published best effort is lost, as Zenoh drops them
            // on a congested link.
            let latest = AtomicU64::new(0);
            Arc::new(Tapped::new(zenoh, move |_, kind, flow| {
                let report = kind == MsgKind::Report && flow == Flow::Latest;
                !(report && latest.fetch_add(1, Ordering::Relaxed).is_multiple_of(3))
            }))
        },
    );
    let receiver = ZenohModule::open(
        &Address::new("t/r1/receiver").unwrap(),
        &classes(),
        &ZenohConfig {
            connect: endpoint,
            ..ZenohConfig::default()
        },
        open,
        |zenoh| zenoh,
    );
    let board = writer.board();
    board.create("Event", "ev").unwrap();
    board.create("Gauge", "tank").unwrap();
    let seen = receiver.board().watch(Filter::class("Event")).unwrap();
    let met = eventually(Duration::from_secs(20), || {
        receiver.board().read("tank", "level").is_ok()
    });
    assert!(met, "the receiver never heard the writer");
    std::thread::sleep(Duration::from_millis(300)); // the receiver's interest arrived
    for i in 1..=EVENTS {
        board.write("tank", "level", f64::from(i)).unwrap();
        board.write("ev", "seq", f64::from(i)).unwrap();
    }
    let last = f64::from(EVENTS);
    let holds = |object: &str, attr: &str| {
        let v = receiver.board().read(object, attr).ok();
        v.and_then(|p| p.value.as_f64()) == Some(last)
    };
    let caught_up = eventually(Duration::from_secs(60), || {
        holds("ev", "seq") && holds("tank", "level")
    });
    let mut events = Vec::new();
    while let Some(change) = seen.try_recv() {
        for item in change.items {
            if let ChangeItem::Write { attr, packet, .. } = item
                && &*attr == "seq"
            {
                events.extend(packet.value.as_f64());
            }
        }
    }
    let stats = receiver.ici.stats();
    writer.close();
    receiver.close();
    assert!(caught_up, "the receiver did not get the final values");
    assert!(
        stats.catch_up.completed > 0,
        "no gap was caught up: {:?}",
        stats.catch_up
    );
    let missing: Vec<f64> = (1..=EVENTS)
        .map(f64::from)
        .filter(|v| !events.contains(v))
        .collect();
    assert!(
        missing.is_empty(),
        "{} events missing, in runs {:?}",
        missing.len(),
        runs(&missing)
    );
    let expected: Vec<f64> = (1..=EVENTS).map(f64::from).collect();
    assert!(events == expected, "every event once, in order");
}

/// `values` (ascending, whole numbers) as runs of consecutive ones: `(first, last)`.
fn runs(values: &[f64]) -> Vec<(f64, f64)> {
    let mut runs: Vec<(f64, f64)> = Vec::new();
    for &v in values {
        match runs.last_mut() {
            Some(run) if run.1 + 1.0 == v => run.1 = v,
            _ => runs.push((v, v)),
        }
    }
    runs
}
