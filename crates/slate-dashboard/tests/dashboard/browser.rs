//! Drives headless Chromium over the DevTools protocol against a live dashboard: the map shows
//! robots, values change over time, both transports work, awkward snapshots render without a
//! console error, and a screenshot lands in `target/dashboard.png`.
//!
//! Runs when `slate_cdp::chromium` finds Chromium (`$SLATE_CHROMIUM`, else `/usr/bin/chromium`
//! or `/usr/bin/chromium-browser`). `SLATE_BROWSER_TESTS=1` makes a missing Chromium a failure,
//! `SLATE_BROWSER_TESTS=0` skips the test.

use std::sync::Arc;
use std::time::{Duration, Instant};

use serde_json::{Value, json};
use slate_cdp::{Chromium, Page, chromium};
use slate_dashboard::SampleTeam;

use slate_testing::screenshot_without_errors;

use crate::support::serve_local;

/// How long any one wait in this test may take before it fails.
const WAIT: Duration = Duration::from_secs(20);

/// Moves the mouse over a grid of points on the map canvas, then away.
fn sweep_mouse_over_map(page: &mut Page) {
    let rect = page.eval(
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
            page.mouse("mouseMoved", x, y);
        }
    }
    page.mouse("mouseMoved", 1.0, 1.0);
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
    let chromium = Chromium::launch(&binary, WAIT);
    let mut page = chromium.page();

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
    sweep_mouse_over_map(&mut page);
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
    let shot = screenshot_without_errors(&mut page, &chromium, "dashboard.png");
    eprintln!(
        "browser test passed in {:.1?}; screenshot at {}",
        started.elapsed(),
        shot.display()
    );
}
