//! `slate bench net`: two nodes (board + ICI) over Zenoh on 127.0.0.1, in one process,
//! against raw Zenoh puts over the same two sessions, in the same run.
//!
//! * Latency: a write on node A until node B's board holds it (taken in B's change
//!   hook, in the thread that applies it), one write at a time; raw: a put of the same
//!   payload size until B's subscriber callback runs, by `Session::put` (the targets'
//!   baseline) and by a declared publisher (reported beside it), both routed to remote
//!   subscribers only, as slate's own publishers are. The three kinds of
//!   probe take turns (each going first in turn), after as many unmeasured warm-up
//!   probes each, so that all see the same machine. Percentiles over the probes.
//! * Throughput: A commits updates in batches of 100 (a sensor's scan; the ICI turns
//!   each into one report) as fast as it can, never more than 20 000 updates ahead of
//!   what B applied; the clock stops when B's board holds A's final state; raw: one put
//!   per update (congestion control `Block`, so none is dropped) until B's callback has
//!   them all, again by `Session::put` and by a declared publisher. Raw and slate rounds
//!   alternate ([`ROUNDS`] of each, each kind starting a round in turn); the medians are
//!   reported.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use anyhow::anyhow;
use crossbeam_channel::Receiver;
use serde_json::json;
use slate_ici::{LinkKind, MsgKind, Rng};
use slate_model::{Board, ChangeHook, Key, TouchKind, Touched};
use zenoh::Wait;
use zenoh::qos::CongestionControl;
use zenoh::sample::Locality;

use crate::zenoh_pair::{ATTRS, OBJECTS, Pair, update};
use crate::{Config, Figures, Target, Unit, free_port, wait};

/// Throughput rounds of each kind (with three, one slow round of the machine's decided
/// the median often enough to swing the ratio from 0.77 to 1.18 between runs).
pub(crate) const ROUNDS: usize = 5;

/// What a probe or a throughput round measures: slate, or one of the raw baselines.
#[derive(Clone, Copy)]
enum Kind {
    Slate,
    Raw(Raw),
}

/// The kinds, in the order of their figures (every loop takes them in turn).
const KINDS: [Kind; 3] = [
    Kind::Slate,
    Kind::Raw(Raw::SessionPut),
    Kind::Raw(Raw::Publisher),
];

/// Time between two latency probes (both sides idle, as a robot's occasional update).
pub(crate) const PROBE_GAP: Duration = Duration::from_micros(200);

/// Runs the suite; `progress` is told each step.
pub fn run(cfg: &Config, progress: &mut dyn FnMut(&str)) -> anyhow::Result<Figures> {
    let mut r = Figures::new(
        "slate bench net: two nodes over Zenoh on 127.0.0.1 vs raw Zenoh puts (same sessions, same run)",
    );
    progress("opening two Zenoh sessions");
    let port = free_port()?;
    let pair = Pair::open("netbench", port, port)?;
    pair.create_objects()?;
    // About 9 500 of each kind by default: the p99 then rests on some ninety probes
    // above it. With 1 000 (ten above it) it swung by a third from run to run; with
    // 3 000 (thirty), the ratio of two p99s still ranged over 0.97-1.26 for one build.
    let probes = (cfg.samples * 450).max(300);
    progress("latency");
    let mut lat = Latency::new(&pair)?;
    let payload = lat.warm_up(probes / 10 + 10)?;
    let mut samples: [Vec<Duration>; 3] = Default::default();
    for k in 0..probes {
        // The kinds take turns going first, so that none always follows the same one.
        for j in 0..KINDS.len() {
            let i = (k + j) % KINDS.len();
            samples[i].push(lat.probe(KINDS[i], k, payload)?);
            std::thread::sleep(PROBE_GAP);
        }
    }
    let [slate, raw, publisher] = samples;
    let (slate_p50, slate_p99) = (percentile(&slate, 50.0), percentile(&slate, 99.0));
    let (publisher_p50, publisher_p99) =
        (percentile(&publisher, 50.0), percentile(&publisher, 99.0));
    r.add_in("raw_zenoh_latency_p50_us", percentile(&raw, 50.0), Unit::Us);
    r.add_in("raw_zenoh_latency_p99_us", percentile(&raw, 99.0), Unit::Us);
    r.add_in(
        "raw_zenoh_publisher_latency_p50_us",
        publisher_p50,
        Unit::Us,
    );
    r.add_in(
        "raw_zenoh_publisher_latency_p99_us",
        publisher_p99,
        Unit::Us,
    );
    let within = vec![Target::RatioAtMost(1.2)];
    r.compare_in(
        "latency_p50_us",
        slate_p50,
        Unit::Us,
        "raw_zenoh_latency_p50_us",
        within.clone(),
    );
    r.compare_in(
        "latency_p99_us",
        slate_p99,
        Unit::Us,
        "raw_zenoh_latency_p99_us",
        within,
    );
    let ratio = |x: f64, base: f64| json!(crate::round(x / base));
    r.fact(
        "latency_p50_ratio_to_publisher",
        ratio(slate_p50, publisher_p50),
    );
    r.fact(
        "latency_p99_ratio_to_publisher",
        ratio(slate_p99, publisher_p99),
    );
    r.fact("latency_probes", json!(probes));
    r.fact("raw_payload_bytes", json!(payload));

    progress("throughput");
    let mut tp = Throughput::new(&pair)?;
    let budget = round_budget(cfg);
    let mut rates: [Vec<f64>; 3] = Default::default();
    let (mut counts, mut delivered) = ([0u64; 3], 0);
    for round in 0..ROUNDS {
        // Each round starts with another kind, as the latency probes do.
        for j in 0..KINDS.len() {
            let i = (round + j) % KINDS.len();
            let (rate, n) = match KINDS[i] {
                Kind::Slate => {
                    let (rate, n, applied) = tp.slate(budget)?;
                    delivered += applied;
                    (rate, n)
                }
                Kind::Raw(how) => tp.raw(how, budget, payload)?,
            };
            rates[i].push(rate);
            counts[i] += n;
        }
    }
    let [rates, raw_rates, publisher_rates] = rates;
    let [count, raw_count, publisher_count] = counts;
    let rate = crate::median(rates);
    r.add_in(
        "raw_zenoh_updates_per_sec",
        crate::median(raw_rates),
        Unit::PerSec,
    );
    let publisher_rate = crate::median(publisher_rates);
    r.add_in(
        "raw_zenoh_publisher_updates_per_sec",
        publisher_rate,
        Unit::PerSec,
    );
    let targets = vec![Target::AtLeast(1_000_000.0), Target::RatioAtLeast(0.8)];
    r.compare_in(
        "updates_per_sec",
        rate,
        Unit::PerSec,
        "raw_zenoh_updates_per_sec",
        targets,
    );
    r.fact(
        "updates_per_sec_ratio_to_publisher",
        ratio(rate, publisher_rate),
    );
    r.fact("throughput_rounds", json!(ROUNDS));
    r.fact("throughput_updates", json!(count));
    r.fact("throughput_updates_applied_by_receiver", json!(delivered));
    r.fact("raw_throughput_updates", json!(raw_count));
    r.fact("raw_publisher_throughput_updates", json!(publisher_count));
    drop(pair);
    Ok(r)
}

/// The `p`th percentile of durations, in microseconds.
pub(crate) fn percentile(samples: &[Duration], p: f64) -> f64 {
    crate::percentile_secs(samples, p) * 1e6
}

/// How long each throughput round runs: a third of a second by default (21 samples of
/// 5 ms).
pub(crate) fn round_budget(cfg: &Config) -> Duration {
    Duration::from_millis(cfg.sample_ms * cfg.samples as u64 * 10 / 3)
}

/// Hands `seen`, in the applying thread, how many of a revision's writes `picks` picks,
/// when it picks any.
struct OnWrites<P, S> {
    picks: P,
    seen: S,
}

impl<P, S> ChangeHook for OnWrites<P, S>
where
    P: Fn(&Touched) -> bool + Send + Sync,
    S: Fn(u64) + Send + Sync,
{
    fn changed(&self, _: &Board, _: u64, touched: &[Touched]) {
        let n = touched
            .iter()
            .filter(|t| t.kind == TouchKind::Write && (self.picks)(t))
            .count();
        if n > 0 {
            (self.seen)(n as u64);
        }
    }
}

/// How a raw baseline puts: through `Session::put` (the key resolved on every put: the
/// baseline of the targets), or through a declared `Publisher` (resolved once: Zenoh at
/// its fastest, reported beside it).
#[derive(Clone, Copy)]
enum Raw {
    SessionPut,
    Publisher,
}

/// A key raw Zenoh puts go to from A's session, both ways ([`Raw`]), and B's subscriber
/// on it. Both ways route to remote subscribers only, as slate's publishers do.
struct RawKey {
    session: zenoh::Session,
    /// The key as text: `Session::put` parses it on every put, as a naive caller's does.
    key: &'static str,
    publisher: zenoh::pubsub::Publisher<'static>,
    _subscriber: zenoh::pubsub::Subscriber<()>,
}

impl RawKey {
    /// Declares the key's publisher on A and its subscriber on B (`on_sample` runs in
    /// B's callback), then puts until `arrived` says B heard one.
    fn new(
        pair: &Pair,
        key: &'static str,
        congestion: CongestionControl,
        on_sample: impl Fn() + Send + Sync + 'static,
        mut arrived: impl FnMut() -> bool,
    ) -> anyhow::Result<Self> {
        let subscriber = pair
            .b
            .transport
            .session()
            .declare_subscriber(key)
            .callback(move |_| on_sample())
            .wait()
            .map_err(|e| anyhow!("zenoh subscriber: {e}"))?;
        let session = pair.a.transport.session().clone();
        let publisher = session
            .declare_publisher(key)
            .congestion_control(congestion)
            .allowed_destination(Locality::Remote)
            .wait()
            .map_err(|e| anyhow!("zenoh publisher: {e}"))?;
        let raw = RawKey {
            session,
            key,
            publisher,
            _subscriber: subscriber,
        };
        let ready = wait(Duration::from_secs(10), || {
            raw.put(Raw::SessionPut, 1).is_ok() && arrived()
        });
        anyhow::ensure!(
            ready,
            "the raw subscriber on {key} was not reached within 10 s"
        );
        Ok(raw)
    }

    fn put(&self, how: Raw, payload: usize) -> anyhow::Result<()> {
        let bytes = vec![0x11; payload];
        match how {
            Raw::SessionPut => self
                .session
                .put(self.key, bytes)
                .congestion_control(self.publisher.congestion_control())
                .allowed_destination(Locality::Remote)
                .wait(),
            Raw::Publisher => self.publisher.put(bytes).wait(),
        }
        .map_err(|e| anyhow!("zenoh put: {e}"))
    }
}

const RAW_LATENCY_KEY: &str = "bench/raw/netbench/r1/a/latency";

/// The latency probes: a write on A until B's hook sees it, and a raw put on A's
/// session (either way) until B's subscriber callback runs.
struct Latency<'p> {
    pair: &'p Pair,
    slate: SlateProbe<'p>,
    raw_arrived: Receiver<Instant>,
    raw_key: RawKey,
}

/// Slate's latency probe on a pair: a write on A until B's board holds it.
pub(crate) struct SlateProbe<'p> {
    pair: &'p Pair,
    key: Key,
    arrived: Receiver<Instant>,
}

impl<'p> SlateProbe<'p> {
    /// Hooks B's board to see writes to `t0` arrive.
    pub(crate) fn new(pair: &'p Pair) -> anyhow::Result<Self> {
        let info = pair
            .b
            .board
            .info("t0")
            .ok_or_else(|| anyhow!("the receiver lacks t0"))?;
        let (tx, arrived) = crossbeam_channel::unbounded();
        // When a write to t0 reaches B's board.
        pair.b.board.add_hook(Arc::new(OnWrites {
            picks: move |t: &Touched| t.object == info.id,
            seen: move |_| {
                let _ = tx.send(Instant::now());
            },
        }));
        Ok(SlateProbe {
            pair,
            key: pair.a.board.key("t0", "range")?,
            arrived,
        })
    }

    /// The `k`th write on A, until B's board holds it.
    pub(crate) fn probe(&self, k: usize) -> anyhow::Result<Duration> {
        self.arrived.try_iter().for_each(drop);
        let value = (k % 90_000) as f64 / 100.0 + 1.0;
        let start = Instant::now();
        self.pair.a.board.write_key(self.key, value)?;
        arrival(&self.arrived, start, "a write on node A (latency probe)").map_err(|e| {
            let (a, b) = (self.pair.a.ici.stats(), self.pair.b.ici.stats());
            anyhow!(
                "{e}: A holds {:?}, B holds {:?}; A's reports {:?}, B's merges {:?}, rejects {:?}, catch-up {:?}",
                self.pair.a.board.read("t0", "range").ok(),
                self.pair.b.board.read("t0", "range").ok(),
                a.reports,
                b.merges,
                b.rejects,
                b.catch_up
            )
        })
    }
}

impl<'p> Latency<'p> {
    fn new(pair: &'p Pair) -> anyhow::Result<Self> {
        let slate = SlateProbe::new(pair)?;
        let (raw_tx, raw_arrived) = crossbeam_channel::unbounded();
        let on_sample = move || {
            let _ = raw_tx.send(Instant::now());
        };
        let heard = raw_arrived.clone();
        let raw_key = RawKey::new(
            pair,
            RAW_LATENCY_KEY,
            CongestionControl::Drop,
            on_sample,
            || heard.recv_timeout(Duration::from_millis(5)).is_ok(),
        )?;
        Ok(Latency {
            pair,
            slate,
            raw_arrived,
            raw_key,
        })
    }

    /// Runs `n` probes of each kind, not measured (the first ones of a kind pay for
    /// its caches and routes), and returns the average size of the reports A sent for
    /// the slate probes: the raw probes' payload.
    fn warm_up(&mut self, n: usize) -> anyhow::Result<usize> {
        let sent = || {
            self.pair
                .a
                .ici
                .stats()
                .get(LinkKind::Robot, MsgKind::Report)
        };
        let before = sent();
        for k in 0..n {
            self.slate(k)?;
            std::thread::sleep(PROBE_GAP);
        }
        let after = sent();
        let msgs = (after.sent_msgs - before.sent_msgs).max(1);
        let payload = usize::try_from((after.sent_bytes - before.sent_bytes) / msgs)?.max(1);
        for _ in 0..n {
            for how in [Raw::SessionPut, Raw::Publisher] {
                self.raw(how, payload)?;
                std::thread::sleep(PROBE_GAP);
            }
        }
        Ok(payload)
    }

    /// The `k`th probe of `kind`.
    fn probe(&self, kind: Kind, k: usize, payload: usize) -> anyhow::Result<Duration> {
        match kind {
            Kind::Slate => self.slate(k),
            Kind::Raw(how) => self.raw(how, payload),
        }
    }

    /// The `k`th write on A, until B's board holds it.
    fn slate(&self, k: usize) -> anyhow::Result<Duration> {
        self.slate.probe(k)
    }

    /// A put of `payload` bytes on A's session (`how`), until B's callback runs.
    fn raw(&self, how: Raw, payload: usize) -> anyhow::Result<Duration> {
        self.raw_arrived.try_iter().for_each(drop);
        let start = Instant::now();
        self.raw_key.put(how, payload)?;
        arrival(&self.raw_arrived, start, "a raw Zenoh put (latency probe)")
    }
}

fn arrival(rx: &Receiver<Instant>, start: Instant, what: &str) -> anyhow::Result<Duration> {
    let at = rx
        .recv_timeout(Duration::from_secs(5))
        .map_err(|_| anyhow!("{what} did not arrive within 5 s"))?;
    Ok(at.saturating_duration_since(start))
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

    /// How many so far, and now (ns after `start`): where a round begins.
    fn mark(&self) -> anyhow::Result<(u64, u64)> {
        let now = u64::try_from(self.start.elapsed().as_nanos())?;
        Ok((self.count.load(Ordering::SeqCst), now))
    }

    /// Rate of `sent` items over a round that began at `start_ns`, until the last hit.
    fn rate(&self, sent: u64, start_ns: u64) -> f64 {
        let ns = self.last_ns.load(Ordering::SeqCst).saturating_sub(start_ns);
        sent as f64 / (ns.max(1) as f64 / 1e9)
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

const RAW_THROUGHPUT_KEY: &str = "bench/raw/netbench/r1/a/throughput";

/// Throughput rounds, raw and slate, over the same pair.
struct Throughput<'p> {
    raw: Arc<Counter>,
    raw_key: RawKey,
    flow: SlateFlow<'p>,
}

impl<'p> Throughput<'p> {
    fn new(pair: &'p Pair) -> anyhow::Result<Self> {
        let raw = Counter::new();
        let (c, heard) = (raw.clone(), raw.clone());
        let raw_key = RawKey::new(
            pair,
            RAW_THROUGHPUT_KEY,
            CongestionControl::Block,
            move || c.hit(1),
            || heard.count.load(Ordering::SeqCst) > 0,
        )?;
        Ok(Throughput {
            raw,
            raw_key,
            flow: SlateFlow::new(pair)?,
        })
    }

    /// One put per update for `budget`; returns updates per second and how many.
    fn raw(&mut self, how: Raw, budget: Duration, payload: usize) -> anyhow::Result<(f64, u64)> {
        std::thread::sleep(Duration::from_millis(50));
        let (base, start_ns) = self.raw.mark()?;
        let end = Instant::now() + budget;
        let mut sent = 0u64;
        while Instant::now() < end {
            for _ in 0..100 {
                self.raw_key.put(how, payload)?;
            }
            sent += 100;
        }
        let all = wait(Duration::from_secs(20), || {
            self.raw.count.load(Ordering::SeqCst) >= base + sent
        });
        anyhow::ensure!(all, "the raw puts did not all arrive within 20 s");
        Ok((self.raw.rate(sent, start_ns), sent))
    }

    /// A round of slate's updates ([`SlateFlow::round`]).
    fn slate(&mut self, budget: Duration) -> anyhow::Result<(f64, u64, u64)> {
        self.flow.round(budget)
    }
}

/// Slate's throughput rounds on a pair: batches of updates on A, counted as B applies
/// them.
pub(crate) struct SlateFlow<'p> {
    pair: &'p Pair,
    applied: Arc<Counter>,
    keys: Vec<Vec<Key>>,
    updates: Vec<slate_model::Update>,
    sent: u64,
}

impl<'p> SlateFlow<'p> {
    /// Hooks B's board to count the packets of class `Tracked` it takes.
    pub(crate) fn new(pair: &'p Pair) -> anyhow::Result<Self> {
        let applied = Counter::new();
        let class = pair
            .b
            .board
            .info("Tracked")
            .ok_or_else(|| anyhow!("the receiver lacks Tracked"))?
            .id;
        let counter = applied.clone();
        pair.b.board.add_hook(Arc::new(OnWrites {
            picks: move |t: &Touched| t.class == class,
            seen: move |n| counter.hit(n),
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
        let updates = (0..4096).map(|_| update(&mut rng)).collect();
        Ok(SlateFlow {
            pair,
            applied,
            keys,
            updates,
            sent: 0,
        })
    }

    /// Batches of 100 updates as fast as A takes them for `budget` (at most [`WINDOW`]
    /// ahead of B), until B holds A's final state. Returns updates per second, how
    /// many, and how many B applied (fewer if Zenoh dropped reports and B caught up
    /// with the current state instead).
    pub(crate) fn round(&mut self, budget: Duration) -> anyhow::Result<(f64, u64, u64)> {
        std::thread::sleep(Duration::from_millis(50));
        let (base, start_ns) = self.applied.mark()?;
        let end = Instant::now() + budget;
        let mut sent = 0u64;
        while Instant::now() < end {
            let mut batch = self.pair.a.board.batch();
            for k in &self.keys {
                let i = self.sent as usize;
                batch.write_key(
                    k[i % ATTRS.len()],
                    self.updates[i % self.updates.len()].clone(),
                );
                self.sent += 1;
                sent += 1;
            }
            batch.commit()?;
            window(&self.applied, base, sent);
        }
        let done = wait(Duration::from_secs(30), || self.pair.converged());
        anyhow::ensure!(done, "the receiver did not converge within 30 s");
        // The clock stops at the last packet B applied (the final state is complete then).
        let applied = self.applied.count.load(Ordering::SeqCst) - base;
        Ok((self.applied.rate(sent, start_ns), sent, applied))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_net_suite_reports_every_field() {
        let j = run(&crate::TINY, &mut |_| {})
            .expect("the suite runs")
            .json();
        crate::assert_reports(
            &j,
            &[
                "latency_p50_us",
                "latency_p99_us",
                "raw_zenoh_latency_p50_us",
                "raw_zenoh_latency_p99_us",
                "updates_per_sec",
                "raw_zenoh_updates_per_sec",
                "latency_p50_ratio",
                "latency_p99_ratio",
                "updates_per_sec_ratio",
                "raw_zenoh_publisher_latency_p50_us",
                "raw_zenoh_publisher_latency_p99_us",
                "raw_zenoh_publisher_updates_per_sec",
                "latency_p50_ratio_to_publisher",
                "latency_p99_ratio_to_publisher",
                "updates_per_sec_ratio_to_publisher",
            ],
        );
    }
}
