//! Drives headless Chromium over the DevTools protocol against a live dashboard: the map shows
//! robots, values change over time, both transports work, awkward snapshots render without a
//! console error, and a screenshot lands in `target/dashboard.png`.
//!
//! Runs when Chromium is found (`$SLATE_CHROMIUM`, else `/usr/bin/chromium` or
//! `/usr/bin/chromium-browser`). `SLATE_BROWSER_TESTS=1` makes a missing Chromium a failure,
//! `SLATE_BROWSER_TESTS=0` skips the test.

use std::io::{BufRead, BufReader};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use base64::Engine;
use serde_json::{Value, json};
use slate_dashboard::SampleTeam;
use tungstenite::{Message, WebSocket};

use crate::support::{serve_local, target_dir};

/// How long any one wait in this test may take before it fails.
const WAIT: Duration = Duration::from_secs(20);

fn chromium() -> Option<PathBuf> {
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
struct Chromium {
    child: Child,
    profile: PathBuf,
    log: Arc<Mutex<Vec<String>>>,
    devtools: String,
}

impl Chromium {
    fn launch(binary: &Path) -> Self {
        use std::os::unix::process::CommandExt;
        let profile = std::env::temp_dir().join(format!(
            "slate-dashboard-chromium-{}-{}",
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

    fn log_tail(&self) -> String {
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
struct Page {
    socket: WebSocket<TcpStream>,
    session: String,
    next_id: u64,
    events: Vec<Value>,
}

impl Page {
    fn open(devtools: &str) -> Self {
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

    fn call(&mut self, method: &str, params: Value) -> Value {
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

    fn navigate(&mut self, url: &str) {
        self.call("Page.navigate", json!({"url": url}));
    }

    /// Evaluates `expression` in the page; a thrown exception fails the test.
    fn eval(&mut self, expression: &str) -> Value {
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

    fn text(&mut self, testid: &str) -> String {
        let expression =
            format!("(document.querySelector('[data-testid=\"{testid}\"]') || {{}}).textContent");
        self.eval(&expression)
            .as_str()
            .unwrap_or_default()
            .to_owned()
    }

    /// Polls `testid`'s text until `ok` accepts it.
    fn wait_text(&mut self, testid: &str, ok: impl Fn(&str) -> bool) -> String {
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

    /// Moves the mouse over a grid of points on the map canvas, then away.
    fn sweep_mouse_over_map(&mut self) {
        let rect = self.eval(
            "(() => { const r = document.querySelector('[data-testid=map]').getBoundingClientRect(); \
             return [r.left, r.top, r.width, r.height]; })()",
        );
        let [left, top, width, height] = [0, 1, 2, 3].map(|i| rect[i].as_f64().unwrap());
        for i in 1..12 {
            for j in 1..8 {
                let (x, y) = (
                    left + width * f64::from(i) / 12.0,
                    top + height * f64::from(j) / 8.0,
                );
                self.mouse("mouseMoved", x, y);
            }
        }
        self.mouse("mouseMoved", 1.0, 1.0);
    }

    fn mouse(&mut self, kind: &str, x: f64, y: f64) {
        self.call(
            "Input.dispatchMouseEvent",
            json!({"type": kind, "x": x, "y": y}),
        );
    }

    fn screenshot(&mut self, path: &Path) {
        let shot = self.call("Page.captureScreenshot", json!({"format": "png"}));
        let png = base64::engine::general_purpose::STANDARD
            .decode(shot["data"].as_str().expect("screenshot data"))
            .expect("screenshot base64");
        std::fs::write(path, png).expect("write screenshot");
    }

    /// Console errors, uncaught exceptions and error log entries seen so far.
    fn console_errors(&mut self) -> Vec<String> {
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

fn seconds(text: &str) -> f64 {
    text.trim().parse().unwrap_or(f64::NAN)
}

/// Snapshots that are valid but awkward: empty, missing or mistyped sections, odd values.
fn awkward_snapshots() -> Vec<Value> {
    vec![
        json!({}),
        json!(null),
        json!([]),
        json!({"title": null, "time": "soon", "status": 3, "summary": [1, 2]}),
        json!({"map": null, "classes": null, "objects": null, "plans": null, "links": null, "events": null}),
        json!({"map": {"bounds": [5, 5, 5, 5], "items": [null, 3, {"kind": "robot"}, {"x": 1, "y": 1}]}}),
        json!({"map": {"bounds": "everywhere", "items": [{"id": "r", "kind": "robot", "x": 1e9, "y": -1e9,
            "heading": "north", "accuracy": -1, "confidence": 7, "alive": "yes", "stale": 1}]}}),
        json!({"map": {"items": [{"id": "solo", "kind": "unknown", "x": 3, "y": 4, "accuracy": 1e12}]}}),
        json!({"classes": [{"name": "A", "parent": "B"}, {"name": "B", "parent": "A"}, {"name": "C", "parent": "C"},
            {"name": "A"}, {"parent": "A"}, "Thing", {"name": 5, "attrs": "x"}]}),
        json!({"objects": [{"name": "x", "attrs": [null, {"name": "v", "value": {"deep": [1, 2]},
            "accuracy": "?", "confidence": null, "age": -3}]}, {"attrs": 5}, null]}),
        json!({"plans": [{"name": "p", "acks": "received", "fired": "many"}, null, {"state": 4}]}),
        json!({"links": [{"name": "l", "bytes_per_s": 10, "budget_bps": 0}, {"bytes_per_s": "fast"}, {}]}),
        json!({"events": [{"t": "later", "text": null, "level": "panic"}, {"t": 2}, 7, {"text": "<b>not html</b>"}]}),
    ]
}

#[test]
fn browser_shows_a_moving_team_without_console_errors() {
    let Some(binary) = chromium() else {
        return;
    };
    let started = Instant::now();
    let clock = Instant::now();
    // Start in the interesting part of the choreography (r3 lost, targets found), at 2x speed.
    let dashboard = serve_local(Arc::new(move || {
        SampleTeam::at(44.0 + 2.0 * clock.elapsed().as_secs_f64())
    }));
    let url = dashboard.url();
    let chromium = Chromium::launch(&binary);
    let mut page = Page::open(&chromium.devtools);

    // WebSocket: robots drawn, time advancing within one load.
    page.navigate(&url);
    page.wait_text("transport", |t| t == "live");
    let robots = page.wait_text("robot-count", |t| t.parse::<u32>().is_ok_and(|n| n > 0));
    assert_eq!(robots, "3");
    let first = seconds(&page.wait_text("snapshot-time", |t| seconds(t).is_finite()));
    let later = seconds(&page.wait_text("snapshot-time", |t| seconds(t) > first));
    assert!(
        page.eval("document.querySelectorAll('[data-testid=plan-row]').length")
            .as_u64()
            > Some(0)
    );

    // A second load shows a later time.
    page.navigate(&url);
    page.wait_text("snapshot-time", |t| seconds(t) > later);

    // Polling fallback.
    page.navigate(&format!("{url}?transport=poll"));
    page.wait_text("transport", |t| t == "polling");
    let polled = seconds(&page.wait_text("snapshot-time", |t| seconds(t).is_finite()));
    page.wait_text("snapshot-time", |t| seconds(t) > polled);
    page.wait_text("robot-count", |t| t == "3");

    // Interaction: hover across the map (tooltips), click a class and an object.
    page.sweep_mouse_over_map();
    page.eval("document.querySelectorAll('[data-testid=class-row]')[2].click()");
    let filtered = page.eval("document.querySelectorAll('[data-testid=object-row]').length");
    assert!(
        filtered.as_u64() > Some(0),
        "the Auv class filter shows the robots"
    );
    page.eval("document.querySelectorAll('[data-testid=object-row]')[1].click()");
    assert_eq!(
        page.eval("document.querySelectorAll('[data-testid=attr-row]').length"),
        3
    );

    // Awkward snapshots render without throwing (each section guards its own fields).
    for snapshot in awkward_snapshots() {
        page.eval(&format!("window.slateDashboard.render({snapshot})"));
    }

    // The screenshot: back on the live page, with some trail behind the robots.
    page.navigate(&url);
    page.wait_text("robot-count", |t| t == "3");
    std::thread::sleep(Duration::from_millis(2500));
    let shot = target_dir().join("dashboard.png");
    page.screenshot(&shot);

    let errors = page.console_errors();
    assert!(
        errors.is_empty(),
        "console errors: {errors:#?}\nchromium log:\n{}",
        chromium.log_tail()
    );
    eprintln!(
        "browser test passed in {:.1?}; screenshot at {}",
        started.elapsed(),
        shot.display()
    );
}
