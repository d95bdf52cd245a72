//! `slate bench record`: a node's write path with its board recorded in MCAP, against the
//! same node without (docs/recording.md), measured in the same run.

use std::hint::black_box;
use std::time::Duration;

use serde_json::json;
use slate_ici::{ClassSet, IciConfig, SimNet};
use slate_model::Address;
use slate_node::{Node, RecordConfig};

use crate::{Config, Figures, measure};

/// The module measured: one vehicle written again and again, exporting everything (the
/// ICI builds its reports on the write path, as in a team).
const WORLD: &str = "class Vehicle { speed: real [m/s] in 0 .. 50 = 0.0; x: real [m]; }\nobject gsr : Vehicle context self;";

/// Runs the suite; `progress` is told each step.
pub fn run(cfg: &Config, progress: &mut dyn FnMut(&str)) -> anyhow::Result<Figures> {
    let mut r = Figures::new(
        "slate bench record: a node's writes with its board recorded in MCAP vs the same node without",
    );
    let net = SimNet::new(1);
    let address = Address::new("team/r1/nav")?;
    let node = Node::builder(address.clone())
        .transport(net.join(&address))
        .clock(net.clock())
        .ici(IciConfig::default().export(ClassSet::all()))
        .source("bench.slate", WORLD)
        .start()?;
    let key = node.board().key("gsr", "speed")?;
    let mut values = crate::Cycle::new(0.0, 49.0);
    let written = std::cell::Cell::new(0u64);
    let calls = std::cell::Cell::new(0u64);
    let mut write = || {
        let ok = black_box(node.board().write_key(key, values.next_value())).is_ok();
        written.set(written.get() + u64::from(ok));
        calls.set(calls.get() + 1);
    };
    // The writer thread's own processor time per write, beside the wall time: what a
    // writer with a core of its own would pay (the time it is not scheduled, while the
    // recorder or another process has the processor, is not in it).
    let on_cpu = |f: &mut dyn FnMut() -> f64| {
        let (cpu, n) = (thread_cpu_ns(), calls.get());
        let ns = f();
        let cpu = thread_cpu_ns().zip(cpu).map(|(b, a)| b.saturating_sub(a));
        let per = cpu.map_or(0.0, |c| c as f64 / (calls.get() - n).max(1) as f64);
        (ns, per)
    };
    progress("node writes, not recording");
    // The node's first writes set things up (the ICI's first reports): not measured.
    (0..10_000).for_each(|_| write());
    let (ns, cpu) = on_cpu(&mut || measure(cfg, &mut write));
    r.add("node_write_ns", ns);
    r.add("node_write_cpu_ns", cpu);
    progress("node writes, a bounded watch drained by a thread that discards");
    let ns = handed_off(node.board(), || measure(cfg, &mut write))?;
    r.compare("node_write_handoff_ns", ns, "node_write_ns", None);
    let dir = std::env::temp_dir().join(format!("slate-bench-record-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let path = dir.join("bench.mcap");
    node.start_recording(RecordConfig::new(&path))?;
    progress("node writes, recording");
    let before = written.get();
    let recorder = thread_named("slate-recorder");
    let recorder_cpu = recorder.as_deref().and_then(thread_cpu_ns_of);
    let (ns, cpu) = on_cpu(&mut || measure(cfg, &mut write));
    r.compare("node_write_recording_ns", ns, "node_write_ns", Some(1.25));
    r.compare(
        "node_write_recording_cpu_ns",
        cpu,
        "node_write_cpu_ns",
        None,
    );
    let recorder_cpu = recorder
        .as_deref()
        .and_then(thread_cpu_ns_of)
        .zip(recorder_cpu)
        .map_or(0, |(b, a)| b.saturating_sub(a));
    let recorded = node.recording().unwrap_or_default();
    let written = written.get() - before;
    let stats = node.stop_recording()?.unwrap_or_default();
    node.close();
    net.run_for(Duration::from_millis(10));
    let _ = std::fs::remove_dir_all(&dir);
    r.fact("recorded_messages", json!(stats.messages));
    r.fact("written_while_recording", json!(written));
    r.fact("recorded_packets", json!(stats.packets));
    let on_channel = stats.by_topic.get(PACKETS).copied().unwrap_or(0);
    r.fact("packet_messages", json!(on_channel));
    r.fact("recorded_bytes", json!(stats.bytes));
    r.fact("dropped_changes", json!(stats.dropped));
    r.fact("recording_failed", json!(stats.failed));
    let per_packet = recorder_cpu as f64 / recorded.packets.max(1) as f64;
    r.fact("recorder_cpu_ns_per_packet", json!(per_packet.round()));
    let per = stats.bytes as f64 / stats.packets.max(1) as f64;
    r.fact("bytes_per_packet", json!((per * 10.0).round() / 10.0));
    Ok(r)
}

/// Runs `op` while a thread takes everything waiting in a gathering watch of the whole
/// board 2 ms after a change comes, as the recorder does, and discards it: the writer's share of recording (the
/// change built and handed over), without the recorder's own work competing for the
/// cores.
fn handed_off(board: &slate_model::Board, op: impl FnOnce() -> f64) -> anyhow::Result<f64> {
    let watch = board.watch_gathered(slate_model::Filter::all(), 1 << 16)?;
    let stop = std::sync::atomic::AtomicBool::new(false);
    std::thread::scope(|s| {
        s.spawn(|| {
            let mut taken = Vec::new();
            while !stop.load(std::sync::atomic::Ordering::Acquire) {
                if watch.wait(Duration::from_millis(10)) {
                    std::thread::sleep(Duration::from_millis(2));
                    watch.take(&mut taken);
                    taken.clear();
                }
            }
        });
        let ns = op();
        stop.store(true, std::sync::atomic::Ordering::Release);
        Ok(ns)
    })
}

/// The processor time of the calling thread so far, in nanoseconds (Linux's
/// `/proc/thread-self/schedstat`; `None` elsewhere). The kernel brings a running thread's
/// count up to date at each scheduler tick (4 ms at most): over a measurement of a second
/// that is half a percent.
fn thread_cpu_ns() -> Option<u64> {
    schedstat(std::path::Path::new("/proc/thread-self/schedstat"))
}

/// The processor time of one of this process's threads (its `/proc/self/task/TID`).
fn thread_cpu_ns_of(task: &std::path::Path) -> Option<u64> {
    schedstat(&task.join("schedstat"))
}

fn schedstat(path: &std::path::Path) -> Option<u64> {
    let text = std::fs::read_to_string(path).ok()?;
    text.split_whitespace().next()?.parse().ok()
}

/// The `/proc/self/task/TID` of this process's thread named `name`, waiting up to a
/// second for it (a new thread names itself once it runs).
fn thread_named(name: &str) -> Option<std::path::PathBuf> {
    let find = || {
        std::fs::read_dir("/proc/self/task")
            .ok()?
            .flatten()
            .map(|e| e.path())
            .find(|task| std::fs::read_to_string(task.join("comm")).is_ok_and(|c| c.trim() == name))
    };
    (0..1000).find_map(|_| {
        find().or_else(|| {
            std::thread::sleep(Duration::from_millis(1));
            None
        })
    })
}

/// The channel of the bench's packets (`gsr` is a `Vehicle`): one message holds the
/// packets written while the recorder gathered them.
const PACKETS: &str = "/slate/class/Vehicle";

/// Every timed field of the JSON object.
pub const TIMED_FIELDS: &[&str] = &[
    "node_write_ns",
    "node_write_handoff_ns",
    "node_write_recording_ns",
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_record_suite_reports_every_field() {
        let j = run(&crate::TINY, &mut |_| {}).unwrap().json();
        crate::assert_fields(&j, TIMED_FIELDS, |x| x > 0.0);
        assert!(j["recorded_messages"].as_u64() > Some(0), "{j}");
        // Processor times are reported; in a run this short they may not have moved (the
        // kernel brings a running thread's count up to date at each scheduler tick).
        for f in [
            "node_write_cpu_ns",
            "node_write_recording_cpu_ns",
            "recorder_cpu_ns_per_packet",
        ] {
            assert!(j[f].as_f64() >= Some(0.0), "{f}: {j}");
        }
        // Every write recorded or counted as dropped (and the file's first packet, the
        // value gsr had when it began).
        let accounted =
            j["recorded_packets"].as_u64().unwrap() + j["dropped_changes"].as_u64().unwrap();
        let written = j["written_while_recording"].as_u64().unwrap();
        assert!(accounted >= written, "{j}");
    }
}
