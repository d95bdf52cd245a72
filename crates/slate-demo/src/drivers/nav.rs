//! Navigation: the pose. An absolute fix every `fix_interval` seconds (the sensor's own
//! board object, which plans may change); between fixes dead reckoning, whose error
//! grows with the distance travelled, and so does the accuracy it reports.

use std::sync::Arc;

use slate_ici::Rng;
use slate_model::Board;

use super::{Sbip, driver_rng, measured};
use crate::world::{P2, World, add, gauss, wrap};

/// Standard deviation of an absolute fix, metres.
const FIX_SIGMA: f64 = 0.3;
/// Dead-reckoning error growth: metres of standard deviation per metre travelled.
const DRIFT_PER_M: f64 = 0.05;
/// Compass noise, radians.
const HEADING_SIGMA: f64 = 0.01;

/// The navigation sensor of one robot.
pub struct Nav {
    pub(crate) robot: usize,
    name: String,
    sbip: Sbip,
    rng: Rng,
    since_fix: f64,
    drift: P2,
    accuracy: f64,
    odometer: f64,
}

impl Nav {
    /// The driver for robot `robot` (named `name`), writing `board`.
    pub fn new(robot: usize, name: &str, board: Arc<Board>, seed: u64) -> Nav {
        Nav {
            robot,
            name: name.to_owned(),
            sbip: Sbip::new(board),
            rng: driver_rng(seed, robot, 0x004e_4156),
            since_fix: f64::INFINITY,
            drift: [0.0, 0.0],
            accuracy: FIX_SIGMA,
            odometer: 0.0,
        }
    }

    /// One measurement, `dt` seconds after the previous one.
    pub fn tick(&mut self, world: &World, dt: f64) {
        let body = &world.bodies[self.robot];
        let sensor = format!("{}_nav", self.name);
        let interval = self.sbip.real(&sensor, "fix_interval").unwrap_or(4.0);
        let moved = (body.odometer - self.odometer).max(0.0);
        self.odometer = body.odometer;
        self.since_fix += dt;
        if self.since_fix >= interval {
            self.since_fix = 0.0;
            self.drift = [
                FIX_SIGMA * gauss(&mut self.rng),
                FIX_SIGMA * gauss(&mut self.rng),
            ];
            self.accuracy = FIX_SIGMA;
        } else if moved > 0.0 {
            let step = DRIFT_PER_M * moved.sqrt();
            self.drift = add(
                self.drift,
                [step * gauss(&mut self.rng), step * gauss(&mut self.rng)],
            );
            self.accuracy += DRIFT_PER_M * moved;
        }
        let location = add(body.pos, self.drift);
        let heading = wrap(body.heading + HEADING_SIGMA * gauss(&mut self.rng));
        let pose = format!("{}_pose", self.name);
        let writes = [
            ("location", measured(location.to_vec(), self.accuracy, 0.95)),
            ("heading", measured(heading, HEADING_SIGMA, 0.95)),
            ("speed", measured(body.speed.min(20.0), 0.05, 0.95)),
        ];
        self.sbip.write_object("Pose", &pose, &writes);
    }
}
