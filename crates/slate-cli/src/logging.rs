//! Logs on stderr through `tracing`: the filter comes from `--log`, else `RUST_LOG`, else
//! the verb's default ([`NODE`] for `slate node`, [`OBSERVER`] for the others). Filters are
//! `LEVEL` or `target=LEVEL` pairs, like `info,slate_ici=debug,zenoh=warn`. Lines are
//! text, or JSON objects with `--log-format json`.

use std::io::IsTerminal;

use anyhow::Context as _;

use crate::cli::LogFormat;
use tracing_subscriber::filter::Targets;
use tracing_subscriber::prelude::*;
use tracing_subscriber::{Registry, reload};

/// The default filter of `slate node`: slate's own news, and only warnings from Zenoh
/// (but not `Skipping name verification of TLS server`, which a secured node's TLS links
/// warn of on every connection: a module's identity is its certificate's name, not its
/// host's, by design; docs/security.md; nor `Route data with unknown scope`, Zenoh's
/// error for a report on the UDP link that overtook the declaration of its key on TCP:
/// a best-effort message lost, which the ICI repairs like any other; Zenoh's timestamp
/// errors in the same place cannot happen, slate turns its timestamps off).
pub const NODE: &str = "warn,slate=info,slate_node=info,slate_ici=info,slate_zenoh=info,slate_dashboard=info,zenoh::net::protocol::gossip=off,zenoh_link_tls::utils=error,zenoh::net::routing::dispatcher::pubsub=off";

/// The default filter of the other verbs: errors only (and not Zenoh's gossip about
/// links it has not finished opening, which a short-lived observer always races).
pub const OBSERVER: &str = "error,zenoh::net::protocol::gossip=off";

/// Zenoh's messages while a node starts: errors only (and slate's own are unchanged).
const QUIET_ZENOH: &str = "zenoh=error";

/// Installs the subscriber, writing text or JSON lines; the handle narrows its filter
/// while a node starts.
pub fn init(flag: Option<&str>, default: &str, format: LogFormat) -> anyhow::Result<Logs> {
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
    let (filter, reload) = reload::Layer::new(targets);
    let json = format == LogFormat::Json;
    let text = (!json).then(|| {
        tracing_subscriber::fmt::layer()
            .with_writer(std::io::stderr)
            .with_ansi(std::io::stderr().is_terminal())
            .with_target(true)
    });
    let json = json.then(|| {
        tracing_subscriber::fmt::layer()
            .json()
            .with_writer(std::io::stderr)
            .with_target(true)
    });
    tracing_subscriber::registry()
        .with(filter)
        .with(text)
        .with(json)
        .try_init()
        .context("cannot install the logger")?;
    Ok(Logs {
        reload,
        spec,
        chosen: flag.is_some() || from == "RUST_LOG",
    })
}

/// The installed filter, to narrow for a while.
pub struct Logs {
    reload: reload::Handle<Targets, Registry>,
    spec: String,
    /// The user chose the filter (`--log` or `RUST_LOG`): it is never narrowed.
    chosen: bool,
}

impl Logs {
    /// Runs `start` with Zenoh's warnings left out, unless the user chose the filter.
    /// Zenoh warns about what then fails the start (a port in use, with its source
    /// paths), and the start's one-line error says it already (docs/cli.md).
    pub fn quiet_zenoh<T>(&self, start: impl FnOnce() -> T) -> T {
        if self.chosen {
            return start();
        }
        self.set(&format!("{},{QUIET_ZENOH}", self.spec));
        let result = start();
        self.set(&self.spec);
        result
    }

    fn set(&self, spec: &str) {
        if let Ok(targets) = spec.parse::<Targets>() {
            let _ = self.reload.reload(targets);
        }
    }
}
