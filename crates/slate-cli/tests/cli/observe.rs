//! `slate hz`, `slate stats` and `slate bw` against a live two-node team whose write rate
//! the test sets: `t/r1/nav` runs in the test and writes `gsr.mode` 10 times a second
//! (each write at its own deadline, so the rate holds whatever the machine's speed),
//! `t/r2/loco` is a `slate node` process. Every figure is checked against that rate,
//! within 10 %.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use serde_json::Value as Json;
use slate_ici::{ClassSet, IciConfig, LinkKind, MsgKind};
use slate_model::Address;
use slate_node::Node;
use slate_zenoh::{Mode, ZenohConfig};

use crate::support::{NodeProc, Team, WORLD, free_port, show, slate};

/// Writes a second, as the test paces them: each write 100 ms after the last, so that
/// each goes out in a report of its own even when the machine is busy.
const RATE: f64 = 10.0;

/// The writer: a node in this process that owns `gsr` and writes its `mode` at [`RATE`]
/// until stopped.
struct Writer {
    node: Arc<Node>,
    endpoint: String,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<u64>>,
}

impl Writer {
    fn start() -> Writer {
        let endpoint = format!("tcp/127.0.0.1:{}", free_port());
        let zenoh = ZenohConfig {
            mode: Mode::Peer,
            listen: vec![endpoint.clone()],
            connect: Vec::new(),
            multicast_scouting: false,
            file: None,
            security: None,
            udp_reports: false,
        };
        let node = Node::builder(Address::new("t/r1/nav").unwrap())
            .zenoh(zenoh)
            .ici(IciConfig::default().export(ClassSet::all()))
            .source("world.slate", WORLD)
            .source("nav.slate", "object gsr : Vehicle context self;")
            .start()
            .expect("start the writer");
        Writer {
            node: Arc::new(node),
            endpoint,
            stop: Arc::new(AtomicBool::new(false)),
            thread: None,
        }
    }

    /// Starts writing: write `i` at `start + i / RATE`, a 100-character text each time
    /// (so that every report has the same size and reports dominate the link).
    fn run(&mut self) {
        let (node, stop) = (self.node.clone(), self.stop.clone());
        self.thread = Some(std::thread::spawn(move || {
            let start = Instant::now();
            let mut i: u64 = 0;
            while !stop.load(Ordering::Acquire) {
                let due = start + Duration::from_secs_f64(i as f64 / RATE);
                std::thread::sleep(due.saturating_duration_since(Instant::now()));
                node.board()
                    .write("gsr", "mode", format!("{i:0>100}"))
                    .unwrap();
                i += 1;
            }
            i
        }));
    }

    /// Bytes of one report of `gsr.mode` on the team link, by the writer's own counters.
    fn report_size(&self) -> f64 {
        let t = self.node.ici().stats().get(LinkKind::Team, MsgKind::Report);
        t.sent_bytes as f64 / t.sent_msgs as f64
    }

    fn finish(mut self) -> u64 {
        self.stop.store(true, Ordering::Release);
        let written = self.thread.take().map_or(0, |t| t.join().unwrap());
        self.node.close();
        written
    }
}

/// Runs `slate ARGS --connect ...` and parses its JSON: the one object it printed, or the
/// last line of those it streamed.
fn last_json(args: &[&str], connect: &[&str]) -> Json {
    let mut all = args.to_vec();
    all.extend(["--format", "json"]);
    for c in connect {
        all.extend(["--connect", c]);
    }
    let out = slate(&all);
    assert!(out.status.success(), "slate {all:?}\n{}", show(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    let last = text.lines().last().unwrap_or_default();
    serde_json::from_str(&text)
        .or_else(|_| serde_json::from_str(last))
        .unwrap_or_else(|e| panic!("{e}: {text}"))
}

/// The row of `link` (and `kind`, if given) of `module` in `slate stats`/`bw` JSON.
fn row<'j>(j: &'j Json, module: &str, table: &str, link: &str, kind: Option<&str>) -> &'j Json {
    let m = j["modules"]
        .as_array()
        .and_then(|ms| ms.iter().find(|m| m["address"] == module))
        .unwrap_or_else(|| panic!("no {module} in {j}"));
    m[table]
        .as_array()
        .and_then(|rows| {
            rows.iter()
                .find(|r| r["link"] == link && kind.is_none_or(|k| r["kind"] == k))
        })
        .unwrap_or_else(|| panic!("no {link} {kind:?} row of {module} in {j}"))
}

fn within_ten_percent(measured: f64, known: f64) -> bool {
    (measured - known).abs() <= 0.1 * known
}

#[test]
fn hz_stats_and_bw_report_the_rate_a_paced_writer_writes_at() {
    let mut team = Team::new("observe");
    let mut writer = Writer::start();
    let loco = NodeProc::start(
        &team.dir,
        "t/r2/loco",
        "",
        std::slice::from_ref(&writer.endpoint),
    );
    assert!(loco.wait_value("gsr", "mode", "auto"), "{}", loco.log());
    writer.run();
    let connect = [writer.endpoint.as_str(), loco.endpoint.as_str()];

    let hz = last_json(
        &["hz", "gsr.mode", "--window", "20", "--count", "3"],
        &connect,
    );
    assert_eq!(hz["window"], 20, "{hz}");
    let rate = hz["rate_hz"].as_f64().unwrap();
    assert!(within_ten_percent(rate, RATE), "hz {rate} for {RATE}: {hz}");

    let stats = last_json(&["stats", "--interval", "3"], &connect);
    let sent = row(&stats, "t/r1/nav", "traffic", "team", Some("report"));
    let received = row(&stats, "t/r2/loco", "traffic", "team", Some("report"));
    for (r, field) in [(sent, "sent_msgs_per_s"), (received, "recv_msgs_per_s")] {
        let measured = r[field].as_f64().unwrap();
        assert!(
            within_ten_percent(measured, RATE),
            "{field} {measured}: {stats}"
        );
    }
    let loco_stats = stats["modules"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["address"] == "t/r2/loco")
        .unwrap();
    assert_eq!(
        loco_stats["peers"],
        serde_json::json!(["t/r1/nav"]),
        "{stats}"
    );
    // Publications dropped for being behind, and plans sent again, are counted (none here).
    assert_eq!(loco_stats["drops"]["behind_dropped"], 0, "{stats}");
    assert_eq!(loco_stats["plans"]["resent"], 0, "{stats}");

    let bw = last_json(&["bw", "t/r2/loco", "--interval", "3"], &connect);
    assert_eq!(bw["modules"].as_array().unwrap().len(), 1, "{bw}");
    let known = RATE * writer.report_size();
    let measured = row(&bw, "t/r2/loco", "links", "team", None)["recv_bytes_per_s"]
        .as_f64()
        .unwrap();
    assert!(
        within_ten_percent(measured, known),
        "bw {measured} B/s, {known} B/s written: {bw}"
    );

    eprintln!("hz {rate:.2} Hz, bw {measured:.1} B/s for {known:.1} B/s written");
    assert!(writer.finish() > 0);
    team.nodes.push(loco);
}

#[test]
fn stats_and_hz_refuse_bad_input_in_one_line_before_joining() {
    let none = "tcp/127.0.0.1:1";
    for (args, says) in [
        (vec!["stats", "t/r1/nav/extra"], "is not a module address"),
        (vec!["stats", "t/r 1"], "is not a module address"),
        (
            vec!["bw", "--interval", "0"],
            "--interval 0: expected a positive number",
        ),
        (vec!["hz", "gsr"], "is not OBJ.ATTR"),
    ] {
        let mut all = args.clone();
        all.extend(["--connect", none, "--wait", "1"]);
        let out = slate(&all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}\n{}", show(&out));
        assert!(
            err.contains(says) && err.lines().count() == 1,
            "{args:?}: {err}"
        );
        assert!(out.stdout.is_empty());
    }
}

#[test]
fn stats_with_no_node_to_ask_says_so() {
    let out = slate(&["stats", "--connect", "tcp/127.0.0.1:1", "--wait", "1"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    assert!(err.contains("no slate module reachable"), "{err}");
}
