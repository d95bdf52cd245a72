//! One module of `slate demo --network processes` in its own OS process (`slate
//! demo-module`): the module as the in-process demo builds it, on its own Zenoh session,
//! and the role's driver beside its board, measuring a replica of the world that it
//! keeps from the world module's board (docs/demo.md, "As processes").

use std::sync::Arc;
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;
use slate_ici::{ClassSet, IciConfig};
use slate_model::{Address, Board, Clock};
use slate_node::Node;
use slate_zenoh::ZenohConfig;

use super::world_link::{WORLD_CLASSES, mirror, publish_command, reader_address};
use crate::config::{Speakers, TeamLink};
use crate::drivers::{Loco, Nav, Operator, Prox, Sbip, Vision};
use crate::error::DemoError;
use crate::module::{Module, Role};
use crate::run::DT;
use crate::world::{Layout, World};

/// What a module process is told by `slate demo` (`slate demo-module`'s flags).
#[derive(Clone, Debug, PartialEq)]
pub struct ModuleSpec {
    /// Its address, `team/ROBOT/ROLE`.
    pub address: Address,
    /// The world's seed (the layout, the drivers' noise).
    pub seed: u64,
    /// Robots in the team.
    pub robots: u8,
    /// Who speaks on the team link: every module, or one gateway per robot.
    pub speakers: Speakers,
    /// When the console calls the robots home, seconds of world time.
    pub return_after: f64,
    /// The Zenoh endpoint it listens on.
    pub listen: String,
    /// The world module's endpoint.
    pub world: String,
    /// The endpoints of the modules started before it.
    pub connect: Vec<String>,
}

impl ModuleSpec {
    /// The address of robot `robot`'s module `role` (`console` on robot `base`), or why
    /// there is no such module.
    pub fn address_of(robot: &str, role: &str) -> Result<Address, DemoError> {
        let address = Address::new(&format!("team/{robot}/{role}"))
            .map_err(|e| DemoError::Config(format!("demo-module: {e}")))?;
        role_of(&address)?;
        Ok(address)
    }

    /// As flags of `slate demo-module` (`--connect` once per endpoint).
    pub fn to_args(&self) -> Vec<String> {
        let flags = [
            ("--robot", self.address.robot().to_owned()),
            ("--role", self.address.module().to_owned()),
            ("--seed", self.seed.to_string()),
            ("--robots", self.robots.to_string()),
            ("--speakers", speakers_arg(self.speakers).to_owned()),
            ("--return-after", self.return_after.to_string()),
            ("--listen", self.listen.clone()),
            ("--world", self.world.clone()),
        ];
        let connect = self.connect.iter().map(|e| ("--connect", e.clone()));
        flags
            .into_iter()
            .chain(connect)
            .flat_map(|(flag, value)| [flag.to_owned(), value])
            .collect()
    }

    fn role(&self) -> Result<Role, DemoError> {
        role_of(&self.address)
    }
}

/// The role of the demo's module at `address`, or why there is none.
fn role_of(address: &Address) -> Result<Role, DemoError> {
    let all = [Role::Console].into_iter().chain(Role::ROBOT);
    all.into_iter()
        .find(|r| r.name() == address.module())
        .ok_or_else(|| {
            let roles: Vec<&str> = [Role::Console]
                .iter()
                .chain(&Role::ROBOT)
                .map(|r| r.name())
                .collect();
            DemoError::Config(format!(
                "{address}: no such module (roles: {})",
                roles.join(", ")
            ))
        })
}

/// A Zenoh config file that turns gossip and multicast scouting off, for the module's
/// session to open with, when robots speak: each module is then linked only to the peers
/// it was told (`ModuleSpec::connect`), instead of to every module its peers tell it of
/// (gossip) or that answers its multicast scouting (which slate's config also turns off
/// for a file that does not name it), either of which links every module to every other
/// across the radio again.
/// Removed when dropped (Zenoh reads it as the session opens).
struct NoGossipFile(std::path::PathBuf);

impl NoGossipFile {
    const TEXT: &str =
        "{ scouting: { gossip: { enabled: false }, multicast: { enabled: false } } }";

    fn for_speakers(speakers: Speakers) -> Result<Option<NoGossipFile>, DemoError> {
        if speakers == Speakers::Modules {
            return Ok(None);
        }
        let name = format!("slate-demo-module-{}.json5", std::process::id());
        let path = std::env::temp_dir().join(name);
        std::fs::write(&path, Self::TEXT)
            .map_err(|e| DemoError::Network(format!("{}: {e}", path.display())))?;
        Ok(Some(NoGossipFile(path)))
    }
}

impl Drop for NoGossipFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// `speakers` as [`ModuleSpec::to_args`] writes it (as `slate demo --speakers` takes it).
fn speakers_arg(speakers: Speakers) -> &'static str {
    match speakers {
        Speakers::Modules => "modules",
        Speakers::Robots => "robots",
    }
}

/// The role's driver, on the module's board.
enum Driver {
    Nav(Nav),
    Prox(Prox),
    Vision(Vision),
    Loco(Loco),
    Operator(Operator),
    None,
}

/// A running module process: the module, its world reader and its driver.
pub struct ModuleProcess {
    module: Module,
    world_reader: Option<Node>,
    replica: World,
    robot: usize,
    driver: Driver,
}

impl ModuleProcess {
    /// Starts the module and, for a role with a driver, its world reader.
    pub fn start(spec: &ModuleSpec) -> Result<ModuleProcess, DemoError> {
        let role = spec.role()?;
        let layout = Layout::generate(spec.seed, usize::from(spec.robots));
        let robots: Vec<String> = layout.regions.iter().map(|r| r.robot.clone()).collect();
        let robot_name = spec.address.robot().to_owned();
        let no_gossip = NoGossipFile::for_speakers(spec.speakers)?;
        let zenoh = ZenohConfig {
            listen: vec![spec.listen.clone()],
            connect: spec.connect.clone(),
            file: no_gossip.as_ref().map(|f| f.0.clone()),
            ..ZenohConfig::default()
        };
        let link = TeamLink::default();
        let link = (&link, spec.speakers);
        let module = Module::start_loaded(zenoh, &robot_name, role, &robots, link)?;
        drop(no_gossip);
        let robot = robots.iter().position(|r| *r == robot_name).unwrap_or(0);
        // The console's operator needs the world's time, as the drivers need the world.
        let world_reader = match role {
            Role::Exec => None,
            _ => Some(world_reader(&robot_name, role, &spec.world)?),
        };
        let board = module.node.board().clone();
        let driver = driver(role, robot, &robot_name, board, spec, &layout);
        Ok(ModuleProcess {
            module,
            world_reader,
            replica: World::new(&layout, spec.seed),
            robot,
            driver,
        })
    }

    /// Runs the driver every [`DT`] of real time until `stop` fires.
    pub fn run(mut self, stop: &Receiver<()>) {
        let start = Instant::now();
        let mut step: u64 = 0;
        loop {
            let due = start + Duration::from_secs_f64(DT * (step + 1) as f64);
            if stop.recv_deadline(due).is_ok() {
                break;
            }
            if self.tick(step) {
                step += 1;
            }
        }
        self.module.node.close();
        if let Some(r) = &self.world_reader {
            r.close();
        }
    }

    /// One step of the driver, once the world has been heard; false before.
    fn tick(&mut self, step: u64) -> bool {
        let world_time = match &self.world_reader {
            Some(r) => mirror(&mut self.replica, r.board()).then_some(self.replica.time),
            None => Some(self.replica.time),
        };
        let Some(now) = world_time else {
            return false;
        };
        let sensing = (step + self.robot as u64).is_multiple_of(2);
        match &mut self.driver {
            Driver::Nav(d) if sensing => d.tick(&self.replica, 2.0 * DT),
            Driver::Prox(d) if sensing => d.tick(&self.replica),
            Driver::Vision(d) if sensing => d.tick(&self.replica, 2.0 * DT),
            Driver::Loco(d) => {
                d.tick(&mut self.replica);
                if let Some(r) = &self.world_reader {
                    publish_command(&self.replica, self.robot, &mut Sbip::new(r.board().clone()));
                }
            }
            Driver::Operator(o) => o.tick(now),
            _ => {}
        }
        true
    }
}

/// The driver of `role` for robot `robot` (named `name`) on `board`.
fn driver(
    role: Role,
    robot: usize,
    name: &str,
    board: Arc<Board>,
    spec: &ModuleSpec,
    layout: &Layout,
) -> Driver {
    match role {
        Role::Nav => Driver::Nav(Nav::new(robot, name, board, spec.seed)),
        Role::Prox => Driver::Prox(Prox::new(robot, name, board, spec.seed)),
        Role::Vision => Driver::Vision(Vision::new(robot, name, board, spec.seed)),
        Role::Loco => Driver::Loco(Loco::new(robot, name, board)),
        Role::Console => {
            let mut operator = Operator::new(board);
            operator.plan(layout, layout.targets.len(), spec.return_after);
            Driver::Operator(operator)
        }
        Role::Exec => Driver::None,
    }
}

/// A driver's node on the world team: it models the world (and exports its commands).
fn world_reader(robot: &str, role: Role, world: &str) -> Result<Node, DemoError> {
    let config = ZenohConfig {
        connect: vec![world.to_owned()],
        ..ZenohConfig::default()
    };
    let ici = IciConfig::default()
        .interest(ClassSet::all())
        .export(ClassSet::none().class("Command"));
    Ok(Node::builder(reader_address(robot, role.name()))
        .zenoh(config)
        .clock(Clock::system())
        .ici(ici)
        .source("world.slate", WORLD_CLASSES)
        .start()?)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Zenoh config a robots-speaking module opens its session with, as `key`'s value.
    fn robots_speaking_setting(key: &str) -> String {
        let file = NoGossipFile::for_speakers(Speakers::Robots)
            .unwrap()
            .expect("robots speaking: a file");
        let config = ZenohConfig {
            file: Some(file.0.clone()),
            ..ZenohConfig::default()
        };
        config.to_zenoh().unwrap().get_json(key).unwrap()
    }

    #[test]
    fn a_robots_speaking_module_links_only_to_the_peers_it_is_told() {
        // Multicast scouting would link every module to every other one it hears (across
        // the radio, which carries the multicast), as gossip would.
        assert_eq!(
            robots_speaking_setting("scouting/multicast/enabled"),
            "false"
        );
        assert_eq!(robots_speaking_setting("scouting/gossip/enabled"), "false");
    }
}
