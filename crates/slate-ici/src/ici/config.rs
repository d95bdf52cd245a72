//! How an ICI behaves: interest, export policy, liveliness and timing.

use std::time::Duration;

use super::classes::ClassSet;
use crate::LinkKind;

/// Heartbeat and timeout of one kind of link.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Liveliness {
    /// How often the module publishes a heartbeat on this kind of link.
    pub heartbeat: Duration,
    /// A peer not heard from for this long is dead (its `Module` object's `alive` goes false).
    pub timeout: Duration,
}

/// The settings of an [`Ici`](crate::Ici).
///
/// ```
/// use slate_ici::{ClassSet, IciConfig, LinkKind};
/// use std::time::Duration;
/// let config = IciConfig::default()
///     .interest(ClassSet::none().class("Vehicle").class("Obstacle"))
///     .export(ClassSet::none().class("Vehicle"))
///     .liveliness(LinkKind::Team, Duration::from_secs(2), Duration::from_secs(10));
/// assert_eq!(config.team.timeout, Duration::from_secs(10));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct IciConfig {
    /// What this board models: only these classes (and contexts, as they are on this
    /// board) are sent to it and applied. Default: everything.
    pub interest: ClassSet,
    /// What may leave the robot on the team link (by class and context on this board);
    /// the robot link carries everything its receivers are interested in. Default:
    /// nothing.
    pub export: ClassSet,
    /// What this module's receivers must get every update of, not only the latest
    /// state (events, counts, a log): reports of these classes (by class and context on
    /// this board) are published with [`Flow::Every`](crate::Flow), so a receiver that
    /// cannot keep up slows this module's writes down instead of losing them, and the
    /// links' report filters do not hold them back (a link's `never` still keeps them
    /// off it; a class's own `report` options still apply).
    /// Default: nothing. docs/ici.md, *A class that needs every update*.
    pub lossless: ClassSet,
    /// Liveliness on the robot link (default: heartbeat 250 ms, timeout 1 s).
    pub robot: Liveliness,
    /// Liveliness on the team link (default: heartbeat 1 s, timeout 5 s).
    pub team: Liveliness,
    /// A value held back by a dead-band or accuracy filter is sent once it has not
    /// changed for this long (default 1 s).
    pub quiet: Duration,
    /// A gap in a source's stream must stay open this long before a catch-up is asked
    /// for: reordered messages fill most gaps (default 300 ms).
    pub gap_grace: Duration,
    /// A catch-up request not answered within this is sent again (default 3 s).
    pub catch_up_retry: Duration,
    /// Most packets in one report (default 128); bigger batches are split.
    pub max_report_items: usize,
    /// Deleted objects remembered (tombstones) to refuse stale packets (default 4096).
    pub max_tombstones: usize,
    /// A module dead for this long is forgotten: its `Module` object is deleted and what
    /// this ICI knew of it dropped, so modules that come and go (the CLI's observers) do
    /// not grow the board without bound (default 10 min). It is found again, like any
    /// new module, if it comes back.
    pub forget_dead: Duration,
    /// The most sources whose name dictionaries the decoder keeps (default 4096,
    /// `slate_wire::MAX_SOURCES`); past it, the one heard least recently gives up its
    /// slot (and is asked for its names again if it is still alive).
    pub max_sources: usize,
    /// The most objects another module may own on this board (default 4096): past it,
    /// what it creates is refused, counted (`rejects.over_limit`) and an event
    /// (`BoardEvent::ObjectLimit`), so one module cannot grow this board without bound.
    pub max_objects_per_source: usize,
    /// The most objects other modules may own on this board together (default 32 768).
    pub max_objects: usize,
    /// The most modules this ICI keeps track of (default 1024): a message or a
    /// liveliness token from a new address past it is refused and counted, so made-up
    /// addresses cannot grow the board's `Module` objects without bound.
    pub max_modules: usize,
    /// The most names one module's messages may make this ICI hold (default 16 384,
    /// `slate_wire::MAX_NAMES_PER_SOURCE`; objects, attributes, classes and addresses
    /// together): a message announcing names past it is refused, counted
    /// (`rejects.over_limit`) and an event (`BoardEvent::NameLimit`), so that one module
    /// cannot fill the decoder's dictionaries (up to 4 x 65 536 names of 1 KiB each).
    pub max_names_per_source: usize,
    /// The most names all modules' messages together may make this ICI hold (default
    /// 262 144, `slate_wire::MAX_NAMES`; at least `max_names_per_source`): past it, the
    /// modules heard least recently give up their names (counted as `decode.evicted`),
    /// and announce them again when next they speak, so that `max_sources` modules
    /// cannot make it hold `max_names_per_source` names each.
    pub max_names: usize,
    /// The most bytes of catch-up answers this module sends one requester a second, on
    /// average (default 64 KiB): an answer goes whole, and the requester's next waits
    /// until the bytes sent are paid off at this rate (counted as
    /// `catch_up.over_budget`), so that one asking in a loop cannot make this module
    /// send without bound (a 3-byte request draws the whole current state).
    pub max_answer_bytes_per_requester: u64,
    /// This module is a short-lived observer (the CLI's `get`, `put`, `ls`...): its
    /// hellos say so, and the boards it meets forget it as soon as it leaves instead of
    /// after `forget_dead`, so it leaves no trace (default false).
    pub observer: bool,
    /// The team protocol of docs/team-protocol.md (one speaker per robot on the team
    /// link): `Some` turns it on with these settings; `None` (the default) keeps the
    /// per-module team protocol of docs/ici.md. A switch while the new path is built.
    pub team_protocol: Option<TeamProtocol>,
    /// The team link's own minimum interval between two reports of one of this module's
    /// attributes (`None`, the default: every value goes at once). A value written
    /// sooner is held and sent when the interval ends (trailing edge), so the last one
    /// always arrives; an attribute the team link policy gives a filter of its own
    /// (`link team { report ... }`) keeps that one. A radio pays a frame's headers for
    /// every report (docs/performance.md, *Bytes on the radio*): `slate node` sets 200 ms.
    pub team_report_every: Option<Duration>,
    /// Reports of own writes that come within this long of the previous report wait
    /// for the end of it and go together, in one message (default 50 µs): a writer
    /// faster than that pays one message, and its receivers one, for many updates,
    /// while a write after a quiet spell (a control loop's, a ping's) goes at once.
    /// A write of a lossless class does not wait (its writer waits for room itself).
    /// Zero: every write's report goes at once. On a manual clock (the simulator),
    /// where time stands still between writes, it is off (docs/ici.md).
    pub linger: Duration,
}

/// Whether a member listens to the team link itself (docs/team-protocol.md, 2.1).
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Listen {
    /// When its interest meets a class another robot exports.
    Auto,
    /// Always.
    Always,
    /// Never: it gets what it models from its robot's gateway.
    Never,
}

/// The settings of the team protocol (docs/team-protocol.md, section 4 step 7). The
/// robot heartbeat's idle period and the robot silence timeout are
/// [`IciConfig::team`]. Presets: [`TeamProtocol::radio`], [`TeamProtocol::acoustic`].
#[derive(Clone, Debug, PartialEq)]
pub struct TeamProtocol {
    /// The rank of this module in its robot's gateway election (lowest first, ties by
    /// address); `None`: never gateway.
    pub priority: Option<u8>,
    /// Whether this module listens to the team link.
    pub listen: Listen,
    /// The largest frame the gateway publishes, in bytes.
    pub mtu: usize,
    /// How long the gateway holds an open frame after its first message.
    pub batch: Duration,
    /// A gap in a robot stream stays open this long before it is NACKed.
    pub gap_grace: Duration,
    /// The upper bound of the NACK's random back-off.
    pub nack_backoff: Duration,
    /// How long a NACK round waits for its repair.
    pub repair_wait: Duration,
    /// How long the gateway gathers NACKs before it repairs.
    pub repair_gather: Duration,
    /// Positions repaired this recently are not repaired again.
    pub repair_holdoff: Duration,
    /// The most positions of one stream a receiver NACKs; more asks for state.
    pub max_nack_frames: u64,
    /// State requests for one member are merged over this interval.
    pub answer_interval: Duration,
    /// The gateway says its robot hello at most this often.
    pub hello_min_interval: Duration,
    /// The history's byte limit.
    pub history_bytes: usize,
    /// The history's age limit.
    pub history_age: Duration,
    /// The gateway's token bucket rate, in bits per second.
    pub rate_bps: u32,
    /// Every this many robot heartbeats is a full one (all members' inner positions).
    pub full_every: u32,
    /// Bytes of recent frames of each remote stream a listening gateway keeps, to
    /// answer its members' `Want`s.
    pub foreign_cache: usize,
}

impl TeamProtocol {
    /// The radio preset (9600 bit/s, about 100 ms one way, 5 % loss).
    pub fn radio() -> Self {
        TeamProtocol {
            priority: Some(0),
            listen: Listen::Auto,
            mtu: 1024,
            batch: Duration::from_millis(250),
            gap_grace: Duration::from_millis(100),
            nack_backoff: Duration::from_millis(300),
            repair_wait: Duration::from_secs(1),
            repair_gather: Duration::from_millis(50),
            repair_holdoff: Duration::from_millis(300),
            max_nack_frames: 64,
            answer_interval: Duration::from_secs(2),
            hello_min_interval: Duration::from_secs(1),
            history_bytes: 64 * 1024,
            history_age: Duration::from_secs(60),
            rate_bps: 9600 * 8 / 10,
            full_every: 30,
            foreign_cache: 16 * 1024,
        }
    }

    /// The acoustic preset (32-byte modem frames, 400 bit/s, 1-2 s one way).
    pub fn acoustic() -> Self {
        TeamProtocol {
            mtu: 32,
            batch: Duration::from_secs(2),
            gap_grace: Duration::from_secs(1),
            nack_backoff: Duration::from_secs(4),
            repair_wait: Duration::from_secs(10),
            repair_gather: Duration::from_secs(1),
            repair_holdoff: Duration::from_secs(4),
            answer_interval: Duration::from_secs(30),
            hello_min_interval: Duration::from_secs(30),
            history_bytes: 4 * 1024,
            history_age: Duration::from_secs(600),
            rate_bps: 400 * 7 / 10,
            full_every: 5,
            ..TeamProtocol::radio()
        }
    }

    /// Sets the election priority (`None`: never gateway).
    pub fn priority(mut self, priority: Option<u8>) -> Self {
        self.priority = priority;
        self
    }
}

impl Default for IciConfig {
    fn default() -> Self {
        IciConfig {
            interest: ClassSet::all(),
            export: ClassSet::none(),
            lossless: ClassSet::none(),
            robot: Liveliness {
                heartbeat: Duration::from_millis(250),
                timeout: Duration::from_secs(1),
            },
            team: Liveliness {
                heartbeat: Duration::from_secs(1),
                timeout: Duration::from_secs(5),
            },
            quiet: Duration::from_secs(1),
            gap_grace: Duration::from_millis(300),
            catch_up_retry: Duration::from_secs(3),
            max_report_items: 128,
            max_tombstones: 4096,
            forget_dead: Duration::from_secs(600),
            max_sources: slate_wire::MAX_SOURCES,
            max_objects_per_source: 4096,
            max_objects: 32_768,
            max_modules: 1024,
            max_names_per_source: slate_wire::MAX_NAMES_PER_SOURCE,
            max_names: slate_wire::MAX_NAMES,
            max_answer_bytes_per_requester: 64 * 1024,
            observer: false,
            team_protocol: None,
            team_report_every: None,
            linger: Duration::from_micros(50),
        }
    }
}

impl IciConfig {
    /// Sets the interest.
    pub fn interest(mut self, interest: ClassSet) -> Self {
        self.interest = interest;
        self
    }

    /// Sets the export policy.
    pub fn export(mut self, export: ClassSet) -> Self {
        self.export = export;
        self
    }

    /// Sets the classes whose every update is sent ([`IciConfig::lossless`]).
    pub fn lossless(mut self, lossless: ClassSet) -> Self {
        self.lossless = lossless;
        self
    }

    /// Sets heartbeat and timeout of one kind of link.
    pub fn liveliness(mut self, link: LinkKind, heartbeat: Duration, timeout: Duration) -> Self {
        *self.link_mut(link) = Liveliness { heartbeat, timeout };
        self
    }

    /// Sets the team link's minimum interval between reports of one attribute
    /// ([`IciConfig::team_report_every`]; `None`: none).
    pub fn team_report_every(mut self, every: Option<Duration>) -> Self {
        self.team_report_every = every;
        self
    }

    /// Sets the quiet period of value filters.
    pub fn quiet(mut self, quiet: Duration) -> Self {
        self.quiet = quiet;
        self
    }

    /// Sets how long a dead module is remembered.
    pub fn forget_dead(mut self, after: Duration) -> Self {
        self.forget_dead = after;
        self
    }

    /// Makes this module a short-lived observer, forgotten as soon as it leaves.
    pub fn observer(mut self, observer: bool) -> Self {
        self.observer = observer;
        self
    }

    /// Turns the team protocol on with these settings (`None`: off).
    pub fn team_protocol(mut self, team_protocol: Option<TeamProtocol>) -> Self {
        self.team_protocol = team_protocol;
        self
    }

    /// Liveliness settings of one kind of link.
    pub fn link(&self, link: LinkKind) -> Liveliness {
        match link {
            LinkKind::Robot => self.robot,
            LinkKind::Team => self.team,
        }
    }

    fn link_mut(&mut self, link: LinkKind) -> &mut Liveliness {
        match link {
            LinkKind::Robot => &mut self.robot,
            LinkKind::Team => &mut self.team,
        }
    }
}
