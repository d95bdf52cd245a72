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
    /// This module is a short-lived observer (the CLI's `get`, `put`, `ls`...): its
    /// hellos say so, and the boards it meets forget it as soon as it leaves instead of
    /// after `forget_dead`, so it leaves no trace (default false).
    pub observer: bool,
}

impl Default for IciConfig {
    fn default() -> Self {
        IciConfig {
            interest: ClassSet::all(),
            export: ClassSet::none(),
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
            observer: false,
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

    /// Sets heartbeat and timeout of one kind of link.
    pub fn liveliness(mut self, link: LinkKind, heartbeat: Duration, timeout: Duration) -> Self {
        *self.link_mut(link) = Liveliness { heartbeat, timeout };
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
