//! Watching the run from outside, the way a test harness or a logger would: it reads the
//! boards (never writes them) and the world's ground truth, and turns what changed into
//! events, investigations, and the fault's detection and recovery. Nothing here takes
//! part in the mission.

use std::collections::{BTreeMap, BTreeSet};

use slate_dashboard::Level;
use slate_model::{Board, Value};
use slate_wire::PlanStep;

use crate::module::Role;
use crate::team::Team;
use crate::world::{World, dist};

/// Something that happened, at world time `t`.
#[derive(Clone, Debug, PartialEq)]
pub struct Event {
    /// Seconds into the run.
    pub t: f64,
    /// How much it matters.
    pub level: Level,
    /// A detail: shown on the dashboard, not in the progress output.
    pub detail: bool,
    /// What happened.
    pub text: String,
}

/// A robot that investigated a target (it held the claim and came within inspection
/// range of the target's true position).
#[derive(Clone, Debug, PartialEq)]
pub struct Investigation {
    /// The target.
    pub target: String,
    /// The robot.
    pub robot: String,
    /// When it came within range.
    pub at: f64,
}

/// The fault and what the team made of it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Fault {
    /// The robot that died.
    pub robot: String,
    /// When.
    pub at: f64,
    /// When every surviving execution controller and the console held it dead.
    pub detected: Option<f64>,
    /// When none of its unfinished work (targets claimed, waypoints assigned) was left
    /// with it on the console's board.
    pub recovered: Option<f64>,
    /// What the others took over.
    pub taken_over: Vec<String>,
}

/// A robot holding a target's claim this close to its true position is investigating
/// it, metres (the mission's inspection range plus what the estimates may be off by).
const INSPECT: f64 = 10.0;

/// The observer.
#[derive(Default)]
pub struct Observer {
    /// Every event so far.
    pub events: Vec<Event>,
    /// Every investigation, in order.
    pub investigations: Vec<Investigation>,
    /// The fault, once it happened.
    pub fault: Option<Fault>,
    /// When each target was found, and by whom.
    pub found: BTreeMap<String, (String, f64)>,
    seen: BTreeMap<String, String>,
    obstacles: BTreeSet<(usize, String)>,
    steps: BTreeMap<(String, u64), usize>,
}

impl Observer {
    /// Notes the fault.
    pub fn killed(&mut self, robot: &str, t: f64) {
        self.fault = Some(Fault {
            robot: robot.to_owned(),
            at: t,
            ..Fault::default()
        });
        self.push(
            t,
            Level::Error,
            format!("{robot} dies: all five of its modules go silent"),
        );
    }

    /// Looks at everything once, at world time `t`.
    pub fn observe(&mut self, team: &Team, world: &World) {
        let t = world.time;
        let console = team.console().node.board();
        self.targets(console, t);
        self.waypoints(console, t);
        self.robots(team, t);
        self.mission(console, t);
        for i in 0..team.robots.len() {
            if !team.dead[i] {
                self.sensors(team, i, world, t);
                self.investigate(team, i, world, t);
            }
        }
        self.circuits(team, t);
        self.fault_progress(team, t);
    }

    fn push(&mut self, t: f64, level: Level, text: String) {
        let detail = false;
        self.events.push(Event {
            t,
            level,
            detail,
            text,
        });
    }

    /// An event for the dashboard only, not the progress output.
    fn push_detail(&mut self, t: f64, text: String) {
        let (level, detail) = (Level::Info, true);
        self.events.push(Event {
            t,
            level,
            detail,
            text,
        });
    }

    /// Remembers `value` under `key`; returns the previous value if it changed.
    fn changed(&mut self, key: String, value: String) -> Option<Option<String>> {
        match self.seen.insert(key, value.clone()) {
            Some(old) if old == value => None,
            old => Some(old),
        }
    }

    fn mission(&mut self, console: &Board, t: f64) {
        let phase = text(console, "mission", "phase");
        if let Some(Some(_)) | Some(None) = self.changed("mission".into(), phase.clone()) {
            let what = match phase.as_str() {
                "ready" => {
                    "on deck: the operator declares the mission ready; the console sends the mission plans"
                }
                "run" => "the operator starts the mission: patrol, investigate, return",
                "return" => "the console calls everybody home",
                "complete" => "mission complete: every robot alive is home",
                _ => return,
            };
            self.push(t, Level::Info, format!("mission: {what}"));
        }
    }

    fn robots(&mut self, team: &Team, t: f64) {
        let console = team.console().node.board();
        for r in &team.robots {
            let phase = text(console, r, "phase");
            if let Some(Some(_)) = self.changed(format!("{r}.phase"), phase.clone()) {
                self.push_detail(t, format!("{r}: {phase} (console's view)"));
            }
            let alive = read(console, r, "alive").map(|v| v == Value::Bool(true));
            let flipped = self.changed(format!("{r}.alive"), format!("{alive:?}"));
            if matches!(flipped, Some(Some(_))) && alive == Some(false) {
                let text = format!(
                    "console: {r} is dead (its execution controller's Module object went \
                     alive = false)"
                );
                self.push(t, Level::Warn, text);
            }
        }
    }

    fn targets(&mut self, console: &Board, t: f64) {
        for name in instances(console, "Target") {
            let identity = console.read(&name, "identity").ok();
            let confidence = identity.as_ref().map_or(0.0, |p| p.confidence);
            let source = identity
                .map(|p| short(&p.source.to_string()))
                .unwrap_or_default();
            let located = point(console, &name, "location").is_some();
            if located && self.changed(format!("{name}.exists"), "yes".into()) == Some(None) {
                let at = point_text(console, &name, "location");
                self.push(
                    t,
                    Level::Info,
                    format!("{source} identifies {name} at {at} (confidence {confidence:.2}); the console hears it"),
                );
            }
            self.claims(console, &name, t);
            let found = text(console, &name, "found_by");
            if !found.is_empty()
                && self
                    .changed(format!("{name}.found"), found.clone())
                    .is_some()
            {
                self.found.insert(name.clone(), (found.clone(), t));
                self.push(
                    t,
                    Level::Info,
                    format!("{found} found {name}: inspected within range, identity confidence {confidence:.2}"),
                );
            }
        }
    }

    fn claims(&mut self, console: &Board, target: &str, t: f64) {
        let claimant = reference(console, target, "claimant");
        let Some(previous) = self.changed(format!("{target}.claim"), claimant.clone()) else {
            return;
        };
        let previous = previous.unwrap_or_default();
        if claimant.is_empty() {
            return;
        }
        if previous.is_empty() {
            let text = format!("{claimant} claims {target} (Target.claimant, merged latest)");
            self.push(t, Level::Info, text);
        } else if is_alive(console, &previous) {
            let text = format!(
                "{previous} and {claimant} both claimed {target}: the later claim wins on every \
                 board, {previous} yields"
            );
            self.push(t, Level::Warn, text);
        } else {
            self.took_over(format!("{target} ({previous} → {claimant})"));
            let text = format!("{claimant} takes over {target} from {previous}, who is dead");
            self.push(t, Level::Warn, text);
        }
    }

    fn waypoints(&mut self, console: &Board, t: f64) {
        for name in instances(console, "Waypoint") {
            let assignee = reference(console, &name, "assignee");
            if let Some(Some(previous)) = self.changed(format!("{name}.assignee"), assignee.clone())
            {
                self.took_over(format!("{name} ({previous} → {assignee})"));
                self.push(
                    t,
                    Level::Warn,
                    format!("{assignee} takes over waypoint {name} from {previous}"),
                );
            }
        }
    }

    fn took_over(&mut self, what: String) {
        if let Some(f) = &mut self.fault {
            f.taken_over.push(what);
        }
    }

    /// The robot's sensors: hand-offs, narrowed searches, obstacles placed.
    fn sensors(&mut self, team: &Team, i: usize, world: &World, t: f64) {
        let r = &team.robots[i];
        let prox = team.module(i, Role::Prox).node.board();
        for c in instances(prox, "Contact") {
            if flag(prox, &c, "handed_off")
                && self
                    .changed(format!("{r}.{c}.handoff"), "yes".into())
                    .is_some()
            {
                let at = point_text(prox, &c, "position");
                self.push(t, Level::Info, format!(
                    "{r}/prox hands {c} to vision: out of proximity range, unidentified, last at {at}"
                ));
            }
        }
        let vision = team.module(i, Role::Vision).node.board();
        let mode = text(vision, &format!("{r}_vision"), "mode");
        let switched = self.changed(format!("{r}.vision.mode"), mode.clone());
        if matches!(switched, Some(Some(_))) && mode == "cued" {
            let at = point_text(vision, &format!("{r}_vision"), "search_at");
            self.push(
                t,
                Level::Info,
                format!(
                    "{r}/vision narrows its search to {at}, from proximity's range and bearing"
                ),
            );
        }
        let loco = team.module(i, Role::Loco).node.board();
        for o in instances(loco, "Obstacle") {
            if self.obstacles.insert((i, o.clone())) {
                let truth = world.obstacles.iter().find(|x| x.id == o).map(|x| x.center);
                let error = truth
                    .zip(point(loco, &o, "position"))
                    .map_or(String::new(), |(a, (b, _))| {
                        format!(", {:.1} m from the truth", dist(a, b))
                    });
                self.push_detail(
                    t,
                    format!(
                        "{r}/loco sees {o} at {} (derived: navigation + proximity{error})",
                        point_text(loco, &o, "position")
                    ),
                );
            }
        }
    }

    /// Counts an investigation when the robot holds a target and is near its true position.
    fn investigate(&mut self, team: &Team, i: usize, world: &World, t: f64) {
        let r = &team.robots[i];
        let exec = team.module(i, Role::Exec).node.board();
        if !flag(exec, r, "busy") {
            return;
        }
        let task = reference(exec, r, "task");
        let Some(target) = world.targets.iter().find(|x| x.id == task) else {
            return;
        };
        let near = dist(world.bodies[i].pos, target.pos) < INSPECT;
        let known = self
            .investigations
            .iter()
            .any(|x| x.target == task && x.robot == *r);
        if near && !known {
            self.investigations.push(Investigation {
                target: task.clone(),
                robot: r.clone(),
                at: t,
            });
        }
    }

    /// Investigations of one target by two robots while both were alive.
    pub fn duplicates(&self) -> Vec<(String, String, String)> {
        let dead_at = self.fault.as_ref().map(|f| (f.robot.clone(), f.at));
        let mut out = Vec::new();
        for (k, a) in self.investigations.iter().enumerate() {
            for b in &self.investigations[k + 1..] {
                let a_dead = dead_at
                    .as_ref()
                    .is_some_and(|(r, at)| *r == a.robot && *at <= b.at);
                if a.target == b.target && a.robot != b.robot && !a_dead {
                    out.push((a.target.clone(), a.robot.clone(), b.robot.clone()));
                }
            }
        }
        out
    }

    /// New acknowledgements on the circuits of the modules alive: acceptances (detail),
    /// rejections, lost destinations (one line per destination).
    fn circuits(&mut self, team: &Team, t: f64) {
        for m in team.alive_modules() {
            let mut lost: BTreeMap<String, Vec<String>> = BTreeMap::new();
            for c in m.node.circuits().sent() {
                let key = (m.address().to_string(), c.circuit);
                let before = self.steps.insert(key, c.steps.len()).unwrap_or(0);
                for step in c.steps.iter().skip(before) {
                    let route = format!(
                        "{} → {}",
                        short(m.address().as_str()),
                        short(c.peer.as_str())
                    );
                    match step {
                        PlanStep::Accepted => {
                            self.push_detail(t, format!("{route}: plan {} accepted", c.name));
                        }
                        PlanStep::Rejected { reason } => {
                            self.push(
                                t,
                                Level::Error,
                                format!("{route}: plan {} rejected: {reason}", c.name),
                            );
                        }
                        PlanStep::DestinationLost => {
                            lost.entry(route).or_default().push(c.name.clone());
                        }
                        _ => {}
                    }
                }
            }
            for (route, plans) in lost {
                let text = format!("{route}: destination lost (plans {})", plans.join(", "));
                self.push(t, Level::Warn, text);
            }
        }
    }

    /// Detection: every survivor's execution controller and the console hold the dead
    /// robot dead. Recovery: the console's board leaves it nothing unfinished.
    fn fault_progress(&mut self, team: &Team, t: f64) {
        let Some(fault) = self.fault.clone() else {
            return;
        };
        let dead = fault.robot.as_str();
        if fault.detected.is_none() {
            let mut boards = vec![team.console().node.board()];
            for i in (0..team.robots.len()).filter(|i| !team.dead[*i]) {
                boards.push(team.module(i, Role::Exec).node.board());
            }
            if boards
                .iter()
                .all(|b| read(b, dead, "alive") == Some(Value::Bool(false)))
            {
                if let Some(f) = self.fault.as_mut() {
                    f.detected = Some(t);
                }
                self.push(
                    t,
                    Level::Warn,
                    format!(
                        "every survivor now holds {dead} dead ({:.1} s after it died)",
                        t - fault.at
                    ),
                );
            }
        }
        if fault.detected.is_some()
            && fault.recovered.is_none()
            && !holds_work(team.console().node.board(), dead)
        {
            if let Some(f) = self.fault.as_mut() {
                f.recovered = Some(t);
            }
            self.push(t, Level::Info, format!(
                "recovered: nothing of {dead}'s unfinished work is left with it ({:.1} s after it died)",
                t - fault.at
            ));
        }
    }
}

/// Does `robot` still hold a target not found, or (while the patrol goes on) a waypoint
/// not visited?
fn holds_work(console: &Board, robot: &str) -> bool {
    let targets = instances(console, "Target").into_iter().any(|t| {
        reference(console, &t, "claimant") == robot && text(console, &t, "found_by").is_empty()
    });
    let patrolling = text(console, "mission", "phase") == "run";
    let waypoints = instances(console, "Waypoint")
        .into_iter()
        .any(|w| reference(console, &w, "assignee") == robot && !flag(console, &w, "visited"));
    targets || (patrolling && waypoints)
}

fn is_alive(board: &Board, robot: &str) -> bool {
    read(board, robot, "alive") != Some(Value::Bool(false))
}

pub(crate) fn instances(board: &Board, class: &str) -> Vec<String> {
    board
        .instances(class)
        .unwrap_or_default()
        .into_iter()
        .filter_map(|id| board.name_of(id).map(|n| n.to_string()))
        .collect()
}

pub(crate) fn read(board: &Board, object: &str, attr: &str) -> Option<Value> {
    board.read(object, attr).ok().map(|p| p.value)
}

pub(crate) fn text(board: &Board, object: &str, attr: &str) -> String {
    match read(board, object, attr) {
        Some(Value::Str(s)) => s.to_string(),
        _ => String::new(),
    }
}

pub(crate) fn reference(board: &Board, object: &str, attr: &str) -> String {
    match read(board, object, attr) {
        Some(Value::Ref(s)) => s.to_string(),
        _ => String::new(),
    }
}

pub(crate) fn flag(board: &Board, object: &str, attr: &str) -> bool {
    read(board, object, attr) == Some(Value::Bool(true))
}

pub(crate) fn point(board: &Board, object: &str, attr: &str) -> Option<([f64; 2], f64)> {
    let p = board.read(object, attr).ok()?;
    match p.value.as_vector()? {
        [x, y] => Some(([*x, *y], p.accuracy)),
        _ => None,
    }
}

fn point_text(board: &Board, object: &str, attr: &str) -> String {
    point(board, object, attr).map_or("(unknown)".into(), |(p, a)| {
        format!("({:.1}, {:.1}) ± {a:.1} m", p[0], p[1])
    })
}

/// `team/r1/vision` → `r1/vision`.
fn short(address: &str) -> String {
    address.strip_prefix("team/").unwrap_or(address).to_owned()
}
