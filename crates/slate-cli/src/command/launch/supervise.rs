//! Running the modules: one `slate node` process each (this same binary), their output
//! into a log file per module and onto the console prefixed with the module's address, a
//! module that dies started again after a back-off that doubles (up to a limit, then
//! given up on, and said so), and every one stopped by pid on Ctrl-C or SIGTERM.

use std::fs::File;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;
use parking_lot::Mutex;
use serde_json::json;

use super::team::{MAX_BACKOFF, ModulePlan, Restart};
use crate::cli::{Format, LogFormat};

/// Longest wait for a module's first start to say it is ready.
const READY_LIMIT: Duration = Duration::from_secs(30);
/// Longest wait for a module to stop after SIGTERM before it is killed.
const STOP_LIMIT: Duration = Duration::from_secs(10);
/// How often the supervisor looks at its children and at the signals.
const POLL: Duration = Duration::from_millis(50);
/// A module that ran this long before it died starts its back-off anew.
const STABLE: Duration = Duration::from_secs(60);

/// Where launch's own events and the modules' lines go: stdout, as text or JSON lines.
#[derive(Clone, Copy)]
pub struct Console {
    /// Text or JSON lines.
    pub format: Format,
}

impl Console {
    /// One of launch's own events about `address`, with its details.
    pub fn event(&self, event: &str, address: &str, text: &str, extra: serde_json::Value) {
        match self.format {
            Format::Text => println!("launch | {address}: {text}"),
            Format::Json => {
                let mut j = json!({"event": event, "address": address, "text": text});
                if let (Some(j), serde_json::Value::Object(extra)) = (j.as_object_mut(), extra) {
                    j.extend(extra);
                }
                println!("{j}");
            }
        }
    }

    /// One line a module printed, on the console.
    fn line(&self, address: &str, line: &str, pipe: Pipe) {
        if let Some(shown) = self.shown(address, line, pipe) {
            println!("{shown}");
        }
    }

    /// How a module's line shows on the console, if it does: as text, its log lines only
    /// (its events, `slate node --format json`'s lines, say the same sentences and stay
    /// in its log file); as JSON, every line.
    fn shown(&self, address: &str, line: &str, pipe: Pipe) -> Option<String> {
        match self.format {
            Format::Text if pipe == Pipe::Events => None,
            Format::Text => Some(format!("{address} | {line}")),
            Format::Json => {
                Some(json!({"event": "log", "address": address, "line": line}).to_string())
            }
        }
    }
}

/// Which of a module's pipes a line came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pipe {
    /// Its log (stderr).
    Log,
    /// Its events (stdout: `slate node --format json`'s lines).
    Events,
}

/// One module under supervision.
struct Supervised {
    plan: ModulePlan,
    config_path: PathBuf,
    log_path: PathBuf,
    child: Option<Child>,
    ready: Arc<AtomicBool>,
    pumps: Vec<JoinHandle<()>>,
    started: Instant,
    restarts: u32,
    backoff: Duration,
    next_start: Option<Instant>,
    gave_up: bool,
}

/// The modules run on this host, and how they are started.
pub struct Supervisor {
    modules: Vec<Supervised>,
    restart: Restart,
    console: Console,
    logs: ModuleLogs,
}

/// How every module logs: launch's own `--log` and `--log-format`, passed on.
#[derive(Clone, Debug)]
pub struct ModuleLogs {
    /// `--log FILTER`, if given.
    pub filter: Option<String>,
    /// `--log-format`.
    pub format: LogFormat,
}

impl Supervisor {
    /// Writes each module's config into `dir` (`ROBOT-KIND.toml`, beside its log
    /// `ROBOT-KIND.log`), ready to start.
    pub fn new(
        plans: Vec<ModulePlan>,
        dir: &Path,
        restart: Restart,
        (console, logs): (Console, ModuleLogs),
    ) -> anyhow::Result<Supervisor> {
        std::fs::create_dir_all(dir).map_err(|e| {
            anyhow::anyhow!(
                "cannot create the log folder {}: {e}; choose another with --logs",
                dir.display()
            )
        })?;
        let modules = plans
            .into_iter()
            .map(|plan| supervised(plan, dir, restart))
            .collect::<anyhow::Result<Vec<_>>>()?;
        Ok(Supervisor {
            modules,
            restart,
            console,
            logs,
        })
    }

    /// Starts every module and waits until each said it is ready; an error (after
    /// stopping the others) if one cannot start or dies first.
    pub fn start_all(&mut self, signals: &Receiver<()>) -> anyhow::Result<bool> {
        for i in 0..self.modules.len() {
            self.spawn(i)?;
        }
        let deadline = Instant::now() + READY_LIMIT;
        while !self.modules.iter().all(|m| m.ready.load(Ordering::Relaxed)) {
            if signals.try_recv().is_ok() {
                return Ok(false);
            }
            if let Some(dead) = self.first_exited() {
                let m = &self.modules[dead];
                let tail = log_tail(&m.log_path);
                anyhow::bail!(
                    "module {} could not start (see {}): {tail}",
                    m.plan.config.address,
                    m.log_path.display()
                );
            }
            if Instant::now() > deadline {
                anyhow::bail!(
                    "modules not ready after {}s: {}",
                    READY_LIMIT.as_secs(),
                    self.not_ready().join(", ")
                );
            }
            std::thread::sleep(POLL);
        }
        Ok(true)
    }

    /// Supervises until a signal (true: every module still had a process) or until
    /// launch gave up on every module (false).
    pub fn run(&mut self, signals: &Receiver<()>) -> bool {
        loop {
            if signals.try_recv().is_ok() {
                return !self.modules.iter().any(|m| m.gave_up);
            }
            for i in 0..self.modules.len() {
                self.look_after(i);
            }
            if self.modules.iter().all(|m| m.gave_up) {
                return false;
            }
            std::thread::sleep(POLL);
        }
    }

    /// Stops every running module by pid: SIGTERM, then SIGKILL past [`STOP_LIMIT`];
    /// waits for each and for its output.
    pub fn stop_all(&mut self) {
        for m in &self.modules {
            if let Some(c) = &m.child {
                terminate(c);
            }
        }
        for m in &mut self.modules {
            if let Some(child) = m.child.take() {
                let status = wait_or_kill(child);
                let address = m.plan.config.address.to_string();
                self.console.event(
                    "stopped",
                    &address,
                    &format!("stopped ({status})"),
                    json!({}),
                );
            }
            for pump in m.pumps.drain(..) {
                let _ = pump.join();
            }
        }
    }

    /// A module that exited is started again once its back-off has passed, or given up
    /// on past the limit.
    fn look_after(&mut self, i: usize) {
        let m = &mut self.modules[i];
        if m.gave_up {
            return;
        }
        if let Some(due) = m.next_start {
            if Instant::now() >= due {
                m.next_start = None;
                if let Err(e) = self.spawn(i) {
                    self.give_up(i, &e.to_string());
                }
            }
            return;
        }
        let status = m.child.as_mut().and_then(|c| c.try_wait().ok().flatten());
        let Some(status) = status else { return };
        m.child = None;
        self.exited(i, &status.to_string());
    }

    /// A module's process ended: schedule its restart, or give up on it.
    fn exited(&mut self, i: usize, status: &str) {
        let restart = self.restart;
        let m = &mut self.modules[i];
        if m.started.elapsed() >= STABLE {
            m.backoff = restart.backoff;
        }
        if m.restarts >= restart.limit {
            let why = format!("exited ({status}) after {} restarts", m.restarts);
            self.give_up(i, &why);
            return;
        }
        m.restarts += 1;
        m.next_start = Some(Instant::now() + m.backoff);
        let (wait, count) = (m.backoff, m.restarts);
        m.backoff = (m.backoff * 2).min(MAX_BACKOFF);
        let address = m.plan.config.address.to_string();
        let text = format!(
            "exited ({status}); restart {count} of {} in {wait:?}",
            restart.limit
        );
        let extra = json!({"status": status, "restart": count, "in_ms": wait.as_millis()});
        self.console.event("exited", &address, &text, extra);
    }

    fn give_up(&mut self, i: usize, why: &str) {
        let m = &mut self.modules[i];
        m.gave_up = true;
        let address = m.plan.config.address.to_string();
        let text = format!("{why}: giving up on it (its log: {})", m.log_path.display());
        self.console.event("gave_up", &address, &text, json!({}));
    }

    /// Starts module `i`'s process, its output pumped into its log and the console.
    fn spawn(&mut self, i: usize) -> anyhow::Result<()> {
        let mut command = self.node_command(&self.modules[i].config_path)?;
        let console = self.console;
        let m = &mut self.modules[i];
        let log = Arc::new(Mutex::new(open_log(&m.log_path)?));
        let address = m.plan.config.address.to_string();
        let mut child = command
            .spawn()
            .map_err(|e| anyhow::anyhow!("cannot start {address}: {e}"))?;
        m.ready.store(false, Ordering::Relaxed);
        m.pumps.retain(|p| !p.is_finished());
        let to = |pipe, ready| Pump {
            address: address.clone(),
            log: log.clone(),
            console,
            pipe,
            ready,
        };
        m.pumps.push(pump(child.stderr.take(), to(Pipe::Log, None)));
        let events = to(Pipe::Events, Some(m.ready.clone()));
        m.pumps.push(pump(child.stdout.take(), events));
        m.started = Instant::now();
        let pid = child.id();
        m.child = Some(child);
        let text = format!("started (pid {pid}, config {})", m.config_path.display());
        let extra = json!({"pid": pid, "module": m.plan.name});
        console.event("started", &address, &text, extra);
        Ok(())
    }

    /// `slate node --config CONFIG --format json` with this binary, its output piped.
    fn node_command(&self, config: &Path) -> anyhow::Result<Command> {
        let exe = std::env::current_exe().map_err(|e| {
            anyhow::anyhow!("cannot find the slate binary to start modules with: {e}")
        })?;
        let mut command = Command::new(exe);
        command.arg("node").arg("--config").arg(config);
        command.args(["--format", "json"]);
        if let Some(filter) = &self.logs.filter {
            command.args(["--log", filter]);
        }
        if self.logs.format == LogFormat::Json {
            command.args(["--log-format", "json"]);
        }
        command
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        Ok(command)
    }

    /// The first module this host runs.
    pub fn first_module(&self) -> Option<&ModulePlan> {
        self.modules.first().map(|m| &m.plan)
    }

    fn first_exited(&mut self) -> Option<usize> {
        self.modules.iter_mut().position(|m| {
            m.child
                .as_mut()
                .is_some_and(|c| c.try_wait().ok().flatten().is_some())
        })
    }

    fn not_ready(&self) -> Vec<String> {
        self.modules
            .iter()
            .filter(|m| !m.ready.load(Ordering::Relaxed))
            .map(|m| m.plan.config.address.to_string())
            .collect()
    }
}

fn supervised(plan: ModulePlan, dir: &Path, restart: Restart) -> anyhow::Result<Supervised> {
    let stem = plan.name.replace('/', "-");
    let config_path = dir.join(format!("{stem}.toml"));
    let header = format!(
        "# Written by `slate launch` for {} (from its team file).\n",
        plan.config.address
    );
    std::fs::write(&config_path, header + &plan.config_text)
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", config_path.display()))?;
    let config_path = std::path::absolute(&config_path).unwrap_or(config_path);
    Ok(Supervised {
        log_path: dir.join(format!("{stem}.log")),
        config_path,
        plan,
        child: None,
        ready: Arc::new(AtomicBool::new(false)),
        pumps: Vec::new(),
        started: Instant::now(),
        restarts: 0,
        backoff: restart.backoff,
        next_start: None,
        gave_up: false,
    })
}

fn open_log(path: &Path) -> anyhow::Result<File> {
    File::options()
        .create(true)
        .append(true)
        .open(path)
        .map_err(|e| anyhow::anyhow!("cannot open the log {}: {e}", path.display()))
}

/// Where one pipe of a module goes.
struct Pump {
    address: String,
    log: Arc<Mutex<File>>,
    console: Console,
    /// Which pipe it is.
    pipe: Pipe,
    /// Set when the node's `ready` event is read (its stdout only).
    ready: Option<Arc<AtomicBool>>,
}

/// Copies a pipe line by line into the module's log and onto the console, until it ends.
fn pump(pipe: Option<impl Read + Send + 'static>, to: Pump) -> JoinHandle<()> {
    std::thread::spawn(move || {
        let Some(pipe) = pipe else { return };
        for line in BufReader::new(pipe).lines() {
            let Ok(line) = line else { break };
            let _ = writeln!(to.log.lock(), "{line}");
            if let Some(ready) = to.ready.as_ref().filter(|_| is_ready_event(&line)) {
                ready.store(true, Ordering::Relaxed);
            }
            to.console.line(&to.address, &line, to.pipe);
        }
    })
}

/// `slate node --format json`'s first line: `{"event": "ready", ...}`.
fn is_ready_event(line: &str) -> bool {
    serde_json::from_str::<serde_json::Value>(line).is_ok_and(|j| j["event"] == "ready")
}

/// SIGTERM to a child, by its pid.
fn terminate(child: &Child) {
    use nix::sys::signal::{Signal, kill};
    if let Ok(pid) = i32::try_from(child.id()) {
        let _ = kill(nix::unistd::Pid::from_raw(pid), Signal::SIGTERM);
    }
}

/// Waits for a child told to stop; kills it past [`STOP_LIMIT`]. How it ended.
fn wait_or_kill(mut child: Child) -> String {
    let deadline = Instant::now() + STOP_LIMIT;
    loop {
        match child.try_wait() {
            Ok(Some(status)) => return status.to_string(),
            Ok(None) if Instant::now() < deadline => std::thread::sleep(POLL),
            _ => {
                let _ = child.kill();
                return match child.wait() {
                    Ok(s) => format!("killed after {}s: {s}", STOP_LIMIT.as_secs()),
                    Err(e) => format!("lost: {e}"),
                };
            }
        }
    }
}

/// The last lines of a log, joined, for an error message.
fn log_tail(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let lines: Vec<&str> = text.lines().rev().take(3).collect();
    lines.into_iter().rev().collect::<Vec<_>>().join(" / ")
}

#[cfg(test)]
mod tests {
    use super::*;

    const NEWS: &str = r#"{"event":"news","level":"info","text":"peer t/r1/loco up","time":1.0}"#;
    const LOGGED: &str = "2026-11-29T04:48:38Z  INFO slate_node::monitor: peer t/r1/loco up";

    #[test]
    fn the_text_console_shows_a_modules_log_once_not_its_events_beside_it() {
        let text = Console {
            format: Format::Text,
        };
        assert_eq!(
            text.shown("t/r1/nav", LOGGED, Pipe::Log).as_deref(),
            Some(format!("t/r1/nav | {LOGGED}").as_str())
        );
        // The same sentence, as the node's JSON event: said once already.
        assert_eq!(text.shown("t/r1/nav", NEWS, Pipe::Events), None);
    }

    #[test]
    fn the_json_console_passes_on_both_pipes_as_log_events() {
        let json = Console {
            format: Format::Json,
        };
        for (line, pipe) in [(LOGGED, Pipe::Log), (NEWS, Pipe::Events)] {
            let shown = json.shown("t/r1/nav", line, pipe).unwrap();
            let j: serde_json::Value = serde_json::from_str(&shown).unwrap();
            assert_eq!(j["event"], "log");
            assert_eq!(j["address"], "t/r1/nav");
            assert_eq!(j["line"], line);
        }
    }
}
