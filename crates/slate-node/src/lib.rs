//! A slate node: one module of a robot, ready to run. A [`Node`] is a
//! [`Board`](slate_model::Board), its plan [`Engine`](slate_plans::Engine), its
//! [`Ici`](slate_ici::Ici) over a transport (Zenoh, or the simulator), and its
//! [`PlanCircuits`](slate_ici::PlanCircuits), with the threads that run their timers on
//! the system clock, an event log, and an optional live dashboard.
//!
//! `slate node --config module.toml` runs one from a [`NodeConfig`] (the keys are in
//! `docs/config.md`); Rust code builds one with [`Node::builder`], Python with
//! `slate.Node`. Two nodes on the simulator:
//!
//! ```
//! use std::time::Duration;
//! use slate_ici::{ClassSet, IciConfig, SimNet};
//! use slate_model::Address;
//! use slate_node::Node;
//!
//! const WORLD: &str = "class Vehicle { speed: real = 0.0; }";
//! let net = SimNet::new(1);
//! let start = |address: &str| -> Result<Node, slate_node::Error> {
//!     let address = Address::new(address)?;
//!     Ok(Node::builder(address.clone())
//!         .transport(net.join(&address))
//!         .clock(net.clock())
//!         .ici(IciConfig::default().export(ClassSet::all()))
//!         .source("world.slate", WORLD)
//!         .start()?)
//! };
//! let nav = start("team/r1/nav")?;
//! let base = start("team/base/console")?;
//! net.run_for(Duration::from_millis(500));
//!
//! nav.board().create("Vehicle", "gsr")?;
//! nav.board().write("gsr", "speed", 2.5)?;
//! net.run_for(Duration::from_millis(500));
//! assert_eq!(base.board().read("gsr", "speed")?.value.as_f64(), Some(2.5));
//! nav.close();
//! base.close();
//! # Ok::<(), slate_node::Error>(())
//! ```
//!
//! [`observe`] joins a live Zenoh team as a short-lived observer (the CLI's `get`, `put`,
//! `watch`, `tree`, `ls` and `plan` verbs).
#![warn(missing_docs)]

pub mod authority;
mod config;
mod error;
mod fields;
mod foxglove;
pub mod inspect;
mod monitor;
mod node;
mod observer;
pub mod record;
pub mod state;
pub mod stats;
pub mod team_keys;
mod timers;
mod view;

pub use authority::{PlanSender, WritesFrom};
pub use config::{NodeConfig, SourceFile, class_set, default_ici, parse_toml, read_text};
pub use error::{ConfigError, Error, ObserveError, StartError};
pub use fields::parse_duration;
pub use foxglove::{FoxgloveError, SCENE_TOPIC};
pub use monitor::{Level, NodeEvent};
pub use node::{Node, NodeBuilder, TransportChoice};
pub use observer::{
    OBSERVER_PREFIX, ObserverOptions, OperatorKeys, discover, is_observer, observe,
};
pub use record::{RecordConfig, RecordError, RecordStats};
pub use slate_dashboard::STALE_AFTER_S;
pub use state::{StateConfig, StateError, StateStats};
pub use stats::{ModuleStats, StatsProbe, query_stats};
pub use timers::TICK;
