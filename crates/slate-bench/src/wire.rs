//! `slate bench wire`: bytes per update, on their own and on a real link.
//!
//! * Codec sizes (deterministic): one update, a batch of 100 updates of 100 objects,
//!   and a robot pose, in steady state (one hour after the sender's epoch, names
//!   announced), as in `docs/wire.md`. Baselines, on the same updates: each update as
//!   a JSON object, and as a naive binary struct (names as length-prefixed strings,
//!   value, accuracy and confidence as f64, timestamp as u64).
//! * A Zenoh TCP link: two nodes (board + ICI) on 127.0.0.1, every byte between them
//!   through a counting proxy, the sender committing its updates in batches of 100 as
//!   a sensor module would (the ICI turns each into one report). The figure is the
//!   bytes that crossed the socket both ways (Zenoh framing, key expressions,
//!   keep-alives, heartbeats included) divided by the updates. Baseline: the same
//!   updates as naive structs, one Zenoh put each, over the same proxied link.

use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use anyhow::anyhow;
use serde_json::json;
use slate_ici::Rng;
use slate_model::{Address, MANUAL_EPOCH, Packet, Timestamp, Value};
use slate_wire::{Assertion, Encoder, Message, ObjectEntry, Report as WireReport, Schema};
use zenoh::Wait;
use zenoh::qos::CongestionControl;

use crate::proxy::{Counts, Proxy};
use crate::zenoh_pair::{ATTRS, OBJECTS, Pair, classes, update};
use crate::{Config, Figures, Target, Unit, free_port, wait};

/// One hour after the epoch, at 10 reports a second: a sender in steady state.
const HOUR_US: u64 = 3_600_000_000;
/// The sequence number of a steady-state report (an hour of reports at 10 a second).
pub const SEQ: u64 = 36_000;

/// Runs the suite; `progress` is told each step.
pub fn run(cfg: &Config, progress: &mut dyn FnMut(&str)) -> anyhow::Result<Figures> {
    let mut r = Figures::new(
        "slate bench wire: bytes per update vs JSON and a naive struct (same updates, same run)",
    );
    progress("codec sizes");
    codec(&mut r)?;
    progress("a Zenoh TCP link through a counting proxy");
    zenoh_tcp(cfg, &mut r)?;
    Ok(r)
}

fn nav() -> Address {
    Address::new("team/r1/nav").expect("address")
}

fn at(micros: u64) -> Timestamp {
    Timestamp::from_duration(MANUAL_EPOCH + Duration::from_micros(micros))
}

fn assertion(object: &ObjectEntry, attr: &str, packet: Packet) -> Assertion {
    Assertion {
        object: object.clone(),
        attr: attr.into(),
        packet,
    }
}

/// 100 updates of 100 objects, one attribute each, spread over a second.
fn batch(start_us: u64, rng: &mut Rng) -> Vec<Assertion> {
    (0..OBJECTS)
        .map(|i| {
            let u = update(rng);
            let t = at(start_us + i as u64 * 10_000 + rng.below(1000));
            let packet = Packet {
                value: u.value,
                accuracy: u.accuracy.unwrap_or(0.0),
                confidence: u.confidence.unwrap_or(1.0),
                timestamp: t,
                source: nav(),
            };
            let object = ObjectEntry::new(&format!("t{i}"), "Tracked").owner(nav());
            assertion(&object, ATTRS[i % ATTRS.len()], packet)
        })
        .collect()
}

fn pose(t: Timestamp) -> Vec<Assertion> {
    let robot = ObjectEntry::new("r1", "Robot").owner(nav());
    let p = |v: f64, acc: f64, conf: f64| Packet {
        value: Value::Real(v),
        accuracy: acc,
        confidence: conf,
        timestamp: t,
        source: nav(),
    };
    vec![
        assertion(&robot, "x", p(1234.56, 0.05, 0.9)),
        assertion(&robot, "y", p(-8765.43, 0.05, 0.9)),
        assertion(&robot, "heading", p(1.234, 0.01, 0.8)),
        assertion(&robot, "speed", p(3.21, 0.1, 0.95)),
    ]
}

fn encode(
    enc: &mut Encoder,
    seq: u64,
    items: Vec<Assertion>,
    schema: &Schema,
) -> anyhow::Result<usize> {
    let msg = Message::Report(WireReport { seq, items });
    Ok(enc.encode(&msg, schema)?.len())
}

/// The update as a JSON object, the way a JSON-over-pub/sub glue would send it.
fn json_bytes(a: &Assertion) -> usize {
    let p = &a.packet;
    json!({
        "object": &*a.object.name,
        "attr": &*a.attr,
        "value": p.value.as_f64(),
        "accuracy": p.accuracy,
        "confidence": p.confidence,
        "timestamp": p.timestamp.as_secs_f64(),
        "source": p.source.as_str(),
    })
    .to_string()
    .len()
}

/// The update as a naive binary struct: three length-prefixed names (u8 length), value,
/// accuracy and confidence as f64, timestamp as u64.
fn naive(a: &Assertion) -> Vec<u8> {
    let p = &a.packet;
    let mut out = Vec::new();
    for name in [&*a.object.name, &*a.attr, p.source.as_str()] {
        out.push(u8::try_from(name.len()).unwrap_or(u8::MAX));
        out.extend_from_slice(name.as_bytes());
    }
    for x in [p.value.as_f64().unwrap_or(0.0), p.accuracy, p.confidence] {
        out.extend_from_slice(&x.to_le_bytes());
    }
    out.extend_from_slice(&p.timestamp.raw().to_le_bytes());
    out
}

fn mean(items: &[Assertion], size: impl Fn(&Assertion) -> usize) -> f64 {
    items.iter().map(size).sum::<usize>() as f64 / items.len() as f64
}

/// A sender's encoder in steady state, one hour after its epoch with every name
/// announced, and the updates the codec figures encode. Deterministic: the same
/// updates and bytes on every run.
pub struct SteadySender {
    /// The schema of the tracked objects and the robot.
    pub schema: Schema,
    /// The encoder, its dictionary holding every name below.
    pub encoder: Encoder,
    /// 100 updates of 100 tracked objects, spread over a second.
    pub updates: Vec<Assertion>,
    /// A robot pose: `x`, `y`, `heading`, `speed`.
    pub pose: Vec<Assertion>,
}

impl SteadySender {
    /// Announces the names (the tracked objects first, then the robot, whose id then
    /// takes 7 bits, as in `docs/wire.md`) and draws the updates.
    pub fn new() -> anyhow::Result<Self> {
        let schema = Schema::new(&classes());
        let mut encoder = Encoder::new(nav());
        let mut rng = Rng::new(7);
        encode(&mut encoder, 1, batch(0, &mut rng), &schema)?;
        encode(&mut encoder, 2, pose(at(0)), &schema)?;
        let updates = batch(HOUR_US, &mut rng);
        let pose = pose(at(HOUR_US));
        Ok(SteadySender {
            schema,
            encoder,
            updates,
            pose,
        })
    }

    /// The report of `items` as the `seq`th message, encoded.
    pub fn encode(&mut self, seq: u64, items: Vec<Assertion>) -> anyhow::Result<usize> {
        encode(&mut self.encoder, seq, items, &self.schema)
    }
}

fn codec(r: &mut Figures) -> anyhow::Result<()> {
    let mut sender = SteadySender::new()?;
    let updates = sender.updates.clone();
    let single = sender.encode(SEQ, updates[..1].to_vec())?;
    let hundred = sender.encode(SEQ + 1, updates.clone())?;
    let pose_items = sender.pose.clone();
    let pose_bytes = sender.encode(SEQ + 2, pose_items.clone())?;

    r.add_in(
        "json_bytes_per_update",
        mean(&updates, json_bytes),
        Unit::Bytes,
    );
    r.add_in(
        "naive_bytes_per_update",
        mean(&updates, |a| naive(a).len()),
        Unit::Bytes,
    );
    let pose_naive = pose_items.iter().map(|a| naive(a).len()).sum::<usize>();
    r.add_in("naive_bytes_pose", pose_naive as f64, Unit::Bytes);
    r.compare_in(
        "bytes_per_update_single",
        single as f64,
        Unit::Bytes,
        "naive_bytes_per_update",
        vec![],
    );
    let per = hundred as f64 / OBJECTS as f64;
    let batch_target = vec![Target::AtMost(10.0)];
    r.compare_in(
        "bytes_per_update_batch100",
        per,
        Unit::Bytes,
        "naive_bytes_per_update",
        batch_target,
    );
    let pose_target = vec![Target::AtMost(32.0)];
    r.compare_in(
        "bytes_pose_report",
        pose_bytes as f64,
        Unit::Bytes,
        "naive_bytes_pose",
        pose_target,
    );
    Ok(())
}

/// Updates committed in batches of 100, paced so that Zenoh's queues never drop.
fn zenoh_tcp(cfg: &Config, r: &mut Figures) -> anyhow::Result<()> {
    let b_port = free_port()?;
    let proxy = Proxy::start(SocketAddr::from(([127, 0, 0, 1], b_port)))?;
    let pair = Pair::open("wirebench", b_port, proxy.port)?;
    pair.create_objects()?;
    std::thread::sleep(Duration::from_millis(300));
    let batches = (cfg.samples * 5).max(10);
    let updates = (batches * OBJECTS) as u64;

    let naive = naive_puts(&pair, &proxy, batches)?;
    r.add_in(
        "naive_zenoh_tcp_bytes_per_update",
        naive.total() as f64 / updates as f64,
        Unit::Bytes,
    );

    let before = proxy.counts();
    let mut rng = Rng::new(11);
    for _ in 0..batches {
        let mut batch = pair.a.board.batch();
        for i in 0..OBJECTS {
            let attr = ATTRS[rng.below(ATTRS.len() as u64) as usize];
            batch.write(&format!("t{i}"), attr, update(&mut rng));
        }
        batch.commit()?;
        std::thread::sleep(Duration::from_millis(2));
    }
    let converged = wait(Duration::from_secs(20), || pair.converged());
    anyhow::ensure!(converged, "the receiver did not converge within 20 s");
    let slate = proxy.counts().since(before);
    let per = slate.total() as f64 / updates as f64;
    r.compare_in(
        "bytes_per_update_zenoh_tcp",
        per,
        Unit::Bytes,
        "naive_zenoh_tcp_bytes_per_update",
        vec![Target::AtMost(14.0)],
    );
    r.fact("zenoh_tcp_updates", json!(updates));
    r.fact("zenoh_tcp_bytes_forward", json!(slate.forward));
    r.fact("zenoh_tcp_bytes_backward", json!(slate.backward));
    drop(pair);
    drop(proxy);
    Ok(())
}

/// The baseline: each update as a naive struct in its own Zenoh put, over the same
/// proxied link; returns the bytes counted.
fn naive_puts(pair: &Pair, proxy: &Proxy, batches: usize) -> anyhow::Result<Counts> {
    let got = Arc::new(AtomicU64::new(0));
    let counter = got.clone();
    let key = "bench/naive/wirebench/r1/a/update";
    let _sub = pair
        .b
        .transport
        .session()
        .declare_subscriber(key)
        .callback(move |_| {
            counter.fetch_add(1, Ordering::SeqCst);
        })
        .wait()
        .map_err(|e| anyhow!("zenoh subscriber: {e}"))?;
    let session = pair.a.transport.session();
    let put = |payload: Vec<u8>| {
        session
            .put(key, payload)
            .congestion_control(CongestionControl::Block)
            .wait()
            .map_err(|e| anyhow!("zenoh put: {e}"))
    };
    // The subscription takes a moment to reach the publisher's session.
    let mut warm = 0u64;
    let ready = wait(Duration::from_secs(10), || {
        warm += 1;
        put(vec![0; 8]).is_ok() && got.load(Ordering::SeqCst) > 0
    });
    anyhow::ensure!(ready, "the raw subscriber was not reached within 10 s");
    std::thread::sleep(Duration::from_millis(100));
    let (base, before) = (got.load(Ordering::SeqCst), proxy.counts());
    let mut rng = Rng::new(13);
    for b in 0..batches {
        for a in batch(HOUR_US + b as u64 * 1_000_000, &mut rng) {
            put(naive(&a))?;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let expected = base + (batches * OBJECTS) as u64;
    let all = wait(Duration::from_secs(20), || {
        got.load(Ordering::SeqCst) >= expected
    });
    anyhow::ensure!(all, "the raw puts did not all arrive within 20 s");
    Ok(proxy.counts().since(before))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_wire_suite_reports_every_field() {
        let j = run(&crate::TINY, &mut |_| {})
            .expect("the suite runs")
            .json();
        crate::assert_reports(
            &j,
            &[
                "bytes_per_update_single",
                "bytes_per_update_batch100",
                "bytes_per_update_zenoh_tcp",
                "bytes_pose_report",
                "json_bytes_per_update",
                "naive_bytes_per_update",
                "naive_bytes_pose",
                "naive_zenoh_tcp_bytes_per_update",
                "bytes_per_update_batch100_ratio",
                "bytes_per_update_zenoh_tcp_ratio",
            ],
        );
    }
}
