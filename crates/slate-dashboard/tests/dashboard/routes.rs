use std::sync::Arc;

use serde_json::Value;
use slate_dashboard::SampleTeam;

use crate::support::{counting_source, http_get, serve_local};

#[test]
fn page_is_one_self_contained_html_document_with_test_hooks() {
    let dashboard = serve_local(counting_source());
    let page = http_get(dashboard.local_addr(), "/");
    assert_eq!(page.status, 200);
    assert!(
        page.header("content-type")
            .unwrap()
            .starts_with("text/html")
    );
    for hook in [
        "map",
        "robot-count",
        "snapshot-time",
        "plans",
        "links",
        "events",
    ] {
        assert!(
            page.body.contains(&format!("data-testid=\"{hook}\"")),
            "missing {hook}"
        );
    }
    assert!(page.body.contains("<script>") && page.body.contains("<style>"));
    assert!(!page.body.contains("<script src") && !page.body.contains("<link rel=\"stylesheet\""));
}

#[test]
fn snapshot_returns_exactly_the_source_json() {
    let expected = SampleTeam::at(47.25);
    let fixed = expected.clone();
    let dashboard = serve_local(Arc::new(move || fixed.clone()));
    let response = http_get(dashboard.local_addr(), "/api/snapshot");
    assert_eq!(response.status, 200);
    assert_eq!(response.header("content-type"), Some("application/json"));
    assert_eq!(response.header("cache-control"), Some("no-store"));
    assert_eq!(response.json(), expected);
}

#[test]
fn snapshot_follows_the_source_over_time() {
    let dashboard = serve_local(counting_source());
    let first = http_get(dashboard.local_addr(), "/api/snapshot").json();
    std::thread::sleep(std::time::Duration::from_millis(150));
    let second = http_get(dashboard.local_addr(), "/api/snapshot").json();
    assert!(second["time"].as_f64() > first["time"].as_f64());
}

#[test]
fn healthz_answers_ok() {
    let dashboard = serve_local(counting_source());
    let response = http_get(dashboard.local_addr(), "/healthz");
    assert_eq!((response.status, response.body.as_str()), (200, "ok"));
}

#[test]
fn unknown_route_is_not_found() {
    let dashboard = serve_local(counting_source());
    assert_eq!(http_get(dashboard.local_addr(), "/nope").status, 404);
}

#[test]
fn panicking_source_gives_500_and_the_server_keeps_serving() {
    let dashboard = serve_local(Arc::new(|| -> Value {
        panic!("source exploded on purpose")
    }));
    assert_eq!(
        http_get(dashboard.local_addr(), "/api/snapshot").status,
        500
    );
    assert_eq!(http_get(dashboard.local_addr(), "/healthz").status, 200);
    assert_eq!(http_get(dashboard.local_addr(), "/").status, 200);
}
