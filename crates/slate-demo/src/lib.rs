//! The slate demo: a team of Ground Surveillance Robots coordinated through distributed
//! blackboards, after Harmon, Aviles & Gage, "A Technique for Coordinating Autonomous
//! Robots" (NOSC, 1986).
//!
//! A seeded 2D world ([`world`]) holds obstacles, slowly moving targets and the robots'
//! bodies. Each robot is five modules, each a board with its own ICI on the network:
//! navigation, proximity, vision, locomotion (Rust drivers that measure the world with
//! noise and write their board, or read it and drive) and an execution controller (plans
//! only). The operator console sends every robot mission plans — patrol a region,
//! investigate the targets identified above a confidence, return — which the execution
//! controllers decompose into sub-plans for their modules. Robots share targets and their
//! claims through the team link, which carries only what their export policies let out.
//! Mid-mission one robot dies; the others see it as a world-model fact and take over.
//!
//! ```no_run
//! use slate_demo::{DemoConfig, run};
//! let summary = run(DemoConfig::default().seed(3), &mut |_progress| {})?;
//! assert_eq!(summary.duplicate_investigations, 0);
//! println!("{}", summary.to_text());
//! # Ok::<(), slate_demo::DemoError>(())
//! ```
//!
//! The `.slate` files are in `examples/demo/`; the design is in `docs/demo.md`.
#![warn(missing_docs)]

mod config;
mod consistency;
pub mod drivers;
mod error;
pub mod files;
mod module;
mod net;
mod observe;
pub mod process;
mod record;
mod run;
mod snapshot;
mod summary;
mod team;
mod traffic;
pub mod world;

pub use config::{
    ACOUSTIC_FRAME_BYTES, ACOUSTIC_FRAME_OVERHEAD, ACOUSTIC_MAX_QUEUE, DECK_BPS, DemoConfig,
    MAX_ROBOTS, MIN_DECK, Placement, Speakers, TeamLink, TeamMedium,
};
pub use consistency::{TEAM_CLASSES, disagreement};
pub use error::DemoError;
pub use module::{Module, Role};
pub use net::NetworkKind;
pub use observe::{Event, Fault, Investigation, Observer};
pub use run::{DT, Demo, Progress, run};
pub use slate_dashboard::Level;
pub use snapshot::snapshot;
pub use summary::{Summary, TargetOutcome, TeamChannel};
pub use team::{BASE, Team};
pub use traffic::LinkRates;
