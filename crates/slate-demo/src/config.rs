//! What a demo run is asked to do.

use std::net::SocketAddr;
use std::time::Duration;

use crate::net::NetworkKind;

/// The largest team the demo runs: the world grows one strip (a route, obstacles,
/// targets) per robot, and the team link's traffic grows faster than the team, so larger
/// teams are refused rather than left to run for hours.
pub const MAX_ROBOTS: usize = 32;

/// The team link between robots: its declared budget and, on the simulator, its faults.
#[derive(Clone, Debug, PartialEq)]
pub struct TeamLink {
    /// Declared capacity of a transmitter on the team link, bit/s (the simulator caps
    /// every transmitter at it; the summary compares the traffic with it).
    pub budget_bps: u64,
    /// Probability that a transmission is lost (simulator).
    pub loss: f64,
    /// Propagation delay (simulator).
    pub delay: Duration,
    /// Extra random delay, uniform in `[0, jitter]` (simulator; it reorders).
    pub jitter: Duration,
}

impl Default for TeamLink {
    fn default() -> Self {
        TeamLink {
            budget_bps: 9600,
            loss: 0.05,
            delay: Duration::from_millis(60),
            jitter: Duration::from_millis(40),
        }
    }
}

/// A demo run: the world's seed, the team, the network, how long, and what to show.
///
/// ```
/// use slate_demo::{DemoConfig, NetworkKind};
/// let config = DemoConfig::default().seed(3).robots(3).network(NetworkKind::Sim);
/// assert_eq!(config.robots, 3);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct DemoConfig {
    /// Seeds the world, the sensors' noise and the simulated network.
    pub seed: u64,
    /// Robots in the team (1 to [`MAX_ROBOTS`]).
    pub robots: usize,
    /// Simulator or Zenoh.
    pub network: NetworkKind,
    /// The longest the mission may run (world time); the operator calls the robots home
    /// at 80 % of it.
    pub duration: Duration,
    /// Serve the live dashboard here.
    pub dashboard: Option<SocketAddr>,
    /// With a dashboard: how long it stays up once the run is over.
    pub linger: Duration,
    /// Virtual seconds per real second on the simulator (`None`: as fast as it goes; the
    /// dashboard sets 1.0 so people can watch). Zenoh always runs in real time.
    pub pace: Option<f64>,
    /// When the last robot dies (seconds into the run); `None`: nobody dies.
    pub fault_at: Option<f64>,
    /// The team link.
    pub team_link: TeamLink,
}

impl Default for DemoConfig {
    fn default() -> Self {
        DemoConfig {
            seed: 7,
            robots: 3,
            network: NetworkKind::Sim,
            duration: Duration::from_secs(240),
            dashboard: None,
            linger: Duration::ZERO,
            pace: None,
            fault_at: Some(30.0),
            team_link: TeamLink::default(),
        }
    }
}

impl DemoConfig {
    /// Sets the seed.
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Sets the number of robots.
    pub fn robots(mut self, robots: usize) -> Self {
        self.robots = robots;
        self
    }

    /// Sets the network.
    pub fn network(mut self, network: NetworkKind) -> Self {
        self.network = network;
        self
    }

    /// Sets the longest run.
    pub fn duration(mut self, duration: Duration) -> Self {
        self.duration = duration;
        self
    }

    /// Serves the dashboard (and paces the simulator to real time unless a pace is set).
    pub fn dashboard(mut self, addr: SocketAddr) -> Self {
        self.dashboard = Some(addr);
        self.pace = self.pace.or(Some(1.0));
        self
    }

    /// Sets the pace (virtual seconds per real second).
    pub fn pace(mut self, pace: Option<f64>) -> Self {
        self.pace = pace;
        self
    }

    /// Sets when the last robot dies.
    pub fn fault_at(mut self, at: Option<f64>) -> Self {
        self.fault_at = at;
        self
    }

    /// Checks the settings.
    pub fn validate(&self) -> Result<(), crate::DemoError> {
        let bad = |m: String| Err(crate::DemoError::Config(m));
        if !(1..=MAX_ROBOTS).contains(&self.robots) {
            return bad(format!(
                "--robots must be 1 to {MAX_ROBOTS}, not {}",
                self.robots
            ));
        }
        if self.duration < Duration::from_secs(10) {
            return bad("--duration must be at least 10 s".into());
        }
        if self.pace.is_some_and(|p| !(p > 0.0 && p.is_finite())) {
            return bad("the pace must be a positive number".into());
        }
        if cfg!(not(feature = "zenoh")) && self.network == NetworkKind::Zenoh {
            return bad(
                "this build has no Zenoh (build slate-demo with the `zenoh` feature)".into(),
            );
        }
        Ok(())
    }
}
