//! Helpers shared by the test modules: sources, timeouts (and the shared HTTP client).

use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use serde_json::json;
use slate_dashboard::{Dashboard, DashboardSource};
pub use slate_testing::{http_get, target_dir, within};

/// Socket timeouts: generous, only there so a broken server fails a test instead of hanging it.
pub const IO_TIMEOUT: Duration = Duration::from_secs(10);

/// Serves `source` on a free loopback port.
pub fn serve_local(source: Arc<dyn DashboardSource>) -> Dashboard {
    slate_dashboard::serve(SocketAddr::from(([127, 0, 0, 1], 0)), source).expect("serve")
}

/// A source whose `time` counts its calls: 1, 2, 3, ...
pub fn counting_source() -> Arc<dyn DashboardSource> {
    let calls = AtomicU64::new(0);
    Arc::new(move || {
        let n = calls.fetch_add(1, Ordering::SeqCst) + 1;
        json!({"title": "counting", "time": n as f64, "status": "running",
               "map": {"items": [{"id": "r1", "kind": "robot", "x": n as f64, "y": 0.0}]}})
    })
}
