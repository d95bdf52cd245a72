//! `slate launch`: the example teams started as processes on 127.0.0.1 (free ports through
//! `--base-port`), seen through the live verbs, a killed module restarted, SIGTERM
//! leaving no process behind, and `--check` naming what is wrong in a broken team.

use std::io::{BufRead, BufReader};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use serde_json::Value as Json;

use crate::support::{Team, eventually, free_ports, http_get, show, slate, slate_err, value_in};

/// Longest wait for a launched team to be up (sixteen processes on two cores).
const UP_LIMIT: Duration = Duration::from_secs(90);

/// `examples/teams/` of the repository.
fn teams() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/teams")
}

/// A running `slate launch --format json`, its events read in a thread; stopped (SIGKILL to
/// it and to every module pid it reported) if the test ends before it was.
struct Launched {
    child: Option<Child>,
    lines: Receiver<Json>,
    events: Vec<Json>,
    stderr: PathBuf,
}

impl Launched {
    fn start(team: &Path, base_port: u16, logs: &Path) -> Launched {
        Launched::start_with(team, base_port, logs, &[])
    }

    /// [`Launched::start`] with more arguments.
    fn start_with(team: &Path, base_port: u16, logs: &Path, more: &[&str]) -> Launched {
        let stderr = logs.with_extension("stderr");
        let mut child = Command::new(env!("CARGO_BIN_EXE_slate"))
            .env_remove("RUST_LOG")
            .arg("launch")
            .arg(team)
            .args(["--base-port", &base_port.to_string(), "--format", "json"])
            .arg("--logs")
            .arg(logs)
            .args(more)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(std::fs::File::create(&stderr).unwrap())
            .spawn()
            .expect("start slate launch");
        let stdout = child.stdout.take().unwrap();
        let (tx, lines) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                let j = serde_json::from_str(&line).unwrap_or(Json::String(line));
                if tx.send(j).is_err() {
                    break;
                }
            }
        });
        Launched {
            child: Some(child),
            lines,
            events: Vec::new(),
            stderr,
        }
    }

    /// Reads events until one matches (true) or `limit` passes or the output ends.
    fn wait_for(&mut self, limit: Duration, matches: impl Fn(&Json) -> bool) -> bool {
        if self.events.iter().any(&matches) {
            return true;
        }
        let deadline = Instant::now() + limit;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(j) => {
                    let hit = matches(&j);
                    self.events.push(j);
                    if hit {
                        return true;
                    }
                }
                Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => return false,
            }
        }
    }

    /// Waits for launch's `ready` event (every module up).
    fn wait_up(&mut self) {
        let up = self.wait_for(UP_LIMIT, |j| {
            j["event"] == "ready" && j.get("logs").is_some()
        });
        assert!(up, "the team did not come up\n{}", self.output());
    }

    /// The endpoint launch's `ready` event says the team is observed through.
    fn connect(&self) -> String {
        let ready = self.events.iter().find(|j| j["event"] == "ready");
        let connect = ready.and_then(|j| j["connect"].as_str());
        let connect = connect.unwrap_or_else(|| panic!("no endpoint in ready\n{}", self.output()));
        connect.to_owned()
    }

    /// The pid of each `started` event, in order, with its address.
    fn started(&self) -> Vec<(String, u32)> {
        self.events
            .iter()
            .filter(|j| j["event"] == "started")
            .map(|j| {
                let pid = j["pid"].as_u64().and_then(|p| u32::try_from(p).ok());
                (j["address"].as_str().unwrap_or("").to_owned(), pid.unwrap())
            })
            .collect()
    }

    /// Sends SIGTERM to launch and waits (at most 30 s) for it and its output; its exit.
    fn terminate(&mut self) -> Option<i32> {
        let mut child = self.child.take()?;
        signal("-TERM", child.id());
        let deadline = Instant::now() + Duration::from_secs(30);
        while child.try_wait().ok().flatten().is_none() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = child.kill();
        let status = child.wait().ok();
        while self.wait_for(Duration::from_secs(1), |_| false) {}
        status.and_then(|s| s.code())
    }

    /// Waits (at most [`UP_LIMIT`]) for launch to exit on its own; its exit code.
    fn terminate_when_done(&mut self) -> Option<i32> {
        let mut child = self.child.take()?;
        let deadline = Instant::now() + UP_LIMIT;
        while child.try_wait().ok().flatten().is_none() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = child.kill();
        let status = child.wait().ok();
        while self.wait_for(Duration::from_secs(1), |_| false) {}
        status.and_then(|s| s.code())
    }

    /// What launch printed, for failure messages.
    /// Every process in `pids` (from [`started`](Self::started)) has exited: none left
    /// as an orphan.
    fn assert_all_gone(&self, pids: &[(String, u32)]) {
        assert!(
            pids.iter().all(|(_, p)| !alive(*p)),
            "{pids:?}\n{}",
            self.output()
        );
    }

    fn output(&self) -> String {
        let events: Vec<String> = self.events.iter().map(Json::to_string).collect();
        let err = std::fs::read_to_string(&self.stderr).unwrap_or_default();
        format!("--- events\n{}\n--- stderr\n{err}", events.join("\n"))
    }
}

impl Drop for Launched {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
        for (_, pid) in self.started() {
            if alive(pid) {
                signal("-KILL", pid);
            }
        }
    }
}

fn signal(which: &str, pid: u32) {
    let _ = Command::new("kill")
        .args([which, &pid.to_string()])
        .status();
}

/// Whether a process with this pid exists (and is not a zombie).
fn alive(pid: u32) -> bool {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    !status.is_empty() && !status.contains("State:\tZ")
}

/// The names of the objects of `class` that `slate ls` shows through `endpoint`.
fn objects(class: &str, endpoint: &str) -> Vec<String> {
    let out = slate(&["ls", class, "--connect", endpoint, "--format", "json"]);
    if !out.status.success() {
        return Vec::new();
    }
    let j: Json = serde_json::from_slice(&out.stdout).unwrap_or(Json::Null);
    let list = j["objects"].as_array().cloned().unwrap_or_default();
    list.iter()
        .filter_map(|o| o["name"].as_str().map(str::to_owned))
        .collect()
}

/// What `slate stats` through `endpoint` shows short of exactly the modules `addresses`,
/// each hearing every other: `None` when it shows that. `more` are further arguments for
/// `slate stats` (an operator's keys).
fn not_up(endpoint: &str, addresses: &[&str], more: &[&str]) -> Option<String> {
    let mut args = vec![
        "stats",
        "--interval",
        "0.2",
        "--connect",
        endpoint,
        "--format",
        "json",
    ];
    args.extend(more);
    let out = slate(&args);
    let j: Json = serde_json::from_slice(&out.stdout).unwrap_or(Json::Null);
    let modules = j["modules"].as_array().cloned().unwrap_or_default();
    let answered: Vec<&str> = modules
        .iter()
        .filter_map(|m| m["address"].as_str())
        .collect();
    let mut sorted = addresses.to_vec();
    sorted.sort_unstable();
    if answered != sorted {
        return Some(format!(
            "answered {answered:?}, want {sorted:?}; stderr {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let deaf: Vec<String> = modules
        .iter()
        .filter_map(|m| {
            let peers = m["peers"].as_array().cloned().unwrap_or_default();
            let mates: Vec<&str> = peers
                .iter()
                .filter_map(Json::as_str)
                .filter(|p| !p.contains("/cli-"))
                .collect();
            let address = m["address"].as_str().unwrap_or_default();
            let missing: Vec<&&str> = addresses
                .iter()
                .filter(|a| **a != address && !mates.contains(a))
                .collect();
            (!missing.is_empty()).then(|| format!("{address} does not hear {missing:?}"))
        })
        .collect();
    (!deaf.is_empty()).then(|| deaf.join("; "))
}

/// Waits up to 30 s until [`not_up`] finds nothing, or panics with what it last found and
/// `output`.
fn wait_all_up(endpoint: &str, addresses: &[&str], more: &[&str], output: impl Fn() -> String) {
    let mut last = None;
    let up = eventually(Duration::from_secs(30), || {
        last = not_up(endpoint, addresses, more);
        last.is_none()
    });
    assert!(
        up,
        "not every module up in `slate stats`: {}\n{}",
        last.unwrap_or_default(),
        output()
    );
}

/// Launches `file`, waits until `ls CLASS` through the endpoint launch says it is
/// observed through shows every one of `expected`, stops it with SIGTERM, and checks that launch exited 0 and no module process is left.
fn launch_and_stop(turn: &Team, file: &Path, modules: u16, class: &str, expected: &[&str]) {
    let base = free_ports(modules);
    let mut launched = Launched::start(file, base, &turn.dir.join("logs"));
    launched.wait_up();
    let endpoint = launched.connect();
    assert!(endpoint.starts_with("tcp/127.0.0.1:"), "{endpoint}");
    let seen = eventually(Duration::from_secs(30), || {
        let names = objects(class, &endpoint);
        expected.iter().all(|e| names.iter().any(|n| n == e))
    });
    assert!(seen, "{expected:?} not on the board\n{}", launched.output());
    let pids = launched.started();
    assert_eq!(pids.len(), usize::from(modules), "{}", launched.output());
    let addresses: Vec<&str> = pids.iter().map(|(a, _)| a.as_str()).collect();
    wait_all_up(&endpoint, &addresses, &[], || launched.output());
    assert_eq!(launched.terminate(), Some(0), "{}", launched.output());
    let left: Vec<_> = pids.iter().filter(|(_, pid)| alive(*pid)).collect();
    assert!(
        left.is_empty(),
        "still running: {left:?}\n{}",
        launched.output()
    );
}

#[test]
fn the_small_team_launches_every_module_and_sigterm_stops_every_process() {
    let turn = Team::new("launch-small");
    let file = teams().join("small.toml");
    launch_and_stop(&turn, &file, 5, "Vehicle", &["r1", "r2"]);
}

#[test]
fn the_gsr_team_launches_as_sixteen_processes_and_sigterm_stops_them_all() {
    let turn = Team::new("launch-gsr");
    let file = teams().join("gsr.toml");
    launch_and_stop(&turn, &file, 16, "Robot", &["r1", "r2", "r3"]);
}

/// `small.toml` copied into `dir` with its files' paths made absolute and a dashboard on
/// a free port for every nav module, to read a module's own board.
fn small_with_dashboards(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(teams().join("small.toml")).unwrap();
    let small = teams().join("small");
    let text = text
        .replace("\"small/", &format!("\"{}/", small.display()))
        .replace(
            "[kinds.nav]\n",
            "[kinds.nav]\ndashboard = \"127.0.0.1:0\"\n",
        );
    let file = dir.join("small.toml");
    std::fs::write(&file, text).unwrap();
    file
}

/// The dashboard URL the newest `ready` line of `address` gave.
fn dashboard_of(launched: &Launched, address: &str) -> Option<String> {
    launched.events.iter().rev().find_map(|j| {
        let line: Json = serde_json::from_str(j["line"].as_str()?).ok()?;
        let ready = j["address"] == address && line["event"] == "ready";
        ready.then(|| line["dashboard"].as_str().map(str::to_owned))?
    })
}

/// The value text of `object.attr` on a dashboard's board.
fn value_on(dashboard: &str, object: &str, attr: &str) -> Option<String> {
    value_in(&http_get(dashboard, "/api/snapshot").json(), object, attr)
}

#[test]
fn a_module_killed_is_restarted_by_launch_and_catches_up_with_the_team() {
    let turn = Team::new("launch-restart");
    let file = small_with_dashboards(&turn.dir);
    let base = free_ports(5);
    let mut launched = Launched::start(&file, base, &turn.dir.join("logs"));
    launched.wait_up();
    let endpoint = format!("tcp/127.0.0.1:{}", base + 4);
    let put = slate(&["put", "r1.mode", "manual", "--connect", &endpoint]);
    assert!(put.status.success(), "{}", show(&put));
    let (_, nav) = launched
        .started()
        .into_iter()
        .find(|(a, _)| a == "small/r1/nav")
        .unwrap();
    signal("-KILL", nav);
    let back = launched.wait_for(UP_LIMIT, |j| {
        j["event"] == "started" && j["address"] == "small/r1/nav" && j["pid"] != nav
    });
    assert!(back, "not restarted\n{}", launched.output());
    assert!(
        launched
            .events
            .iter()
            .any(|j| j["event"] == "exited" && j["address"] == "small/r1/nav"),
        "{}",
        launched.output()
    );
    let ready = launched.wait_for(UP_LIMIT, |j| {
        j["address"] == "small/r1/nav"
            && j["line"].as_str().is_some_and(|l| l.contains("\"ready\""))
            && j["line"]
                .as_str()
                .is_some_and(|l| !l.contains(&format!("\"pid\":{nav}")))
    });
    assert!(
        ready,
        "the restarted module never said ready\n{}",
        launched.output()
    );
    let dashboard = dashboard_of(&launched, "small/r1/nav").expect("its dashboard");
    // Its file says "auto"; the team's value is "manual", which it must take back.
    let caught_up = eventually(Duration::from_secs(20), || {
        value_on(&dashboard, "r1", "mode").as_deref() == Some("manual")
    });
    assert!(
        caught_up,
        "the restarted module did not catch up\n{}",
        launched.output()
    );
    let pids = launched.started();
    assert_eq!(launched.terminate(), Some(0), "{}", launched.output());
    launched.assert_all_gone(&pids);
}

#[test]
fn launch_exits_non_zero_and_stops_the_others_when_a_module_cannot_start() {
    let turn = Team::new("launch-cannot");
    let base = free_ports(5);
    // The last module's port is taken: it cannot listen, so it cannot start.
    let _taken = TcpListener::bind(("127.0.0.1", base + 4)).unwrap();
    let mut launched = Launched::start(&teams().join("small.toml"), base, &turn.dir.join("logs"));
    let code = launched.terminate_when_done();
    assert_eq!(code, Some(2), "{}", launched.output());
    let err = std::fs::read_to_string(&launched.stderr).unwrap();
    assert!(err.contains("small/base/console could not start"), "{err}");
    let pids = launched.started();
    launched.assert_all_gone(&pids);
}

#[test]
fn every_example_team_checks() {
    for team in ["small.toml", "gsr.toml"] {
        let path = teams().join(team);
        let out = slate(&["launch", path.to_str().unwrap(), "--check"]);
        assert!(out.status.success(), "{team}\n{}", show(&out));
    }
}

#[test]
fn check_names_the_file_and_line_of_each_problem_in_a_broken_team() {
    let turn = Team::new("launch-check");
    let dir = &turn.dir;
    std::fs::write(dir.join("bad.slate"), "class V { speed: real }\n").unwrap();
    let team = "team = \"t\"\nbase_port = 7700\n\n[kinds.nav]\nfiles = [\"missing.slate\"]\ndashboard = \"127.0.0.1:8080\"\n\n[kinds.loco]\nfiles = [\"bad.slate\"]\n\n[[robots]]\nname = \"r1\"\nmodules = [\"nav\", \"loco\"]\n\n[[robots]]\nname = \"r2\"\nmodules = [\"nav\"]\n";
    let file = dir.join("broken.toml");
    std::fs::write(&file, team).unwrap();
    let err = slate_err(&["launch", file.to_str().unwrap(), "--check"]);
    let file = file.display().to_string();
    assert!(
        err.contains(&format!("{file}:4: module r1/nav: cannot read")),
        "{err}"
    );
    assert!(err.contains("bad.slate:1:23: error: expected `;`"), "{err}");
    assert!(
        err.contains("port 8080 on 127.0.0.1 for its dashboard, which r1/nav has"),
        "{err}"
    );
    // A kind nobody defined, and a key launch owns: one line each, with the line number.
    for (from, to, says) in [
        (
            "name = \"r2\"",
            "name = \"r 2\"",
            ":16: robot name \"r 2\": use letters, digits, _ and -",
        ),
        (
            "[\"nav\"]",
            "[\"nva\"]",
            ":16: robot \"r2\": no kind \"nva\": define `[kinds.nva]`",
        ),
        (
            "[kinds.loco]\n",
            "[kinds.loco]\naddress = \"t/x/y\"\n",
            ":8: kind \"loco\": remove `address`",
        ),
    ] {
        std::fs::write(dir.join("broken.toml"), team.replace(from, to)).unwrap();
        let err = slate_err(&["launch", &file, "--check"]);
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(&format!("{file}{says}")), "{err}");
    }
}

#[test]
fn robot_runs_only_that_robots_modules_on_this_host() {
    let turn = Team::new("launch-robot");
    let base = free_ports(5);
    let file = teams().join("small.toml");
    let mut launched =
        Launched::start_with(&file, base, &turn.dir.join("logs"), &["--robot", "r2"]);
    launched.wait_up();
    let mut started: Vec<String> = launched.started().into_iter().map(|(a, _)| a).collect();
    started.sort();
    assert_eq!(
        started,
        ["small/r2/loco", "small/r2/nav"],
        "{}",
        launched.output()
    );
    assert_eq!(launched.terminate(), Some(0), "{}", launched.output());
    let err = slate_err(&["launch", file.to_str().unwrap(), "--only", "r9/nav"]);
    assert!(err.contains("has no module \"r9/nav\""), "{err}");
}

#[test]
fn a_module_that_keeps_dying_is_restarted_after_a_doubling_wait_then_given_up_on() {
    let turn = Team::new("launch-give-up");
    let text = std::fs::read_to_string(teams().join("small.toml")).unwrap();
    let small = teams().join("small");
    let text = text
        .replace("\"small/", &format!("\"{}/", small.display()))
        .replace("limit = 5", "limit = 2")
        .replace("backoff = \"500ms\"", "backoff = \"100ms\"");
    let file = turn.dir.join("small.toml");
    std::fs::write(&file, text).unwrap();
    let base = free_ports(5);
    let mut launched =
        Launched::start_with(&file, base, &turn.dir.join("logs"), &["--only", "r1/nav"]);
    launched.wait_up();
    let mut killed = Vec::new();
    for round in 0..3 {
        let (_, pid) = *launched.started().last().unwrap();
        signal("-KILL", pid);
        killed.push(pid);
        let next = |j: &Json| {
            let pid = j["pid"].as_u64().and_then(|p| u32::try_from(p).ok());
            let restarted = j["event"] == "started" && pid.is_some_and(|p| !killed.contains(&p));
            restarted || j["event"] == "gave_up"
        };
        assert!(
            launched.wait_for(UP_LIMIT, next),
            "round {round}\n{}",
            launched.output()
        );
    }
    // Each restart waits twice as long as the one before.
    let waits: Vec<u64> = launched
        .events
        .iter()
        .filter(|j| j["event"] == "exited")
        .filter_map(|j| j["in_ms"].as_u64())
        .collect();
    assert_eq!(waits, [100, 200], "{}", launched.output());
    let gave_up = launched.events.iter().find(|j| j["event"] == "gave_up");
    let text = gave_up.map(|j| j["text"].to_string()).unwrap_or_default();
    assert!(
        text.contains("after 2 restarts: giving up on it"),
        "{}",
        launched.output()
    );
    // Nothing left to run: launch exits 1 on its own.
    assert_eq!(
        launched.terminate_when_done(),
        Some(1),
        "{}",
        launched.output()
    );
}

/// `--log-format json` given to launch is given to every module: every line a module
/// writes (launch's `log` events) is a JSON object, its log lines as `slate node
/// --log-format json` writes them.
#[test]
fn launch_passes_its_log_format_to_every_module() {
    let turn = Team::new("launch-log-format");
    let file = teams().join("small.toml");
    let base = free_ports(5);
    let logs = turn.dir.join("logs");
    let mut launched = Launched::start_with(&file, base, &logs, &["--log-format", "json"]);
    launched.wait_up();
    let lines: Vec<(String, String)> = launched
        .events
        .iter()
        .filter(|j| j["event"] == "log")
        .map(|j| {
            let address = j["address"].as_str().unwrap_or_default().to_owned();
            (address, j["line"].as_str().unwrap_or_default().to_owned())
        })
        .collect();
    assert_eq!(launched.terminate(), Some(0), "{}", launched.output());
    for (address, _) in launched.started() {
        let own: Vec<&String> = lines
            .iter()
            .filter(|l| l.0 == address)
            .map(|l| &l.1)
            .collect();
        assert!(
            !own.is_empty(),
            "{address} logged nothing\n{}",
            launched.output()
        );
        // Its stdout (`slate node --format json` events) was JSON already; its log too now.
        let parsed: Vec<Json> = own
            .iter()
            .map(|line| {
                serde_json::from_str(line)
                    .unwrap_or_else(|_| panic!("{address}: not a JSON line: {line}"))
            })
            .collect();
        assert!(
            parsed.iter().any(|j| j.get("level").is_some()),
            "{address}: no JSON log line among {parsed:?}"
        );
    }
}

/// `slate launch --keys DIR`: a two-robot team secured with keys from `slate keys`. Every
/// module listens and connects over TLS, the operator's `slate stats` (with the keys) sees
/// both modules hearing each other, a CLI without the keys finds none, and SIGTERM stops
/// both processes.
#[test]
fn a_team_launched_with_keys_runs_over_tls_and_sigterm_stops_it() {
    let turn = Team::new("launch-keys");
    let small = teams().join("small");
    for file in ["world.slate", "robot.slate"] {
        std::fs::copy(small.join(file), turn.dir.join(file)).unwrap();
    }
    let team = "team = \"sec\"\nbase_port = 1\n[kinds.nav]\nfiles = [\"world.slate\", \"robot.slate\"]\nexport = [\"Vehicle\"]\n[[robots]]\nname = \"r1\"\nmodules = [\"nav\"]\n[[robots]]\nname = \"r2\"\nmodules = [\"nav\"]\n";
    let file = turn.dir.join("sec.toml");
    std::fs::write(&file, team).unwrap();
    let keys = turn.dir.join("keys");
    let k = keys.to_str().unwrap();
    crate::support::slate_ok(&["keys", "init", k]);
    crate::support::slate_ok(&["keys", "issue", k, "sec/r1/nav", "sec/r2/nav", "sec/alice"]);
    let base = free_ports(2);
    let logs = turn.dir.join("logs");
    let mut launched = Launched::start_with(&file, base, &logs, &["--keys", k]);
    launched.wait_up();
    let config = std::fs::read_to_string(logs.join("r1-nav.toml")).unwrap();
    assert!(
        config.contains(&format!("tls/127.0.0.1:{base}")),
        "{config}"
    );
    let endpoint = launched.connect();
    assert_eq!(endpoint, format!("tls/127.0.0.1:{base}"));
    let ready = launched.events.iter().find(|j| j["event"] == "ready");
    let said = ready.and_then(|j| j["text"].as_str()).unwrap_or_default();
    assert!(
        said.contains(&format!("--keys {k} --operator sec/")),
        "{said}"
    );
    let alice = ["--keys", k, "--operator", "sec/alice"];
    wait_all_up(&endpoint, &["sec/r1/nav", "sec/r2/nav"], &alice, || {
        launched.output()
    });
    let plain = format!("tcp/127.0.0.1:{}", base + 1);
    assert!(
        objects("Vehicle", &plain).is_empty(),
        "a CLI without keys read the team"
    );
    let pids = launched.started();
    assert_eq!(launched.terminate(), Some(0), "{}", launched.output());
    launched.assert_all_gone(&pids);
}

#[test]
fn a_kinds_state_gives_each_launched_module_a_store_of_its_own() {
    let turn = Team::new("launch-state");
    let text = std::fs::read_to_string(teams().join("small.toml")).unwrap();
    let small = teams().join("small");
    let text = text
        .replace("\"small/", &format!("\"{}/", small.display()))
        .replace("[kinds.nav]\n", "[kinds.nav]\nstate = \"state\"\n");
    let file = turn.dir.join("small.toml");
    std::fs::write(&file, text).unwrap();
    launch_and_stop(&turn, &file, 5, "Vehicle", &["r1", "r2"]);
    for robot in ["r1", "r2"] {
        let store = turn
            .dir
            .join("state")
            .join(robot)
            .join("nav")
            .join("board.redb");
        assert!(store.exists(), "{} kept", store.display());
    }
}
