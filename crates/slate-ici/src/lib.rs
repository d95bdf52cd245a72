//! slate's Intelligent Communications Interface (the paper's ICI): keeps the boards of
//! many modules and robots consistent over a [`Transport`], sending as little as it can.
//!
//! An [`Ici`] connects one [`Board`](slate_model::Board) to one transport. It reports
//! what its board writes (through each attribute's report policy: minimum interval,
//! heartbeat, dead-band, accuracy; never losing the last value), only to the peers
//! interested and, between robots, only what the export policy lets out. It applies
//! what it receives through each attribute's merge policy (`latest`, `confident`,
//! `owned`, `fused`), creates and deletes objects as their owners do, catches up with a
//! source's current state after loss or a late join, and makes other modules'
//! liveliness a world-model fact (`Module` objects).
//!
//! [`PlanCircuits`] joins a plan engine to the ICI: a plan sent to another module travels
//! on a virtual circuit whose origin hears every step of its progression (received,
//! accepted or rejected, initiated, triggered, terminated, cancelled, destination lost),
//! and plans' `report` actions go out through [`Ici::report`].
//!
//! The transport trait, its link and message kinds, and [`SimNet`], a deterministic
//! network simulator (virtual time, seeded loss, duplication, reordering, delay,
//! partitions, bandwidth caps, killed nodes) on which whole teams run reproducibly, live
//! in `slate-transport` and are re-exported here. The test suite every transport passes
//! is `slate_transport::conformance`, compiled with that crate's `testing` feature only.
//!
//! ```
//! use std::sync::Arc;
//! use std::time::Duration;
//! use slate_ici::{ClassSet, Ici, IciConfig, SimNet};
//! use slate_model::{Address, AttrDecl, Board, ClassDef, ValueType};
//!
//! let net = SimNet::new(1);
//! let vehicle = ClassDef::new("Vehicle").attr(AttrDecl::new("speed", ValueType::Real));
//! let start = |text: &str| -> Result<(Arc<Board>, Ici), slate_ici::Error> {
//!     let address = Address::new(text)?;
//!     let board = Arc::new(Board::builder().clock(net.clock()).address(address.clone()).build());
//!     board.define(vehicle.clone())?;
//!     let config = IciConfig::default().export(ClassSet::all());
//!     let ici = Ici::new(board.clone(), net.join(&address), config)?;
//!     Ok((board, ici))
//! };
//! let (nav, _nav_ici) = start("team/r1/nav")?;
//! let (base, _base_ici) = start("team/base/console")?;
//! net.run_for(Duration::from_millis(500)); // they meet
//!
//! nav.create("Vehicle", "gsr")?;
//! nav.write("gsr", "speed", 2.5)?;
//! net.run_for(Duration::from_millis(500));
//! assert_eq!(base.read("gsr", "speed")?.value.as_f64(), Some(2.5));
//! # Ok::<(), slate_ici::Error>(())
//! ```
//!
//! The protocol, the simulator's model and the counters are described in `docs/ici.md`.
#![warn(missing_docs)]

mod circuits;
mod error;
mod ici;

pub use circuits::HeldPlan;
pub use circuits::{
    ACK_GAP_GRACE, AddressPattern, CircuitStats, CircuitStatus, LOST_WAIT, MAX_PLAN_TEXT_BYTES,
    MAX_QUEUED_PLANS, MAX_QUEUED_REFUSALS, PatternError, PlanAuthority, PlanCircuits, PlanHandle,
    RefusedPlan, SendPlanError,
};
pub use error::Error;
pub use ici::{
    CatchUpStats, ClassSet, Ici, IciConfig, IciStartError, IciStats, LinkPolicy, LinkReport,
    Listen, Liveliness, LivelinessStats, MODULE_CLASS, MergeStats, PlanHandler, RejectStats,
    ReportStats, SendRawError, TeamProtocol, TeamStats, link_kind, module_class,
    module_object_name,
};
pub use slate_transport::{
    Channel, Flow, Handler, LinkConfig, LinkCounter, LinkKind, LinkStats, MsgKind, Radio, Rng,
    SendError, SimConfig, SimNet, SimStats, SimTransport, Traffic, Transport,
};
