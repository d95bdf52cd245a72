//! Reports that linger (`IciConfig::linger`) over real Zenoh sessions on 127.0.0.1: a
//! burst of writes goes in a few reports, and the receiver ends with the last value.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use slate_ici::{ClassSet, IciConfig, MsgKind};
use slate_model::{Address, AttrDecl, ClassDef, ValueType};
use slate_testing::{eventually, free_port};
use slate_transport::tap::Tapped;
use slate_zenoh::ZenohConfig;

use crate::support::ZenohModule;

/// Writes `WRITES` values as fast as a loop can and counts the report messages the
/// writer publishes, with reports lingering `linger`.
fn burst(linger: Duration) -> (u64, bool) {
    const WRITES: u32 = 2_000;
    let port = free_port();
    let endpoint = vec![format!("tcp/127.0.0.1:{port}")];
    let classes = [ClassDef::new("Gauge").attr(AttrDecl::new("level", ValueType::Real))];
    let config = IciConfig {
        linger,
        ..IciConfig::default().export(ClassSet::all())
    };
    let reports = Arc::new(AtomicU64::new(0));
    let counted = reports.clone();
    let writer = ZenohModule::open(
        &Address::new("t/r1/writer").unwrap(),
        &classes,
        &ZenohConfig {
            listen: endpoint.clone(),
            ..ZenohConfig::default()
        },
        config.clone(),
        |zenoh| {
            Arc::new(Tapped::new(zenoh, move |_, kind, _| {
                if kind == MsgKind::Report {
                    counted.fetch_add(1, Ordering::Relaxed);
                }
                true
            }))
        },
    );
    let receiver = ZenohModule::open(
        &Address::new("t/r1/receiver").unwrap(),
        &classes,
        &ZenohConfig {
            connect: endpoint,
            ..ZenohConfig::default()
        },
        config,
        |zenoh| zenoh,
    );
    let board = writer.board();
    board.create("Gauge", "tank").unwrap();
    let met = eventually(Duration::from_secs(20), || {
        receiver.board().read("tank", "level").is_ok()
    });
    assert!(met, "the receiver never heard the writer");
    std::thread::sleep(Duration::from_millis(300)); // the receiver's interest arrived
    let before = reports.load(Ordering::Relaxed);
    for i in 1..=WRITES {
        board.write("tank", "level", f64::from(i)).unwrap();
    }
    let last = Some(f64::from(WRITES));
    let arrived = eventually(Duration::from_secs(20), || {
        let held = receiver.board().read("tank", "level").ok();
        held.and_then(|p| p.value.as_f64()) == last
    });
    let sent = reports.load(Ordering::Relaxed) - before;
    writer.close();
    receiver.close();
    (sent, arrived)
}

#[test]
fn a_burst_of_writes_goes_in_a_few_reports_and_the_last_value_arrives() {
    let (lingering, arrived) = burst(Duration::from_millis(5));
    assert!(arrived, "the last value never arrived (lingering)");
    let (at_once, arrived) = burst(Duration::ZERO);
    assert!(arrived, "the last value never arrived (no linger)");
    // 2 000 writes take a few milliseconds: one report, then the rest in a handful
    // (19 in one run). Without a linger, about one each (1 156 in the same run: a drain
    // finds a few writes together when another thread held the lock meanwhile).
    assert!(
        lingering * 5 < at_once,
        "{lingering} reports lingering, {at_once} without"
    );
}
