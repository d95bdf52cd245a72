//! A synthetic team that fills every section of the JSON contract, for previews
//! (`examples/fake_team.rs`) and tests. It is choreography, not a simulation: the view is a
//! pure function of time.

use std::f64::consts::TAU;
use std::time::Instant;

use serde_json::{Value, json};

use crate::DashboardSource;

/// The map's extent.
const BOUNDS: [f64; 4] = [0.0, 0.0, 200.0, 120.0];
/// The choreography repeats with this period, in seconds.
const CYCLE: f64 = 90.0;
/// Within each cycle r3 is lost during this interval.
const R3_LOST: (f64, f64) = (40.0, 70.0);

/// Three robots patrolling around obstacles, finding targets, one of them lost and recovered
/// every cycle. `time` is seconds since the source was created.
#[derive(Debug, Clone)]
pub struct SampleTeam {
    start: Instant,
}

impl Default for SampleTeam {
    fn default() -> Self {
        Self::new()
    }
}

impl SampleTeam {
    /// A team whose clock starts now.
    pub fn new() -> Self {
        Self {
            start: Instant::now(),
        }
    }

    /// The view at `t` seconds.
    pub fn at(t: f64) -> Value {
        let robots: Vec<Robot> = (1..=3).map(|n| Robot::at(n, t)).collect();
        let phase = t.rem_euclid(CYCLE);
        json!({
            "title": "slate sample team",
            "time": round(t, 2),
            "status": "running",
            "summary": summary(&robots, phase),
            "map": { "bounds": BOUNDS, "items": items(&robots, phase) },
            "classes": classes(),
            "objects": objects(&robots),
            "plans": plans(phase),
            "links": links(t),
            "events": events(t),
        })
    }
}

impl DashboardSource for SampleTeam {
    fn snapshot(&self) -> Value {
        Self::at(self.start.elapsed().as_secs_f64())
    }
}

/// One robot's pose and health at some time.
struct Robot {
    id: String,
    x: f64,
    y: f64,
    heading: f64,
    speed: f64,
    alive: bool,
    age: f64,
}

impl Robot {
    fn at(n: u32, t: f64) -> Self {
        let phase = t.rem_euclid(CYCLE);
        let lost = n == 3 && (R3_LOST.0..R3_LOST.1).contains(&phase);
        // A lost robot stays where it was last heard of.
        let seen = if lost { t - (phase - R3_LOST.0) } else { t };
        let (x, y, heading) = orbit(n, seen);
        Self {
            id: format!("r{n}"),
            x,
            y,
            heading,
            speed: if lost { 0.0 } else { 2.0 + f64::from(n) * 0.4 },
            alive: !lost,
            age: if lost { t - seen } else { 0.1 * f64::from(n) },
        }
    }
}

/// Each robot loops an ellipse of its own, counter-clockwise; heading follows the tangent.
fn orbit(n: u32, t: f64) -> (f64, f64, f64) {
    let k = f64::from(n);
    let (cx, cy, rx, ry) = (50.0 + 45.0 * (k - 1.0), 60.0, 35.0, 30.0 + 5.0 * k);
    let a = TAU * t / (40.0 + 10.0 * k) + k;
    let (x, y) = (cx + rx * a.cos(), cy + ry * a.sin());
    let heading = (ry * a.cos()).atan2(-rx * a.sin());
    (x, y, heading)
}

fn round(v: f64, digits: i32) -> f64 {
    let scale = 10f64.powi(digits);
    (v * scale).round() / scale
}

fn summary(robots: &[Robot], phase: f64) -> Value {
    json!({
        "robots alive": format!("{}/{}", robots.iter().filter(|r| r.alive).count(), robots.len()),
        "targets found": targets_found(phase),
        "consistency": if robots.iter().all(|r| r.alive) { "converged" } else { "partitioned" },
        "seed": 7,
    })
}

fn targets_found(phase: f64) -> usize {
    [15.0, 35.0, 60.0].iter().filter(|t| phase >= **t).count()
}

fn items(robots: &[Robot], phase: f64) -> Vec<Value> {
    let mut items: Vec<Value> = robots.iter().map(robot_item).collect();
    for (i, (x, y, r)) in [(95.0, 60.0, 9.0), (30.0, 25.0, 5.0), (160.0, 95.0, 7.0)]
        .into_iter()
        .enumerate()
    {
        items.push(
            json!({"id": format!("o{}", i + 1), "kind": "obstacle", "x": x, "y": y,
            "radius": r, "accuracy": 2.0, "confidence": 0.7 + 0.1 * i as f64, "age": 4.0}),
        );
    }
    let finders = ["r1", "r2", "r1"];
    for (i, (x, y)) in [(20.0, 95.0), (120.0, 20.0), (180.0, 40.0)]
        .into_iter()
        .enumerate()
    {
        let found = targets_found(phase) > i;
        items.push(
            json!({"id": format!("t{}", i + 1), "kind": "target", "x": x, "y": y,
            "accuracy": if found { 1.0 } else { 6.0 }, "confidence": if found { 0.95 } else { 0.4 },
            "found_by": if found { finders[i] } else { "" }, "board": "team/base/console"}),
        );
    }
    items.push(json!({"id": "home", "kind": "goal", "label": "home", "x": 100.0, "y": 8.0}));
    items.push(
        json!({"id": "buoy", "kind": "other", "x": 190.0, "y": 112.0, "stale": true,
        "age": 30.0, "confidence": 0.3}),
    );
    items
}

fn robot_item(r: &Robot) -> Value {
    json!({
        "id": r.id, "kind": "robot", "label": r.id, "x": round(r.x, 2), "y": round(r.y, 2),
        "heading": round(r.heading, 3), "accuracy": if r.alive { 1.5 } else { 1.5 + r.age },
        "confidence": if r.alive { 0.9 } else { 0.5 }, "age": round(r.age, 2),
        "stale": !r.alive, "alive": r.alive, "owner": format!("team/{}/nav", r.id),
        "board": "team/base/console",
    })
}

fn classes() -> Value {
    json!([
        {"name": "Thing", "attrs": ["position"]},
        {"name": "Vehicle", "parent": "Thing", "attrs": ["heading", "speed", "battery"]},
        {"name": "Auv", "parent": "Vehicle", "attrs": ["depth"]},
        {"name": "Obstacle", "parent": "Thing", "attrs": ["clearance"]},
        {"name": "Target", "parent": "Thing", "attrs": ["found_by"]},
        {"name": "Plan", "parent": "Thing", "attrs": ["state", "fired"]},
    ])
}

fn objects(robots: &[Robot]) -> Vec<Value> {
    let mut objects = Vec::new();
    for r in robots {
        let source = format!("team/{}/nav", r.id);
        let attr = |name: &str, value: String, accuracy: f64| {
            json!({"name": name, "value": value, "accuracy": accuracy,
                   "confidence": if r.alive { 0.9 } else { 0.4 }, "age": round(r.age, 2),
                   "source": source})
        };
        let attrs = vec![
            attr("position", format!("({:.1}, {:.1})", r.x, r.y), 1.5),
            attr("heading", format!("{:.2}", r.heading), 0.05),
            attr("speed", format!("{:.1}", r.speed), 0.1),
        ];
        for (board, context) in [
            (format!("team/{}/exec", r.id), "self"),
            ("team/base/console".to_owned(), "system"),
        ] {
            objects.push(
                json!({"board": board, "name": r.id, "class": "Auv", "context": context,
                "owner": source, "attrs": attrs}),
            );
        }
    }
    objects.push(
        json!({"board": "team/base/console", "name": "o1", "class": "Obstacle",
        "context": "surroundings", "owner": "team/r1/sonar",
        "attrs": [{"name": "position", "value": "(95.0, 60.0)", "accuracy": 2.0, "confidence": 0.7,
                   "age": 4.0, "source": "team/r1/sonar"}]}),
    );
    objects
}

fn plans(phase: f64) -> Value {
    let takeover = if phase >= R3_LOST.0 + 2.0 {
        "active"
    } else {
        "waiting"
    };
    json!([
        {"board": "team/r1/exec", "name": "patrol", "state": "active", "fired": (phase / 5.0) as u64,
         "origin": "team/base/console", "acks": ["received", "accepted", "initiated", "triggered ok"]},
        {"board": "team/r2/exec", "name": "investigate_t2", "state": if phase >= 35.0 { "terminated" } else { "active" },
         "fired": 1, "origin": "team/base/console", "acks": ["received", "accepted", "initiated"]},
        {"board": "team/r3/exec", "name": "survey_east", "state": if phase >= R3_LOST.0 { "lost" } else { "active" },
         "fired": 3, "last_error": if phase >= R3_LOST.0 { "destination lost" } else { "" },
         "origin": "team/base/console", "acks": ["received", "accepted", "initiated", "triggered ok"]},
        {"board": "team/r1/exec", "name": "take_over_r3", "state": takeover, "fired": 0,
         "origin": "team/base/console", "acks": ["received", "accepted"]},
    ])
}

fn links(t: f64) -> Value {
    let wave = |period: f64| 0.5 + 0.5 * (TAU * t / period).sin();
    json!([
        {"name": "team link", "kind": "team", "bytes_per_s": round(500.0 + 600.0 * wave(17.0), 1),
         "budget_bps": 1200.0, "total_bytes": (t * 780.0) as u64},
        {"name": "r1 LAN", "kind": "robot", "bytes_per_s": round(40_000.0 + 20_000.0 * wave(5.0), 1),
         "budget_bps": 1_000_000.0, "total_bytes": (t * 50_000.0) as u64},
        {"name": "acoustic", "kind": "acoustic", "bytes_per_s": round(60.0 + 40.0 * wave(11.0), 1),
         "budget_bps": 80.0, "total_bytes": (t * 75.0) as u64},
    ])
}

fn events(t: f64) -> Vec<Value> {
    const SCRIPT: [(f64, &str, &str); 7] = [
        (1.0, "info", "team up: r1, r2, r3 joined"),
        (15.0, "info", "t1 found by r1"),
        (35.0, "info", "t2 found by r2; investigate_t2 terminated"),
        (R3_LOST.0, "error", "r3 lost (no heartbeat for 3 s)"),
        (R3_LOST.0 + 2.0, "warn", "r1 takes over survey_east from r3"),
        (60.0, "info", "t3 found by r1"),
        (
            R3_LOST.1,
            "info",
            "r3 rejoined; caught up from current state",
        ),
    ];
    let cycles = (t / CYCLE).floor();
    let mut events = Vec::new();
    for cycle in 0..=(cycles as u64) {
        let base = cycle as f64 * CYCLE;
        for (at, level, text) in SCRIPT {
            if base + at <= t {
                events.push(json!({"t": base + at, "level": level, "text": text}));
            }
        }
    }
    events
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_robots_move_and_time_advances() {
        let (a, b) = (SampleTeam::at(1.0), SampleTeam::at(2.0));
        assert_eq!(a["time"], 1.0);
        assert_eq!(b["time"], 2.0);
        assert_ne!(a["map"]["items"][0]["x"], b["map"]["items"][0]["x"]);
    }

    #[test]
    fn sample_loses_r3_during_each_cycle() {
        let r3 = |t: f64| SampleTeam::at(t)["map"]["items"][2]["alive"].clone();
        assert_eq!(r3(10.0), true);
        assert_eq!(r3(50.0), false);
        assert_eq!(r3(CYCLE + 50.0), false);
        assert_eq!(r3(CYCLE + 75.0), true);
    }
}
