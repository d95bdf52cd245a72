//! Benchmark programs: a small harness that reports the median time per operation over
//! several samples, each against a baseline measured in the same run.

pub mod core;
pub mod plans;

use std::hint::black_box;
use std::time::{Duration, Instant};

use serde_json::{Map, Value, json};

/// How long and how often to measure.
#[derive(Clone, Copy, Debug)]
pub struct Config {
    /// Samples per measurement (the median is reported).
    pub samples: usize,
    /// Target duration of one sample.
    pub sample_ms: u64,
}

/// One measured operation.
#[derive(Clone, Debug)]
pub struct Row {
    /// JSON field name, e.g. `read_ns`.
    pub name: &'static str,
    /// Median nanoseconds per operation.
    pub ns: f64,
    /// The baseline row's name and this row's ratio to it.
    pub baseline: Option<(&'static str, f64)>,
    /// The target ratio, if the issue sets one.
    pub target: Option<f64>,
}

/// The result of a suite.
#[derive(Clone, Debug)]
pub struct Report {
    /// Suite title.
    pub title: String,
    /// Rows, baselines included.
    pub rows: Vec<Row>,
}

impl Report {
    /// A new empty report.
    pub fn new(title: &str) -> Self {
        Report {
            title: title.to_owned(),
            rows: Vec::new(),
        }
    }

    /// Adds a measured row.
    pub fn add(&mut self, name: &'static str, ns: f64) {
        self.rows.push(Row {
            name,
            ns,
            baseline: None,
            target: None,
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
        let base = self
            .rows
            .iter()
            .find(|r| r.name == baseline)
            .map_or(f64::NAN, |r| r.ns);
        self.rows.push(Row {
            name,
            ns,
            baseline: Some((baseline, ns / base)),
            target,
        });
    }

    /// One JSON object: every row's median as a field, plus `<row>_ratio` fields, the
    /// build profile and whether every target was met.
    pub fn json(&self) -> Value {
        let mut m = Map::new();
        for r in &self.rows {
            m.insert(r.name.to_owned(), json!(round(r.ns)));
            if let Some((_, ratio)) = r.baseline {
                m.insert(
                    format!("{}_ratio", r.name.trim_end_matches("_ns")),
                    json!(round(ratio)),
                );
            }
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

    /// Did every row with a target meet it?
    pub fn targets_met(&self) -> bool {
        self.rows.iter().all(|r| {
            r.target
                .is_none_or(|t| r.baseline.is_some_and(|(_, ratio)| ratio <= t))
        })
    }
}

fn round(x: f64) -> f64 {
    (x * 100.0).round() / 100.0
}

/// Median nanoseconds per call of `op` (each call is one operation).
pub fn measure(cfg: &Config, mut op: impl FnMut()) -> f64 {
    let target = Duration::from_millis(cfg.sample_ms);
    let iters = calibrate(target, &mut op);
    let mut per_op: Vec<f64> = (0..cfg.samples)
        .map(|_| {
            let start = Instant::now();
            for _ in 0..iters {
                op();
            }
            start.elapsed().as_nanos() as f64 / iters as f64
        })
        .collect();
    per_op.sort_by(f64::total_cmp);
    black_box(per_op[per_op.len() / 2])
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
        let mut r = Report::new("t");
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
        let cfg = Config {
            samples: 3,
            sample_ms: 1,
        };
        let mut n = 0u64;
        let ns = measure(&cfg, || n = black_box(n + 1));
        assert!(ns > 0.0 && ns.is_finite());
    }
}
