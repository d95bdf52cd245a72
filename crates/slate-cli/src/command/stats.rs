//! `slate stats [ADDR]` and `slate bw`: each module's counters, and the rates between two
//! answers `--interval` apart, once or on and on (`--watch`).
//!
//! A rate is the difference of two answers' counts over the difference of their
//! `uptime_s`, both from the module itself; a module that restarted between them (its
//! uptime went back) has totals but no rates until its next answer.

use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context as _;
use serde_json::{Value as Json, json};
use slate_node::stats::{ModuleStats, StatsProbe, TrafficRow};

use crate::cli::{Format, StatsArgs};
use crate::command::live::{interrupted, operator_keys, print_json, print_line, wait};

/// What a verb prints of one round of answers (JSON on one line per round when the
/// last argument says it streams).
type Render = fn(&[Measured], Format, bool) -> anyhow::Result<()>;

/// `slate stats`: every count, per link and message kind.
pub fn run(args: &StatsArgs, format: Format) -> anyhow::Result<ExitCode> {
    repeat(args, format, print_stats)
}

/// `slate bw`: bytes per second per link.
pub fn bw(args: &StatsArgs, format: Format) -> anyhow::Result<ExitCode> {
    repeat(args, format, print_bw)
}

/// One module's answer, with the rates since its previous one.
pub struct Measured {
    now: ModuleStats,
    /// Seconds between the two answers, by the module's clock; `None` without a
    /// previous answer from the same run of the module.
    window_s: Option<f64>,
    before: Option<ModuleStats>,
}

impl Measured {
    /// Per second of the window: what `now` counts beyond `before`.
    fn rate(&self, of: impl Fn(&ModuleStats) -> u64) -> Option<f64> {
        let (w, b) = (self.window_s?, self.before.as_ref()?);
        Some(of(&self.now).saturating_sub(of(b)) as f64 / w)
    }

    /// A traffic row's counts and rates, as JSON.
    fn row_json(&self, row: &TrafficRow, find: impl Fn(&ModuleStats) -> TrafficRow) -> Json {
        json!({
            "link": row.link,
            "kind": row.kind,
            "sent_msgs": row.sent_msgs,
            "sent_bytes": row.sent_bytes,
            "recv_msgs": row.recv_msgs,
            "recv_bytes": row.recv_bytes,
            "sent_msgs_per_s": self.rate(|s| find(s).sent_msgs),
            "sent_bytes_per_s": self.rate(|s| find(s).sent_bytes),
            "recv_msgs_per_s": self.rate(|s| find(s).recv_msgs),
            "recv_bytes_per_s": self.rate(|s| find(s).recv_bytes),
        })
    }

    fn links_json(&self) -> Vec<Json> {
        ["robot", "team"]
            .iter()
            .map(|l| self.row_json(&self.now.link(l), |s| s.link(l)))
            .collect()
    }

    fn traffic_json(&self) -> Vec<Json> {
        self.now
            .traffic
            .iter()
            .map(|r| self.row_json(r, |s| kind_row(s, &r.link, &r.kind)))
            .collect()
    }
}

/// The row of one link and kind in `s` (zeros if it has none).
fn kind_row(s: &ModuleStats, link: &str, kind: &str) -> TrafficRow {
    s.traffic
        .iter()
        .find(|r| r.link == link && r.kind == kind)
        .cloned()
        .unwrap_or_default()
}

/// Asks, waits `--interval`, asks again and prints; with `--watch`, on until Ctrl-C.
fn repeat(args: &StatsArgs, format: Format, render: Render) -> anyhow::Result<ExitCode> {
    let interval = seconds(args.interval, "--interval")?;
    let connection = &args.connection;
    let operator = operator_keys(connection)?;
    let signals = interrupted()?;
    let probe = StatsProbe::open(
        &connection.connect,
        args.address.as_deref(),
        wait(connection)?,
        operator.as_ref(),
    )?;
    let mut before = probe.sample()?;
    loop {
        if signals.recv_timeout(interval).is_ok() {
            break;
        }
        let now = probe.sample()?;
        render(&measure(&before, &now), format, args.watch)?;
        before = now;
        if !args.watch {
            break;
        }
    }
    probe.close();
    Ok(ExitCode::SUCCESS)
}

/// A positive number of seconds from a flag.
fn seconds(value: f64, flag: &str) -> anyhow::Result<Duration> {
    Duration::try_from_secs_f64(value)
        .ok()
        .filter(|d| !d.is_zero())
        .with_context(|| format!("{flag} {value}: expected a positive number of seconds"))
}

/// Each module of `now` with its answer in `before`, if it has one from the same run.
fn measure(before: &[ModuleStats], now: &[ModuleStats]) -> Vec<Measured> {
    now.iter()
        .map(|n| {
            let b = before
                .iter()
                .find(|b| b.address == n.address && b.uptime_s < n.uptime_s);
            Measured {
                now: n.clone(),
                window_s: b.map(|b| n.uptime_s - b.uptime_s),
                before: b.cloned(),
            }
        })
        .collect()
}

fn print_stats(round: &[Measured], format: Format, lines: bool) -> anyhow::Result<()> {
    match format {
        Format::Json => {
            let modules: Vec<Json> = round.iter().map(stats_json).collect();
            emit(&json!({ "modules": modules }), lines)
        }
        Format::Text => {
            round.iter().for_each(print_stats_text);
            Ok(())
        }
    }
}

fn stats_json(m: &Measured) -> Json {
    let s = &m.now;
    json!({
        "address": s.address,
        "uptime_s": s.uptime_s,
        "window_s": m.window_s,
        "peers": s.peers,
        "links": m.links_json(),
        "traffic": m.traffic_json(),
        "drops": s.drops,
        "catch_up": s.catch_up,
        "merges": s.merges,
        "plans": s.plans,
    })
}

/// One JSON object: pretty once, or on one line per round (`--watch` streams).
fn emit(j: &Json, lines: bool) -> anyhow::Result<()> {
    if lines { print_line(j) } else { print_json(j) }
}

fn print_stats_text(m: &Measured) {
    let s = &m.now;
    let peers = match s.peers.len() {
        1 => format!("1 peer ({})", s.peers[0]),
        n => format!("{n} peers ({})", s.peers.join(", ")),
    };
    let over = m.window_s.map_or("no rates yet".to_owned(), |w| {
        format!("rates over {w:.2} s")
    });
    println!("{}: up {:.1} s, {peers}, {over}", s.address, s.uptime_s);
    println!(
        "  {:<6} {:<17} {:>10} {:>10} {:>10} {:>10} {:>12} {:>12}",
        "link", "kind", "out msg/s", "out B/s", "in msg/s", "in B/s", "out B total", "in B total"
    );
    for r in &s.traffic {
        let rate = |f: fn(&TrafficRow) -> u64| {
            m.rate(|x| f(&kind_row(x, &r.link, &r.kind)))
                .map_or("-".to_owned(), |v| format!("{v:.1}"))
        };
        println!(
            "  {:<6} {:<17} {:>10} {:>10} {:>10} {:>10} {:>12} {:>12}",
            r.link,
            r.kind,
            rate(|t| t.sent_msgs),
            rate(|t| t.sent_bytes),
            rate(|t| t.recv_msgs),
            rate(|t| t.recv_bytes),
            r.sent_bytes,
            r.recv_bytes
        );
    }
    let d = &s.drops;
    println!(
        "  drops: send failed {}, undecodable {}, refused {}, duplicates {}, team protocol {}, behind {}",
        d.send_failed, d.undecodable, d.refused, d.duplicates, d.team_dropped, d.behind_dropped
    );
    let c = &s.catch_up;
    println!(
        "  catch-ups: gaps {}, requested {}, retried {}, completed {}, answered {}",
        c.gaps, c.requested, c.retried, c.completed, c.answered
    );
    let p = &s.plans;
    println!(
        "  plans sent: {}; received: {}, accepted {}, rejected {} (no authority {}, busy {}), answered again {}; sent again {}, last steps repeated {}",
        p.sent,
        p.received,
        p.accepted,
        p.rejected,
        p.unauthorised,
        p.busy,
        p.answered_again,
        p.resent,
        p.repeated
    );
}

fn print_bw(round: &[Measured], format: Format, lines: bool) -> anyhow::Result<()> {
    match format {
        Format::Json => {
            let modules: Vec<Json> = round.iter().map(bw_json).collect();
            emit(&json!({ "modules": modules }), lines)
        }
        Format::Text => {
            round.iter().for_each(print_bw_text);
            Ok(())
        }
    }
}

fn bw_json(m: &Measured) -> Json {
    let links: Vec<Json> = ["robot", "team"]
        .iter()
        .map(|l| {
            let now = m.now.link(l);
            json!({
                "link": l,
                "sent_bytes": now.sent_bytes,
                "recv_bytes": now.recv_bytes,
                "sent_bytes_per_s": m.rate(|s| s.link(l).sent_bytes),
                "recv_bytes_per_s": m.rate(|s| s.link(l).recv_bytes),
            })
        })
        .collect();
    json!({ "address": m.now.address, "window_s": m.window_s, "links": links })
}

fn print_bw_text(m: &Measured) {
    for l in ["robot", "team"] {
        let rate = |f: fn(&TrafficRow) -> u64| {
            m.rate(|s| f(&s.link(l)))
                .map_or("-".to_owned(), |v| format!("{}/s", bytes(v)))
        };
        println!(
            "{}  {l:<5}  out {}  in {}",
            m.now.address,
            rate(|t| t.sent_bytes),
            rate(|t| t.recv_bytes)
        );
    }
}

/// Bytes with a unit, as `ros2 topic bw` prints them: `812.00 B`, `4.03 KB`, `1.20 MB`.
fn bytes(b: f64) -> String {
    match b {
        b if b >= 1e6 => format!("{:.2} MB", b / 1e6),
        b if b >= 1e3 => format!("{:.2} KB", b / 1e3),
        b => format!("{b:.2} B"),
    }
}
