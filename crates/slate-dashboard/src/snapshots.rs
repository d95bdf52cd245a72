//! A short-lived cache in front of the source, shared by every client.
//!
//! Several WebSocket clients and pollers then cost one `snapshot()` call per
//! [`MAX_AGE`] between them, and a slow source never blocks the server's own thread.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::DashboardSource;

/// How long one serialized snapshot is reused.
const MAX_AGE: Duration = Duration::from_millis(100);

/// The source plus its last serialized snapshot.
pub(crate) struct Snapshots {
    source: Arc<dyn DashboardSource>,
    last: Mutex<Option<(Instant, Arc<str>)>>,
}

/// The source panicked while producing a snapshot.
#[derive(Debug)]
pub(crate) struct SourceFailed;

impl Snapshots {
    pub(crate) fn new(source: Arc<dyn DashboardSource>) -> Self {
        Self {
            source,
            last: Mutex::new(None),
        }
    }

    /// The current snapshot as JSON text, fresh to within [`MAX_AGE`].
    pub(crate) async fn get(&self) -> Result<Arc<str>, SourceFailed> {
        if let Some(json) = self.cached() {
            return Ok(json);
        }
        let source = Arc::clone(&self.source);
        let json: Arc<str> = tokio::task::spawn_blocking(move || source.snapshot().to_string())
            .await
            .map_err(|_| SourceFailed)?
            .into();
        *self.lock() = Some((Instant::now(), Arc::clone(&json)));
        Ok(json)
    }

    fn cached(&self) -> Option<Arc<str>> {
        match &*self.lock() {
            Some((at, json)) if at.elapsed() < MAX_AGE => Some(Arc::clone(json)),
            _ => None,
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Option<(Instant, Arc<str>)>> {
        // The guarded value is replaced whole, so a poisoned lock still holds a valid one.
        self.last
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}
