//! What a demo run is asked to do.

use std::net::SocketAddr;
use std::time::Duration;

use crate::net::NetworkKind;

/// The largest team the demo runs: the world grows one strip (a route, obstacles,
/// targets) per robot, and the team link's traffic grows faster than the team, so larger
/// teams are refused rather than left to run for hours.
pub const MAX_ROBOTS: usize = 32;

/// What carries the team link.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TeamMedium {
    /// A radio per module (a robot's five share one in the summary's model): every
    /// transmitter has the whole budget, messages go whole.
    #[default]
    Radio,
    /// One shared half-duplex acoustic channel for the whole team (the paper's narrow
    /// channel): everyone queues behind whoever transmits, messages go as frames of at
    /// most [`ACOUSTIC_FRAME_BYTES`], each lost on its own.
    Acoustic,
}

impl TeamMedium {
    /// `radio` or `acoustic`.
    pub fn name(self) -> &'static str {
        match self {
            TeamMedium::Radio => "radio",
            TeamMedium::Acoustic => "acoustic",
        }
    }

    /// The rate when none is given, bit/s: 9600 for a radio; for the acoustic channel
    /// 80, the WHOI Micro-Modem's lowest rate (the regime of the paper's case).
    pub fn default_bps(self) -> u64 {
        match self {
            TeamMedium::Radio => 9600,
            TeamMedium::Acoustic => 80,
        }
    }
}

/// The largest frame on the acoustic channel, bytes (the Micro-Modem's 80 bit/s frame).
pub const ACOUSTIC_FRAME_BYTES: usize = 32;

/// Airtime every acoustic frame takes besides its bits: preamble, synchronisation and
/// the guard before the next frame. A modelling choice (a quarter second), not a
/// modem's datasheet figure.
pub const ACOUSTIC_FRAME_OVERHEAD: Duration = Duration::from_millis(250);

/// The longest a message waits for the acoustic channel before its sender drops it: a
/// modem's transmit queue holds about a minute of airtime, so an overloaded channel
/// loses messages rather than delivering them hours late. A modelling choice.
pub const ACOUSTIC_MAX_QUEUE: Duration = Duration::from_secs(60);

/// The deck's team link: a fast clean radio, bit/s (the robots are side by side).
pub const DECK_BPS: u64 = 1_000_000;

/// The shortest deck phase: the operator declares the mission ready 3 s into the run
/// (the modules have met), and the plans need a moment to be accepted.
pub const MIN_DECK: Duration = Duration::from_secs(5);

/// The team link between robots: its medium, its declared budget and, on the
/// simulator, its faults.
#[derive(Clone, Debug, PartialEq)]
pub struct TeamLink {
    /// Radios or one acoustic channel.
    pub medium: TeamMedium,
    /// Declared capacity of a transmitter on the team link (of the one shared channel,
    /// for the acoustic medium), bit/s: the simulator caps it; the summary compares the
    /// traffic with it.
    pub budget_bps: u64,
    /// Probability that a transmission (a frame, when framed) is lost (simulator).
    pub loss: f64,
    /// Propagation delay (simulator).
    pub delay: Duration,
    /// Extra random delay, uniform in `[0, jitter]` (simulator; it reorders).
    pub jitter: Duration,
    /// The largest frame, bytes (`None`: a message goes whole).
    pub frame_bytes: Option<usize>,
    /// Airtime of every frame besides its bits.
    pub frame_overhead: Duration,
    /// The longest a message waits for its transmitter before its sender drops it
    /// (`None`: as long as it takes).
    pub max_queue: Option<Duration>,
}

impl Default for TeamLink {
    fn default() -> Self {
        TeamLink::radio(TeamMedium::Radio.default_bps())
    }
}

impl TeamLink {
    /// Radios of `bps` bit/s each: 60 ms delay, up to 40 ms jitter, 5 % loss.
    pub fn radio(bps: u64) -> TeamLink {
        TeamLink {
            medium: TeamMedium::Radio,
            budget_bps: bps,
            loss: 0.05,
            delay: Duration::from_millis(60),
            jitter: Duration::from_millis(40),
            frame_bytes: None,
            frame_overhead: Duration::ZERO,
            max_queue: None,
        }
    }

    /// One shared acoustic channel of `bps` bit/s: 32-byte frames, 20 % frame loss,
    /// 1 to 2 s of latency (1 s delay, up to 1 s jitter), and a transmit queue of
    /// [`ACOUSTIC_MAX_QUEUE`].
    pub fn acoustic(bps: u64) -> TeamLink {
        TeamLink {
            medium: TeamMedium::Acoustic,
            budget_bps: bps,
            loss: 0.2,
            delay: Duration::from_secs(1),
            jitter: Duration::from_secs(1),
            frame_bytes: Some(ACOUSTIC_FRAME_BYTES),
            frame_overhead: ACOUSTIC_FRAME_OVERHEAD,
            max_queue: Some(ACOUSTIC_MAX_QUEUE),
        }
    }

    /// The deck's link before launch, for a mission on `mission`: radios of
    /// [`DECK_BPS`], no loss, cut into the mission link's frames (with no frame
    /// overhead) so that the largest frame the summary reports is the mission link's
    /// whatever the deck carried; frames cost nothing on a clean fast link.
    pub fn deck(mission: &TeamLink) -> TeamLink {
        TeamLink {
            loss: 0.0,
            frame_bytes: mission.frame_bytes,
            ..TeamLink::radio(DECK_BPS)
        }
    }

    /// The medium's link at `bps` (its default rate when `None`).
    pub fn of(medium: TeamMedium, bps: Option<u64>) -> TeamLink {
        let bps = bps.unwrap_or(medium.default_bps());
        match medium {
            TeamMedium::Radio => TeamLink::radio(bps),
            TeamMedium::Acoustic => TeamLink::acoustic(bps),
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
    /// A deck phase this long before launch (`None`: none, the mission starts 3 s into
    /// the run, once the modules have met): the team link is a fast clean radio
    /// ([`TeamLink::deck`]), the console sends the mission plans, and at launch the link
    /// becomes [`Self::team_link`] and the mission runs. The mission's duration, its
    /// deadline and the fault count from launch.
    pub deck: Option<Duration>,
    /// Who speaks on the team link: one gateway per robot (the default,
    /// docs/team-protocol.md) or every module (the per-module protocol of docs/ici.md).
    pub speakers: Speakers,
    /// On Zenoh: a secured team (docs/security.md), with keys made for the run in a
    /// temporary folder, TLS with mutual authentication and the generated access control.
    pub secure: bool,
    /// With [`NetworkKind::Processes`]: where the module processes run (default: all
    /// on 127.0.0.1, in this network namespace).
    pub placement: Placement,
    /// Record the console's board in MCAP to this file (docs/recording.md).
    pub record: Option<std::path::PathBuf>,
    /// Write the console's board as the run ends to this JSON file (the shape of `slate
    /// play --format json`'s `objects`).
    pub final_board: Option<std::path::PathBuf>,
}

/// Where the module processes of `--network processes` run: each robot's modules (the
/// console's: robot `base`) in a network namespace of its own, listening on its
/// address there, as on a machine of their own; the world and the referee (this
/// process) listening on `world`. Robots not named run on 127.0.0.1 here.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Placement {
    /// The IP address this process's world module listens on (default 127.0.0.1).
    pub world: Option<String>,
    /// Robot name → (network namespace, IP address its modules listen on).
    pub robots: std::collections::BTreeMap<String, (String, String)>,
}

/// Who speaks on the team link.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Speakers {
    /// Every module greets, heartbeats and catches up with every module of the other
    /// robots (the protocol in docs/ici.md): its cost grows with the square of the
    /// number of modules.
    Modules,
    /// One gateway per robot relays its modules' exports as one robot stream, repaired by
    /// NACK (`IciConfig::team_protocol`; docs/team-protocol.md).
    #[default]
    Robots,
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
            deck: None,
            speakers: Speakers::default(),
            secure: false,
            placement: Placement::default(),
            record: None,
            final_board: None,
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

    /// Sets the team link.
    pub fn team_link(mut self, link: TeamLink) -> Self {
        self.team_link = link;
        self
    }

    /// Sets who speaks on the team link.
    pub fn speakers(mut self, speakers: Speakers) -> Self {
        self.speakers = speakers;
        self
    }

    /// Runs a secured team (with [`NetworkKind::Zenoh`] only).
    pub fn secure(mut self, secure: bool) -> Self {
        self.secure = secure;
        self
    }

    /// Sets the deck phase before launch.
    pub fn deck(mut self, deck: Option<Duration>) -> Self {
        self.deck = deck;
        self
    }

    /// Seconds from the start of the run to launch (0 without a deck phase).
    pub fn launch_seconds(&self) -> f64 {
        self.deck.map_or(0.0, |d| d.as_secs_f64())
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
        if self.team_link.budget_bps == 0 {
            return bad("--team-rate must be at least 1 bit/s".into());
        }
        if self.team_link.medium == TeamMedium::Acoustic && self.network != NetworkKind::Sim {
            return bad(
                "--team-link acoustic is a simulated channel: use it with --network sim".into(),
            );
        }
        if self.secure && self.network != NetworkKind::Zenoh {
            return bad("--secure secures Zenoh's links: use it with --network zenoh".into());
        }
        if self.network == NetworkKind::Processes && self.deck.is_some() {
            return bad("--network processes runs the mission without --deck (each module's process builds its module as that run does)".into());
        }
        if self.deck.is_some_and(|d| d < MIN_DECK) {
            return bad(format!(
                "--deck must be at least {} s (the mission is declared ready at 3 s)",
                MIN_DECK.as_secs()
            ));
        }
        if self.pace.is_some_and(|p| !(p > 0.0 && p.is_finite())) {
            return bad("the pace must be a positive number".into());
        }
        Ok(())
    }
}
