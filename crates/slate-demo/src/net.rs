//! The network the modules join: the deterministic simulator (virtual time, a team link
//! with a bandwidth cap and loss) or Zenoh on 127.0.0.1 (real time, one session per
//! module, all in this process).

use std::sync::Arc;
use std::time::Duration;

use slate_ici::{Channel, LinkConfig, LinkKind, SimConfig, SimNet, SimStats, Transport};
use slate_model::{Address, Clock};

use crate::config::{TeamLink, TeamMedium};
use crate::error::DemoError;

/// Which network carries the team.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NetworkKind {
    /// The deterministic in-process simulator (the default).
    #[default]
    Sim,
    /// Zenoh sessions on 127.0.0.1, one per module, in this process.
    Zenoh,
    /// Zenoh on 127.0.0.1, every module its own OS process (`slate demo-module`).
    Processes,
}

impl NetworkKind {
    /// `sim` or `zenoh`.
    pub fn name(self) -> &'static str {
        match self {
            NetworkKind::Sim => "sim",
            NetworkKind::Zenoh => "zenoh",
            NetworkKind::Processes => "processes",
        }
    }
}

/// A running network.
pub(crate) enum Network {
    Sim(SimNet),
    Zenoh(zenoh_net::ZenohNet),
    Processes(Box<crate::process::ProcessNet>),
}

pub(crate) use zenoh_net::{ZenohNet, free_endpoint_on};

impl Network {
    /// The simulator with the team link shaped as `team` (the robot link is clean, 100 µs).
    pub fn sim(seed: u64, team: &TeamLink) -> Network {
        let config = SimConfig {
            team: team_link_config(team),
            ..SimConfig::default()
        };
        Network::Sim(SimNet::with_config(seed, config))
    }

    /// From now on the team link is shaped as `team` (the simulator's; Zenoh's links are
    /// what they are): the deck's radio gives way to the mission's link at launch.
    pub fn set_team_link(&self, team: &TeamLink) {
        if let Network::Sim(net) = self {
            net.set_team_link(team_link_config(team));
        }
    }

    /// The team link's air on the simulator: its counters and the fraction of the time
    /// its transmitters spent on the air.
    pub fn team_channel(&self) -> Option<(Channel, SimStats, f64)> {
        match self {
            Network::Sim(net) => {
                let stats = net.stats();
                let channel = stats.channels.get(&LinkKind::Team).copied();
                let utilisation = net.channel_utilisation(LinkKind::Team);
                Some((channel.unwrap_or_default(), stats, utilisation))
            }
            Network::Zenoh(_) | Network::Processes(_) => None,
        }
    }

    /// Zenoh on loopback.
    pub fn zenoh() -> Network {
        Network::Zenoh(zenoh_net::ZenohNet::new(None))
    }

    /// Zenoh on loopback as a secured team of `members` (docs/security.md): keys made for
    /// them in a temporary folder (removed with the network), TLS links with mutual
    /// authentication, and the access control generated from the keys.
    pub fn secured_zenoh(members: &[Address]) -> Result<Network, DemoError> {
        let keys = zenoh_net::Keys::make(members)?;
        Ok(Network::Zenoh(zenoh_net::ZenohNet::new(Some(keys))))
    }

    /// Every module its own process, and the world served as a module.
    pub fn processes(config: &crate::config::DemoConfig) -> Result<Network, DemoError> {
        Ok(Network::Processes(Box::new(
            crate::process::ProcessNet::start(config)?,
        )))
    }

    /// With module processes: the world takes locomotion's commands and is written for
    /// the drivers (in-process, the drivers hold the world itself).
    pub fn exchange_world(&self, world: &mut crate::world::World) {
        if let Network::Processes(p) = self {
            p.exchange_world(world);
        }
    }

    /// With module processes, every module's counters as it last answered (`None`
    /// in-process: the modules' ICIs are at hand).
    pub fn module_stats(&self) -> Option<Vec<slate_node::ModuleStats>> {
        match self {
            Network::Processes(p) => Some(p.module_stats()),
            _ => None,
        }
    }

    /// The module processes' ids (none in-process).
    pub fn pids(&self) -> Vec<u32> {
        match self {
            Network::Processes(p) => p.pids(),
            _ => Vec::new(),
        }
    }

    /// Do the drivers and the operator run in this process?
    pub fn drives_here(&self) -> bool {
        !matches!(self, Network::Processes(_))
    }

    /// The clock every board on this network uses.
    pub fn clock(&self) -> Clock {
        match self {
            Network::Sim(net) => net.clock(),
            Network::Zenoh(_) | Network::Processes(_) => Clock::system(),
        }
    }

    /// Is time virtual (it only moves when [`advance`](Self::advance) is called)?
    pub fn is_virtual(&self) -> bool {
        matches!(self, Network::Sim(_))
    }

    /// A new endpoint.
    pub fn join(&self, address: &Address) -> Result<Arc<dyn Transport>, DemoError> {
        match self {
            Network::Sim(net) => Ok(net.join(address)),
            Network::Zenoh(z) => z.join(address),
            Network::Processes(p) => p.join(address),
        }
    }

    /// The module dies: it neither sends nor receives any more.
    pub fn kill(&self, address: &Address) {
        match self {
            Network::Sim(net) => net.kill(address),
            Network::Zenoh(z) => z.kill(address),
            Network::Processes(p) => p.kill(address),
        }
    }

    /// Lets `d` pass: the simulator runs its events for `d` of virtual time; on Zenoh
    /// this waits until `d` after the previous call (real time).
    pub fn advance(&self, d: Duration) {
        match self {
            Network::Sim(net) => net.run_for(d),
            Network::Zenoh(z) => z.advance(d),
            Network::Processes(p) => p.advance(d),
        }
    }

    /// The simulator's counters (per directed link and message kind), if simulated.
    pub fn sim_stats(&self) -> Option<SimStats> {
        match self {
            Network::Sim(net) => Some(net.stats()),
            Network::Zenoh(_) | Network::Processes(_) => None,
        }
    }
}

mod zenoh_net {
    use std::net::TcpListener;
    use std::sync::Arc;
    use std::time::{Duration, Instant};

    use parking_lot::Mutex;
    use slate_ici::Transport;
    use slate_model::Address;
    use slate_node::team_keys::{Identity, TemporaryKeys};
    use slate_zenoh::{Security, ZenohConfig, ZenohTransport};

    use crate::error::DemoError;

    /// Ports tried per endpoint before giving up.
    const PORT_TRIES: u32 = 200;

    /// The lowest port an endpoint is drawn from.
    const LOWEST_PORT: u16 = 10_000;

    /// A free TCP endpoint on `host` (the port is free on 127.0.0.1 here when asked;
    /// another host, a fresh network namespace, has it free too), never one handed out
    /// before by this process. The port is below the kernel's ephemeral range: in it, a
    /// module's outgoing connection can take the port as its source before the module
    /// meant to listen there does ("Address already in use").
    pub fn free_endpoint_on(host: &str) -> Result<String, DemoError> {
        use std::sync::atomic::{AtomicU32, Ordering};
        static NEXT: AtomicU32 = AtomicU32::new(0);
        let span = u32::from(ephemeral_start().saturating_sub(LOWEST_PORT).max(1));
        let start = std::process::id().wrapping_mul(2_654_435_761) % span;
        for _ in 0..PORT_TRIES {
            let draw = NEXT.fetch_add(1, Ordering::Relaxed);
            let offset = u16::try_from((start + draw) % span).unwrap_or(0);
            let port = LOWEST_PORT + offset;
            if TcpListener::bind(("127.0.0.1", port)).is_ok() {
                return Ok(format!("tcp/{host}:{port}"));
            }
        }
        Err(DemoError::Network(format!(
            "no free TCP port on 127.0.0.1 in {PORT_TRIES} tries below {}",
            ephemeral_start()
        )))
    }

    /// The first port of the kernel's ephemeral range (32768 if it cannot be read).
    fn ephemeral_start() -> u16 {
        std::fs::read_to_string("/proc/sys/net/ipv4/ip_local_port_range")
            .ok()
            .and_then(|t| t.split_whitespace().next()?.parse().ok())
            .unwrap_or(32768)
    }

    /// A free TCP endpoint on 127.0.0.1.
    pub fn free_endpoint() -> Result<String, DemoError> {
        free_endpoint_on("127.0.0.1")
    }

    /// Zenoh sessions on loopback: each listens on its own port and connects to the ones
    /// opened before it (and to those [added](Self::add_endpoint) from elsewhere).
    pub struct ZenohNet {
        endpoints: Mutex<Vec<String>>,
        transports: Mutex<Vec<Arc<ZenohTransport>>>,
        next_wake: Mutex<Option<Instant>>,
        /// A secured team's keys (`None`: plain TCP).
        keys: Option<Keys>,
    }

    /// A secured team's keys, made by `slate keys`' code for this run and removed when
    /// dropped.
    pub struct Keys(TemporaryKeys);

    impl Keys {
        /// A team authority and a key and certificate for each of `members`.
        pub fn make(members: &[Address]) -> Result<Keys, DemoError> {
            let identities: Vec<Identity> = members.iter().cloned().map(Identity::Module).collect();
            TemporaryKeys::make("demo", &identities)
                .map(Keys)
                .map_err(|e| DemoError::Network(format!("cannot make the team's keys: {e}")))
        }

        /// What `address`'s session needs to run secured.
        fn security(&self, address: &Address) -> Result<Security, DemoError> {
            self.0
                .security(&Identity::Module(address.clone()))
                .map_err(|e| DemoError::Network(format!("{address}: {e}")))
        }
    }

    impl ZenohNet {
        pub fn new(keys: Option<Keys>) -> Self {
            ZenohNet {
                endpoints: Mutex::new(Vec::new()),
                transports: Mutex::new(Vec::new()),
                next_wake: Mutex::new(None),
                keys,
            }
        }

        /// The endpoints a new session connects to.
        pub fn endpoints(&self) -> Vec<String> {
            self.endpoints.lock().clone()
        }

        /// A session opened elsewhere (another process) that new ones connect to.
        pub fn add_endpoint(&self, endpoint: String) {
            self.endpoints.lock().push(endpoint);
        }

        pub fn join(&self, address: &Address) -> Result<Arc<dyn Transport>, DemoError> {
            let endpoint = free_endpoint()?;
            let endpoint = match self.keys {
                Some(_) => endpoint.replacen("tcp/", "tls/", 1),
                None => endpoint,
            };
            let security = self
                .keys
                .as_ref()
                .map(|k| k.security(address))
                .transpose()?;
            let config = ZenohConfig {
                listen: vec![endpoint.clone()],
                connect: self.endpoints.lock().clone(),
                security,
                ..ZenohConfig::default()
            };
            let t = ZenohTransport::open(address.clone(), &config)
                .map_err(|e| DemoError::Network(format!("{address}: {e}")))?;
            self.endpoints.lock().push(endpoint);
            self.transports.lock().push(t.clone());
            Ok(t)
        }

        pub fn kill(&self, address: &Address) {
            for t in self.transports.lock().iter() {
                if t.address() == address {
                    t.close();
                }
            }
        }

        pub fn advance(&self, d: Duration) {
            let mut next = self.next_wake.lock();
            let wake = next.unwrap_or_else(Instant::now) + d;
            *next = Some(wake);
            drop(next);
            let now = Instant::now();
            if wake > now {
                std::thread::sleep(wake - now);
            }
        }
    }

    #[cfg(test)]
    mod tests {
        use super::*;

        #[test]
        fn free_endpoints_are_distinct_and_below_the_kernels_ephemeral_range() {
            // In the range, a module's outgoing connection can take the port as its
            // source before the module meant to listen there does ("Address already in
            // use", seen in a namespace of the real-link harness).
            let ports: Vec<u16> = (0..32)
                .map(|_| free_endpoint_on("10.77.0.3").unwrap())
                .map(|e| e.rsplit(':').next().unwrap().parse().unwrap())
                .collect();
            assert!(ports.iter().all(|p| *p < ephemeral_start()), "{ports:?}");
            let distinct: std::collections::BTreeSet<u16> = ports.iter().copied().collect();
            assert_eq!(distinct.len(), ports.len(), "{ports:?}");
        }

        #[test]
        fn a_secured_networks_keys_are_its_members_own_and_go_with_it() {
            let members = ["team/r1/nav", "team/base/console"].map(|a| Address::new(a).unwrap());
            let keys = Keys::make(&members).unwrap();
            let dir = keys.0.dir().to_path_buf();
            for m in &members {
                let security = keys.security(m).unwrap();
                let team = security.team.unwrap();
                assert_eq!(team.modules.len(), 2, "{:?}", team.modules);
            }
            let net = ZenohNet::new(Some(keys));
            drop(net);
            assert!(!dir.exists(), "{}", dir.display());
        }
    }
}

/// The simulator's team link for `team`: radios (a transmitter per sender, messages
/// whole) or one shared acoustic channel of frames.
fn team_link_config(team: &TeamLink) -> LinkConfig {
    let mut link = LinkConfig::clean()
        .delay(team.delay)
        .jitter(team.jitter)
        .loss(team.loss)
        .bandwidth(team.budget_bps);
    if team.medium == TeamMedium::Acoustic {
        link = link.shared();
    }
    if let Some(bytes) = team.frame_bytes {
        link = link.frames(bytes, team.frame_overhead);
    }
    if let Some(wait) = team.max_queue {
        link = link.max_queue(wait);
    }
    link
}

/// Paces a virtual-time loop to real time (for people watching the dashboard).
#[derive(Debug)]
pub(crate) struct Pacer {
    start: Option<std::time::Instant>,
    speed: f64,
}

impl Pacer {
    /// `speed` virtual seconds per real second; `None` runs as fast as it can.
    pub fn new(speed: Option<f64>) -> Pacer {
        Pacer {
            start: speed.map(|_| std::time::Instant::now()),
            speed: speed.unwrap_or(0.0),
        }
    }

    /// Waits until real time catches up with virtual time `t`.
    pub fn wait(&self, t: f64) {
        let Some(start) = self.start else { return };
        let due = Duration::from_secs_f64((t / self.speed).max(0.0));
        let elapsed = start.elapsed();
        if due > elapsed {
            std::thread::sleep(due - elapsed);
        }
    }
}
