//! A team of `slate node` processes on loopback, and running `slate` with a time limit.

pub use slate_testing::{
    TempDir, WORLD, entry, eventually, free_port, free_ports, http_get, keys, temp_dir,
};

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Longest any one `slate` command may take.
const COMMAND_LIMIT: Duration = Duration::from_secs(30);

fn command() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_slate"));
    c.env_remove("RUST_LOG");
    // A run chasing a rare failure can ask every process for more (like `info,zenoh=debug`).
    if let Ok(filter) = std::env::var("SLATE_TEST_LOG") {
        c.env("RUST_LOG", filter);
    }
    c
}

/// Runs `slate ARGS`, killed if it takes longer than [`COMMAND_LIMIT`].
pub fn slate(args: &[&str]) -> Output {
    let child = command()
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run slate");
    wait_output(child, COMMAND_LIMIT)
}

/// Runs `slate ARGS` as [`slate`] does and fails the test, showing what it printed,
/// unless it succeeds; its stdout.
pub fn slate_ok(args: &[&str]) -> String {
    let out = slate(args);
    assert!(out.status.success(), "slate {args:?}\n{}", show(&out));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs `slate ARGS` as [`slate`] does and fails the test, showing what it printed,
/// unless it fails; its stderr.
pub fn slate_err(args: &[&str]) -> String {
    let out = slate(args);
    assert!(!out.status.success(), "slate {args:?}\n{}", show(&out));
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Waits for a child's output, killing it (by pid) past `limit`.
pub fn wait_output(mut child: Child, limit: Duration) -> Output {
    let out = drain(child.stdout.take());
    let err = drain(child.stderr.take());
    let deadline = Instant::now() + limit;
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            break child.wait().unwrap();
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    Output {
        status,
        stdout: out.join().unwrap(),
        stderr: err.join().unwrap(),
    }
}

/// Reads a pipe to its end in a thread (nothing if the pipe was taken already).
fn drain(pipe: Option<impl Read + Send + 'static>) -> std::thread::JoinHandle<Vec<u8>> {
    std::thread::spawn(move || {
        let mut b = Vec::new();
        if let Some(mut p) = pipe {
            let _ = p.read_to_end(&mut b);
        }
        b
    })
}

/// A child process killed (by pid) if the test ends before it was waited for.
pub struct Guard(pub Option<Child>);

impl Guard {
    /// Takes the child back, to wait for it.
    pub fn take(mut self) -> Child {
        self.0.take().expect("a child")
    }
}

impl Drop for Guard {
    fn drop(&mut self) {
        if let Some(c) = self.0.as_mut() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// The `step` of each JSON line `slate plan` printed.
pub fn steps(out: &Output) -> Vec<String> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| {
            serde_json::from_str::<serde_json::Value>(l).unwrap()["step"]
                .as_str()
                .unwrap()
                .to_owned()
        })
        .collect()
}

/// The class `name` in the JSON of `slate tree`.
pub fn class_in<'j>(tree: &'j serde_json::Value, name: &str) -> &'j serde_json::Value {
    entry(&tree["classes"], "name", name).unwrap_or_else(|| panic!("no class {name} in {tree}"))
}

/// Stdout and stderr as text, for assertion messages.
pub fn show(out: &Output) -> String {
    format!(
        "exit {:?}\n--- stdout\n{}--- stderr\n{}",
        out.status.code(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// One `slate node` process.
pub struct NodeProc {
    pub address: String,
    pub endpoint: String,
    pub dashboard: String,
    child: Child,
    log: PathBuf,
}

impl NodeProc {
    /// Starts `slate node` with a config in `dir`: it listens on a free port, connects to
    /// `connect`, serves its dashboard on a free port, loads WORLD and `extra`. Returns
    /// once it printed its ready line.
    pub fn start(dir: &Path, address: &str, extra: &str, connect: &[String]) -> NodeProc {
        NodeProc::start_exporting(dir, address, extra, connect, "\"Thing\"")
    }

    /// [`NodeProc::start`] with its own `export` list (TOML items, like `"Vehicle"`).
    pub fn start_exporting(
        dir: &Path,
        address: &str,
        extra: &str,
        connect: &[String],
        export: &str,
    ) -> NodeProc {
        NodeProc::start_with(dir, address, extra, connect, export, "")
    }

    /// [`NodeProc::start_exporting`] with more `[ici]` settings (TOML lines).
    pub fn start_with(
        dir: &Path,
        address: &str,
        extra: &str,
        connect: &[String],
        export: &str,
        ici: &str,
    ) -> NodeProc {
        NodeProc::start_config(dir, address, extra, connect, &[export, ici, ""])
    }

    /// [`NodeProc::start_with`] with more top-level keys (TOML lines): `settings` is the
    /// export list, the `[ici]` lines and the top-level lines.
    pub fn start_config(
        dir: &Path,
        address: &str,
        extra: &str,
        connect: &[String],
        settings: &[&str; 3],
    ) -> NodeProc {
        let [export, ici, top] = settings;
        let stem = address.replace('/', "_");
        std::fs::write(dir.join("world.slate"), WORLD).unwrap();
        std::fs::write(dir.join(format!("{stem}.slate")), extra).unwrap();
        let endpoint = format!("tcp/127.0.0.1:{}", free_port());
        let dashboard = format!("127.0.0.1:{}", free_port());
        let connect: Vec<String> = connect.iter().map(|c| format!("{c:?}")).collect();
        let config = format!(
            "address = \"{address}\"\nfiles = [\"world.slate\", \"{stem}.slate\"]\nexport = [{export}]\ndashboard = \"{dashboard}\"\n{top}\n[zenoh]\nlisten = [\"{endpoint}\"]\nconnect = [{}]\n\n[ici]\nrobot_timeout = \"2s\"\nteam_timeout = \"3s\"\n{ici}\n",
            connect.join(", ")
        );
        NodeProc::spawn(dir, address, &config, endpoint, dashboard)
    }

    /// Starts `slate node` with the config text `config` (written to `dir`), which listens
    /// on `endpoint` and serves its dashboard at `dashboard`; returns once it printed its
    /// ready line.
    pub fn spawn(
        dir: &Path,
        address: &str,
        config: &str,
        endpoint: String,
        dashboard: String,
    ) -> NodeProc {
        let stem = address.replace('/', "_");
        let path = dir.join(format!("{stem}.toml"));
        std::fs::write(&path, config).unwrap();
        let log = dir.join(format!("{stem}.log"));
        let mut child = command()
            .args([
                "node",
                "--config",
                path.to_str().unwrap(),
                "--format",
                "json",
            ])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .expect("start slate node");
        let ready = first_line(&mut child, Duration::from_secs(30));
        let j: serde_json::Value = serde_json::from_str(&ready)
            .unwrap_or_else(|e| panic!("{address} not ready ({e}): {ready:?}\n{}", read(&log)));
        assert_eq!(j["event"], "ready", "{j}");
        assert_eq!(j["address"], address);
        NodeProc {
            address: address.to_owned(),
            endpoint,
            dashboard: format!("http://{dashboard}/"),
            child,
            log,
        }
    }

    /// Its dashboard's snapshot: the node's own board.
    pub fn snapshot(&self) -> serde_json::Value {
        http_get(&self.dashboard, "/api/snapshot").json()
    }

    /// The value text of `object.attr` on this node's board, if it has one.
    pub fn value(&self, object: &str, attr: &str) -> Option<String> {
        value_in(&self.snapshot(), object, attr)
    }

    /// Waits (at most 10 s) until `object.attr` reads `value` on this node.
    pub fn wait_value(&self, object: &str, attr: &str, value: &str) -> bool {
        eventually(Duration::from_secs(10), || {
            self.value(object, attr).as_deref() == Some(value)
        })
    }

    /// Its log so far.
    pub fn log(&self) -> String {
        read(&self.log)
    }

    /// Kills it by pid with SIGKILL, as a crash would, and waits for it.
    pub fn kill(mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// Stops it by pid with SIGTERM and waits (SIGKILL after 10 s); returns its stdout.
    pub fn stop(mut self) -> (bool, String) {
        self.terminate()
    }

    fn terminate(&mut self) -> (bool, String) {
        let pid = self.child.id().to_string();
        let _ = Command::new("kill").args(["-TERM", &pid]).status();
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut clean = true;
        while self.child.try_wait().ok().flatten().is_none() {
            if Instant::now() > deadline {
                let _ = self.child.kill();
                clean = false;
                break;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let status = self.child.wait().ok();
        let mut rest = String::new();
        if let Some(mut out) = self.child.stdout.take() {
            let _ = out.read_to_string(&mut rest);
        }
        (clean && status.is_some_and(|s| s.success()), rest)
    }
}

impl Drop for NodeProc {
    fn drop(&mut self) {
        if self.child.try_wait().ok().flatten().is_none() {
            self.terminate();
        }
    }
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_default()
}

/// The first line a child prints on stdout (empty if none within `limit`).
fn first_line(child: &mut Child, limit: Duration) -> String {
    let stdout = child.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut reader = BufReader::new(stdout);
        let mut line = String::new();
        let _ = reader.read_line(&mut line);
        let _ = tx.send((line, reader.into_inner()));
    });
    match rx.recv_timeout(limit) {
        Ok((line, stdout)) => {
            child.stdout = Some(stdout);
            line
        }
        Err(_) => String::new(),
    }
}

/// A team of node processes; each connects to the ones started before it. One team
/// runs at a time (on two cores, several teams at once starve each other's timers).
pub struct Team {
    pub dir: TempDir,
    pub nodes: Vec<NodeProc>,
    _turn: std::sync::MutexGuard<'static, ()>,
}

static TURN: std::sync::Mutex<()> = std::sync::Mutex::new(());

impl Team {
    pub fn new(name: &str) -> Team {
        let turn = TURN
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        Team {
            dir: temp_dir(name),
            nodes: Vec::new(),
            _turn: turn,
        }
    }

    /// A team of the nodes `members` (address, and the source each loads beside
    /// [`WORLD`]), started in order, once every node hears every other.
    pub fn connected(name: &str, members: &[(&str, &str)]) -> Team {
        let mut team = Team::new(name);
        for (address, extra) in members {
            team.add(address, extra);
        }
        team.wait_connected();
        team
    }

    /// `slate plan send PLAN --to TO --timeout SECONDS --format json` against the team.
    pub fn send_plan(&self, plan: &Path, to: &str, seconds: &str) -> Output {
        let plan = plan.to_str().unwrap();
        self.slate(&[
            "plan",
            "send",
            plan,
            "--to",
            to,
            "--timeout",
            seconds,
            "--format",
            "json",
        ])
    }

    /// Starts one more node.
    pub fn add(&mut self, address: &str, extra: &str) -> &NodeProc {
        let connect: Vec<String> = self.nodes.iter().map(|n| n.endpoint.clone()).collect();
        let node = NodeProc::start(&self.dir, address, extra, &connect);
        self.nodes.push(node);
        self.nodes.last().unwrap()
    }

    /// Starts one more node that exports only `export` (TOML items, like `"Vehicle"`).
    pub fn add_exporting(&mut self, address: &str, extra: &str, export: &str) -> &NodeProc {
        let connect: Vec<String> = self.nodes.iter().map(|n| n.endpoint.clone()).collect();
        let node = NodeProc::start_exporting(&self.dir, address, extra, &connect, export);
        self.nodes.push(node);
        self.nodes.last().unwrap()
    }

    /// Starts one more node with more `[ici]` settings (TOML lines).
    pub fn add_with_ici(&mut self, address: &str, extra: &str, ici: &str) -> &NodeProc {
        let connect: Vec<String> = self.nodes.iter().map(|n| n.endpoint.clone()).collect();
        let node = NodeProc::start_with(&self.dir, address, extra, &connect, "\"Thing\"", ici);
        self.nodes.push(node);
        self.nodes.last().unwrap()
    }

    /// Kills the node at `address` (SIGKILL) and starts it again from the same files,
    /// connected to the others.
    pub fn kill_and_restart(&mut self, address: &str, extra: &str) -> &NodeProc {
        let at = self
            .nodes
            .iter()
            .position(|n| n.address == address)
            .unwrap();
        self.nodes.remove(at).kill();
        self.add(address, extra)
    }

    /// The node at `address`.
    pub fn node(&self, address: &str) -> &NodeProc {
        self.nodes.iter().find(|n| n.address == address).unwrap()
    }

    /// `--connect E` for every node, so an observer reaches all at once.
    /// Adds a node that records its own board to `record` (an MCAP file).
    pub fn add_recording(&mut self, address: &str, extra: &str, record: &Path) -> &NodeProc {
        let connect: Vec<String> = self.nodes.iter().map(|n| n.endpoint.clone()).collect();
        let top = format!("record = {:?}", record.display().to_string());
        let settings = ["\"Thing\"", "", top.as_str()];
        let node = NodeProc::start_config(&self.dir, address, extra, &connect, &settings);
        self.nodes.push(node);
        self.nodes.last().unwrap()
    }

    /// Starts `slate ARGS` against the team without waiting for it, its output piped;
    /// killed if the test ends first.
    pub fn spawn(&self, args: &[&str]) -> Guard {
        self.spawn_with(args, &self.connect_args())
    }

    /// [`spawn`](Self::spawn), reaching the team through the node at `via` only (one
    /// that stays up while others restart).
    pub fn spawn_via(&self, via: &str, args: &[&str]) -> Guard {
        let connect = ["--connect".to_owned(), self.node(via).endpoint.clone()];
        self.spawn_with(args, &connect)
    }

    fn spawn_with(&self, args: &[&str], connect: &[String]) -> Guard {
        let child = command()
            .args(args)
            .args(connect)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("run slate");
        Guard(Some(child))
    }

    pub fn connect_args(&self) -> Vec<String> {
        self.nodes
            .iter()
            .flat_map(|n| ["--connect".to_owned(), n.endpoint.clone()])
            .collect()
    }

    /// Runs a live verb against the team.
    pub fn slate(&self, args: &[&str]) -> Output {
        let connect = self.connect_args();
        let mut all: Vec<&str> = args.to_vec();
        all.extend(connect.iter().map(String::as_str));
        slate(&all)
    }

    /// Runs a live verb and expects success.
    pub fn ok(&self, args: &[&str]) -> String {
        let out = self.slate(args);
        assert!(
            out.status.success(),
            "slate {args:?}\n{}\n{}",
            show(&out),
            self.logs()
        );
        String::from_utf8(out.stdout).unwrap()
    }

    /// Runs a live verb with `--format json` and parses its one JSON object.
    pub fn json(&self, args: &[&str]) -> serde_json::Value {
        let mut all = args.to_vec();
        all.extend(["--format", "json"]);
        let text = self.ok(&all);
        serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}"))
    }

    /// Waits until every node sees every other alive.
    pub fn wait_connected(&self) {
        let n = self.nodes.len();
        for node in &self.nodes {
            let met = eventually(Duration::from_secs(15), || {
                let snap = node.snapshot();
                snap["summary"]["peers alive"].as_u64() >= Some(n as u64 - 1)
            });
            assert!(
                met,
                "{} did not meet the team\n{}",
                node.address,
                self.logs()
            );
        }
    }

    /// Every node's log, for failure messages.
    pub fn logs(&self) -> String {
        self.nodes
            .iter()
            .map(|n| format!("--- log of {}\n{}", n.address, n.log()))
            .collect()
    }

    /// Stops every node by pid; asserts each stopped cleanly and said so.
    pub fn stop(mut self) {
        let logs = self.logs();
        for node in self.nodes.drain(..) {
            let address = node.address.clone();
            let (clean, rest) = node.stop();
            assert!(clean, "{address} did not stop cleanly\n{logs}");
            assert!(rest.contains("\"stopped\""), "{address}: {rest}");
        }
    }
}

impl Drop for Team {
    /// Stops what is left (a failed test); the folder goes with `dir`, after.
    fn drop(&mut self) {
        self.nodes.clear();
    }
}

/// The value text of `object.attr` in a dashboard's `/api/snapshot`, if it holds one.
pub fn value_in(snapshot: &serde_json::Value, object: &str, attr: &str) -> Option<String> {
    let o = snapshot["objects"]
        .as_array()?
        .iter()
        .find(|o| o["name"] == object)?;
    let a = o["attrs"].as_array()?.iter().find(|a| a["name"] == attr)?;
    a["value"].as_str().map(str::to_owned)
}
