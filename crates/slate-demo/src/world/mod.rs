//! The physical world the robots live in: terrain bounds, obstacles, targets that move,
//! and the robots' bodies. It is the only thing modules share besides the network, and
//! only the simulator's step, the sensors (reading it, with noise) and the locomotion
//! effector (commanding a body) touch it, as real hardware would.

mod geometry;
mod layout;

pub use geometry::{P2, add, angle, dist, gauss, norm, scale, sub, uniform, unit, wrap};
pub use layout::{Layout, Region, STRIP, WIDTH};

use slate_ici::Rng;

/// Robot body radius, metres.
pub const BODY_RADIUS: f64 = 0.6;
/// Top speed of a body, m/s.
pub const MAX_SPEED: f64 = 3.0;
/// Top turn rate of a body, rad/s.
pub const MAX_TURN: f64 = 1.5;

/// An obstacle: a disc.
#[derive(Clone, Debug, PartialEq)]
pub struct Obstacle {
    /// Stable id (`o1`, `o2`, ...): what the proximity sensor's tracker associates by.
    pub id: String,
    /// Centre.
    pub center: P2,
    /// Radius, metres.
    pub radius: f64,
}

/// A target: wanders slowly around where it started.
#[derive(Clone, Debug, PartialEq)]
pub struct Target {
    /// Stable id (`t1`, `t2`, ...).
    pub id: String,
    /// Where it is.
    pub pos: P2,
    /// Where it is heading (radians).
    pub heading: f64,
    /// Its speed, m/s.
    pub speed: f64,
    /// Where it started; it stays within `roam` of it.
    pub anchor: P2,
    /// How far it wanders, metres.
    pub roam: f64,
}

/// A robot's body: where it truly is, and the command its locomotion gave it.
#[derive(Clone, Debug, PartialEq)]
pub struct Body {
    /// The robot's name (`r1`, ...).
    pub name: String,
    /// True position.
    pub pos: P2,
    /// True heading (radians).
    pub heading: f64,
    /// True speed, m/s.
    pub speed: f64,
    /// Distance travelled, metres (the odometer dead reckoning integrates).
    pub odometer: f64,
    /// Commanded speed and turn rate.
    pub command: (f64, f64),
    /// False once the robot is dead: it stops where it is.
    pub powered: bool,
}

/// The world.
#[derive(Clone, Debug)]
pub struct World {
    /// `[xmin, ymin, xmax, ymax]`, metres.
    pub bounds: [f64; 4],
    /// Obstacles (static).
    pub obstacles: Vec<Obstacle>,
    /// Targets (moving).
    pub targets: Vec<Target>,
    /// Robot bodies, in robot order.
    pub bodies: Vec<Body>,
    /// Seconds since the start.
    pub time: f64,
    rng: Rng,
}

impl World {
    /// The world of `layout`, its motion drawn from `seed`.
    pub fn new(layout: &Layout, seed: u64) -> World {
        World {
            bounds: layout.bounds,
            obstacles: layout.obstacles.clone(),
            targets: layout.targets.clone(),
            bodies: layout
                .regions
                .iter()
                .map(|r| Body {
                    name: r.robot.clone(),
                    pos: r.home,
                    heading: 0.0,
                    speed: 0.0,
                    odometer: 0.0,
                    command: (0.0, 0.0),
                    powered: true,
                })
                .collect(),
            time: 0.0,
            rng: Rng::new(seed ^ 0x0057_0521_d000),
        }
    }

    /// Moves everything by `dt` seconds.
    pub fn step(&mut self, dt: f64) {
        self.time += dt;
        for i in 0..self.targets.len() {
            self.move_target(i, dt);
        }
        for i in 0..self.bodies.len() {
            self.move_body(i, dt);
        }
    }

    /// The locomotion effector's command: speed (m/s) and turn rate (rad/s), clamped to
    /// what the body can do.
    pub fn command(&mut self, robot: usize, speed: f64, turn: f64) {
        if let Some(b) = self.bodies.get_mut(robot) {
            b.command = (speed.clamp(0.0, MAX_SPEED), turn.clamp(-MAX_TURN, MAX_TURN));
        }
    }

    /// The robot dies: it stops and never moves again.
    pub fn power_off(&mut self, robot: usize) {
        if let Some(b) = self.bodies.get_mut(robot) {
            b.powered = false;
            b.command = (0.0, 0.0);
            b.speed = 0.0;
        }
    }

    fn move_body(&mut self, i: usize, dt: f64) {
        let b = &self.bodies[i];
        if !b.powered {
            return;
        }
        let (v, w) = b.command;
        let heading = wrap(b.heading + w * dt);
        let before = b.pos;
        let next = add(b.pos, scale(unit(heading), v * dt));
        let next = clamp_to(self.clear_of_obstacles(next, BODY_RADIUS), self.bounds);
        let b = &mut self.bodies[i];
        b.heading = heading;
        b.pos = next;
        b.speed = dist(before, b.pos) / dt;
        b.odometer += dist(before, b.pos);
    }

    fn move_target(&mut self, i: usize, dt: f64) {
        let turn = 0.6 * gauss(&mut self.rng) * dt.sqrt();
        let t = &mut self.targets[i];
        let home = sub(t.anchor, t.pos);
        t.heading = if norm(home) > t.roam {
            angle(home)
        } else {
            wrap(t.heading + turn)
        };
        let next = add(t.pos, scale(unit(t.heading), t.speed * dt));
        let next = self.clear_of_obstacles(next, 0.5);
        self.targets[i].pos = clamp_to(next, self.bounds);
    }

    /// `p` pushed out of every obstacle it would overlap (a body of radius `r`).
    fn clear_of_obstacles(&self, mut p: P2, r: f64) -> P2 {
        for o in &self.obstacles {
            let d = sub(p, o.center);
            let gap = o.radius + r;
            let n = norm(d);
            if n < gap {
                let dir = if n > 1e-9 {
                    scale(d, 1.0 / n)
                } else {
                    [1.0, 0.0]
                };
                p = add(o.center, scale(dir, gap));
            }
        }
        p
    }
}

fn clamp_to(p: P2, b: [f64; 4]) -> P2 {
    [p[0].clamp(b[0], b[2]), p[1].clamp(b[1], b[3])]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_commanded_body_moves_and_never_enters_an_obstacle() {
        let layout = Layout::generate(5, 3);
        let mut world = World::new(&layout, 5);
        for _ in 0..600 {
            world.command(0, MAX_SPEED, 0.05);
            world.step(0.1);
            for o in &world.obstacles {
                assert!(dist(world.bodies[0].pos, o.center) >= o.radius + BODY_RADIUS - 1e-6);
            }
        }
        assert!(world.bodies[0].odometer > 30.0);
    }

    #[test]
    fn targets_stay_near_where_they_started() {
        let layout = Layout::generate(9, 3);
        let mut world = World::new(&layout, 9);
        for _ in 0..3000 {
            world.step(0.1);
        }
        for t in &world.targets {
            assert!(dist(t.pos, t.anchor) < t.roam + 8.0, "{t:?}");
        }
    }

    #[test]
    fn a_dead_robot_stays_where_it_died() {
        let layout = Layout::generate(1, 2);
        let mut world = World::new(&layout, 1);
        world.command(1, 2.0, 0.0);
        world.step(1.0);
        world.power_off(1);
        let at = world.bodies[1].pos;
        world.command(1, 2.0, 0.0);
        world.step(1.0);
        assert_eq!(world.bodies[1].pos, at);
    }
}
