//! Locomotion: the effector. It reads its board — the goal the execution controller set,
//! the pose navigation reports, the obstacles proximity reports (their absolute position
//! derived from both), the speed limit its plans set — and commands the body: towards
//! the goal, around obstacles.

use std::sync::Arc;

use slate_model::Board;

use super::Sbip;
use crate::world::{BODY_RADIUS, MAX_SPEED, P2, World, add, angle, norm, scale, sub, unit, wrap};

/// How far obstacles push, metres from their edge.
const AVOID: f64 = 5.0;
/// Closer than this to the goal, the robot holds.
const ARRIVED: f64 = 1.0;

/// The locomotion effector of one robot.
pub struct Loco {
    robot: usize,
    name: String,
    sbip: Sbip,
    mode: &'static str,
}

impl Loco {
    /// The driver for robot `robot` (named `name`), reading `board`.
    pub fn new(robot: usize, name: &str, board: Arc<Board>) -> Loco {
        Loco {
            robot,
            name: name.to_owned(),
            sbip: Sbip::new(board),
            mode: "",
        }
    }

    /// One control step.
    pub fn tick(&mut self, world: &mut World) {
        let (speed, turn, mode) = self.control().unwrap_or((0.0, 0.0, "holding"));
        world.command(self.robot, speed, turn);
        if mode != self.mode {
            self.mode = mode;
            let sensor = format!("{}_loco", self.name);
            self.sbip.write(&sensor, "mode", mode);
        }
    }

    /// Speed, turn rate and mode, or `None` to hold.
    fn control(&self) -> Option<(f64, f64, &'static str)> {
        let robot = &self.name;
        let phase = self.sbip.text(robot, "phase")?;
        if phase != "patrol" && phase != "return" {
            return None;
        }
        let (goal, _) = self.sbip.point(robot, "goal")?;
        let pose = format!("{robot}_pose");
        let (me, _) = self.sbip.point(&pose, "location")?;
        let heading = self.sbip.real(&pose, "heading")?;
        let to_goal = sub(goal, me);
        let d = norm(to_goal);
        if d < ARRIVED {
            return None;
        }
        let push = self.repulsion(me, to_goal);
        let wanted = add(unit(angle(to_goal)), push);
        let error = wrap(angle(wanted) - heading);
        let limit = self
            .sbip
            .real(&format!("{robot}_loco"), "speed_limit")
            .unwrap_or(MAX_SPEED);
        let speed = limit.min(MAX_SPEED).min(0.8 * d) * error.cos().max(0.0);
        let mode = if norm(push) > 0.05 {
            "avoiding"
        } else {
            "driving"
        };
        Some((speed, 2.0 * error, mode))
    }

    /// Pushes away from the obstacles on the board, with a sideways part towards the
    /// goal so that an obstacle straight ahead is skirted rather than stopped at.
    fn repulsion(&self, me: P2, to_goal: P2) -> P2 {
        let mut push = [0.0, 0.0];
        let Ok(ids) = self.sbip.board.instances("Obstacle") else {
            return push;
        };
        for id in ids {
            let Some(name) = self.sbip.board.name_of(id) else {
                continue;
            };
            let Some((center, _)) = self.sbip.point(&name, "position") else {
                continue;
            };
            let radius = self.sbip.real(&name, "radius").unwrap_or(1.0);
            let away = sub(me, center);
            let gap = norm(away) - radius - BODY_RADIUS;
            if gap < AVOID && norm(away) > 1e-6 {
                let strength = (AVOID - gap.max(0.0)) / AVOID;
                let out = scale(away, 1.0 / norm(away));
                let mut tangent = [-out[1], out[0]];
                if tangent[0] * to_goal[0] + tangent[1] * to_goal[1] < 0.0 {
                    tangent = scale(tangent, -1.0);
                }
                push = add(push, scale(add(scale(out, 1.5), tangent), strength));
            }
        }
        push
    }
}
