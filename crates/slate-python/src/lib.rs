//! The native module `slate._slate`: slate's world model and plan engine for Python.
//!
//! The pure-Python package `slate` (in `python/slate/`) re-exports what is here; its
//! `_slate.pyi` stub describes every class and is checked against this module by stubtest.
//! One file per wrapped concept:
//!
//! | file | holds |
//! |---|---|
//! | `board.rs` | `Board` (the SBIPs), `Info` |
//! | `batch.rs` | `Batch` (atomic groups of operations, a context manager) |
//! | `packet.rs` | `Packet`, `Ref`, value conversion between Python and slate |
//! | `clock.rs` | `Clock` (system or manual) |
//! | `watch.rs` | `Watch` (iterator over changes), `Change`, `ChangeItem` |
//! | `events.rs` | `Event`, `Events` (board and plan events) |
//! | `active.rs` | Python callables as active functions, and the `Call` they receive |
//! | `node.rs` | `Node` (a board on the network), `PlanHandle`, `Acks`, `Ack` |
//! | `recording.rs` | `Recording` (an MCAP recording read back), `RecordedPacket`, `RecordedEvent` |
//! | `engine.rs` | `load`, `Plan`, `Loaded`, and the outbox: `Outbox`, `Report`, `PlanMessage` |
//! | `errors.rs` | the exception classes, mirroring the core's error enums; `Diagnostic` |
//! | `stream.rs` | waiting on a subscription with the GIL released |
#![warn(missing_docs)]

mod active;
mod batch;
mod board;
mod clock;
mod engine;
mod errors;
mod events;
mod node;
mod packet;
mod recording;
mod stream;
mod watch;

use pyo3::prelude::*;

/// The native part of the `slate` package.
#[pymodule]
fn _slate(m: &Bound<'_, PyModule>) -> PyResult<()> {
    log_if_asked();
    errors::register(m)?;
    m.add_class::<board::PyBoard>()?;
    m.add_class::<batch::PyBatch>()?;
    m.add_class::<board::Info>()?;
    m.add_class::<packet::PyPacket>()?;
    m.add_class::<packet::Reference>()?;
    m.add_class::<clock::PyClock>()?;
    m.add_class::<watch::PyWatch>()?;
    m.add_class::<watch::Change>()?;
    m.add_class::<watch::PyChangeItem>()?;
    m.add_class::<events::Event>()?;
    m.add_class::<events::Events>()?;
    m.add_class::<active::PyCall>()?;
    m.add_class::<engine::Loaded>()?;
    m.add_class::<engine::Plan>()?;
    m.add_class::<engine::Report>()?;
    m.add_class::<engine::ReportItem>()?;
    m.add_class::<engine::PlanMessage>()?;
    m.add_class::<engine::Outbox>()?;
    m.add_class::<errors::PyDiagnostic>()?;
    m.add_class::<node::PyNode>()?;
    m.add_class::<node::PlanHandle>()?;
    m.add_class::<node::Acks>()?;
    m.add_class::<node::Ack>()?;
    m.add_class::<recording::PyRecording>()?;
    m.add_class::<recording::RecordingIter>()?;
    m.add_class::<recording::RecordedPacket>()?;
    m.add_class::<recording::RecordedEvent>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    let profile = if cfg!(debug_assertions) {
        "debug"
    } else {
        "release"
    };
    m.add("BUILD_PROFILE", profile)?;
    Ok(())
}

/// With `SLATE_LOG` set (a filter like `info` or `warn,slate_ici=debug`), the library's
/// logs go to stderr, as a `slate node`'s do: what its ICI and Zenoh say, for a process
/// that misbehaves. A filter that does not parse is said once on stderr and ignored.
fn log_if_asked() {
    use tracing_subscriber::layer::SubscriberExt;
    use tracing_subscriber::util::SubscriberInitExt;
    let Some(spec) = std::env::var("SLATE_LOG")
        .ok()
        .filter(|s| !s.trim().is_empty())
    else {
        return;
    };
    match spec.parse::<tracing_subscriber::filter::Targets>() {
        Ok(filter) => {
            let fmt = tracing_subscriber::fmt::layer()
                .with_writer(std::io::stderr)
                .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()));
            let _ = tracing_subscriber::registry()
                .with(filter)
                .with(fmt)
                .try_init();
        }
        Err(e) => eprintln!("slate: SLATE_LOG {spec:?} is not a log filter ({e}); no logs"),
    }
}
