//! The demo's main loop: the world moves, drivers measure and act, the network runs,
//! the observer watches; then the boards settle and the summary is made.

use std::sync::Arc;
use std::time::{Duration, Instant};

use parking_lot::Mutex;
use serde_json::Value;
use slate_dashboard::Status;
use slate_ici::{LinkKind, MsgKind};
use slate_model::Address;
use slate_wire::PlanStep;

use crate::config::{DemoConfig, TeamLink};
use crate::consistency::Propagation;
use crate::error::DemoError;
use crate::module::Role;
use crate::net::{Network, NetworkKind, Pacer};
use crate::observe::{Event, Observer, text};
use crate::summary::{Summary, TargetOutcome};
use crate::team::Team;
use crate::traffic::{LinkRates, by_kind};
use crate::world::{Layout, World};

/// World step, seconds.
pub const DT: f64 = 0.1;
/// Longest wait for the boards to agree at the end, seconds.
const SETTLE_LIMIT: f64 = 30.0;

/// What a run reports while it goes.
#[derive(Clone, Debug, PartialEq)]
pub enum Progress {
    /// The run started: what it is.
    Started(String),
    /// Something happened.
    Event(Event),
    /// A periodic status line.
    Status(String),
    /// The dashboard is being served here.
    Dashboard(String),
}

/// A running demo.
pub struct Demo {
    /// What it was asked to do.
    pub config: DemoConfig,
    pub(crate) net: Network,
    /// The terrain and routes.
    pub layout: Layout,
    /// The physical world.
    pub world: World,
    /// The modules and drivers.
    pub team: Team,
    /// What the observer saw.
    pub observer: Observer,
    /// What the links carried.
    pub traffic: LinkRates,
    /// How long changes took to reach every board of the team view.
    pub propagation: Propagation,
    step: u64,
    /// Has the mission launched (always, without a deck phase)?
    launched: bool,
    /// Team-link bytes per message kind sent on deck (empty without a deck phase).
    deck_by_kind: std::collections::BTreeMap<slate_ici::MsgKind, u64>,
    fault_done: bool,
    started: Instant,
}

impl Demo {
    /// Sets up the world, the network and every module; nothing has moved yet.
    pub fn start(config: DemoConfig) -> Result<Demo, DemoError> {
        config.validate()?;
        let layout = Layout::generate(config.seed, config.robots);
        let net = match config.network {
            NetworkKind::Sim => Network::sim(config.seed, &first_team_link(&config)),
            NetworkKind::Zenoh if config.secure => {
                Network::secured_zenoh(&team_addresses(&layout))?
            }
            NetworkKind::Zenoh => Network::zenoh(),
            NetworkKind::Processes => Network::processes(&config)?,
        };
        let world = World::new(&layout, config.seed);
        let mut team = Team::start(
            &net,
            &layout,
            config.seed,
            (&config.team_link, config.speakers),
        )?;
        crate::record::start(&team, &config)?;
        let return_after = config.duration.as_secs_f64() * 0.8;
        if config.deck.is_some() {
            team.operator.deck_until(config.launch_seconds());
            team.set_team_link(&TeamLink::deck(&config.team_link));
        }
        if team.drives {
            team.operator
                .plan(&layout, layout.targets.len(), return_after);
        }
        Ok(Demo {
            launched: config.deck.is_none(),
            deck_by_kind: Default::default(),
            traffic: LinkRates::new(config.team_link.budget_bps),
            config,
            net,
            layout,
            world,
            team,
            observer: Observer::default(),
            propagation: Propagation::default(),
            step: 0,
            fault_done: false,
            started: Instant::now(),
        })
    }

    /// World time, seconds.
    pub fn time(&self) -> f64 {
        self.world.time
    }

    /// One step of [`DT`]: the world moves, drivers run, the fault strikes when due, the
    /// network runs for `DT`, the observer looks.
    pub fn step(&mut self) {
        self.world.step(DT);
        self.net.exchange_world(&mut self.world);
        self.maybe_launch();
        self.team.tick(&mut self.world, self.step, DT);
        self.step += 1;
        self.maybe_fault();
        self.advance();
        self.observer.observe(&self.team, &self.world);
        if self.step.is_multiple_of(2) {
            self.propagation.observe(&self.team, self.world.time);
        }
        if self.step.is_multiple_of(10) {
            self.traffic.sample(&self.net, &self.team, self.world.time);
        }
    }

    /// Lets the network run for [`DT`] (on the system clock, Zenoh, each node's timer
    /// thread runs its ICI's and engine's timers; on the simulator the clock runs them).
    fn advance(&self) {
        self.net.advance(Duration::from_secs_f64(DT));
    }

    /// At launch, the deck's radio gives way to the mission's team link, and what the
    /// deck carried is set apart (the operator writes `"run"` in this same step).
    fn maybe_launch(&mut self) {
        if self.launched || self.world.time < self.config.launch_seconds() {
            return;
        }
        self.launched = true;
        self.traffic.sample(&self.net, &self.team, self.world.time);
        self.traffic.launch();
        self.deck_by_kind = by_kind(&self.net, &self.team, LinkKind::Team);
        self.net.set_team_link(&self.config.team_link);
        self.team.set_team_link(&self.config.team_link);
    }

    /// Seconds since launch (world time, the deck phase excluded).
    pub fn mission_time(&self) -> f64 {
        self.world.time - self.config.launch_seconds()
    }

    fn maybe_fault(&mut self) {
        let Some(at) = self.config.fault_at else {
            return;
        };
        if self.fault_done || self.mission_time() < at || self.team.robots.len() < 2 {
            return;
        }
        self.fault_done = true;
        let last = self.team.robots.len() - 1;
        self.team.kill(last, &self.net, &mut self.world);
        let name = self.team.robots[last].clone();
        self.observer.killed(&name, self.world.time);
    }

    /// The console's mission phase.
    pub fn mission_phase(&self) -> String {
        text(self.team.console().node.board(), "mission", "phase")
    }

    /// Is the mission over (complete, or out of time)?
    pub fn done(&self) -> bool {
        self.mission_phase() == "complete"
            || self.mission_time() >= self.config.duration.as_secs_f64()
    }

    /// The simulator's counters, if simulated.
    pub fn net_stats(&self) -> Option<slate_ici::SimStats> {
        self.net.sim_stats()
    }

    /// Ends the run: the drivers stop (nothing changes any more), the network runs until
    /// the team's boards agree, and the summary is made.
    pub fn finish(&mut self) -> Summary {
        let mission_seconds = self.mission_time();
        self.traffic.sample(&self.net, &self.team, self.world.time);
        let (lag, left) = self.settle();
        let recording = crate::record::finish(&self.team, &self.config);
        Summary {
            recording,
            ..self.summary(mission_seconds, lag, left)
        }
    }

    /// Runs the network alone until the boards agree: seconds it took, or the
    /// disagreement left at the limit.
    fn settle(&mut self) -> (Option<f64>, Option<String>) {
        let mut waited = 0.0;
        loop {
            let left = self.propagation.disagreement(&self.team);
            if left.is_none() {
                return (Some(waited), None);
            }
            if waited >= SETTLE_LIMIT {
                return (None, left);
            }
            self.advance();
            waited += DT;
        }
    }

    fn summary(&self, mission_seconds: f64, lag: Option<f64>, left: Option<String>) -> Summary {
        let console = self.team.console().node.board();
        let targets: Vec<TargetOutcome> = self
            .world
            .targets
            .iter()
            .map(|t| TargetOutcome {
                name: t.id.clone(),
                found_by: text(console, &t.id, "found_by"),
                found_at: self.observer.found.get(&t.id).map(|f| f.1),
                investigators: self
                    .observer
                    .investigations
                    .iter()
                    .filter(|i| i.target == t.id)
                    .map(|i| i.robot.clone())
                    .collect(),
            })
            .collect();
        let found = targets.iter().filter(|t| !t.found_by.is_empty()).count();
        let fault = self.observer.fault.as_ref();
        let (sent, accepted, rejected) = self.plan_counts();
        let kinds = |link| names(&by_kind(&self.net, &self.team, link));
        let team_bytes = self.traffic.bytes(LinkKind::Team);
        Summary {
            seed: self.config.seed,
            robots: self.config.robots,
            network: self.config.network.name().to_owned(),
            mission_seconds,
            wall_seconds: self.started.elapsed().as_secs_f64(),
            mission_complete: self.mission_phase() == "complete" && found == targets.len(),
            mission_phase: self.mission_phase(),
            targets_total: targets.len(),
            targets_found: found,
            targets,
            duplicate_investigations: self.observer.duplicates().len(),
            robot_failures: self.team.dead.iter().filter(|d| **d).count(),
            fault: fault.map(|f| (f.robot.clone(), f.at)),
            detection_seconds: fault.and_then(|f| f.detected.map(|d| d - f.at)),
            recovery_seconds: fault.and_then(|f| f.recovered.map(|r| r - f.at)),
            taken_over: fault.map(|f| f.taken_over.clone()).unwrap_or_default(),
            team_link_bytes: team_bytes,
            intra_robot_bytes: self.traffic.bytes(LinkKind::Robot),
            team_link_budget_bps: self.config.team_link.budget_bps,
            team_link_peak_bps: self.traffic.peak_radio_bps.0,
            team_link_peak_radio: self.traffic.peak_radio_bps.1.clone(),
            team_channel_peak_bps: self.traffic.peak_channel_bps,
            team_link_offered_peak_bps: self.traffic.peak_offered_bps,
            team_link_max_backlog_seconds: self.traffic.max_backlog_s,
            team_link_mean_bps: team_bytes.saturating_sub(self.traffic.deck_bytes) as f64 * 8.0
                / mission_seconds.max(1e-9),
            team_bytes_by_kind: kinds(LinkKind::Team),
            intra_bytes_by_kind: kinds(LinkKind::Robot),
            consistency_lag_seconds: lag,
            propagation_changes: self.propagation.delays.len(),
            propagation_median_seconds: self.propagation.quantile(0.5),
            propagation_p95_seconds: self.propagation.quantile(0.95),
            propagation_max_seconds: self.propagation.quantile(1.0),
            disagreement: left,
            plans_sent: sent,
            plans_accepted: accepted,
            plans_rejected: rejected,
            events: self.observer.events.len(),
            team_channel: crate::traffic::team_channel(&self.net, &self.config.team_link),
            deck_seconds: self.config.deck.map(|d| d.as_secs_f64()),
            deck_bytes: self.traffic.deck_bytes,
            deck_bytes_by_kind: names(&self.deck_by_kind),
            team_repair_bytes: self.team_repair_bytes(),
            team_queue_max_seconds: self
                .net
                .module_stats()
                .is_none()
                .then(|| crate::traffic::team_queue_max_seconds(&self.team)),
            recording: None,
        }
    }

    /// Bytes of the team protocol's repairs the modules sent: from their ICIs, or with
    /// module processes from the traffic each module answered.
    fn team_repair_bytes(&self) -> u64 {
        let Some(modules) = self.net.module_stats() else {
            return crate::traffic::team_repair_bytes(&self.team);
        };
        let repair = MsgKind::TeamRepair.name();
        let rows = modules.iter().flat_map(|m| &m.traffic);
        rows.filter(|r| r.link == "team" && r.kind == repair)
            .map(|r| r.sent_bytes)
            .sum()
    }

    /// Plans sent, accepted and rejected: from the senders' circuits, or with module
    /// processes from the counters each module answered (circuits it opened; plans it
    /// accepted or rejected as their destination).
    fn plan_counts(&self) -> (usize, usize, usize) {
        if let Some(modules) = self.net.module_stats() {
            let sum = |f: fn(&slate_node::stats::Plans) -> u64| {
                let total: u64 = modules.iter().map(|m| f(&m.plans)).sum();
                usize::try_from(total).unwrap_or(usize::MAX)
            };
            return (sum(|p| p.sent), sum(|p| p.accepted), sum(|p| p.rejected));
        }
        let circuits: Vec<_> = self
            .team
            .modules
            .iter()
            .flat_map(|m| m.node.circuits().sent())
            .collect();
        let has = |f: &dyn Fn(&PlanStep) -> bool| {
            circuits.iter().filter(|c| c.steps.iter().any(f)).count()
        };
        (
            circuits.len(),
            has(&|s| *s == PlanStep::Accepted),
            has(&|s| matches!(s, PlanStep::Rejected { .. })),
        )
    }

    /// A one-line status.
    pub fn status_line(&self) -> String {
        let console = self.team.console().node.board();
        let found = self.observer.found.len();
        let alive = self.team.dead.iter().filter(|d| !**d).count();
        let team = self.traffic.team_bps();
        format!(
            "mission {} · targets {found}/{} found · robots {alive}/{} alive · team link {:.1} kbit/s (radio peak {:.1} of {:.1}) · {:.1} s wall",
            text(console, "mission", "phase"),
            self.world.targets.len(),
            self.team.robots.len(),
            team / 1000.0,
            self.traffic.peak_radio_bps.0 / 1000.0,
            self.config.team_link.budget_bps as f64 / 1000.0,
            self.started.elapsed().as_secs_f64()
        )
    }

    fn describe(&self) -> String {
        let c = &self.config;
        format!(
            "slate demo: seed {}, {} robots ({} boards each: {}) + the operator console, {} network, team link {} bit/s per radio{}",
            c.seed,
            c.robots,
            Role::ROBOT.len(),
            Role::ROBOT.map(|r| r.name()).join(", "),
            c.network.name(),
            c.team_link.budget_bps,
            match c.network {
                NetworkKind::Sim => format!(", {:.0} % loss", c.team_link.loss * 100.0),
                NetworkKind::Zenoh | NetworkKind::Processes => " (measured, not enforced)".into(),
            }
        )
    }
}

/// Bytes per message kind, by the kinds' names.
/// Every module's address: each robot's, and the console at the base.
fn team_addresses(layout: &Layout) -> Vec<Address> {
    let robots = layout.regions.iter().map(|r| r.robot.as_str());
    let modules = robots.flat_map(|r| Role::ROBOT.map(|role| (r.to_owned(), role)));
    let console = std::iter::once((crate::team::BASE.to_owned(), Role::Console));
    modules
        .chain(console)
        .filter_map(|(robot, role)| Address::new(&format!("team/{robot}/{}", role.name())).ok())
        .collect()
}

fn names(
    by_kind: &std::collections::BTreeMap<slate_ici::MsgKind, u64>,
) -> std::collections::BTreeMap<String, u64> {
    by_kind
        .iter()
        .map(|(k, b)| (k.name().to_owned(), *b))
        .collect()
}

/// The team link the run starts on: the deck's fast clean radio, or the mission's link.
fn first_team_link(config: &DemoConfig) -> crate::config::TeamLink {
    match config.deck {
        Some(_) => crate::config::TeamLink::deck(&config.team_link),
        None => config.team_link.clone(),
    }
}

/// Runs a whole demo: starts it, serves the dashboard if asked, runs the mission until
/// it completes or runs out of time, and returns the summary. `progress` hears what
/// happens as it happens.
pub fn run(config: DemoConfig, progress: &mut dyn FnMut(Progress)) -> Result<Summary, DemoError> {
    let mut demo = Demo::start(config)?;
    progress(Progress::Started(demo.describe()));
    let pids = demo.net.pids();
    if !pids.is_empty() {
        let pids: Vec<String> = pids.iter().map(ToString::to_string).collect();
        progress(Progress::Status(format!(
            "module processes: pids {}",
            pids.join(" ")
        )));
    }
    let shared = Arc::new(Mutex::new(Value::Null));
    let dashboard = match demo.config.dashboard {
        Some(addr) => {
            let source = shared.clone();
            let d = slate_dashboard::serve(addr, Arc::new(move || source.lock().clone()))?;
            progress(Progress::Dashboard(d.url()));
            Some(d)
        }
        None => None,
    };
    let pacer = Pacer::new(if demo.net.is_virtual() {
        demo.config.pace
    } else {
        None
    });
    let mut told = 0;
    while !demo.done() {
        demo.step();
        for e in &demo.observer.events[told..] {
            if !e.detail {
                progress(Progress::Event(e.clone()));
            }
        }
        told = demo.observer.events.len();
        if demo.step.is_multiple_of(150) {
            progress(Progress::Status(demo.status_line()));
        }
        if dashboard.is_some() && demo.step.is_multiple_of(2) {
            *shared.lock() = crate::snapshot::snapshot(&demo, Status::Running).to_json();
        }
        pacer.wait(demo.time());
    }
    let summary = demo.finish();
    *shared.lock() = crate::snapshot::snapshot(&demo, Status::Finished).to_json();
    if let Some(d) = dashboard {
        if !demo.config.linger.is_zero() {
            progress(Progress::Status(format!(
                "finished; the dashboard stays up {:.0} s more",
                demo.config.linger.as_secs_f64()
            )));
            std::thread::sleep(demo.config.linger);
        }
        d.stop();
    }
    Ok(summary)
}
