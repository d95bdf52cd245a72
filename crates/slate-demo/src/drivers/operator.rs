//! The operator at the console: lays out each robot's patrol route (Waypoint objects,
//! which the console exports to the team), sets the mission's parameters, and starts it.
//! Everything else the console does is plans (console.slate, mission.slate).

use std::sync::Arc;

use slate_model::{Board, Value};

use super::{Sbip, measured};
use crate::world::Layout;

/// When the operator starts the mission, seconds into the run (the modules have met).
pub const START_AT: f64 = 3.0;

/// The operator.
pub struct Operator {
    sbip: Sbip,
    started: bool,
}

impl Operator {
    /// The operator at the console whose board is `board`.
    pub fn new(board: Arc<Board>) -> Operator {
        Operator {
            sbip: Sbip::new(board),
            started: false,
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
        let deadline = self.sbip.board.clock().physical().as_secs_f64() + return_after;
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

    /// Starts the mission once it is time.
    pub fn tick(&mut self, now: f64) {
        if !self.started && now >= START_AT {
            self.started = true;
            self.sbip.write("mission", "phase", "run");
        }
    }
}
