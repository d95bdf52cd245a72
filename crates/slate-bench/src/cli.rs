//! `slate bench cli`: the round trip of `slate get` on a live team, as a user runs it.
//!
//! Two `slate node` processes (this very executable) on 127.0.0.1: `clibench/r1/a` owns
//! the object `p1` (loaded from a `.slate` file, `p1.level = 42.5`), `clibench/r2/b`
//! connects to it; both export everything. Each run spawns
//! `slate get p1.level --connect <b's endpoint> --format json` and times it from spawn to
//! exit; its output is then parsed and must hold `42.5` from `clibench/r1/a` (the value
//! travels from a, through b, to the observer). Baselines, interleaved with the gets in
//! the same run:
//!
//! * `process_start_ms`: the same executable spawned with `--version` (no networking):
//!   what starting a process costs.
//! * `raw_zenoh_query_ms`: in this process, a Zenoh client session opened to b's
//!   endpoint, one liveliness query answered by the team (both modules' tokens), and the
//!   session closed: the least a program can do to ask the team anything. Zenoh's runtime
//!   is already up in this process, which a fresh process must start first: a low
//!   estimate.
//! * `process_start_plus_raw_zenoh_ms`: the sum of the two medians, the floor of any
//!   separate process that asks the team one question.
//!
//! Every process the suite starts is stopped by its pid when it ends, also on error.

use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context as _, anyhow, bail, ensure};
use serde_json::{Value, json};
use zenoh::Wait;

use crate::{Config, Figures, Unit, free_port, percentile_secs, round};

/// The team's name, the owner of the object and the node the observers connect to.
const TEAM: &str = "clibench";
const OWNER: &str = "clibench/r1/a";
const RELAY: &str = "clibench/r2/b";

/// The object, the attribute read and its value.
const OBJECT: &str = "p1";
const ATTR: &str = "level";
const VALUE: f64 = 42.5;

/// Longest a node may take to say it is ready, and the team to answer a first `get`.
const READY_LIMIT: Duration = Duration::from_secs(30);

/// Longest one measured process may take (`slate get` gives up after 5 s by itself).
const RUN_LIMIT: Duration = Duration::from_secs(30);

/// Successful `get`s before measuring (the nodes settle, caches warm).
const WARM_UP: usize = 3;

/// Runs the suite with this executable as `slate`; `progress` is told each step.
pub fn run(cfg: &Config, progress: &mut dyn FnMut(&str)) -> anyhow::Result<Figures> {
    let exe = std::env::current_exe().context("cannot find the slate executable")?;
    run_with(&exe, cfg, progress)
}

/// Runs the suite with `exe` as the `slate` binary.
pub fn run_with(
    exe: &Path,
    cfg: &Config,
    progress: &mut dyn FnMut(&str),
) -> anyhow::Result<Figures> {
    let runs = cfg.samples.max(3);
    let mut r = Figures::new(
        "slate bench cli: `slate get` on a live two-node team (processes on 127.0.0.1), spawn to exit, vs process start and a raw Zenoh query (same run)",
    );
    progress("starting two slate nodes");
    let team = Team::start(exe)?;
    progress("waiting until `slate get` answers");
    team.warm_up()?;
    zenoh_query(&team.relay_endpoint)?;
    progress(&format!(
        "{runs} runs each of `slate --version`, a raw Zenoh query and `slate get`"
    ));
    let (mut start, mut raw, mut get) = (Vec::new(), Vec::new(), Vec::new());
    let mut replies = 0;
    for _ in 0..runs {
        start.push(team.process_start()?);
        let (took, n) = zenoh_query(&team.relay_endpoint)?;
        raw.push(took);
        replies = n;
        get.push(team.get()?);
    }
    let endpoint = team.relay_endpoint.clone();
    progress("stopping the nodes");
    team.stop();

    let start_ms = percentile_ms(&start, 50.0);
    let raw_ms = percentile_ms(&raw, 50.0);
    r.add_in("process_start_ms", start_ms, Unit::Ms);
    r.add_in("raw_zenoh_query_ms", raw_ms, Unit::Ms);
    let floor = "process_start_plus_raw_zenoh_ms";
    r.add_in(floor, start_ms + raw_ms, Unit::Ms);
    let p50 = percentile_ms(&get, 50.0);
    r.compare_in("get_round_trip_ms", p50, Unit::Ms, floor, Vec::new());
    let p90 = percentile_ms(&get, 90.0);
    r.compare_in("get_round_trip_p90_ms", p90, Unit::Ms, floor, Vec::new());
    r.fact("runs", json!(runs));
    let ms = |samples: &[Duration], p| json!(round(percentile_ms(samples, p)));
    r.fact("get_round_trip_min_ms", ms(&get, 0.0));
    r.fact("get_round_trip_max_ms", ms(&get, 100.0));
    let slow = get
        .iter()
        .filter(|d| d.as_secs_f64() * 1e3 > 2.0 * p50)
        .count();
    r.fact("get_round_trips_over_twice_the_median", json!(slow));
    r.fact("process_start_p90_ms", ms(&start, 90.0));
    r.fact("raw_zenoh_query_p90_ms", ms(&raw, 90.0));
    r.fact("raw_zenoh_query_replies", json!(replies));
    r.fact(
        "get_command",
        json!(format!(
            "slate get {OBJECT}.{ATTR} --connect {endpoint} --format json"
        )),
    );
    Ok(r)
}

/// The `p`th percentile of durations, in milliseconds.
fn percentile_ms(samples: &[Duration], p: f64) -> f64 {
    percentile_secs(samples, p) * 1e3
}

/// A child process, stopped by its pid when dropped: SIGTERM (a node leaves the
/// network cleanly), SIGKILL if it has not exited within 5 s, then waited for.
struct Proc {
    child: Child,
}

impl Proc {
    fn spawn(command: &mut Command) -> anyhow::Result<Proc> {
        let child = command
            .spawn()
            .context("cannot start the slate executable")?;
        Ok(Proc { child })
    }

    /// Waits until it exits, at most `limit` (then kills it and fails).
    fn wait(&mut self, limit: Duration) -> anyhow::Result<std::process::ExitStatus> {
        let deadline = Instant::now() + limit;
        loop {
            if let Some(status) = self.child.try_wait()? {
                return Ok(status);
            }
            if Instant::now() > deadline {
                let _ = self.child.kill();
                let _ = self.child.wait();
                bail!("a slate process did not exit within {} s", limit.as_secs());
            }
            std::thread::sleep(Duration::from_micros(200));
        }
    }

    /// Has it exited?
    fn exited(&mut self) -> bool {
        !matches!(self.child.try_wait(), Ok(None))
    }

    /// Its output (piped, and small: read once it has exited).
    fn output(mut self, status: std::process::ExitStatus) -> Output {
        let stdout = read_pipe(self.child.stdout.as_mut());
        let stderr = read_pipe(self.child.stderr.as_mut());
        Output {
            status,
            stdout,
            stderr,
        }
    }
}

/// What is left in a pipe (nothing if there is none).
fn read_pipe(pipe: Option<&mut impl Read>) -> Vec<u8> {
    let mut bytes = Vec::new();
    if let Some(p) = pipe {
        let _ = p.read_to_end(&mut bytes);
    }
    bytes
}

impl Drop for Proc {
    fn drop(&mut self) {
        if self.exited() {
            return;
        }
        let pid = self.child.id().to_string();
        let termed = Command::new("kill")
            .args(["-TERM", &pid])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        let deadline = Instant::now() + Duration::from_secs(5);
        while termed && !self.exited() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(10));
        }
        if !self.exited() {
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}

/// The two nodes, their folder (configs, files, logs) and the executable. Dropping it
/// stops the nodes and removes the folder.
struct Team {
    exe: PathBuf,
    dir: PathBuf,
    relay_endpoint: String,
    nodes: Vec<(&'static str, Proc)>,
}

impl Team {
    /// Writes the configs and starts both nodes; returns once both said they are ready.
    fn start(exe: &Path) -> anyhow::Result<Team> {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        let dir =
            std::env::temp_dir().join(format!("slate-bench-cli-{}-{nanos}", std::process::id()));
        std::fs::create_dir_all(&dir)
            .with_context(|| format!("cannot create {}", dir.display()))?;
        let mut team = Team {
            exe: exe.to_owned(),
            dir,
            relay_endpoint: String::new(),
            nodes: Vec::new(),
        };
        let write = |name: &str, text: &str| {
            let path = team.dir.join(name);
            std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))
        };
        write(
            "world.slate",
            "class Probe { level: real [m] in 0 .. 1000; }\n",
        )?;
        write(
            "a.slate",
            &format!("object {OBJECT} : Probe {{ {ATTR} = {VALUE}; }}\n"),
        )?;
        write("b.slate", "")?;
        let owner_endpoint = format!("tcp/127.0.0.1:{}", free_port()?);
        team.node("a", OWNER, &owner_endpoint, None)?;
        let relay_endpoint = format!("tcp/127.0.0.1:{}", free_port()?);
        team.node("b", RELAY, &relay_endpoint, Some(&owner_endpoint))?;
        team.relay_endpoint = relay_endpoint;
        Ok(team)
    }

    /// `slate ARGS` with this executable, its output piped, no `RUST_LOG`.
    fn command(&self, args: &[&str]) -> Command {
        let mut c = Command::new(&self.exe);
        c.args(args)
            .env_remove("RUST_LOG")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        c
    }

    /// Starts `slate node` at `address` (files `world.slate` and `{stem}.slate`),
    /// listening on `listen` and connecting to `connect`, and waits for its ready line.
    fn node(
        &mut self,
        stem: &'static str,
        address: &str,
        listen: &str,
        connect: Option<&str>,
    ) -> anyhow::Result<()> {
        let connect = connect.map_or(String::new(), |c| format!("{c:?}"));
        let config = format!(
            "address = {address:?}\nfiles = [\"world.slate\", \"{stem}.slate\"]\nexport = [\"Thing\"]\n\n[zenoh]\nlisten = [{listen:?}]\nconnect = [{connect}]\n"
        );
        let path = self.dir.join(format!("{stem}.toml"));
        std::fs::write(&path, config)?;
        let out = self.dir.join(format!("{stem}.out"));
        let log = self.dir.join(format!("{stem}.log"));
        let mut command = self.command(&[
            "node",
            "--config",
            &path.to_string_lossy(),
            "--format",
            "json",
        ]);
        command
            .stdout(File::create(&out)?)
            .stderr(File::create(&log)?);
        self.nodes.push((stem, Proc::spawn(&mut command)?));
        let deadline = Instant::now() + READY_LIMIT;
        loop {
            let text = std::fs::read_to_string(&out).unwrap_or_default();
            if let Some(line) = text.lines().next()
                && let Ok(j) = serde_json::from_str::<Value>(line)
            {
                ensure!(
                    j["event"] == "ready" && j["address"] == address,
                    "{address}: unexpected first line {line}"
                );
                return Ok(());
            }
            let exited = self.nodes.last_mut().is_some_and(|(_, p)| p.exited());
            if exited || Instant::now() > deadline {
                bail!(
                    "the node {address} did not start (see its log below)\n{}",
                    self.logs()
                );
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Every node's log, for error messages.
    fn logs(&self) -> String {
        self.nodes
            .iter()
            .map(|(stem, _)| {
                let log = std::fs::read_to_string(self.dir.join(format!("{stem}.log")));
                format!("--- log of node {stem}\n{}", log.unwrap_or_default())
            })
            .collect()
    }

    /// Runs `slate get` until it answers with the value (the team has met), then
    /// [`WARM_UP`] more times.
    fn warm_up(&self) -> anyhow::Result<()> {
        let deadline = Instant::now() + READY_LIMIT;
        let mut last = anyhow!("no answer");
        while Instant::now() < deadline {
            match self.get() {
                Ok(_) => {
                    for _ in 0..WARM_UP {
                        self.get()?;
                    }
                    return Ok(());
                }
                Err(e) => last = e,
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        Err(last.context(format!(
            "the team did not answer `slate get` within {} s\n{}",
            READY_LIMIT.as_secs(),
            self.logs()
        )))
    }

    /// Runs `slate ARGS` and times it from spawn to exit; returns its output too.
    fn timed(&self, args: &[&str]) -> anyhow::Result<(Duration, Output)> {
        let mut command = self.command(args);
        let start = Instant::now();
        let mut p = Proc::spawn(&mut command)?;
        let status = p.wait(RUN_LIMIT)?;
        let took = start.elapsed();
        Ok((took, p.output(status)))
    }

    /// One `slate --version`, timed; its output checked.
    fn process_start(&self) -> anyhow::Result<Duration> {
        let (took, out) = self.timed(&["--version"])?;
        let text = String::from_utf8_lossy(&out.stdout);
        ensure!(
            out.status.success() && text.starts_with("slate "),
            "`slate --version` failed: {}",
            show(&out)
        );
        Ok(took)
    }

    /// One `slate get`, timed; its output checked.
    fn get(&self) -> anyhow::Result<Duration> {
        let target = format!("{OBJECT}.{ATTR}");
        let args = [
            "get",
            &target,
            "--connect",
            &self.relay_endpoint,
            "--format",
            "json",
        ];
        let (took, out) = self.timed(&args)?;
        ensure!(out.status.success(), "`slate get` failed: {}", show(&out));
        let j: Value = serde_json::from_slice(&out.stdout)
            .with_context(|| format!("`slate get` printed no JSON: {}", show(&out)))?;
        let a = &j["attrs"][0];
        let right = j["object"] == OBJECT
            && j["owner"] == OWNER
            && a["attr"] == ATTR
            && a["value"].as_f64() == Some(VALUE)
            && a["source"] == OWNER;
        ensure!(right, "`slate get` answered {j}, not {VALUE} from {OWNER}");
        Ok(took)
    }

    /// Stops the nodes (by pid) and removes the folder.
    fn stop(self) {
        drop(self);
    }
}

impl Drop for Team {
    fn drop(&mut self) {
        // Each `Proc` stops its node; the relay first, as the owner's only peer.
        while let Some(node) = self.nodes.pop() {
            drop(node);
        }
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Exit status, stdout and stderr, for error messages.
fn show(out: &Output) -> String {
    format!(
        "exit {:?}\n--- stdout\n{}--- stderr\n{}",
        out.status.code(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// Opens a Zenoh client session to `endpoint` (as an observer does: client mode, no
/// scouting, no Zenoh timestamps), asks for every liveliness token of the team, and
/// closes it. Returns the time taken and how many modules answered.
fn zenoh_query(endpoint: &str) -> anyhow::Result<(Duration, usize)> {
    let mut c = zenoh::Config::default();
    let settings = [
        ("mode", "\"client\"".to_owned()),
        ("connect/endpoints", format!("[{endpoint:?}]")),
        ("scouting/multicast/enabled", "false".to_owned()),
        (
            "timestamping/enabled",
            "{ router: false, peer: false, client: false }".to_owned(),
        ),
    ];
    for (key, value) in settings {
        c.insert_json5(key, &value)
            .map_err(|e| anyhow!("zenoh configuration {key}: {e}"))?;
    }
    let start = Instant::now();
    let session = zenoh::open(c)
        .wait()
        .map_err(|e| anyhow!("zenoh session to {endpoint}: {e}"))?;
    let replies = session
        .liveliness()
        .get(slate_zenoh::keys::alive_in(TEAM))
        .timeout(Duration::from_secs(5))
        .wait()
        .map_err(|e| anyhow!("zenoh liveliness query: {e}"))?;
    let mut found = Vec::new();
    while let Ok(reply) = replies.recv() {
        if let Ok(sample) = reply.result() {
            found.push(sample.key_expr().as_str().to_owned());
        }
    }
    session
        .close()
        .wait()
        .map_err(|e| anyhow!("zenoh close: {e}"))?;
    let took = start.elapsed();
    let both = [OWNER, RELAY]
        .iter()
        .all(|a| found.iter().any(|k| k.ends_with(a)));
    ensure!(
        both,
        "the raw Zenoh query found {found:?}, not {OWNER} and {RELAY}"
    );
    Ok((took, found.len()))
}

// The suite's own test, `the_cli_suite_reports_every_field`, lives in slate-cli's
// tests/cli/offline.rs: it needs the built `slate` executable, which cargo only guarantees to
// integration tests of the crate that defines it (`CARGO_BIN_EXE_slate`).
