//! `slate bench net --secure`: what TLS costs. Two pairs of nodes (board + ICI) over
//! Zenoh on 127.0.0.1 in one process, measured in the same run: one over plain TCP (the
//! baseline), one over TLS with mutual authentication and the access control a secured
//! team generates from its keys (docs/security.md), with keys and certificates made by
//! the `slate keys` code in a temporary directory (removed at the end).
//!
//! The measurements are slate's own from `slate bench net` ([`SlateProbe`],
//! [`SlateFlow`]): a write on A until B's board holds it, one at a time, the two pairs
//! taking turns (each going first in turn); and throughput rounds of batches of 100
//! updates, the pairs alternating, the medians reported. Raw Zenoh puts are not measured
//! here: the access control of a secured team allows puts on slate's keys only.

use std::time::Duration;

use serde_json::json;
use slate_node::team_keys::{Identity, TemporaryKeys};

use crate::net::{PROBE_GAP, ROUNDS, SlateFlow, SlateProbe, percentile, round_budget};
use crate::zenoh_pair::Pair;
use crate::{Config, Figures, Unit, free_port};

/// The secured pair's team (its modules are `TEAM/r1/a` and `TEAM/r1/b`).
const TEAM: &str = "netsecure";

/// Runs the comparison; `progress` is told each step.
pub fn run(cfg: &Config, progress: &mut dyn FnMut(&str)) -> anyhow::Result<Figures> {
    let mut r = Figures::new(
        "slate bench net --secure: two nodes over Zenoh on 127.0.0.1, TLS with mutual authentication and access control vs plain TCP (same run)",
    );
    progress("making a team's keys in a temporary directory");
    let members = [format!("{TEAM}/r1/a"), format!("{TEAM}/r1/b")];
    let identities = members
        .iter()
        .map(|m| Identity::parse(m))
        .collect::<Result<Vec<_>, _>>()?;
    let keys = TemporaryKeys::make("bench", &identities)?;
    progress("opening two pairs of Zenoh sessions: TCP, and TLS");
    let port = free_port()?;
    let tcp = Pair::open("netplain", port, port)?;
    let tls_port = free_port()?;
    let tls = Pair::open_secured(TEAM, tls_port, keys.dir())?;
    for pair in [&tcp, &tls] {
        pair.create_objects()?;
    }
    progress("latency");
    latency(cfg, [&tcp, &tls], &mut r)?;
    progress("throughput");
    throughput(cfg, [&tcp, &tls], &mut r)?;
    drop((tcp, tls));
    Ok(r)
}

/// Latency probes on both pairs, taking turns, after unmeasured warm-up probes.
fn latency(cfg: &Config, pairs: [&Pair; 2], r: &mut Figures) -> anyhow::Result<()> {
    let probes = (cfg.samples * 450).max(300);
    let probe = [SlateProbe::new(pairs[0])?, SlateProbe::new(pairs[1])?];
    for k in 0..probes / 10 + 10 {
        for p in &probe {
            p.probe(k)?;
            std::thread::sleep(PROBE_GAP);
        }
    }
    let mut samples: [Vec<Duration>; 2] = Default::default();
    for k in 0..probes {
        for j in 0..2 {
            let i = (k + j) % 2;
            samples[i].push(probe[i].probe(k)?);
            std::thread::sleep(PROBE_GAP);
        }
    }
    let [tcp, tls] = samples;
    let rows = [
        (50.0, "tcp_latency_p50_us", "tls_latency_p50_us"),
        (99.0, "tcp_latency_p99_us", "tls_latency_p99_us"),
    ];
    for (p, base, name) in rows {
        r.add_in(base, percentile(&tcp, p), Unit::Us);
        r.compare_in(name, percentile(&tls, p), Unit::Us, base, Vec::new());
    }
    r.fact("latency_probes", json!(probes));
    Ok(())
}

/// Throughput rounds on both pairs, alternating, each starting a round in turn.
fn throughput(cfg: &Config, pairs: [&Pair; 2], r: &mut Figures) -> anyhow::Result<()> {
    let budget = round_budget(cfg);
    let mut flows = [SlateFlow::new(pairs[0])?, SlateFlow::new(pairs[1])?];
    let mut rates: [Vec<f64>; 2] = Default::default();
    let mut counts = [0u64; 2];
    for round in 0..ROUNDS {
        for j in 0..2 {
            let i = (round + j) % 2;
            let (rate, sent, _) = flows[i].round(budget)?;
            rates[i].push(rate);
            counts[i] += sent;
        }
    }
    let [tcp, tls] = rates;
    let base = "tcp_updates_per_sec";
    r.add_in(base, crate::median(tcp), Unit::PerSec);
    let tls = crate::median(tls);
    r.compare_in("tls_updates_per_sec", tls, Unit::PerSec, base, Vec::new());
    r.fact("throughput_rounds", json!(ROUNDS));
    r.fact("tcp_throughput_updates", json!(counts[0]));
    r.fact("tls_throughput_updates", json!(counts[1]));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_secure_net_suite_reports_tls_against_tcp() {
        let j = run(&crate::TINY, &mut |_| {})
            .expect("the suite runs")
            .json();
        crate::assert_reports(
            &j,
            &[
                "tcp_latency_p50_us",
                "tls_latency_p50_us",
                "tls_latency_p50_ratio",
                "tcp_latency_p99_us",
                "tls_latency_p99_us",
                "tcp_updates_per_sec",
                "tls_updates_per_sec",
                "tls_updates_per_sec_ratio",
            ],
        );
    }
}
