//! How slate's ICI reaches other modules, whatever carries the bytes: the [`Transport`]
//! trait (whose doc is its contract), the [`Handler`] it delivers to, the kinds of links
//! ([`LinkKind`]) and messages ([`MsgKind`]) it routes by, and its counters
//! ([`LinkStats`], [`Traffic`]).
//!
//! [`SimNet`] is a deterministic network simulator (virtual time, seeded loss,
//! duplication, reordering, delay, partitions, bandwidth caps, killed nodes) whose
//! endpoints implement the trait, so whole teams run reproducibly. The test suite every
//! transport passes is the `conformance` module, compiled with the `testing` feature
//! only.
//!
//! The crate depends on `slate-model` (addresses, the clock) and `slate-wire` (message
//! kinds, the size limit) only, so a transport implementation (`slate-zenoh`) does not
//! compile the ICI or the plan engine. `slate-ici` re-exports every public name.
//!
//! ```
//! use std::sync::{Arc, Mutex};
//! use std::time::Duration;
//! use slate_model::Address;
//! use slate_transport::{Handler, LinkKind, MsgKind, SimNet, Transport};
//!
//! /// Keeps what arrives.
//! #[derive(Default)]
//! struct Received(Mutex<Vec<Vec<u8>>>);
//!
//! impl Handler for Received {
//!     fn message(&self, _from: &Address, payload: &[u8]) {
//!         self.0.lock().unwrap().push(payload.to_vec());
//!     }
//!     fn peer(&self, _peer: &Address, _up: bool) {}
//! }
//!
//! let net = SimNet::new(1);
//! let nav = net.join(&Address::new("team/r1/nav")?);
//! let camera = net.join(&Address::new("team/r1/camera")?);
//! let received = Arc::new(Received::default());
//! camera.set_handler(received.clone());
//! net.run_for(Duration::from_millis(100)); // liveliness: they see each other
//!
//! nav.publish(LinkKind::Robot, MsgKind::Report, b"hello")?;
//! net.run_for(Duration::from_millis(100));
//! assert_eq!(received.0.lock().unwrap().len(), 1);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The transport's semantics and the simulator's model are described in `docs/ici.md`.
#![warn(missing_docs)]

#[cfg(feature = "testing")]
pub mod conformance;
mod sim;
#[cfg(feature = "testing")]
pub mod tap;
mod transport;

pub use sim::{
    Channel, LinkConfig, LinkCounter, Radio, Rng, SimConfig, SimNet, SimStats, SimTransport,
};
pub use transport::{Flow, Handler, LinkKind, LinkStats, MsgKind, SendError, Traffic, Transport};
