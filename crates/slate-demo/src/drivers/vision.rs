//! Vision: a camera with a narrow field of view that identifies targets, with a
//! confidence that grows as the robot gets closer (and with a narrower search). It looks
//! where its board says: at the target under investigation (`track_at`, set by a sub-plan
//! of the execution controller), else at what proximity handed over (`search_at`, set by
//! proximity's hand-off plan), else it sweeps around.
//!
//! A target seen becomes a `Sighting` (range and bearing); its absolute position is the
//! sighting's derived `position` (navigation + vision, declared in classes.slate), which
//! the driver reads back and writes as the `Target`'s location for the team.

use std::sync::Arc;

use slate_ici::Rng;
use slate_model::{Board, Value};

use super::{Sbip, driver_rng, measured};
use crate::world::{P2, World, angle, dist, gauss, sub, wrap};

/// How far vision identifies anything, metres.
pub const VISION_RANGE: f64 = 40.0;
/// Width of the sweeping field of view, radians.
const SWEEP_WIDTH: f64 = 0.7;
/// Sweep rate, radians per second.
const SWEEP_RATE: f64 = 0.8;
/// Below this confidence nothing is reported.
const DETECT: f64 = 0.15;
/// From this confidence on, a contact counts as identified.
const IDENTIFIED: f64 = 0.5;

/// Where vision looks this frame.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Aim {
    mode: &'static str,
    /// Bearing relative to the robot's heading.
    bearing: f64,
    /// Field of view.
    width: f64,
}

/// The vision sensor of one robot.
pub struct Vision {
    robot: usize,
    name: String,
    sbip: Sbip,
    rng: Rng,
    sweep: f64,
    mode: &'static str,
}

impl Vision {
    /// The driver for robot `robot` (named `name`), writing `board`.
    pub fn new(robot: usize, name: &str, board: Arc<Board>, seed: u64) -> Vision {
        Vision {
            robot,
            name: name.to_owned(),
            sbip: Sbip::new(board),
            rng: driver_rng(seed, robot, 0x5649_5349),
            sweep: 0.0,
            mode: "",
        }
    }

    /// One frame, `dt` seconds after the previous one.
    pub fn tick(&mut self, world: &World, dt: f64) {
        self.sweep = wrap(self.sweep + SWEEP_RATE * dt);
        let aim = self.aim();
        if aim.mode != self.mode {
            self.mode = aim.mode;
            let sensor = format!("{}_vision", self.name);
            self.sbip.write(&sensor, "mode", aim.mode);
        }
        let body = world.bodies[self.robot].clone();
        for t in &world.targets {
            let d = dist(body.pos, t.pos);
            let rel = wrap(angle(sub(t.pos, body.pos)) - body.heading);
            if d <= VISION_RANGE && wrap(rel - aim.bearing).abs() <= aim.width / 2.0 {
                self.identify(&t.id, d, rel, aim.width);
            }
        }
    }

    /// Decides where to look from the board.
    fn aim(&self) -> Aim {
        let sensor = format!("{}_vision", self.name);
        let pose = format!("{}_pose", self.name);
        let me = self.sbip.point(&pose, "location");
        let heading = self.sbip.real(&pose, "heading").unwrap_or(0.0);
        let toward = |(p, acc): (P2, f64), mode| {
            let (me, _) = me?;
            let d = dist(me, p).max(1.0);
            Some(Aim {
                mode,
                bearing: wrap(angle(sub(p, me)) - heading),
                width: (2.0 * (acc + 1.5).atan2(d)).clamp(0.2, 0.9),
            })
        };
        let tracked = self
            .sbip
            .flag(&sensor, "tracking")
            .then(|| self.sbip.point(&sensor, "track_at"))
            .flatten()
            .and_then(|p| toward(p, "tracking"));
        let cued = self
            .sbip
            .flag(&sensor, "cue_active")
            .then(|| self.sbip.point(&sensor, "search_at"))
            .flatten()
            .and_then(|p| toward(p, "cued"));
        tracked.or(cued).unwrap_or(Aim {
            mode: "sweep",
            bearing: self.sweep,
            width: SWEEP_WIDTH,
        })
    }

    /// Target `id` is in view at range `d`, bearing `rel`, through a field of `width`.
    fn identify(&mut self, id: &str, d: f64, rel: f64, width: f64) {
        let narrow = if width < 0.5 { 0.05 } else { 0.0 };
        let confidence =
            (0.98 - (d - 6.0) / 42.0 + narrow + 0.02 * gauss(&mut self.rng)).clamp(0.05, 0.99);
        if confidence < DETECT {
            return;
        }
        let sighting = format!("s_{id}");
        let range_sigma = 0.2 + 0.03 * d;
        let range = (d + range_sigma * gauss(&mut self.rng)).clamp(0.0, 500.0);
        let bearing = wrap(rel + 0.01 * gauss(&mut self.rng));
        let observer = Value::reference(&format!("{}_pose", self.name));
        let writes = [
            ("observer", measured(observer, 0.0, 1.0)),
            ("range", measured(range, range_sigma, confidence)),
            ("bearing", measured(bearing, 0.01, confidence)),
        ];
        self.sbip.write_object("Sighting", &sighting, &writes);
        // Navigation + vision: the absolute position, derived on this board.
        let Some((location, accuracy)) = self.sbip.point(&sighting, "position") else {
            return;
        };
        let mut writes = vec![(
            "location",
            measured(location.to_vec(), accuracy, confidence),
        )];
        let known = self
            .sbip
            .board
            .read(id, "identity")
            .map_or(0.0, |p| p.confidence);
        if confidence > known + 0.01 {
            writes.push(("identity", measured("target", 0.0, confidence)));
        }
        self.sbip.write_object("Target", id, &writes);
        // Tell proximity its contact is identified (it then never hands it over).
        let contact = format!("c_{id}");
        if confidence >= IDENTIFIED
            && self.sbip.exists(&contact)
            && !self.sbip.flag(&contact, "identified")
        {
            self.sbip.write(&contact, "identified", true);
        }
    }
}
