//! The team: the operator console and the robots, each robot five modules (five boards,
//! five ICIs) and the drivers of its sensors and effector.

use crate::config::{Speakers, TeamLink};
use crate::drivers::{Loco, Nav, Operator, Prox, RobotDrivers, Vision};
use crate::error::DemoError;
use crate::module::{Module, Role};
use crate::net::Network;
use crate::world::{Layout, World};

/// The console's robot name (its address is `team/base/console`).
pub const BASE: &str = "base";

/// Every module, the drivers, the operator.
pub struct Team {
    /// Robot names, in order.
    pub robots: Vec<String>,
    /// The console first, then each robot's modules in [`Role::ROBOT`] order.
    pub modules: Vec<Module>,
    /// The drivers, one set per robot.
    pub drivers: Vec<RobotDrivers>,
    /// The operator at the console.
    pub operator: Operator,
    /// Robots that died.
    pub dead: Vec<bool>,
    /// Do the drivers and the operator run in this process (not with module processes,
    /// where each module's process runs its own)?
    pub drives: bool,
}

impl Team {
    /// Starts every module on `net` (with the files of the team link's medium, and its
    /// speakers: every module or one gateway per robot) and the drivers (the console
    /// first).
    pub(crate) fn start(
        net: &Network,
        layout: &Layout,
        seed: u64,
        link: (&TeamLink, Speakers),
    ) -> Result<Team, DemoError> {
        let robots: Vec<String> = layout.regions.iter().map(|r| r.robot.clone()).collect();
        if !net.drives_here() {
            return Team::referee(net, robots, link.1);
        }
        let console = Module::start(net, BASE, Role::Console, &robots, link)?;
        let mut modules = vec![console];
        for robot in &robots {
            for role in Role::ROBOT {
                modules.push(Module::start(net, robot, role, &robots, link)?);
            }
        }
        let operator = Operator::new(modules[0].node.board().clone());
        let mut team = Team {
            dead: vec![false; robots.len()],
            robots,
            modules,
            drivers: Vec::new(),
            operator,
            drives: true,
        };
        team.drivers = (0..team.robots.len())
            .map(|i| team.robot_drivers(i, seed))
            .collect();
        Ok(team)
    }

    /// With module processes: the referee, an observer on each robot and the base that
    /// stands in for each of its modules (it hears the robot's LAN and the team link as
    /// they do); no driver and no operator run here.
    fn referee(net: &Network, robots: Vec<String>, speakers: Speakers) -> Result<Team, DemoError> {
        let mut modules = vec![Module::referee(net, BASE, Role::Console, speakers)?];
        for robot in &robots {
            let observer = Module::referee(net, robot, Role::Exec, speakers)?;
            for role in Role::ROBOT {
                modules.push(Module {
                    role,
                    robot: robot.clone(),
                    node: observer.node.clone(),
                });
            }
        }
        let operator = Operator::new(modules[0].node.board().clone());
        Ok(Team {
            dead: vec![false; robots.len()],
            robots,
            modules,
            drivers: Vec::new(),
            operator,
            drives: false,
        })
    }

    fn robot_drivers(&self, i: usize, seed: u64) -> RobotDrivers {
        let name = &self.robots[i];
        let board = |role| self.module(i, role).node.board().clone();
        RobotDrivers {
            nav: Nav::new(i, name, board(Role::Nav), seed),
            prox: Prox::new(i, name, board(Role::Prox), seed),
            vision: Vision::new(i, name, board(Role::Vision), seed),
            loco: Loco::new(i, name, board(Role::Loco)),
        }
    }

    /// The console.
    pub fn console(&self) -> &Module {
        &self.modules[0]
    }

    /// Robot `i`'s module in `role`.
    pub fn module(&self, i: usize, role: Role) -> &Module {
        let k = Role::ROBOT.iter().position(|r| *r == role).unwrap_or(0);
        &self.modules[1 + i * Role::ROBOT.len() + k]
    }

    /// Robot `i`'s modules.
    pub fn robot_modules(&self, i: usize) -> &[Module] {
        let n = Role::ROBOT.len();
        &self.modules[1 + i * n..1 + (i + 1) * n]
    }

    /// The modules still running.
    pub fn alive_modules(&self) -> impl Iterator<Item = &Module> {
        self.modules.iter().filter(|m| {
            self.robots
                .iter()
                .position(|r| *r == m.robot)
                .is_none_or(|i| !self.dead[i])
        })
    }

    /// Runs the drivers of the robots still alive.
    pub(crate) fn tick(&mut self, world: &mut World, step: u64, dt: f64) {
        if self.drives {
            self.operator.tick(world.time);
        }
        for (i, d) in self.drivers.iter_mut().enumerate() {
            if !self.dead[i] {
                d.tick(world, step, dt);
            }
        }
    }

    /// From now on the team link is `link`: each gateway paces its radio to it
    /// ([`slate_ici::Ici::set_team_rate`]; the modules of every robot and the console
    /// share an acoustic channel). Without the team protocol it changes nothing.
    pub(crate) fn set_team_link(&self, link: &TeamLink) {
        let rate = crate::module::team_rate(link, self.robots.len() + 1);
        for m in &self.modules {
            m.node.ici().set_team_rate(rate);
        }
    }

    /// Robot `i` dies: every module of it leaves the network, its body stops.
    pub(crate) fn kill(&mut self, i: usize, net: &Network, world: &mut World) {
        self.dead[i] = true;
        world.power_off(i);
        for m in self.robot_modules(i) {
            net.kill(m.address());
        }
    }
}
