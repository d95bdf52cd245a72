//! Logs on stderr through `tracing`: the filter comes from `--log`, else `RUST_LOG`, else
//! the verb's default ([`NODE`] for `slate node`, [`OBSERVER`] for the others). Filters are
//! `LEVEL` or `target=LEVEL` pairs, like `info,slate_ici=debug,zenoh=warn`.

use std::io::IsTerminal;

use anyhow::Context as _;
use tracing_subscriber::filter::Targets;
use tracing_subscriber::prelude::*;

/// The default filter of `slate node`: slate's own news, and only warnings from Zenoh.
pub const NODE: &str = "warn,slate=info,slate_node=info,slate_ici=info,slate_zenoh=info,slate_dashboard=info,zenoh::net::protocol::gossip=off";

/// The default filter of the other verbs: errors only (and not Zenoh's gossip about
/// links it has not finished opening, which a short-lived observer always races).
pub const OBSERVER: &str = "error,zenoh::net::protocol::gossip=off";

/// Installs the subscriber.
pub fn init(flag: Option<&str>, default: &str) -> anyhow::Result<()> {
    let env = std::env::var("RUST_LOG")
        .ok()
        .filter(|s| !s.trim().is_empty());
    let (spec, from) = match (flag, env) {
        (Some(f), _) => (f.to_owned(), "--log"),
        (None, Some(e)) => (e, "RUST_LOG"),
        (None, None) => (default.to_owned(), "the default"),
    };
    let targets: Targets = spec.parse().with_context(|| {
        format!("{from} {spec:?} is not a log filter (like `info` or `warn,slate_ici=debug`)")
    })?;
    let layer = tracing_subscriber::fmt::layer()
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .with_target(true);
    tracing_subscriber::registry()
        .with(layer.with_filter(targets))
        .try_init()
        .context("cannot install the logger")
}
