//! `slate bench net`: two nodes (board + ICI) over Zenoh on 127.0.0.1, in one process,
//! against raw Zenoh puts over the same two sessions, in the same run.
//!
//! * Latency: a write on node A until node B's board holds it (taken in B's change
//!   hook, in the thread that applies it), one write at a time; raw: a put of the same
//!   payload size until B's subscriber callback runs. Percentiles over the probes.
//! * Throughput: A commits updates in batches of 100 (a sensor's scan; the ICI turns
//!   each into one report) as fast as it can for the sample time, never more than
//!   20 000 updates ahead of what B applied; the clock stops when B's board holds A's
//!   final state; raw: one put per update (congestion control
//!   `Block`, so none is dropped) until B's callback has them all.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use anyhow::anyhow;
use crossbeam_channel::{Receiver, Sender};
use serde_json::json;
use slate_ici::{LinkKind, MsgKind, Rng};
use slate_model::{Board, ChangeHook, ObjectId, TouchKind, Touched};
use zenoh::Wait;
use zenoh::qos::CongestionControl;

use super::zenoh_pair::{ATTRS, OBJECTS, Pair, free_port, update, wait};
use super::{Config, Report, Target, Unit};

/// Runs the suite; `progress` is told each step.
pub fn run(cfg: &Config, progress: &mut dyn FnMut(&str)) -> anyhow::Result<Report> {
    let mut r = Report::new(
        "slate bench net: two nodes over Zenoh on 127.0.0.1 vs raw Zenoh puts (same sessions, same run)",
    );
    progress("opening two Zenoh sessions");
    let port = free_port()?;
    let pair = Pair::open("netbench", port, port)?;
    pair.create_objects()?;
    let probes = (cfg.samples * 50).max(100);
    progress("latency");
    let (slate, payload) = slate_latency(&pair, probes)?;
    let raw = raw_latency(&pair, probes, payload)?;
    r.add_in("raw_zenoh_latency_p50_us", percentile(&raw, 50.0), Unit::Us);
    r.add_in("raw_zenoh_latency_p99_us", percentile(&raw, 99.0), Unit::Us);
    let p50 = percentile(&slate, 50.0);
    let within = vec![Target::RatioAtMost(1.2)];
    r.compare_in(
        "latency_p50_us",
        p50,
        Unit::Us,
        "raw_zenoh_latency_p50_us",
        within.clone(),
    );
    let p99 = percentile(&slate, 99.0);
    r.compare_in(
        "latency_p99_us",
        p99,
        Unit::Us,
        "raw_zenoh_latency_p99_us",
        within,
    );
    r.fact("latency_probes", json!(probes));
    r.fact("raw_payload_bytes", json!(payload));

    progress("throughput");
    let budget = Duration::from_millis(cfg.sample_ms * cfg.samples as u64 * 10);
    let (raw_rate, raw_count) = raw_throughput(&pair, budget, payload)?;
    r.add_in("raw_zenoh_updates_per_sec", raw_rate, Unit::PerSec);
    let (rate, count, delivered) = slate_throughput(&pair, budget)?;
    let targets = vec![Target::AtLeast(1_000_000.0), Target::RatioAtLeast(0.8)];
    r.compare_in(
        "updates_per_sec",
        rate,
        Unit::PerSec,
        "raw_zenoh_updates_per_sec",
        targets,
    );
    r.fact("throughput_updates", json!(count));
    r.fact("throughput_updates_applied_by_receiver", json!(delivered));
    r.fact("raw_throughput_updates", json!(raw_count));
    drop(pair);
    Ok(r)
}

/// The `p`th percentile of durations, in microseconds.
fn percentile(samples: &[Duration], p: f64) -> f64 {
    let mut us: Vec<f64> = samples.iter().map(|d| d.as_secs_f64() * 1e6).collect();
    us.sort_by(f64::total_cmp);
    let rank = ((p / 100.0) * (us.len() - 1) as f64).round() as usize;
    us.get(rank).copied().unwrap_or(f64::NAN)
}

/// Tells when a write to one object reaches the board (in the applying thread).
struct Arrivals {
    object: ObjectId,
    tx: Sender<Instant>,
}

impl ChangeHook for Arrivals {
    fn changed(&self, _: &Board, _: u64, touched: &[Touched]) {
        let hit = touched
            .iter()
            .any(|t| t.object == self.object && t.kind == TouchKind::Write);
        if hit {
            let _ = self.tx.send(Instant::now());
        }
    }
}

/// One write at a time on A, until B's hook sees it. Returns the latencies and the
/// average size of the reports A sent for them (the raw payload size).
fn slate_latency(pair: &Pair, probes: usize) -> anyhow::Result<(Vec<Duration>, usize)> {
    let info = pair
        .b
        .board
        .info("t0")
        .ok_or_else(|| anyhow!("the receiver lacks t0"))?;
    let (tx, rx) = crossbeam_channel::unbounded();
    pair.b.board.add_hook(Arc::new(Arrivals {
        object: info.id,
        tx,
    }));
    let key = pair.a.board.key("t0", "range")?;
    let sent = || pair.a.ici.stats().get(LinkKind::Robot, MsgKind::Report);
    let before = sent();
    let mut out = Vec::with_capacity(probes);
    for k in 0..probes {
        rx.try_iter().for_each(drop);
        let value = (k % 90_000) as f64 / 100.0 + 1.0;
        let start = Instant::now();
        pair.a.board.write_key(key, value)?;
        out.push(arrival(&rx, start)?);
        std::thread::sleep(Duration::from_micros(200));
    }
    let after = sent();
    let msgs = (after.sent_msgs - before.sent_msgs).max(1);
    let payload = (after.sent_bytes - before.sent_bytes) / msgs;
    Ok((out, usize::try_from(payload)?.max(1)))
}

fn arrival(rx: &Receiver<Instant>, start: Instant) -> anyhow::Result<Duration> {
    let at = rx
        .recv_timeout(Duration::from_secs(5))
        .map_err(|_| anyhow!("a probe did not arrive within 5 s"))?;
    Ok(at.saturating_duration_since(start))
}

/// A put of `payload` bytes on A's session at a time, until B's callback runs.
fn raw_latency(pair: &Pair, probes: usize, payload: usize) -> anyhow::Result<Vec<Duration>> {
    let (tx, rx) = crossbeam_channel::unbounded();
    let key = "bench/raw/netbench/r1/a/latency";
    let _sub = pair
        .b
        .transport
        .session()
        .declare_subscriber(key)
        .callback(move |_| {
            let _ = tx.send(Instant::now());
        })
        .wait()
        .map_err(|e| anyhow!("zenoh subscriber: {e}"))?;
    let session = pair.a.transport.session();
    let put = || {
        session
            .put(key, vec![0x11; payload])
            .wait()
            .map_err(|e| anyhow!("zenoh put: {e}"))
    };
    let ready = wait(Duration::from_secs(10), || {
        put().is_ok() && rx.recv_timeout(Duration::from_millis(5)).is_ok()
    });
    anyhow::ensure!(ready, "the raw subscriber was not reached within 10 s");
    std::thread::sleep(Duration::from_millis(50));
    let mut out = Vec::with_capacity(probes);
    for _ in 0..probes {
        rx.try_iter().for_each(drop);
        let start = Instant::now();
        put()?;
        out.push(arrival(&rx, start)?);
        std::thread::sleep(Duration::from_micros(200));
    }
    Ok(out)
}

/// Counts arrivals and keeps the time of the last one (ns after `start`).
struct Counter {
    start: Instant,
    count: AtomicU64,
    last_ns: AtomicU64,
}

impl Counter {
    fn new() -> Arc<Counter> {
        Arc::new(Counter {
            start: Instant::now(),
            count: AtomicU64::new(0),
            last_ns: AtomicU64::new(0),
        })
    }

    fn hit(&self, n: u64) {
        self.count.fetch_add(n, Ordering::SeqCst);
        let ns = u64::try_from(self.start.elapsed().as_nanos()).unwrap_or(u64::MAX);
        self.last_ns.fetch_max(ns, Ordering::SeqCst);
    }
}

/// One put per update for `budget`; returns updates per second and how many.
fn raw_throughput(pair: &Pair, budget: Duration, payload: usize) -> anyhow::Result<(f64, u64)> {
    let counter = Counter::new();
    let c = counter.clone();
    let key = "bench/raw/netbench/r1/a/throughput";
    let _sub = pair
        .b
        .transport
        .session()
        .declare_subscriber(key)
        .callback(move |_| c.hit(1))
        .wait()
        .map_err(|e| anyhow!("zenoh subscriber: {e}"))?;
    let session = pair.a.transport.session();
    let put = || {
        session
            .put(key, vec![0x11; payload])
            .congestion_control(CongestionControl::Block)
            .wait()
            .map_err(|e| anyhow!("zenoh put: {e}"))
    };
    let ready = wait(Duration::from_secs(10), || {
        put().is_ok() && counter.count.load(Ordering::SeqCst) > 0
    });
    anyhow::ensure!(ready, "the raw subscriber was not reached within 10 s");
    std::thread::sleep(Duration::from_millis(100));
    let base = counter.count.load(Ordering::SeqCst);
    let start_ns = u64::try_from(counter.start.elapsed().as_nanos())?;
    let end = Instant::now() + budget;
    let mut sent = 0u64;
    while Instant::now() < end {
        for _ in 0..100 {
            put()?;
        }
        sent += 100;
    }
    let all = wait(Duration::from_secs(20), || {
        counter.count.load(Ordering::SeqCst) >= base + sent
    });
    anyhow::ensure!(all, "the raw puts did not all arrive within 20 s");
    let ns = counter.last_ns.load(Ordering::SeqCst) - start_ns;
    Ok((sent as f64 / (ns as f64 / 1e9), sent))
}

/// Counts the packets of one class B's board takes.
struct Applied {
    class: ObjectId,
    counter: Arc<Counter>,
}

impl ChangeHook for Applied {
    fn changed(&self, _: &Board, _: u64, touched: &[Touched]) {
        let n = touched
            .iter()
            .filter(|t| t.kind == TouchKind::Write && t.class == self.class)
            .count();
        if n > 0 {
            self.counter.hit(n as u64);
        }
    }
}

/// Updates written but not yet applied by B, at most (a sender is not to run ahead
/// of its receiver without bound: that measures a queue, not a link).
const WINDOW: u64 = 20_000;

/// Waits until B has applied all but [`WINDOW`] of the `sent` updates, or until it
/// stops making progress for 20 ms (Zenoh dropped reports: B will catch up with the
/// current state instead).
fn window(counter: &Counter, base: u64, sent: u64) {
    let applied = || counter.count.load(Ordering::SeqCst) - base;
    let mut last = applied();
    let mut since = Instant::now();
    while sent.saturating_sub(last) > WINDOW && since.elapsed() < Duration::from_millis(20) {
        // Sleep, not spin: on a small machine a spinning sender takes the receiver's core.
        std::thread::sleep(Duration::from_micros(50));
        let now = applied();
        if now != last {
            (last, since) = (now, Instant::now());
        }
    }
}

/// Batches of 100 updates as fast as A takes them for `budget` (at most [`WINDOW`]
/// ahead of B), until B holds A's
/// final state. Returns updates per second, how many, and how many B applied (fewer
/// if Zenoh dropped reports and B caught up with the current state instead).
fn slate_throughput(pair: &Pair, budget: Duration) -> anyhow::Result<(f64, u64, u64)> {
    let counter = Counter::new();
    let class = pair
        .b
        .board
        .info("Tracked")
        .ok_or_else(|| anyhow!("the receiver lacks Tracked"))?
        .id;
    pair.b.board.add_hook(Arc::new(Applied {
        class,
        counter: counter.clone(),
    }));
    let keys = (0..OBJECTS)
        .map(|i| {
            let name = format!("t{i}");
            ATTRS
                .iter()
                .map(|a| pair.a.board.key(&name, a))
                .collect::<Result<Vec<_>, _>>()
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mut rng = Rng::new(5);
    let updates: Vec<_> = (0..4096).map(|_| update(&mut rng)).collect();
    std::thread::sleep(Duration::from_millis(100));
    let base = counter.count.load(Ordering::SeqCst);
    let start_ns = u64::try_from(counter.start.elapsed().as_nanos())?;
    let end = Instant::now() + budget;
    let mut sent = 0u64;
    while Instant::now() < end {
        let mut batch = pair.a.board.batch();
        for k in &keys {
            let i = sent as usize;
            batch.write_key(k[i % ATTRS.len()], updates[i % updates.len()].clone());
            sent += 1;
        }
        batch.commit()?;
        window(&counter, base, sent);
    }
    let done = wait(Duration::from_secs(30), || pair.converged());
    anyhow::ensure!(done, "the receiver did not converge within 30 s");
    // The clock stops at the last packet B applied (the final state is complete then).
    let elapsed = (counter.last_ns.load(Ordering::SeqCst) - start_ns) as f64 / 1e9;
    let applied = counter.count.load(Ordering::SeqCst) - base;
    Ok((sent as f64 / elapsed, sent, applied))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_net_suite_reports_every_field() {
        let cfg = Config {
            samples: 3,
            sample_ms: 1,
        };
        let j = run(&cfg, &mut |_| {}).expect("the suite runs").json();
        for f in [
            "latency_p50_us",
            "latency_p99_us",
            "raw_zenoh_latency_p50_us",
            "raw_zenoh_latency_p99_us",
            "updates_per_sec",
            "raw_zenoh_updates_per_sec",
            "latency_p50_ratio",
            "updates_per_sec_ratio",
        ] {
            assert!(j[f].as_f64().is_some_and(|x| x > 0.0), "{f}: {}", j[f]);
        }
        assert!(j["targets_met"].is_boolean());
    }
}
