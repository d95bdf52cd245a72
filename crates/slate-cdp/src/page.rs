//! One DevTools protocol session on one tab.

use std::net::TcpStream;
use std::path::Path;
use std::time::{Duration, Instant};

use base64::Engine;
use serde_json::{Value, json};
use tungstenite::{Message, WebSocket};

/// How often [`Page::wait_text`] looks again.
const POLL: Duration = Duration::from_millis(100);

/// A DevTools protocol session on one tab, recording every event it sees.
///
/// Made by [`Chromium::page`](crate::Chromium::page). Calls are synchronous: each sends one
/// command and reads until its reply, keeping the events that arrive meanwhile (for
/// [`Page::console_errors`]).
pub struct Page {
    socket: WebSocket<TcpStream>,
    session: String,
    next_id: u64,
    events: Vec<Value>,
    limit: Duration,
}

impl Page {
    /// Connects to the browser at `devtools` (its `ws://` URL), creates a blank 1280×800 tab
    /// and attaches to it with the runtime, log and page domains enabled.
    pub(crate) fn open(devtools: &str, limit: Duration) -> Self {
        let host = devtools
            .trim_start_matches("ws://")
            .split('/')
            .next()
            .expect("a DevTools URL names a host");
        let stream = TcpStream::connect(host).expect("connect to DevTools");
        stream.set_read_timeout(Some(limit)).unwrap();
        let (socket, _) = tungstenite::client(devtools, stream).expect("DevTools handshake");
        let mut page = Self {
            socket,
            session: String::new(),
            next_id: 0,
            events: Vec::new(),
            limit,
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

    /// Sends the protocol command `method` with `params` and returns its result.
    ///
    /// # Panics
    ///
    /// When the socket fails, no message arrives within the limit, or the command fails.
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

    /// Starts loading `url` (without waiting for the load to finish).
    pub fn navigate(&mut self, url: &str) {
        self.call("Page.navigate", json!({"url": url}));
    }

    /// Evaluates `expression` in the page and returns its value.
    ///
    /// # Panics
    ///
    /// When the expression throws.
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

    /// The text content of the element with `data-testid="{testid}"`, empty if there is none.
    pub fn text(&mut self, testid: &str) -> String {
        let expression =
            format!("(document.querySelector('[data-testid=\"{testid}\"]') || {{}}).textContent");
        self.eval(&expression)
            .as_str()
            .unwrap_or_default()
            .to_owned()
    }

    /// Polls `testid`'s text until `ok` accepts it, and returns that text.
    ///
    /// # Panics
    ///
    /// When `ok` accepts nothing within the limit.
    pub fn wait_text(&mut self, testid: &str, ok: impl Fn(&str) -> bool) -> String {
        let deadline = Instant::now() + self.limit;
        loop {
            let text = self.text(testid);
            if ok(&text) {
                return text;
            }
            assert!(Instant::now() < deadline, "{testid} stayed {text:?}");
            std::thread::sleep(POLL);
        }
    }

    /// Dispatches a mouse event of `kind` (`mouseMoved`, `mousePressed`, ...) at page
    /// coordinates (`x`, `y`).
    pub fn mouse(&mut self, kind: &str, x: f64, y: f64) {
        self.call(
            "Input.dispatchMouseEvent",
            json!({"type": kind, "x": x, "y": y}),
        );
    }

    /// Writes a PNG screenshot of the viewport to `path`.
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
        self.events.iter().filter_map(console_error).collect()
    }
}

/// The error `event` reports, if it is an uncaught exception, a `console.error` call or an
/// error log entry.
fn console_error(event: &Value) -> Option<String> {
    let params = &event["params"];
    match event["method"].as_str()? {
        "Runtime.exceptionThrown" => Some(params["exceptionDetails"].to_string()),
        "Runtime.consoleAPICalled" if params["type"] == "error" => Some(params["args"].to_string()),
        "Log.entryAdded" if params["entry"]["level"] == "error" => {
            Some(params["entry"].to_string())
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn console_error_keeps_exceptions_console_errors_and_error_log_entries() {
        let events = [
            json!({"method": "Runtime.exceptionThrown", "params": {"exceptionDetails": {"text": "boom"}}}),
            json!({"method": "Runtime.consoleAPICalled", "params": {"type": "error", "args": ["bad"]}}),
            json!({"method": "Log.entryAdded", "params": {"entry": {"level": "error", "text": "404"}}}),
        ];
        for event in &events {
            assert!(console_error(event).is_some(), "{event}");
        }
    }

    #[test]
    fn console_error_ignores_logs_warnings_and_other_events() {
        let events = [
            json!({"method": "Runtime.consoleAPICalled", "params": {"type": "log", "args": ["hi"]}}),
            json!({"method": "Log.entryAdded", "params": {"entry": {"level": "warning"}}}),
            json!({"method": "Page.loadEventFired", "params": {}}),
            json!({"id": 3, "result": {}}),
        ];
        for event in &events {
            assert_eq!(console_error(event), None, "{event}");
        }
    }
}
