//! Link policies: what a module's `link` blocks (`link team { export ...; report ...;
//! heartbeat ...; }`, compiled by slate-plans) say about one kind of link, and how the ICI
//! applies them: the export part to the export policy (team link), the liveliness part to
//! [`IciConfig`] timing, and the report overrides to that link's own filters
//! (`filter.rs`, [`LinkFilters`](super::filter::LinkFilters)).
//!
//! Send side: an own packet the class's filter let go is offered to the link's filter in
//! [`State::link_filter`] (one call in `flush`), and what a link's filter releases later
//! (trailing edges, heartbeats) goes on that link only, from [`State::link_filter_timers`].
//! Catch-up answers (`catchup.rs`) do not consult the link filters: a `never` attribute
//! still travels in a state answer (left for the team protocol's state requests, step 11).

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;

use slate_model::Packet;
use smallvec::SmallVec;

pub use slate_plans::LinkReport;

use super::classes::ClassSet;
use super::config::IciConfig;
use super::filter::{Due, Key, LinkVerdict, Overrides};
use super::ops::own_packet;
use super::send::Item;
use super::state::State;
use crate::LinkKind;

/// What a module says about one kind of link: the ICI's form of a `link` block
/// ([`slate_plans::LinkPolicy`], converted with `From`).
///
/// ```
/// use slate_ici::{ClassSet, LinkPolicy, LinkReport};
/// use slate_model::{Context, ReportPolicy};
/// let policy = LinkPolicy::default()
///     .export(ClassSet::none().class_in("Robot", &[Context::Self_]))
///     .report("Robot", "heading", LinkReport::Never);
/// assert_eq!(policy.reports.len(), 1);
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LinkPolicy {
    /// What may leave the robot on this link (team link only), united with the export the
    /// ICI was started with.
    pub export: ClassSet,
    /// Filters of this link, by `(class, attribute)`, on top of the class's own; a class's
    /// applies to its subclasses.
    pub reports: BTreeMap<(String, String), LinkReport>,
    /// Replaces the link's heartbeat period if set.
    pub heartbeat: Option<Duration>,
    /// Replaces the link's silence timeout if set.
    pub timeout: Option<Duration>,
}

impl LinkPolicy {
    /// Sets the export policy.
    pub fn export(mut self, export: ClassSet) -> Self {
        self.export = export;
        self
    }

    /// Sets the link's filter of `class.attr`.
    pub fn report(mut self, class: &str, attr: &str, report: LinkReport) -> Self {
        self.reports.insert((class.into(), attr.into()), report);
        self
    }

    /// Applies the export and liveliness parts to `config`: the export (team link only)
    /// is united with `config.export`, heartbeat and timeout replace the link's if set.
    pub fn apply_to(&self, link: LinkKind, config: &mut IciConfig) {
        if link == LinkKind::Team {
            config.export = united(&config.export, &self.export);
        }
        let now = config.link(link);
        let heartbeat = self.heartbeat.unwrap_or(now.heartbeat);
        let timeout = self.timeout.unwrap_or(now.timeout);
        *config = std::mem::take(config).liveliness(link, heartbeat, timeout);
    }

    /// The report overrides as the filters look them up.
    fn overrides(&self) -> Overrides {
        let mut out = Overrides::new();
        for ((class, attr), report) in &self.reports {
            out.entry(Arc::from(class.as_str()))
                .or_default()
                .insert(Arc::from(attr.as_str()), report.clone());
        }
        out
    }
}

impl From<&slate_plans::LinkPolicy> for LinkPolicy {
    fn from(p: &slate_plans::LinkPolicy) -> Self {
        let export = p.export.iter().fold(ClassSet::none(), |set, e| {
            if e.contexts.is_empty() {
                set.class(&e.class)
            } else {
                set.class_in(&e.class, &e.contexts)
            }
        });
        LinkPolicy {
            export,
            reports: p.reports.clone(),
            heartbeat: p.heartbeat,
            timeout: p.timeout,
        }
    }
}

/// The kind of link a `.slate` link name stands for.
pub fn link_kind(name: slate_plans::LinkName) -> LinkKind {
    match name {
        slate_plans::LinkName::Robot => LinkKind::Robot,
        slate_plans::LinkName::Team => LinkKind::Team,
    }
}

/// `a` with `b`'s classes and contexts added.
fn united(a: &ClassSet, b: &ClassSet) -> ClassSet {
    b.rules()
        .iter()
        .fold(a.clone(), |set, (class, mask)| set.with(class, *mask))
}

/// The link policies an ICI was given, with the export it was started with (a policy's
/// export is united with that, not with the previous policy's).
#[derive(Default)]
pub(crate) struct Links {
    started_export: ClassSet,
    policies: BTreeMap<LinkKind, LinkPolicy>,
}

impl Links {
    /// Remembers the export the ICI starts with.
    pub fn new(config: &IciConfig) -> Self {
        Links {
            started_export: config.export.clone(),
            policies: BTreeMap::new(),
        }
    }

    /// The policy of `link`, if one was set.
    pub fn get(&self, link: LinkKind) -> Option<&LinkPolicy> {
        self.policies.get(&link)
    }

    /// Stores `policy` and applies it to the state: export, liveliness, filters.
    /// A changed team export is followed by this module's state for the team, so that
    /// what it wrote before the change stands on the other robots as if it had always
    /// been exported (the answer's object list sweeps what is no longer exported).
    pub fn set(&mut self, st: &mut State, link: LinkKind, policy: LinkPolicy) {
        let before = st.config.export.clone();
        if link == LinkKind::Team {
            st.config.export = self.started_export.clone();
        }
        policy.apply_to(link, &mut st.config);
        // A new timeout may bring a live peer's deadline earlier: walk at the next tick.
        st.timeouts_from = Duration::ZERO;
        // And a dead peer's time to be forgotten (`forget_due`).
        st.forget_from = Duration::ZERO;
        st.filters.set_link(link, policy.overrides());
        self.policies.insert(link, policy);
        if st.config.export != before {
            st.team_export_changed();
        }
    }
}

/// Items released by the links' filters, by link.
type Released = BTreeMap<LinkKind, Vec<Item>>;

impl State {
    /// Keeps off `link` the own values its link policy refuses (`never`) or its filter
    /// holds (sent at the trailing edge by [`Self::link_filter_timers`]). Other modules'
    /// packets (relays) and lifecycle items pass.
    pub(super) fn link_filter(&mut self, link: LinkKind, chosen: &mut SmallVec<[&Item; 8]>) {
        let (now, quiet) = (self.now, self.config.quiet);
        let every = (link == LinkKind::Team)
            .then_some(self.config.team_report_every)
            .flatten();
        let State {
            filters,
            me,
            stats,
            config,
            ..
        } = self;
        let Some(filters) = filters.link_every(link, every) else {
            return;
        };
        let (mut held, mut never) = (0, 0);
        chosen.retain(|item| {
            let Item::Value(s, p) = &**item else {
                return true;
            };
            if p.source != *me {
                return true;
            }
            let key = (s.object.name.clone(), s.attr.clone());
            match filters.offer(&s.lineage, key, p.clone(), now, quiet) {
                LinkVerdict::Send => true,
                // Every update of a lossless class goes: the link's filter would hold
                // some back (its trailing edge then sends the last one again, which
                // receivers already hold). `never` still keeps it off the link.
                LinkVerdict::Held if config.lossless.contains(&s.lineage, s.object.context) => true,
                LinkVerdict::Held => {
                    held += 1;
                    false
                }
                LinkVerdict::Never => {
                    never += 1;
                    false
                }
            }
        });
        stats.reports.held += held;
        stats.reports.suppressed_export += never;
    }

    /// Sends what the links' filters release now (trailing edges, heartbeats), each on
    /// its own link only, to the peers there that want it.
    pub(super) fn link_filter_timers(&mut self) {
        if self.filters.next_link_due().is_none_or(|t| t > self.now) {
            return;
        }
        let mut released = Released::new();
        for (link, due) in self.filters.link_due(self.now) {
            let Some((key, packet)) = self.link_due(link, due) else {
                continue;
            };
            let item = self.value_item(&key.0, &key.1, packet);
            released.entry(link).or_default().extend(item);
        }
        self.tick_again |= !released.is_empty();
        for (link, items) in released {
            let wanted: Vec<&Item> = items.iter().filter(|i| self.wanted_on(link, i)).collect();
            self.emit(link, &wanted);
        }
    }

    /// The packet a link filter's timer sends, if any (a heartbeat of a value that is no
    /// longer this module's sends nothing and stops).
    fn link_due(&mut self, link: LinkKind, due: Due) -> Option<(Key, Packet)> {
        match due {
            Due::Trailing(key, packet) => {
                self.stats.reports.trailing += 1;
                Some((key, packet))
            }
            Due::Heartbeat(key) => {
                let current = own_packet(&self.board, &key).filter(|p| p.source == self.me);
                let now = self.now;
                if let Some(filters) = self.filters.link(link) {
                    filters.sent(&key, current.clone(), now);
                }
                self.stats.reports.heartbeats += u64::from(current.is_some());
                current.map(|p| (key, p))
            }
        }
    }

    /// May a released value go on `link` (export, team link) and does a peer there want
    /// it?
    fn wanted_on(&self, link: LinkKind, item: &Item) -> bool {
        let Item::Value(s, _) = item else {
            return false;
        };
        let export = &self.config.export;
        let exported = link == LinkKind::Robot
            || if s.is_class {
                export.relates_to_class(&s.lineage, &self.catalog)
            } else {
                export.contains(&s.lineage, s.object.context)
            };
        exported
            && self
                .peers
                .iter()
                .filter(|(_, p)| p.up && p.link == link)
                .any(|(a, _)| self.peer_wants_item(a, item))
    }
}
