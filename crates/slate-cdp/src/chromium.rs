//! Finding Chromium and running it as a headless child in its own process group.

use std::io::{BufRead, BufReader};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crate::Page;

/// Where Chromium is looked for when `SLATE_CHROMIUM` is unset or names no file.
const CANDIDATES: [&str; 2] = ["/usr/bin/chromium", "/usr/bin/chromium-browser"];

/// How many of Chromium's last log lines [`Chromium::log_tail`] returns.
const TAIL_LINES: usize = 40;

/// The Chromium binary a browser test should drive, or `None` when the test should skip.
///
/// Looks at `$SLATE_CHROMIUM`, then `/usr/bin/chromium` and `/usr/bin/chromium-browser`.
/// `SLATE_BROWSER_TESTS=0` skips even when Chromium is there; `SLATE_BROWSER_TESTS=1` makes a
/// missing Chromium a failure. A skip is reported on stderr.
///
/// # Panics
///
/// When `SLATE_BROWSER_TESTS=1` and no Chromium is found.
pub fn chromium() -> Option<PathBuf> {
    let wanted = std::env::var("SLATE_BROWSER_TESTS").ok();
    if wanted.as_deref() == Some("0") {
        eprintln!("browser test skipped: SLATE_BROWSER_TESTS=0");
        return None;
    }
    let candidates = std::env::var_os("SLATE_CHROMIUM")
        .map(PathBuf::from)
        .into_iter()
        .chain(CANDIDATES.map(PathBuf::from));
    let found = candidates.into_iter().find(|path| path.exists());
    match (found, wanted.as_deref()) {
        (Some(path), _) => Some(path),
        (None, Some("1")) => panic!("SLATE_BROWSER_TESTS=1 but no Chromium found"),
        (None, _) => {
            eprintln!("browser test skipped: no Chromium (apt-get install chromium)");
            None
        }
    }
}

/// A headless Chromium in its own process group, killed (group and all) when dropped.
///
/// Its stderr is kept in memory for [`Chromium::log_tail`]; its profile lives in a fresh
/// temporary directory, removed on drop.
pub struct Chromium {
    child: Child,
    profile: PathBuf,
    log: Arc<Mutex<Vec<String>>>,
    devtools: String,
    limit: Duration,
}

impl Chromium {
    /// Starts `binary` headless at 1280×800 and waits, at most `limit`, for its DevTools URL.
    ///
    /// `limit` also bounds every wait of the pages this browser opens.
    ///
    /// # Panics
    ///
    /// When Chromium cannot be started or prints no DevTools URL within `limit`.
    pub fn launch(binary: &Path, limit: Duration) -> Self {
        let profile = std::env::temp_dir().join(format!(
            "slate-cdp-chromium-{}-{}",
            std::process::id(),
            nanos_now()
        ));
        std::fs::create_dir_all(&profile).expect("create the Chromium profile directory");
        let mut child = headless(binary, &profile).spawn().expect("start chromium");
        let log = Arc::new(Mutex::new(Vec::new()));
        let (tx, rx) = std::sync::mpsc::channel();
        let stderr = child.stderr.take().expect("chromium's stderr is piped");
        let sink = Arc::clone(&log);
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if let Some(at) = line.find("ws://") {
                    let _ = tx.send(line[at..].trim().to_owned());
                }
                sink.lock().unwrap().push(line);
            }
        });
        let mut chromium = Self {
            child,
            profile,
            log,
            devtools: String::new(),
            limit,
        };
        chromium.devtools = rx.recv_timeout(limit).unwrap_or_else(|_| {
            panic!("chromium printed no DevTools URL:\n{}", chromium.log_tail())
        });
        chromium
    }

    /// Opens a new blank tab and attaches a DevTools session to it.
    ///
    /// # Panics
    ///
    /// When the DevTools socket cannot be reached or a setup call fails.
    pub fn page(&self) -> Page {
        Page::open(&self.devtools, self.limit)
    }

    /// The last lines Chromium wrote to stderr, for failure messages.
    pub fn log_tail(&self) -> String {
        let log = self.log.lock().unwrap();
        log[log.len().saturating_sub(TAIL_LINES)..].join("\n")
    }
}

impl Drop for Chromium {
    fn drop(&mut self) {
        // Chromium forks renderers and helpers: killing the group leaves none behind.
        let group = format!("-{}", self.child.id());
        let _ = Command::new("kill").args(["-KILL", "--", &group]).status();
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self.profile);
    }
}

/// The command line of a quiet headless Chromium with its own profile and process group,
/// printing its DevTools URL (on a free port) to a piped stderr.
fn headless(binary: &Path, profile: &Path) -> Command {
    let mut command = Command::new(binary);
    command
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--disable-dev-shm-usage",
            "--hide-scrollbars",
            "--window-size=1280,800",
            "--remote-debugging-port=0",
            "--enable-logging=stderr",
            "--v=0",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg("about:blank")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .process_group(0);
    command
}

/// Nanoseconds since the epoch, to keep profile directories of one process apart.
fn nanos_now() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}
