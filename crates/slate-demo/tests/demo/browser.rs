//! The dashboard of a running demo, in headless Chromium: the map shows the robots, the
//! values change as the mission goes on, the plans show their acknowledgements, the page
//! logs no error; a screenshot lands in `target/demo-dashboard.png`.
//!
//! Runs when `slate_cdp::chromium` finds Chromium (`$SLATE_CHROMIUM`, else `/usr/bin/chromium`
//! or `/usr/bin/chromium-browser`). `SLATE_BROWSER_TESTS=1` makes a missing Chromium a
//! failure, `SLATE_BROWSER_TESTS=0` skips the test.

use std::net::SocketAddr;
use std::sync::mpsc;
use std::time::Duration;

use slate_cdp::{Chromium, Page, chromium};
use slate_demo::{DemoConfig, Progress, run};
use slate_testing::screenshot_without_errors;

/// How long any one wait in this test may take before it fails. Generous: CI runs this
/// binary's demos side by side on 2 cores, and a starved demo once held the dashboard's
/// clock still for 30 s.
const WAIT: Duration = Duration::from_secs(120);

fn seconds(text: &str) -> f64 {
    text.trim().parse().unwrap_or(f64::NAN)
}

fn count(page: &mut Page, testid: &str) -> u64 {
    page.eval(&format!(
        "document.querySelectorAll('[data-testid={testid}]').length"
    ))
    .as_u64()
    .unwrap_or(0)
}

#[test]
fn the_dashboard_shows_the_team_at_work_without_console_errors() {
    let Some(binary) = chromium() else {
        return;
    };
    // Four times real time, long enough to see the fault and the take-over.
    let config = DemoConfig::default()
        .seed(7)
        .duration(Duration::from_secs(70))
        .dashboard(SocketAddr::from(([127, 0, 0, 1], 0)))
        .pace(Some(4.0));
    let (tx, rx) = mpsc::channel();
    let demo = std::thread::spawn(move || {
        run(config, &mut |p| {
            if let Progress::Dashboard(url) = p {
                let _ = tx.send(url);
            }
        })
    });
    let url = rx
        .recv_timeout(Duration::from_secs(60))
        .expect("the dashboard is served");
    let chromium = Chromium::launch(&binary, WAIT);
    let mut page = chromium.page();
    page.navigate(&url);
    page.wait_text("transport", |t| t == "live");
    let robots = page.wait_text("robot-count", |t| t == "3");
    assert_eq!(robots, "3");
    let first = seconds(&page.wait_text("snapshot-time", |t| seconds(t).is_finite()));
    let items = page.wait_text("item-count", |t| t.parse::<u64>().is_ok_and(|n| n > 10));
    // Later: the mission is under way, r3 has died, targets are found.
    page.wait_text("snapshot-time", |t| seconds(t) > first.max(40.0));
    assert!(
        count(&mut page, "plan-row") >= 9,
        "the console's mission plans and the sub-plans show"
    );
    assert!(count(&mut page, "event") > 5, "the event log fills");
    assert!(
        count(&mut page, "link-row") >= 4,
        "a radio per robot and the console"
    );
    assert!(count(&mut page, "object-row") > 10, "the console's board");
    let summary = page.text("summary");
    assert!(summary.contains("2/3"), "the dead robot shows: {summary}");
    let later_items = page.text("item-count");
    assert!(!later_items.is_empty() && items != "0");
    let shot = screenshot_without_errors(&mut page, &chromium, "demo-dashboard.png");
    drop(chromium);
    let summary = demo.join().expect("the demo thread").expect("the demo ran");
    assert_eq!(summary.duplicate_investigations, 0);
    eprintln!("screenshot at {}", shot.display());
}
