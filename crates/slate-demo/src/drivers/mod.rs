//! The robots' drivers: Rust code that, like a real driver, measures the physical world
//! with noise and writes its own module's board through the SBIPs (sensors), or reads its
//! board and commands the physical world (the locomotion effector). A driver touches its
//! own board and the world, nothing else; modules talk only through boards, ICIs and
//! plans.

mod loco;
mod nav;
mod operator;
mod prox;
mod vision;

use std::sync::Arc;

use slate_ici::Rng;
use slate_model::{Board, Context, NewObject, Packet, Update, Value};

pub use loco::Loco;
pub use nav::Nav;
pub use operator::Operator;
pub use prox::Prox;
pub use vision::Vision;

use crate::world::{P2, World};

/// The seed of one driver's noise: independent of the order drivers run in.
pub(crate) fn driver_rng(seed: u64, robot: usize, salt: u64) -> Rng {
    Rng::new(seed ^ (robot as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ salt)
}

/// One robot's four drivers (the execution controller has none: it is plans only).
pub struct RobotDrivers {
    /// Navigation.
    pub nav: Nav,
    /// Proximity.
    pub prox: Prox,
    /// Vision.
    pub vision: Vision,
    /// Locomotion.
    pub loco: Loco,
}

impl RobotDrivers {
    /// Runs the drivers due at step `step` (the world moves in steps of `dt` seconds).
    pub fn tick(&mut self, world: &mut World, step: u64, dt: f64) {
        // Sensors at 5 Hz, locomotion at 10 Hz; robots are staggered by a step.
        let offset = self.nav.robot as u64;
        if (step + offset).is_multiple_of(2) {
            self.nav.tick(world, 2.0 * dt);
            self.prox.tick(world);
            self.vision.tick(world, 2.0 * dt);
        }
        self.loco.tick(world);
    }
}

/// A board as a driver uses it: reads that tolerate missing data, writes that log
/// (and count) refusals instead of failing the robot.
#[derive(Clone)]
pub(crate) struct Sbip {
    pub board: Arc<Board>,
    pub failures: u64,
}

impl Sbip {
    pub fn new(board: Arc<Board>) -> Self {
        Sbip { board, failures: 0 }
    }

    pub fn packet(&self, object: &str, attr: &str) -> Option<Packet> {
        self.board
            .read(object, attr)
            .ok()
            .filter(|p| !p.value.is_none())
    }

    pub fn real(&self, object: &str, attr: &str) -> Option<f64> {
        self.packet(object, attr)?.value.as_f64()
    }

    pub fn flag(&self, object: &str, attr: &str) -> bool {
        matches!(
            self.packet(object, attr).map(|p| p.value),
            Some(Value::Bool(true))
        )
    }

    pub fn text(&self, object: &str, attr: &str) -> Option<String> {
        match self.packet(object, attr)?.value {
            Value::Str(s) => Some(s.to_string()),
            _ => None,
        }
    }

    /// A vector attribute and its accuracy.
    pub fn point(&self, object: &str, attr: &str) -> Option<(P2, f64)> {
        let p = self.packet(object, attr)?;
        match p.value.as_vector()? {
            [x, y] => Some(([*x, *y], p.accuracy)),
            _ => None,
        }
    }

    pub fn exists(&self, object: &str) -> bool {
        self.board.info(object).is_some()
    }

    /// Writes a batch: creates `object` (class, SURROUNDINGS) if this board lacks it.
    pub fn write_object(&mut self, class: &str, object: &str, writes: &[(&str, Update)]) {
        let mut batch = self.board.batch();
        if !self.exists(object) {
            batch.create_with(NewObject::new(class, object).context(Context::Surroundings));
        }
        for (attr, update) in writes {
            batch.write(object, attr, update.clone());
        }
        if let Err(e) = batch.commit() {
            self.fail(object, &e);
        }
    }

    pub fn write(&mut self, object: &str, attr: &str, update: impl Into<Update>) {
        if let Err(e) = self.board.write(object, attr, update) {
            self.fail(object, &e);
        }
    }

    pub fn delete(&mut self, object: &str) {
        if let Err(e) = self.board.delete(object) {
            self.fail(object, &e);
        }
    }

    fn fail(&mut self, object: &str, e: &dyn std::fmt::Display) {
        self.failures += 1;
        tracing::debug!(board = %self.board.address(), object, error = %e, "driver write refused");
    }
}

/// A measured value: value, accuracy, confidence.
pub(crate) fn measured(value: impl Into<Value>, accuracy: f64, confidence: f64) -> Update {
    Update::new(value)
        .accuracy(accuracy.max(0.0))
        .confidence(confidence.clamp(0.0, 1.0))
}
