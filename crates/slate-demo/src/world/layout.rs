//! The terrain a seed gives: one horizontal strip per robot, each with its home on the
//! west edge, a patrol route eastwards, obstacles and targets.

use slate_ici::Rng;

use super::geometry::{P2, dist, uniform};
use super::{Obstacle, Target};

/// Width of the terrain, metres.
pub const WIDTH: f64 = 120.0;
/// Height of one robot's strip, metres.
pub const STRIP: f64 = 30.0;
/// Obstacles per strip.
const OBSTACLES_PER_STRIP: usize = 3;
/// Targets per strip.
const TARGETS_PER_STRIP: usize = 2;
/// Target speed, m/s.
const TARGET_SPEED: f64 = 0.25;
/// How far a target wanders from where it started, metres.
const TARGET_ROAM: f64 = 5.0;

/// One robot's region: where it starts and the route the operator gives it.
#[derive(Clone, Debug, PartialEq)]
pub struct Region {
    /// The robot (`r1`, ...).
    pub robot: String,
    /// Its home.
    pub home: P2,
    /// Its patrol route, in order.
    pub waypoints: Vec<P2>,
}

/// Everything a seed decides before the run.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// `[xmin, ymin, xmax, ymax]`.
    pub bounds: [f64; 4],
    /// One region per robot.
    pub regions: Vec<Region>,
    /// Obstacles.
    pub obstacles: Vec<Obstacle>,
    /// Targets.
    pub targets: Vec<Target>,
}

impl Layout {
    /// The layout for `robots` robots from `seed`.
    pub fn generate(seed: u64, robots: usize) -> Layout {
        let mut rng = Rng::new(seed);
        let regions: Vec<Region> = (0..robots).map(region).collect();
        let mut layout = Layout {
            bounds: [0.0, 0.0, WIDTH, STRIP * robots as f64],
            regions,
            obstacles: Vec::new(),
            targets: Vec::new(),
        };
        for strip in 0..robots {
            for _ in 0..OBSTACLES_PER_STRIP {
                let o = layout.place_obstacle(&mut rng, strip);
                layout.obstacles.push(o);
            }
        }
        for strip in 0..robots {
            for _ in 0..TARGETS_PER_STRIP {
                let t = layout.place_target(&mut rng, strip);
                layout.targets.push(t);
            }
        }
        layout
    }

    fn place_obstacle(&self, rng: &mut Rng, strip: usize) -> Obstacle {
        let y0 = strip as f64 * STRIP;
        let mut candidate = || {
            let radius = uniform(rng, 1.5, 3.5);
            let center = [
                uniform(rng, 20.0, 112.0),
                y0 + uniform(rng, 5.0, STRIP - 5.0),
            ];
            (center, radius)
        };
        let (center, radius) = retry(&mut candidate, |(c, r)| {
            self.clear_of_route(*c, r + 5.0)
                && self
                    .obstacles
                    .iter()
                    .all(|o| dist(o.center, *c) > o.radius + r + 4.0)
        });
        Obstacle {
            id: format!("o{}", self.obstacles.len() + 1),
            center,
            radius,
        }
    }

    fn place_target(&self, rng: &mut Rng, strip: usize) -> Target {
        let y0 = strip as f64 * STRIP;
        let mut candidate = || {
            [
                uniform(rng, 36.0, 110.0),
                y0 + uniform(rng, 6.0, STRIP - 6.0),
            ]
        };
        let pos = retry(&mut candidate, |p| {
            self.obstacles
                .iter()
                .all(|o| dist(o.center, *p) > o.radius + TARGET_ROAM + 2.0)
                && self.targets.iter().all(|t| dist(t.pos, *p) > 15.0)
        });
        Target {
            id: format!("t{}", self.targets.len() + 1),
            pos,
            heading: uniform(rng, -std::f64::consts::PI, std::f64::consts::PI),
            speed: TARGET_SPEED,
            anchor: pos,
            roam: TARGET_ROAM,
        }
    }

    fn clear_of_route(&self, p: P2, margin: f64) -> bool {
        self.regions
            .iter()
            .all(|r| dist(r.home, p) > margin && r.waypoints.iter().all(|w| dist(*w, p) > margin))
    }
}

/// Robot `i`'s strip: home on the west edge, a zig-zag route eastwards.
fn region(i: usize) -> Region {
    let yc = STRIP * (i as f64 + 0.5);
    let zig = STRIP / 4.0;
    Region {
        robot: format!("r{}", i + 1),
        home: [6.0, yc],
        waypoints: vec![
            [28.0, yc - zig],
            [52.0, yc + zig],
            [76.0, yc - zig],
            [100.0, yc + zig],
            [113.0, yc],
        ],
    }
}

/// Draws candidates until one is acceptable (or returns the last of 500 tries: a crowded
/// layout is still a layout).
fn retry<T>(draw: &mut impl FnMut() -> T, ok: impl Fn(&T) -> bool) -> T {
    let mut c = draw();
    for _ in 0..500 {
        if ok(&c) {
            break;
        }
        c = draw();
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_seed_gives_one_layout() {
        assert_eq!(Layout::generate(7, 3), Layout::generate(7, 3));
        assert_ne!(Layout::generate(7, 3), Layout::generate(8, 3));
    }

    #[test]
    fn every_strip_has_its_robot_obstacles_and_targets() {
        let l = Layout::generate(11, 4);
        assert_eq!(l.regions.len(), 4);
        assert_eq!(l.obstacles.len(), 4 * OBSTACLES_PER_STRIP);
        assert_eq!(l.targets.len(), 4 * TARGETS_PER_STRIP);
        assert_eq!(l.bounds, [0.0, 0.0, WIDTH, 4.0 * STRIP]);
        for o in &l.obstacles {
            for r in &l.regions {
                assert!(
                    r.waypoints
                        .iter()
                        .all(|w| dist(*w, o.center) > o.radius + 2.0)
                );
            }
        }
    }
}
