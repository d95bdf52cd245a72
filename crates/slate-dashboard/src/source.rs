//! The one thing a dashboard needs from its host: the current view as JSON.

use serde_json::Value;

/// Something that can describe the world as the dashboard's JSON contract
/// (see `docs/dashboard.md`).
///
/// Implementations are called from a background thread a few times per second, so they
/// should be quick and must not block for long (take a snapshot under a lock, then release it).
/// Any closure `Fn() -> serde_json::Value` is a source.
pub trait DashboardSource: Send + Sync + 'static {
    /// The current view as JSON. Every section is optional; the page tolerates missing ones.
    fn snapshot(&self) -> Value;
}

impl<F> DashboardSource for F
where
    F: Fn() -> Value + Send + Sync + 'static,
{
    fn snapshot(&self) -> Value {
        self()
    }
}
