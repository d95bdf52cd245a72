//! Proximity: range and bearing (relative to the body) to what is within range.
//! Obstacles become `Obstacle` objects, anything small a `Contact` it cannot identify.
//! The tracker associates returns by the physical thing's id (the demo's simplification);
//! it forgets obstacles a few seconds after losing them, contacts later.

use std::collections::BTreeMap;
use std::sync::Arc;

use slate_ici::Rng;
use slate_model::{Board, Update, Value};

use super::{Sbip, driver_rng, measured};
use crate::world::{World, angle, dist, gauss, sub, wrap};

/// How far proximity sees, metres.
pub const PROX_RANGE: f64 = 18.0;
const RANGE_SIGMA: f64 = 0.1;
const BEARING_SIGMA: f64 = 0.01;
/// Seconds after which a lost obstacle is forgotten.
const FORGET_OBSTACLE: f64 = 3.0;
/// Seconds after which a lost contact is forgotten.
const FORGET_CONTACT: f64 = 20.0;

/// The proximity sensor of one robot.
pub struct Prox {
    robot: usize,
    name: String,
    sbip: Sbip,
    rng: Rng,
    /// Object name → when last seen (world time).
    seen: BTreeMap<String, f64>,
    /// Contacts currently in range.
    in_range: BTreeMap<String, bool>,
}

impl Prox {
    /// The driver for robot `robot` (named `name`), writing `board`.
    pub fn new(robot: usize, name: &str, board: Arc<Board>, seed: u64) -> Prox {
        Prox {
            robot,
            name: name.to_owned(),
            sbip: Sbip::new(board),
            rng: driver_rng(seed, robot, 0x5052_4f58),
            seen: BTreeMap::new(),
            in_range: BTreeMap::new(),
        }
    }

    /// One scan.
    pub fn tick(&mut self, world: &World) {
        let now = world.time;
        let body = world.bodies[self.robot].clone();
        for o in &world.obstacles {
            let d = dist(body.pos, o.center);
            if d - o.radius <= PROX_RANGE {
                let rel = wrap(angle(sub(o.center, body.pos)) - body.heading);
                let first = self.seen.insert(o.id.clone(), now).is_none();
                let radius = (o.radius + 0.1 * gauss(&mut self.rng)).max(0.2);
                let extra = [("radius", measured(radius, 0.2, 0.9))];
                self.observe("Obstacle", &o.id, d, rel, if first { &extra } else { &[] });
            }
        }
        for t in &world.targets {
            let name = format!("c_{}", t.id);
            let d = dist(body.pos, t.pos);
            if d <= PROX_RANGE {
                let rel = wrap(angle(sub(t.pos, body.pos)) - body.heading);
                let entered = self.in_range.insert(name.clone(), true) != Some(true);
                let extra = [
                    ("in_range", measured(true, 0.0, 1.0)),
                    ("target", measured(Value::reference(&t.id), 0.0, 0.9)),
                ];
                self.observe("Contact", &name, d, rel, if entered { &extra } else { &[] });
                self.seen.insert(name, now);
            } else if self.in_range.insert(name.clone(), false) == Some(true) {
                self.sbip.write(&name, "in_range", false);
            }
        }
        self.forget(now);
    }

    /// Writes one return; `extra` goes with it (the first return of a track also names
    /// the observer).
    fn observe(&mut self, class: &str, name: &str, range: f64, rel: f64, extra: &[(&str, Update)]) {
        let range = (range + RANGE_SIGMA * gauss(&mut self.rng)).clamp(0.0, 500.0);
        let bearing = wrap(rel + BEARING_SIGMA * gauss(&mut self.rng));
        let mut writes = vec![
            ("range", measured(range, RANGE_SIGMA, 0.9)),
            ("bearing", measured(bearing, BEARING_SIGMA, 0.9)),
        ];
        if !extra.is_empty() {
            let observer = Value::reference(&format!("{}_pose", self.name));
            writes.push(("observer", measured(observer, 0.0, 1.0)));
        }
        writes.extend(extra.iter().cloned());
        self.sbip.write_object(class, name, &writes);
    }

    fn forget(&mut self, now: f64) {
        let stale: Vec<String> = self
            .seen
            .iter()
            .filter(|(name, at)| {
                let limit = if name.starts_with("c_") {
                    FORGET_CONTACT
                } else {
                    FORGET_OBSTACLE
                };
                now - **at > limit
            })
            .map(|(n, _)| n.clone())
            .collect();
        for name in stale {
            self.seen.remove(&name);
            self.in_range.remove(&name);
            self.sbip.delete(&name);
        }
    }
}
