//! The operator at the console: lays out each robot's patrol route (Waypoint objects,
//! which the console exports to the team), sets the mission's parameters, and starts it.
//! Everything else the console does is plans (console.slate, mission.slate).
//!
//! With a deck phase the start has two steps: `mission.phase = "ready"` once the modules
//! have met (mission.slate then sends the plans, which wait for `"run"`), and
//! `mission.phase = "run"` at launch, one short report on the mission's link.

use std::sync::Arc;

use slate_model::{Board, Value};

use super::{Sbip, measured};
use crate::world::Layout;

/// When the operator starts the mission (or, with a deck phase, declares it ready),
/// seconds into the run (the modules have met).
pub const START_AT: f64 = 3.0;

/// The operator.
pub struct Operator {
    sbip: Sbip,
    /// How many of [`Self::phases`] are written (at most two).
    written: usize,
    /// Launch, seconds into the run, with a deck phase; `None`: no deck, the mission
    /// runs from [`START_AT`].
    launch_at: Option<f64>,
}

/// A phase the operator writes into `mission.phase`, and when.
struct Phase {
    value: &'static str,
    at: f64,
}

impl Operator {
    /// The operator at the console whose board is `board`.
    pub fn new(board: Arc<Board>) -> Operator {
        Operator {
            sbip: Sbip::new(board),
            written: 0,
            launch_at: None,
        }
    }

    /// A deck phase until `launch` seconds into the run: the mission is declared
    /// `ready` at [`START_AT`] and runs from `launch` (which is after it).
    pub fn deck_until(&mut self, launch: f64) {
        self.launch_at = Some(launch);
    }

    /// The phases to write, in order: `run` at [`START_AT`], or with a deck `ready`
    /// at [`START_AT`] and `run` at launch.
    fn phases(&self) -> Vec<Phase> {
        match self.launch_at {
            None => vec![Phase {
                value: "run",
                at: START_AT,
            }],
            Some(launch) => vec![
                Phase {
                    value: "ready",
                    at: START_AT,
                },
                Phase {
                    value: "run",
                    at: launch,
                },
            ],
        }
    }

    /// Lays out the routes and the mission: `targets` expected, robots called home
    /// `return_after` seconds after the start if they have not found them all.
    pub fn plan(&mut self, layout: &Layout, targets: usize, return_after: f64) {
        for (i, region) in layout.regions.iter().enumerate() {
            for (k, w) in region.waypoints.iter().enumerate() {
                let name = format!("w_{}_{}", region.robot, k + 1);
                let writes = [
                    ("position", measured(w.to_vec(), 0.0, 1.0)),
                    ("order", measured((100 * i + k) as i64, 0.0, 1.0)),
                    (
                        "assignee",
                        measured(Value::reference(&region.robot), 0.0, 1.0),
                    ),
                    ("visited", measured(false, 0.0, 1.0)),
                ];
                self.sbip.write_object("Waypoint", &name, &writes);
            }
        }
        let launch = self.launch_at.unwrap_or(0.0);
        let deadline = self.sbip.board.clock().physical().as_secs_f64() + launch + return_after;
        let mut batch = self.sbip.board.batch();
        batch
            .write("mission", "targets_expected", targets as i64)
            .write("mission", "min_confidence", 0.6)
            .write("mission", "inspect_range", 8.0)
            .write("mission", "deadline", deadline);
        if let Err(e) = batch.commit() {
            tracing::warn!(error = %e, "the operator could not set the mission");
        }
    }

    /// Writes the next phase once it is due (one per call at most).
    pub fn tick(&mut self, now: f64) {
        let phases = self.phases();
        let Some(next) = phases.get(self.written) else {
            return;
        };
        if now >= next.at {
            self.written += 1;
            self.sbip.write("mission", "phase", next.value);
        }
    }
}
