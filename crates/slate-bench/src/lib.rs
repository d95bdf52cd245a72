//! slate's benchmark suites, run by `slate bench SUITE`: a small harness that reports the
//! median time per operation over several samples, each against a baseline measured in
//! the same run.
//!
//! The micro-benchmarks (`core`, `plans`, `wire`) measure one process's hot paths; the
//! multi-process ones (`net`: two nodes over Zenoh on 127.0.0.1, `cli`: `slate get`
//! against two `slate node` processes) need a loopback network, and `cli` needs the
//! `slate` executable itself. The figures docs/performance.md cites come from these
//! suites, so their row names and JSON fields are a contract with those docs.
//!
//! ```no_run
//! use slate_bench::{Config, Suite};
//!
//! let cfg = Config { samples: 21, sample_ms: 5 };
//! let report = slate_bench::run(Suite::Core, &cfg, &mut |step| eprintln!("{step}"))?;
//! print!("{}", report.text());
//! # Ok::<(), anyhow::Error>(())
//! ```

pub mod cli;
pub mod core;
pub mod net;
pub mod net_secure;
pub mod plans;
mod proxy;
pub mod record;
pub mod state;
pub mod wire;
mod zenoh_pair;

use std::hint::black_box;
use std::net::TcpListener;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use serde_json::{Map, Value, json};

/// A benchmark suite `slate bench` can run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[non_exhaustive]
pub enum Suite {
    /// The world model: reads, writes, batches, active functions, queries.
    Core,
    /// The plan engine: compiling plans, writes with plans installed, write to action.
    Plans,
    /// Bytes on the wire: per update (one, a batch, over a real Zenoh TCP link) and per
    /// pose report, against JSON and a naive binary struct.
    Wire,
    /// Two nodes over Zenoh on 127.0.0.1: write-to-visible latency and updates per
    /// second, against raw Zenoh puts of the same size.
    Net,
    /// `slate get` on a live two-node team (`slate node` processes on 127.0.0.1), spawn
    /// to exit, against starting a process and a raw Zenoh session and query; needs this
    /// process to be the `slate` executable.
    Cli,
    /// A node's writes with its board recorded in MCAP, against the same node without.
    Record,
    /// A node's writes with its board kept in a state directory (redb), against a node
    /// of the same config without.
    State,
}

/// Runs `suite`; `progress` is told each step before it is measured.
pub fn run(suite: Suite, cfg: &Config, progress: &mut dyn FnMut(&str)) -> anyhow::Result<Figures> {
    match suite {
        Suite::Core => Ok(core::run(cfg, progress)),
        Suite::Plans => Ok(plans::run(cfg, progress)),
        Suite::Wire => wire::run(cfg, progress),
        Suite::Net => net::run(cfg, progress),
        Suite::Cli => cli::run(cfg, progress),
        Suite::Record => record::run(cfg, progress),
        Suite::State => state::run(cfg, progress),
    }
}

/// How long and how often to measure.
#[derive(Clone, Copy, Debug)]
pub struct Config {
    /// Samples per measurement (the median is reported).
    pub samples: usize,
    /// Target duration of one sample.
    pub sample_ms: u64,
}

/// What a row's figure counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    /// Nanoseconds per operation.
    Ns,
    /// Microseconds.
    Us,
    /// Milliseconds.
    Ms,
    /// Bytes.
    Bytes,
    /// Operations per second (more is better).
    PerSec,
}

impl Unit {
    fn symbol(self) -> &'static str {
        match self {
            Unit::Ns => "ns",
            Unit::Us => "us",
            Unit::Ms => "ms",
            Unit::Bytes => "B",
            Unit::PerSec => "/s",
        }
    }

    /// The unit a row's name ends with (`_ns`, `_ms`, `_us`); nanoseconds otherwise.
    fn of_name(name: &str) -> Unit {
        if name.ends_with("_ms") {
            Unit::Ms
        } else if name.ends_with("_us") {
            Unit::Us
        } else {
            Unit::Ns
        }
    }
}

/// What a row must achieve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// Its ratio to the baseline is at most this.
    RatioAtMost(f64),
    /// Its ratio to the baseline is at least this (throughputs).
    RatioAtLeast(f64),
    /// Its figure is at most this.
    AtMost(f64),
    /// Its figure is at least this.
    AtLeast(f64),
}

impl Target {
    fn met(self, row: &Row) -> bool {
        let ratio = row.baseline.map(|(_, r)| r);
        match self {
            Target::RatioAtMost(t) => ratio.is_some_and(|r| r <= t),
            Target::RatioAtLeast(t) => ratio.is_some_and(|r| r >= t),
            Target::AtMost(t) => row.ns <= t,
            Target::AtLeast(t) => row.ns >= t,
        }
    }

    fn describe(self, unit: Unit) -> String {
        match self {
            Target::RatioAtMost(t) => format!("<= {t}x"),
            Target::RatioAtLeast(t) => format!(">= {t}x"),
            Target::AtMost(t) => format!("<= {t} {}", unit.symbol()),
            Target::AtLeast(t) => format!(">= {t} {}", unit.symbol()),
        }
    }
}

/// One measured figure.
#[derive(Clone, Debug)]
pub struct Row {
    /// JSON field name, e.g. `read_ns`.
    pub name: &'static str,
    /// The figure: median nanoseconds per operation for the timing suites, or the
    /// row's [`Unit`].
    pub ns: f64,
    /// What the figure counts.
    pub unit: Unit,
    /// The baseline row's name and this row's ratio to it.
    pub baseline: Option<(&'static str, f64)>,
    /// Targets the row must meet (a ratio to the baseline, or a bound on the figure).
    pub targets: Vec<Target>,
}

/// The figures a suite measured (named apart from the paper's report, which `slate_wire::Report` carries).
#[derive(Clone, Debug)]
pub struct Figures {
    /// Suite title.
    pub title: String,
    /// Rows, baselines included.
    pub rows: Vec<Row>,
    /// Extra facts for the JSON object (settings, counts).
    pub facts: Vec<(&'static str, Value)>,
}

impl Figures {
    /// A new empty report.
    pub fn new(title: &str) -> Self {
        Figures {
            title: title.to_owned(),
            rows: Vec::new(),
            facts: Vec::new(),
        }
    }

    /// Adds a measured row (its unit from its name: `_ms`, `_us`, else nanoseconds).
    pub fn add(&mut self, name: &'static str, ns: f64) {
        self.add_in(name, ns, Unit::of_name(name));
    }

    /// Adds a measured row in `unit`.
    pub fn add_in(&mut self, name: &'static str, value: f64, unit: Unit) {
        self.rows.push(Row {
            name,
            ns: value,
            unit,
            baseline: None,
            targets: Vec::new(),
        });
    }

    /// Adds a row compared with an earlier baseline row, with an optional target ratio.
    pub fn compare(
        &mut self,
        name: &'static str,
        ns: f64,
        baseline: &'static str,
        target: Option<f64>,
    ) {
        let targets = target.map(Target::RatioAtMost).into_iter().collect();
        self.compare_in(name, ns, Unit::of_name(name), baseline, targets);
    }

    /// Adds a row in `unit` compared with an earlier baseline row, with its targets.
    pub fn compare_in(
        &mut self,
        name: &'static str,
        value: f64,
        unit: Unit,
        baseline: &'static str,
        targets: Vec<Target>,
    ) {
        let base = self
            .rows
            .iter()
            .find(|r| r.name == baseline)
            .map_or(f64::NAN, |r| r.ns);
        self.rows.push(Row {
            name,
            ns: value,
            unit,
            baseline: Some((baseline, value / base)),
            targets,
        });
    }

    /// Records a fact for the JSON object.
    pub fn fact(&mut self, name: &'static str, value: Value) {
        self.facts.push((name, value));
    }

    /// One JSON object: every row's figure as a field, plus `<row>_ratio` fields, the
    /// facts, the build profile and whether every target was met.
    pub fn json(&self) -> Value {
        let mut m = Map::new();
        for r in &self.rows {
            m.insert(r.name.to_owned(), json!(round(r.ns)));
            if let Some((_, ratio)) = r.baseline {
                let stem = ["_ns", "_us", "_ms"]
                    .iter()
                    .fold(r.name, |n, s| n.strip_suffix(s).unwrap_or(n));
                m.insert(format!("{stem}_ratio"), json!(round(ratio)));
            }
        }
        for (name, value) in &self.facts {
            m.insert((*name).to_owned(), value.clone());
        }
        m.insert(
            "build".into(),
            json!(if cfg!(debug_assertions) {
                "debug"
            } else {
                "release"
            }),
        );
        m.insert("targets_met".into(), json!(self.targets_met()));
        Value::Object(m)
    }

    /// Did every row meet each of its targets?
    pub fn targets_met(&self) -> bool {
        self.rows.iter().all(|r| r.targets.iter().all(|t| t.met(r)))
    }

    /// The report as `slate bench` prints it: the title, one line per row (figure, ratio
    /// to its baseline, verdicts), then the facts.
    pub fn text(&self) -> String {
        let mut out = format!(
            "{}\n\n{:<36} {:>15}  {}\n",
            self.title, "figure", "value", "vs baseline"
        );
        for m in &self.rows {
            let ratio = m
                .baseline
                .map_or(String::new(), |(name, ratio)| format!("{ratio:.2}x {name}"));
            out.push_str(&format!(
                "{:<36} {}  {ratio}{}\n",
                m.name,
                m.figure(),
                m.verdicts()
            ));
        }
        if !self.facts.is_empty() {
            out.push('\n');
        }
        for (name, value) in &self.facts {
            out.push_str(&format!("{name:<36} {value}\n"));
        }
        out
    }
}

impl Row {
    /// `(target <= 2x: meets)` for each target, or nothing.
    pub fn verdicts(&self) -> String {
        self.targets
            .iter()
            .map(|t| {
                let verdict = if t.met(self) { "meets" } else { "MISSES" };
                format!("  (target {}: {verdict})", t.describe(self.unit))
            })
            .collect()
    }

    /// The figure with its unit, for text output.
    pub fn figure(&self) -> String {
        match self.unit {
            Unit::PerSec => format!("{:>12.0} {}", self.ns, self.unit.symbol()),
            Unit::Bytes => format!("{:>12.2} {}", self.ns, self.unit.symbol()),
            u => format!("{:>12.1} {}", self.ns, u.symbol()),
        }
    }
}

fn round(x: f64) -> f64 {
    (x * 100.0).round() / 100.0
}

/// Values for a write loop, so that every write is a change: `low + 1`, `low + 2`, ...
/// up to `high`, then `low`, and round again.
#[derive(Clone, Copy, Debug)]
pub struct Cycle {
    v: f64,
    low: f64,
    high: f64,
}

impl Cycle {
    /// A cycle between `low` and `high`, whose first value is `low + 1`.
    pub fn new(low: f64, high: f64) -> Self {
        Cycle { v: low, low, high }
    }

    /// The next value.
    pub fn next_value(&mut self) -> f64 {
        self.v = if self.v >= self.high {
            self.low
        } else {
            self.v + 1.0
        };
        self.v
    }
}

/// The median of `xs` (the upper one of an even count); NaN without samples.
pub fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    xs.get(xs.len() / 2).copied().unwrap_or(f64::NAN)
}

/// A free TCP port on 127.0.0.1 (the OS picks it; the listener is dropped before use).
pub fn free_port() -> anyhow::Result<u16> {
    let l = TcpListener::bind("127.0.0.1:0").context("no free port on 127.0.0.1")?;
    Ok(l.local_addr()?.port())
}

/// Polls `done` every millisecond until it holds or `max` passes.
pub fn wait(max: Duration, mut done: impl FnMut() -> bool) -> bool {
    let end = Instant::now() + max;
    while Instant::now() < end {
        if done() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    done()
}

/// The `p`th percentile of durations (nearest rank; 0: the least, 100: the most), in
/// seconds; NaN without samples.
pub fn percentile_secs(samples: &[Duration], p: f64) -> f64 {
    let mut secs: Vec<f64> = samples.iter().map(Duration::as_secs_f64).collect();
    secs.sort_by(f64::total_cmp);
    let rank = ((p / 100.0) * secs.len().saturating_sub(1) as f64).round() as usize;
    secs.get(rank).copied().unwrap_or(f64::NAN)
}

/// The smallest measurement a test of a suite needs: three samples of a millisecond.
#[cfg(test)]
const TINY: Config = Config {
    samples: 3,
    sample_ms: 1,
};

/// Asserts that a suite's JSON has each field, positive, and says whether its targets
/// were met.
#[cfg(test)]
fn assert_reports(j: &Value, fields: &[&str]) {
    assert_fields(j, fields, |x| x > 0.0);
    assert!(j["targets_met"].is_boolean());
}

/// Asserts that each of `fields` in a suite's JSON is a number for which `holds`.
#[cfg(test)]
fn assert_fields(j: &Value, fields: &[&str], holds: fn(f64) -> bool) {
    for f in fields {
        assert!(j[f].as_f64().is_some_and(holds), "{f}: {}", j[f]);
    }
}

/// Median nanoseconds per call of `op` (each call is one operation).
pub fn measure(cfg: &Config, mut op: impl FnMut()) -> f64 {
    let target = Duration::from_millis(cfg.sample_ms);
    // The most of three calibrations: on a busy machine one pass that lost the processor
    // for milliseconds would otherwise make every sample a few iterations long.
    let iters = (0..3)
        .map(|_| calibrate(target, &mut op))
        .max()
        .unwrap_or(1);
    let per_op: Vec<f64> = (0..cfg.samples)
        .map(|_| {
            let start = Instant::now();
            for _ in 0..iters {
                op();
            }
            start.elapsed().as_nanos() as f64 / iters as f64
        })
        .collect();
    black_box(median(per_op))
}

/// Iterations that make one sample last about `target` (also warms up).
fn calibrate(target: Duration, op: &mut impl FnMut()) -> u64 {
    let mut iters = 1u64;
    loop {
        let start = Instant::now();
        for _ in 0..iters {
            op();
        }
        let took = start.elapsed();
        if took >= target / 4 || iters >= 1 << 30 {
            let scale = target.as_secs_f64() / took.as_secs_f64().max(1e-9);
            return ((iters as f64 * scale) as u64).max(1);
        }
        iters *= 2;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratios_and_targets_are_computed_against_the_named_baseline() {
        let mut r = Figures::new("t");
        r.add("base_ns", 10.0);
        r.compare("fast_ns", 15.0, "base_ns", Some(2.0));
        assert!(r.targets_met());
        r.compare("slow_ns", 30.0, "base_ns", Some(2.0));
        assert!(!r.targets_met());
        let j = r.json();
        assert_eq!(j["fast_ratio"], json!(1.5));
        assert_eq!(j["slow_ns"], json!(30.0));
        assert_eq!(j["targets_met"], json!(false));
    }

    #[test]
    fn measure_reports_a_positive_median() {
        let cfg = crate::TINY;
        let mut n = 0u64;
        let ns = measure(&cfg, || n = black_box(n + 1));
        assert!(ns > 0.0 && ns.is_finite());
    }
}
