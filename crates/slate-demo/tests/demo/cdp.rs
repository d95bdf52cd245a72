//! A headless Chromium driven over the DevTools protocol (no npm, no driver), after the
//! dashboard crate's browser test (`crates/slate-dashboard/tests/dashboard/browser.rs`),
//! whose small client this copies.
//!
//! Runs when Chromium is found (`$SLATE_CHROMIUM`, else `/usr/bin/chromium` or
//! `/usr/bin/chromium-browser`). `SLATE_BROWSER_TESTS=1` makes a missing Chromium a
//! failure, `SLATE_BROWSER_TESTS=0` skips the tests.

use std::io::{BufRead, BufReader};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use base64::Engine;
use serde_json::{Value, json};
use tungstenite::{Message, WebSocket};

/// How long any one wait in this test may take before it fails.
pub const WAIT: Duration = Duration::from_secs(30);

pub fn chromium() -> Option<PathBuf> {
    let wanted = std::env::var("SLATE_BROWSER_TESTS").ok();
    if wanted.as_deref() == Some("0") {
        eprintln!("browser test skipped: SLATE_BROWSER_TESTS=0");
        return None;
    }
    let candidates = std::env::var_os("SLATE_CHROMIUM")
        .map(PathBuf::from)
        .into_iter()
        .chain(["/usr/bin/chromium", "/usr/bin/chromium-browser"].map(PathBuf::from));
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
pub struct Chromium {
    child: Child,
    profile: PathBuf,
    log: Arc<Mutex<Vec<String>>>,
    pub devtools: String,
}

impl Chromium {
    pub fn launch(binary: &Path) -> Self {
        use std::os::unix::process::CommandExt;
        let profile = std::env::temp_dir().join(format!(
            "slate-demo-chromium-{}-{}",
            std::process::id(),
            rand_seed()
        ));
        std::fs::create_dir_all(&profile).unwrap();
        let mut child = Command::new(binary)
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
            .process_group(0)
            .spawn()
            .expect("start chromium");
        let log = Arc::new(Mutex::new(Vec::new()));
        let (tx, rx) = std::sync::mpsc::channel();
        let stderr = child.stderr.take().unwrap();
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
        };
        chromium.devtools = rx.recv_timeout(WAIT).unwrap_or_else(|_| {
            panic!("chromium printed no DevTools URL:\n{}", chromium.log_tail())
        });
        chromium
    }

    pub fn log_tail(&self) -> String {
        let log = self.log.lock().unwrap();
        log[log.len().saturating_sub(40)..].join("\n")
    }
}

impl Drop for Chromium {
    fn drop(&mut self) {
        let group = format!("-{}", self.child.id());
        let _ = Command::new("kill").args(["-KILL", "--", &group]).status();
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self.profile);
    }
}

fn rand_seed() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}

/// A DevTools protocol session on one page, recording every event it sees.
pub struct Page {
    socket: WebSocket<TcpStream>,
    session: String,
    next_id: u64,
    events: Vec<Value>,
}

impl Page {
    pub fn open(devtools: &str) -> Self {
        let host = devtools
            .trim_start_matches("ws://")
            .split('/')
            .next()
            .unwrap();
        let stream = TcpStream::connect(host).expect("connect to DevTools");
        stream.set_read_timeout(Some(WAIT)).unwrap();
        let (socket, _) = tungstenite::client(devtools, stream).expect("DevTools handshake");
        let mut page = Self {
            socket,
            session: String::new(),
            next_id: 0,
            events: Vec::new(),
        };
        let target = page.call("Target.createTarget", json!({"url": "about:blank"}));
        let attached = page.call(
            "Target.attachToTarget",
            json!({"targetId": target["targetId"], "flatten": true}),
        );
        page.session = attached["sessionId"].as_str().unwrap().to_owned();
        for domain in ["Runtime.enable", "Log.enable", "Page.enable"] {
            page.call(domain, json!({}));
        }
        page.call(
            "Emulation.setDeviceMetricsOverride",
            json!({"width": 1280, "height": 800, "deviceScaleFactor": 1, "mobile": false}),
        );
        page
    }

    pub fn call(&mut self, method: &str, params: Value) -> Value {
        self.next_id += 1;
        let id = self.next_id;
        let mut message = json!({"id": id, "method": method, "params": params});
        if !self.session.is_empty() {
            message["sessionId"] = json!(self.session);
        }
        self.socket
            .send(Message::Text(message.to_string().into()))
            .expect("send to DevTools");
        loop {
            let Message::Text(text) = self.socket.read().expect("read from DevTools") else {
                continue;
            };
            let reply: Value = serde_json::from_str(text.as_str()).expect("DevTools JSON");
            if reply["id"] == id {
                assert!(
                    reply["error"].is_null(),
                    "{method} failed: {}",
                    reply["error"]
                );
                return reply["result"].clone();
            }
            if reply["method"].is_string() {
                self.events.push(reply);
            }
        }
    }

    pub fn navigate(&mut self, url: &str) {
        self.call("Page.navigate", json!({"url": url}));
    }

    /// Evaluates `expression` in the page; a thrown exception fails the test.
    pub fn eval(&mut self, expression: &str) -> Value {
        let result = self.call(
            "Runtime.evaluate",
            json!({"expression": expression, "returnByValue": true}),
        );
        assert!(
            result["exceptionDetails"].is_null(),
            "{expression} threw: {}",
            result["exceptionDetails"]
        );
        result["result"]["value"].clone()
    }

    pub fn text(&mut self, testid: &str) -> String {
        let expression =
            format!("(document.querySelector('[data-testid=\"{testid}\"]') || {{}}).textContent");
        self.eval(&expression)
            .as_str()
            .unwrap_or_default()
            .to_owned()
    }

    /// Polls `testid`'s text until `ok` accepts it.
    pub fn wait_text(&mut self, testid: &str, ok: impl Fn(&str) -> bool) -> String {
        let deadline = Instant::now() + WAIT;
        loop {
            let text = self.text(testid);
            if ok(&text) {
                return text;
            }
            assert!(Instant::now() < deadline, "{testid} stayed {text:?}");
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    pub fn screenshot(&mut self, path: &Path) {
        let shot = self.call("Page.captureScreenshot", json!({"format": "png"}));
        let png = base64::engine::general_purpose::STANDARD
            .decode(shot["data"].as_str().expect("screenshot data"))
            .expect("screenshot base64");
        std::fs::write(path, png).expect("write screenshot");
    }

    /// Console errors, uncaught exceptions and error log entries seen so far.
    pub fn console_errors(&mut self) -> Vec<String> {
        self.eval("0"); // drain events that arrived since the last call
        self.events
            .iter()
            .filter_map(|event| {
                let params = &event["params"];
                match event["method"].as_str()? {
                    "Runtime.exceptionThrown" => Some(params["exceptionDetails"].to_string()),
                    "Runtime.consoleAPICalled" if params["type"] == "error" => {
                        Some(params["args"].to_string())
                    }
                    "Log.entryAdded" if params["entry"]["level"] == "error" => {
                        Some(params["entry"].to_string())
                    }
                    _ => None,
                }
            })
            .collect()
    }
}
