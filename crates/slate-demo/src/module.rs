//! A module: a `slate_node::Node` (one board with its own ICI, plan engine and plan
//! circuits) on the demo's network, as a separate board on a real network would be. What
//! each kind of module models (its interest) and which files it loads (among them its
//! export policy, a `link team` block) is decided here.

use std::sync::Arc;
use std::time::Duration;

use slate_ici::{ClassSet, IciConfig, TeamProtocol};
use slate_model::{Address, Context};
use slate_node::Node;
use slate_node::PlanSender;
use slate_node::authority::default_plans_from;
use slate_zenoh::ZenohConfig;

use crate::config::{Speakers, TeamLink, TeamMedium};
use crate::error::DemoError;
use crate::files::{self, SlateFile};
use crate::net::Network;

/// What a module does on its robot (or at the base).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Role {
    /// Navigation sensor: the pose, with an accuracy that grows between fixes.
    Nav,
    /// Proximity sensor: range and bearing to nearby obstacles and contacts.
    Prox,
    /// Vision sensor: identifies targets, more confidently as the robot approaches.
    Vision,
    /// Locomotion effector: drives towards the goal, around obstacles.
    Loco,
    /// Execution controller: runs the mission plans, decomposes them into sub-plans.
    Exec,
    /// The operator console at the base.
    Console,
}

impl Role {
    /// The modules of one robot, in start order.
    pub const ROBOT: [Role; 5] = [Role::Exec, Role::Nav, Role::Prox, Role::Vision, Role::Loco];

    /// The last segment of its address.
    pub fn name(self) -> &'static str {
        match self {
            Role::Nav => "nav",
            Role::Prox => "prox",
            Role::Vision => "vision",
            Role::Loco => "loco",
            Role::Exec => "exec",
            Role::Console => "console",
        }
    }

    /// The classes this board models (and so receives). Vision writes the targets it
    /// identifies but needs nobody else's; only the execution controller and the console
    /// model the whole team's targets.
    fn interest(self) -> ClassSet {
        let own_robot = |s: ClassSet| s.class_in("Robot", &[Context::Self_]);
        match self {
            Role::Nav => own_robot(ClassSet::none().class("Pose").class("Sensor")),
            Role::Prox => own_robot(classes(&["Pose", "Sensor", "Obstacle", "Contact"])),
            Role::Vision => own_robot(classes(&["Pose", "Sensor", "Contact"])),
            Role::Loco => own_robot(classes(&["Pose", "Sensor", "Obstacle"])),
            Role::Exec => classes(&["Pose", "Sensor", "Robot", "Target", "Waypoint", "Mission"]),
            Role::Console => classes(&["Robot", "Target", "Waypoint", "Mission"]),
        }
    }

    /// The ICI settings: interest, and with robots speaking the team protocol for
    /// `link` shared by `gateways` speakers. The export policy and the slower team
    /// heartbeat of the modules that export nothing come from the role's files when they
    /// load (`link team` blocks).
    pub fn ici_config(self, speakers: Speakers, link: &TeamLink, gateways: usize) -> IciConfig {
        let mut config = IciConfig::default().interest(self.interest());
        // A catch-up answer can wait behind others on a 9600 bit/s radio: asking again
        // after the default 3 s would only queue more answers.
        config.catch_up_retry = Duration::from_secs(10);
        if speakers == Speakers::Robots {
            let mut protocol =
                team_protocol(link, gateways).priority(Some(self.gateway_priority()));
            if link.medium == TeamMedium::Acoustic && self.models_only_its_robot() {
                // On the shared channel every listener's NACKs take airtime: a module
                // that models only its own robot hears the team through its gateway.
                protocol.listen = slate_ici::Listen::Never;
            }
            config = config.team_protocol(Some(protocol));
        }
        config
    }

    /// Does its interest hold its own robot's objects only (the sensing and motion
    /// modules), so that nothing another robot says is for it?
    fn models_only_its_robot(self) -> bool {
        matches!(self, Role::Nav | Role::Prox | Role::Vision | Role::Loco)
    }

    /// Its place in its robot's gateway election (lowest first): the execution
    /// controller, which exports the most, then vision; the console is alone at the base.
    fn gateway_priority(self) -> u8 {
        match self {
            Role::Exec | Role::Console => 0,
            Role::Vision => 1,
            Role::Nav => 2,
            Role::Loco => 3,
            Role::Prox => 4,
        }
    }

    /// The files this module loads after the classes and its role's files, for the team
    /// link's medium: the acoustic channel's filters (every module writes some of the
    /// attributes they filter, so every module loads them).
    fn medium_files(medium: TeamMedium) -> &'static [SlateFile] {
        match medium {
            TeamMedium::Radio => &[],
            TeamMedium::Acoustic => &[files::LINK_ACOUSTIC],
        }
    }

    /// The files this module loads after the classes: (file, robot it is for).
    fn files(self) -> &'static [SlateFile] {
        match self {
            Role::Exec => &[files::ROBOT_OBJECTS, files::EXEC],
            Role::Vision => &[files::ROBOT_OBJECTS, files::VISION],
            Role::Console => &[files::CONSOLE],
            Role::Nav | Role::Prox | Role::Loco => &[files::ROBOT_OBJECTS, files::QUIET],
        }
    }
}

/// `file`'s text for `robot`, or why the robot's name cannot stand in it.
fn for_robot(file: SlateFile, robot: &str) -> Result<String, DemoError> {
    file.for_robot(robot)
        .map_err(|e| DemoError::Config(format!("robot {robot:?}: {e}")))
}

fn classes(names: &[&str]) -> ClassSet {
    names.iter().fold(ClassSet::none(), |s, c| s.class(c))
}

/// The files [`Module::load_files`] loads, as (label, text), for a node to load before
/// it joins.
fn sources(
    role: Role,
    robot: &str,
    team: &[String],
    medium: TeamMedium,
) -> Result<Vec<(String, String)>, DemoError> {
    let mut out = Vec::new();
    for file in std::iter::once(files::CLASSES).chain(role.files().iter().copied()) {
        out.push((file.label(robot), for_robot(file, robot)?));
    }
    if role == Role::Console {
        for r in team {
            out.push((
                files::MISSION.label(r),
                files::terse(&for_robot(files::MISSION, r)?),
            ));
        }
    }
    for file in Role::medium_files(medium) {
        out.push((file.label(robot), for_robot(*file, robot)?));
    }
    Ok(out)
}

/// Who may send a module plans: its robot's modules, the team's operators, and the
/// console at the base, which sends each robot its mission plans (and whose plans the
/// execution controller sends on to its robot's modules).
fn plans_from() -> Vec<PlanSender> {
    let console = format!("team/{}/{}", crate::team::BASE, Role::Console.name());
    let mut senders = default_plans_from();
    senders.extend(console.parse::<PlanSender>().ok());
    senders
}

/// The team protocol's preset for the demo's link, paced at [`team_rate`].
fn team_protocol(link: &TeamLink, gateways: usize) -> TeamProtocol {
    let mut protocol = match link.medium {
        TeamMedium::Radio => TeamProtocol::radio(),
        TeamMedium::Acoustic => TeamProtocol::acoustic(),
    };
    protocol.rate_bps = team_rate(link, gateways);
    protocol
}

/// A gateway's pace on `link`: 80 % of a radio's budget, or 70 % of the shared acoustic
/// channel's divided among the `gateways` that share it (so that together they never
/// offer it more).
pub(crate) fn team_rate(link: &TeamLink, gateways: usize) -> u32 {
    let share = match link.medium {
        TeamMedium::Radio => link.budget_bps * 8 / 10,
        TeamMedium::Acoustic => link.budget_bps * 7 / 10 / gateways.max(1) as u64,
    };
    u32::try_from(share.max(1)).unwrap_or(u32::MAX)
}

/// One module: a [`slate_node::Node`] (board, plan engine, ICI, plan circuits) on the
/// demo's network and clock, and what it does on which robot.
pub struct Module {
    /// What it does.
    pub role: Role,
    /// Its robot's name (`base` for the console).
    pub robot: String,
    /// The node: its board (the paper's blackboard; drivers use it through the SBIPs), ICI,
    /// plan engine and plan circuits. (Shared: with module processes, the referee's
    /// observer on a robot stands in for each of its modules.)
    pub node: Arc<Node>,
}

impl Module {
    /// Starts a module on `net`: a node with the role's ICI settings, into which it then
    /// loads the classes and its role's files for its robot (the console also the mission
    /// of each robot in `team`), then the team link's files for `medium`, as an operator
    /// loads files into a running node. The
    /// order is the demo's: its seeds' runs are what they were with the ICI started first.
    pub(crate) fn start(
        net: &Network,
        robot: &str,
        role: Role,
        team: &[String],
        (link, speakers): (&TeamLink, Speakers),
    ) -> Result<Module, DemoError> {
        let address = Address::new(&format!("team/{robot}/{}", role.name()))
            .map_err(|e| DemoError::Config(e.to_string()))?;
        let mut builder = Node::builder(address.clone())
            .transport(net.join(&address)?)
            .clock(net.clock())
            .ici(role.ici_config(speakers, link, team.len() + 1))
            .plans_from(plans_from());
        if !net.is_virtual() {
            // In real time the robot's other modules may already be speaking: its shared
            // objects must be declared before it joins, or theirs arrive first and clash.
            for (label, text) in sources(role, robot, team, link.medium)? {
                builder = builder.source(&label, &text);
            }
        }
        let module = Module {
            role,
            robot: robot.to_owned(),
            node: Arc::new(builder.start()?),
        };
        if net.is_virtual() {
            module.load_files(team, link.medium)?;
        }
        Ok(module)
    }

    /// Starts a module on its own Zenoh session (`zenoh`) with its files loaded before
    /// its ICI starts, as `slate node` does: the same files as [`Module::start`] (the
    /// console's missions terse), for a module process that joins a team already
    /// running, whose catch-up answers would otherwise create the objects its files then
    /// create again. Like `slate node`, it answers `slate stats`.
    pub(crate) fn start_loaded(
        zenoh: ZenohConfig,
        robot: &str,
        role: Role,
        team: &[String],
        (link, speakers): (&TeamLink, Speakers),
    ) -> Result<Module, DemoError> {
        let address = Address::new(&format!("team/{robot}/{}", role.name()))
            .map_err(|e| DemoError::Config(e.to_string()))?;
        let mut builder = Node::builder(address)
            .zenoh(zenoh)
            .clock(slate_model::Clock::system())
            .ici(role.ici_config(speakers, link, team.len() + 1))
            .plans_from(plans_from());
        for (label, text) in sources(role, robot, team, link.medium)? {
            builder = builder.source(&label, &text);
        }
        Ok(Module {
            role,
            robot: robot.to_owned(),
            node: Arc::new(builder.start()?),
        })
    }

    /// Loads the classes, the role's files, the console's missions and the medium's files.
    fn load_files(&self, team: &[String], medium: TeamMedium) -> Result<(), DemoError> {
        let robot = self.robot.as_str();
        for file in std::iter::once(files::CLASSES).chain(self.role.files().iter().copied()) {
            self.load(file, robot)?;
        }
        if self.role == Role::Console {
            for r in team {
                self.load_terse(files::MISSION, r)?;
            }
        }
        for file in Role::medium_files(medium) {
            self.load(*file, robot)?;
        }
        Ok(())
    }

    fn load(&self, file: SlateFile, robot: &str) -> Result<(), DemoError> {
        self.node
            .load(&file.label(robot), &for_robot(file, robot)?)
            .map(|_| ())
            .map_err(|e| DemoError::Load {
                board: self.address().to_string(),
                rendered: e.rendered,
            })
    }

    /// Its address, `team/ROBOT/ROLE`.
    pub fn address(&self) -> &Address {
        self.node.address()
    }

    /// Loads a file whose plans are sent: terse, so they travel in few bytes (if it
    /// fails, the file as written is loaded for readable diagnostics).
    fn load_terse(&self, file: SlateFile, robot: &str) -> Result<(), DemoError> {
        let text = files::terse(&for_robot(file, robot)?);
        match self.node.load(&file.label(robot), &text) {
            Ok(_) => Ok(()),
            Err(_) => self.load(file, robot),
        }
    }

    /// The referee's observer on `robot` (`team/ROBOT/cli-referee`), standing in for its
    /// module in `role`: it models everything, exports nothing, and has the team's
    /// classes. With robots speaking it is a member of its robot that is never gateway
    /// and listens to the team link itself, so that it hears the team link as the robot's
    /// modules do without its robot's gateway relaying everything to it.
    pub(crate) fn referee(
        net: &Network,
        robot: &str,
        role: Role,
        speakers: Speakers,
    ) -> Result<Module, DemoError> {
        let address = Address::new(&format!("team/{robot}/cli-referee"))
            .map_err(|e| DemoError::Config(e.to_string()))?;
        let mut ici = IciConfig::default()
            .interest(ClassSet::all())
            .export(ClassSet::none())
            .observer(true);
        if speakers == Speakers::Robots {
            let mut protocol = TeamProtocol::radio().priority(None);
            protocol.listen = slate_ici::Listen::Always;
            ici = ici.team_protocol(Some(protocol));
        }
        let node = Node::builder(address.clone())
            .transport(net.join(&address)?)
            .clock(net.clock())
            .ici(ici)
            .source(files::CLASSES.name, files::CLASSES.source)
            .start()?;
        Ok(Module {
            role,
            robot: robot.to_owned(),
            node: Arc::new(node),
        })
    }

    /// The address of the module this stands for, `team/ROBOT/ROLE`: its node's, or
    /// with module processes the module's whose place the referee's observer takes
    /// (what the module wrote carries this address as its source).
    pub fn stands_for(&self) -> Address {
        let text = format!("team/{}/{}", self.robot, self.role.name());
        Address::new(&text).unwrap_or_else(|_| self.address().clone())
    }

    /// The name of this module's object on other boards (`team_r1_exec`).
    pub fn object_name(&self) -> String {
        slate_ici::module_object_name(self.address())
    }
}
