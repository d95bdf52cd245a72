//! `slate demo --network processes`: every module its own OS process (`slate
//! demo-module`), over Zenoh on 127.0.0.1; this process steps the world, serves it as a
//! module of its own team ([`world_link`]), and referees through observers on the
//! mission's team (docs/demo.md, "As processes").
//!
//! Every child reads its standard input until it closes and then leaves, so that none
//! outlives this process even if it dies without stopping them.

mod module;
pub mod world_link;

pub use module::{ModuleProcess, ModuleSpec};

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::time::Duration;

use parking_lot::Mutex;
use slate_ici::{ClassSet, IciConfig, Transport};
use slate_model::{Address, Clock};
use slate_node::{ModuleStats, Node, StatsProbe};
use slate_zenoh::ZenohConfig;

use crate::config::{DemoConfig, Speakers};
use crate::drivers::Sbip;
use crate::error::DemoError;
use crate::module::Role;
use crate::net::{ZenohNet, free_endpoint_on};
use crate::team::BASE;
use crate::world::{Layout, World};
use world_link::{WORLD_CLASSES, apply_commands, publish, world_address};

/// How long a module process may take to say it is ready.
const READY_LIMIT: Duration = Duration::from_secs(60);
/// How long one ask for the modules' counters may wait for their answers.
const STATS_WAIT: Duration = Duration::from_secs(1);
/// How long a module process may take to leave once its input is closed.
const STOP_LIMIT: Duration = Duration::from_secs(5);

/// A module process and its address.
struct ModuleChild {
    address: Address,
    child: Child,
    /// Killed on purpose (its robot died): how it ended says nothing of the run.
    killed: bool,
}

/// The module processes, the world module and the referee's sessions.
pub(crate) struct ProcessNet {
    zenoh: ZenohNet,
    children: Mutex<Vec<ModuleChild>>,
    world: Node,
    /// The module processes' logs: removed at the end when every one stopped cleanly.
    logs: PathBuf,
    /// Each robot's modules' endpoints, by robot (`base`: the console).
    modules: BTreeMap<String, Vec<String>>,
    /// Per robot still alive, what asks its modules for their counters, through its own
    /// modules (so that no query crosses the team link); opened at the first ask.
    probes: Mutex<BTreeMap<String, Option<StatsProbe>>>,
    /// Each module's latest counters, by address: a dead module's last answer stays.
    latest: Mutex<BTreeMap<String, ModuleStats>>,
}

impl ProcessNet {
    /// Serves the world, then starts every module's process in the demo's order (the
    /// console, then each robot's modules), each connecting to those before it.
    pub fn start(config: &DemoConfig) -> Result<ProcessNet, DemoError> {
        let placement = &config.placement;
        let world_endpoint = free_endpoint_on(placement.world.as_deref().unwrap_or(LOCAL))?;
        let world = world_node(&world_endpoint)?;
        let layout = Layout::generate(config.seed, config.robots);
        let logs = log_dir()?;
        let kept = logs.clone();
        let mut net = ProcessNet {
            zenoh: ZenohNet::new(None),
            children: Mutex::new(Vec::new()),
            world,
            logs: kept,
            modules: BTreeMap::new(),
            probes: Mutex::new(BTreeMap::new()),
            latest: Mutex::new(BTreeMap::new()),
        };
        let mut started: Vec<(Address, String)> = Vec::new();
        for address in addresses(&layout)? {
            let listen = free_endpoint_on(host(placement, &address))?;
            let connect = match config.speakers {
                Speakers::Modules => net.zenoh.endpoints(),
                Speakers::Robots => robots_speaking_peers(&address, &started),
            };
            let spec = ModuleSpec {
                address,
                seed: config.seed,
                robots: u8::try_from(config.robots).unwrap_or(u8::MAX),
                speakers: config.speakers,
                return_after: config.duration.as_secs_f64() * 0.8,
                listen,
                world: world_endpoint.clone(),
                connect,
            };
            let netns = placement
                .robots
                .get(spec.address.robot())
                .map(|p| p.0.as_str());
            net.spawn(&spec, netns, &logs)?;
            net.zenoh.add_endpoint(spec.listen.clone());
            started.push((spec.address.clone(), spec.listen.clone()));
            let robot = spec.address.robot().to_owned();
            net.probes.get_mut().insert(robot.clone(), None);
            net.modules.entry(robot).or_default().push(spec.listen);
        }
        Ok(net)
    }

    /// Starts one module process and waits until it says it is ready.
    /// In network namespace `netns` if given (`ip netns exec`, which becomes the module's
    /// process: its pid is the module's).
    fn spawn(
        &self,
        spec: &ModuleSpec,
        netns: Option<&str>,
        logs: &std::path::Path,
    ) -> Result<(), DemoError> {
        let failed = |e: String| DemoError::Network(format!("{}: {e}", spec.address));
        let program = std::env::current_exe().map_err(|e| failed(e.to_string()))?;
        let log_path = logs.join(format!(
            "{}.log",
            spec.address.to_string().replace('/', "_")
        ));
        let log = std::fs::File::create(&log_path).map_err(|e| failed(e.to_string()))?;
        let mut command = match netns {
            Some(ns) => {
                let mut c = Command::new("ip");
                c.args(["netns", "exec", ns]).arg(program);
                c
            }
            None => Command::new(program),
        };
        let mut child = command
            .arg("demo-module")
            .args(spec.to_args())
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(log)
            .spawn()
            .map_err(|e| failed(format!("cannot start its process: {e}")))?;
        let stdout = child.stdout.take();
        self.children.lock().push(ModuleChild {
            address: spec.address.clone(),
            child,
            killed: false,
        });
        if !ready(stdout) {
            return Err(failed(format!(
                "its process did not say it was ready; its log: {}",
                log_path.display()
            )));
        }
        Ok(())
    }

    /// A referee's session: connected to every module.
    pub fn join(&self, address: &Address) -> Result<Arc<dyn Transport>, DemoError> {
        self.zenoh.join(address)
    }

    /// Every module process of `address`'s robot is killed (SIGKILL): the robot dies
    /// (its modules' last counters stay; nobody asks them again).
    pub fn kill(&self, address: &Address) {
        self.probes.lock().remove(address.robot());
        for c in self.children.lock().iter_mut() {
            if c.address.robot() == address.robot() {
                c.killed = true;
                let _ = c.child.kill();
                let _ = c.child.wait();
            }
        }
    }

    /// Real time: waits until `d` after the previous call.
    pub fn advance(&self, d: Duration) {
        self.zenoh.advance(d);
    }

    /// The world takes the commands locomotion wrote, and is written for the drivers.
    pub fn exchange_world(&self, world: &mut World) {
        apply_commands(world, self.world.board());
        publish(world, &mut Sbip::new(self.world.board().clone()));
    }

    /// Every module's counters as it last answered (`slate stats`' query, which each
    /// module process answers as `slate node` does); a dead module's last answer stays,
    /// so that totals never go back.
    pub fn module_stats(&self) -> Vec<ModuleStats> {
        let mut found = Vec::new();
        for (robot, probe) in self.probes.lock().iter_mut() {
            if probe.is_none() {
                let endpoints = self.modules.get(robot).cloned().unwrap_or_default();
                let filter = format!("team/{robot}");
                *probe = StatsProbe::open(&endpoints, Some(&filter), STATS_WAIT, None).ok();
            }
            found.extend(
                probe
                    .as_ref()
                    .and_then(|p| p.sample().ok())
                    .into_iter()
                    .flatten(),
            );
        }
        let mut latest = self.latest.lock();
        for s in found {
            latest.insert(s.address.clone(), s);
        }
        latest.values().cloned().collect()
    }

    /// The processes' ids, in start order.
    pub fn pids(&self) -> Vec<u32> {
        self.children.lock().iter().map(|c| c.child.id()).collect()
    }
}

impl Drop for ProcessNet {
    /// Closes every child's input (it leaves), waits a little, then kills what is left.
    /// The logs are removed when every module not killed on purpose stopped cleanly,
    /// and kept (and their folder named) otherwise.
    fn drop(&mut self) {
        let mut children = self.children.lock();
        for c in children.iter_mut() {
            drop(c.child.stdin.take());
        }
        let deadline = std::time::Instant::now() + STOP_LIMIT;
        let mut clean = true;
        for c in children.iter_mut() {
            while matches!(c.child.try_wait(), Ok(None)) && std::time::Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(20));
            }
            let stopped = matches!(c.child.try_wait(), Ok(Some(s)) if s.success());
            clean &= c.killed || stopped;
            let _ = c.child.kill();
            let _ = c.child.wait();
        }
        self.world.close();
        if clean {
            let _ = std::fs::remove_dir_all(&self.logs);
        } else {
            tracing::warn!("module processes' logs kept in {}", self.logs.display());
        }
    }
}

/// The IP address every host listens on unless placed elsewhere.
const LOCAL: &str = "127.0.0.1";

/// The IP address `address`'s module listens on.
fn host<'p>(placement: &'p crate::config::Placement, address: &Address) -> &'p str {
    placement
        .robots
        .get(address.robot())
        .map_or(LOCAL, |(_, ip)| ip.as_str())
}

/// Whom a module connects to when robots speak, among the modules `started` before it:
/// its own robot's modules (its LAN), and for a robot's execution controller (its
/// gateway) or the console, the other robots' execution controllers and the console. The
/// team protocol puts only gateways on the team link and the console's plans go to the
/// execution controllers, so no other module needs a link across the radio; with every
/// module connected to every other (as when modules speak), the radio carried a Zenoh
/// session's keep-alives and declarations for each of the 90 pairs across robots.
fn robots_speaking_peers(address: &Address, started: &[(Address, String)]) -> Vec<String> {
    let speaks_for_robot =
        |a: &Address| a.module() == Role::Exec.name() || a.module() == Role::Console.name();
    started
        .iter()
        .filter(|(other, _)| {
            other.robot() == address.robot()
                || (speaks_for_robot(address) && speaks_for_robot(other))
        })
        .map(|(_, endpoint)| endpoint.clone())
        .collect()
}

/// The modules' addresses in start order: the console, then each robot's modules.
fn addresses(layout: &Layout) -> Result<Vec<Address>, DemoError> {
    let console = format!("team/{BASE}/{}", Role::Console.name());
    let robots = layout.regions.iter().flat_map(|r| {
        Role::ROBOT
            .iter()
            .map(move |role| format!("team/{}/{}", r.robot, role.name()))
    });
    std::iter::once(console)
        .chain(robots)
        .map(|a| Address::new(&a).map_err(|e| DemoError::Config(e.to_string())))
        .collect()
}

/// The world simulator's module, listening on `endpoint`.
fn world_node(endpoint: &str) -> Result<Node, DemoError> {
    let config = ZenohConfig {
        listen: vec![endpoint.to_owned()],
        ..ZenohConfig::default()
    };
    let ici = IciConfig::default()
        .interest(ClassSet::all())
        .export(ClassSet::all());
    Ok(Node::builder(world_address())
        .zenoh(config)
        .clock(Clock::system())
        .ici(ici)
        .source("world.slate", WORLD_CLASSES)
        .start()?)
}

/// Waits (at most [`READY_LIMIT`]) for the line `ready` on a child's output.
fn ready(stdout: Option<std::process::ChildStdout>) -> bool {
    let Some(stdout) = stdout else { return false };
    let (tx, rx) = crossbeam_channel::bounded(1);
    std::thread::spawn(move || {
        let said = BufReader::new(stdout)
            .lines()
            .map_while(Result::ok)
            .any(|l| l.trim() == "ready");
        let _ = tx.send(said);
    });
    rx.recv_timeout(READY_LIMIT).unwrap_or(false)
}

/// Where the module processes' logs go: a fresh folder under the system's temporary one.
fn log_dir() -> Result<PathBuf, DemoError> {
    let dir = std::env::temp_dir().join(format!("slate-demo-{}", std::process::id()));
    std::fs::create_dir_all(&dir)
        .map_err(|e| DemoError::Network(format!("{}: {e}", dir.display())))?;
    Ok(dir)
}
