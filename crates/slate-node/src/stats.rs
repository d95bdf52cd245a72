//! A module's counters for `slate stats`, `slate bw` and launch's checks: what a node
//! answers on its stats key ([`keys::stats`]) and how a tool asks every module for them.
//!
//! A node on Zenoh declares a queryable on `slate/stats/TEAM/ROBOT/MODULE` that answers
//! with its [`ModuleStats`] as JSON: the ICI's cumulative counters and the time since the
//! node started, by the node's own clock. Rates are the difference of two answers divided
//! by the difference of their `uptime_s`, so they do not depend on when the asking tool
//! ran or how long the answers took to arrive.

use std::collections::BTreeSet;
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};
use slate_ici::{CircuitStats, IciStats, LinkKind, MsgKind, Traffic, Transport};
use slate_model::Address;
use slate_zenoh::keys;
use zenoh::Wait;
use zenoh::query::{Query, QueryTarget, Queryable};

use crate::error::ObserveError;
use crate::observer::{OperatorKeys, alive_within, is_observer, open_probe, operator_security};
use crate::view::View;

/// One module's counters, as it answers a stats query. Every count is cumulative since
/// the module started.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ModuleStats {
    /// The module's address, `team/robot/module`.
    pub address: String,
    /// Seconds since the node started, by its own monotonic clock.
    pub uptime_s: f64,
    /// The modules this one hears from (alive, by its ICI's liveliness), observers (the
    /// CLI's short-lived modules) left out.
    pub peers: Vec<String>,
    /// Messages and bytes per link kind and message kind (kinds never seen are left out).
    pub traffic: Vec<TrafficRow>,
    /// What was lost or refused.
    pub drops: Drops,
    /// Catch-ups, as receiver and as source.
    pub catch_up: CatchUps,
    /// Packets received and what they did to the board.
    pub merges: Merges,
    /// Plans received on circuits and what became of them (absent from the answers of
    /// nodes that predate it: zeros).
    #[serde(default)]
    pub plans: Plans,
}

/// Plans sent and received on circuits, and copies sent again (docs/ici.md, "Plan
/// circuits").
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Plans {
    /// Circuits this module opened: plans it sent (its plan engine's sub-plans, or an
    /// operator's through it). Absent from the answers of nodes that predate it: zero.
    #[serde(default)]
    pub sent: u64,
    /// Plans that opened a circuit here.
    pub received: u64,
    /// Loaded and acknowledged `Accepted`.
    pub accepted: u64,
    /// Refused with a reason on their circuit, for any reason.
    pub rejected: u64,
    /// Of those, refused because their sender or origin has no authority to send this
    /// module plans (`[authority] plans_from`).
    pub unauthorised: u64,
    /// Of those, refused because the module was busy loading others.
    pub busy: u64,
    /// Copies of a plan already had, answered with its steps again (never loaded twice).
    #[serde(default)]
    pub answered_again: u64,
    /// Last steps sent again unasked (a link that loses messages may have lost them).
    #[serde(default)]
    pub repeated: u64,
    /// Plans and cancellations this module sent again on its circuits.
    #[serde(default)]
    pub resent: u64,
}

impl Plans {
    /// The counters of a module's plan circuits, `sent` of them opened by it.
    pub fn of(s: &CircuitStats, sent: usize) -> Self {
        Plans {
            sent: u64::try_from(sent).unwrap_or(u64::MAX),
            received: s.received,
            accepted: s.accepted,
            rejected: s.rejected,
            unauthorised: s.unauthorised,
            busy: s.busy,
            answered_again: s.answered_again,
            repeated: s.repeated,
            resent: s.resent,
        }
    }
}

/// Messages and bytes one way and the other on one link kind, of one message kind.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TrafficRow {
    /// `robot` or `team`.
    pub link: String,
    /// The message kind (`report`, `heartbeat`, ... as `MsgKind::name`).
    pub kind: String,
    /// Messages sent.
    pub sent_msgs: u64,
    /// Bytes sent.
    pub sent_bytes: u64,
    /// Messages received.
    pub recv_msgs: u64,
    /// Bytes received.
    pub recv_bytes: u64,
}

/// What was lost or refused (docs/ici.md, "Counters", says when each moves).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Drops {
    /// Sends the transport refused, and packets that could not be encoded.
    pub send_failed: u64,
    /// Received messages that did not decode (slate-wire messages and ICI frames).
    pub undecodable: u64,
    /// Received packets refused: invalid, stamped in the future, stale, about objects
    /// or classes defined differently, past a bound (objects, modules), or for an
    /// `owned` attribute from another module than its owner.
    pub refused: u64,
    /// Duplicate stream messages received (already had).
    pub duplicates: u64,
    /// Messages the team protocol dropped (pending without a gateway, parked, kept
    /// without names past their limits).
    pub team_dropped: u64,
    /// Publications the transport dropped because this module was too far behind to
    /// take them (its receive queue full): the ICI catches up on what they carried.
    #[serde(default)]
    pub behind_dropped: u64,
}

/// Catch-ups (docs/ici.md).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CatchUps {
    /// Gaps found in a source's stream.
    pub gaps: u64,
    /// Requests sent (first tries).
    pub requested: u64,
    /// Requests sent again.
    pub retried: u64,
    /// Answers received in full.
    pub completed: u64,
    /// Requests this module answered.
    pub answered: u64,
}

/// Received packets.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Merges {
    /// Stored on the board.
    pub applied: u64,
    /// The board's packet won.
    pub kept: u64,
}

impl ModuleStats {
    /// The counters of `ici` at `address`, `uptime` after the node started.
    pub fn of(address: &Address, stats: &IciStats, peers: &[Address], uptime: Duration) -> Self {
        ModuleStats {
            address: address.to_string(),
            uptime_s: uptime.as_secs_f64(),
            peers: peers
                .iter()
                .filter(|p| !is_observer(p))
                .map(ToString::to_string)
                .collect(),
            traffic: stats
                .traffic
                .iter()
                .map(|((link, kind), t)| TrafficRow::of(*link, *kind, t))
                .collect(),
            drops: Drops::of(stats),
            catch_up: CatchUps::of(stats),
            merges: Merges {
                applied: stats.merges.applied,
                kept: stats.merges.kept,
            },
            plans: Plans::default(),
        }
    }

    /// Every counter of a node's parts: its ICI, its transport's drops, its plan circuits.
    pub(crate) fn of_view(view: &View, uptime: Duration) -> Self {
        let address = view.board.address();
        let mut stats =
            ModuleStats::of(address, &view.ici.stats(), &view.ici.alive_peers(), uptime);
        stats.drops.behind_dropped = view.transport.stats().behind_dropped;
        stats.plans = Plans::of(&view.circuits.stats(), view.circuits.sent().len());
        stats
    }

    /// Messages and bytes of one link kind (`robot` or `team`), every kind together.
    pub fn link(&self, link: &str) -> TrafficRow {
        let mut total = TrafficRow {
            link: link.to_owned(),
            ..TrafficRow::default()
        };
        self.traffic
            .iter()
            .filter(|r| r.link == link)
            .for_each(|r| total.add(r));
        total
    }
}

impl TrafficRow {
    fn of(link: LinkKind, kind: MsgKind, t: &Traffic) -> Self {
        TrafficRow {
            link: link.name().to_owned(),
            kind: kind.name().to_owned(),
            sent_msgs: t.sent_msgs,
            sent_bytes: t.sent_bytes,
            recv_msgs: t.recv_msgs,
            recv_bytes: t.recv_bytes,
        }
    }

    /// Adds another row's counts to this one.
    pub fn add(&mut self, other: &TrafficRow) {
        self.sent_msgs += other.sent_msgs;
        self.sent_bytes += other.sent_bytes;
        self.recv_msgs += other.recv_msgs;
        self.recv_bytes += other.recv_bytes;
    }
}

impl Drops {
    /// The drops among an ICI's counters.
    pub(crate) fn of(s: &IciStats) -> Self {
        let r = &s.rejects;
        let t = &s.team;
        Drops {
            send_failed: s.reports.send_errors + s.reports.encode_errors,
            undecodable: r.decode.rejected() + r.frames + t.refused,
            refused: r.invalid
                + r.future
                + r.stale
                + r.object_conflicts
                + r.class_conflicts
                + r.over_limit
                + s.merges.not_owner
                + s.merges.unauthorised,
            duplicates: r.duplicates,
            team_dropped: t.pending_dropped + t.parked_dropped + t.undecoded_dropped,
            behind_dropped: 0,
        }
    }
}

impl CatchUps {
    fn of(s: &IciStats) -> Self {
        let c = &s.catch_up;
        CatchUps {
            gaps: c.gaps,
            requested: c.requested,
            retried: c.retried,
            completed: c.completed,
            answered: c.answered,
        }
    }
}

/// Declares the queryable that answers `view`'s counters on its stats key. It holds the
/// view weakly: a query after the node closed goes unanswered.
pub(crate) fn serve(session: &zenoh::Session, view: &Arc<View>) -> zenoh::Result<Queryable<()>> {
    let key = keys::stats(view.board.address());
    let reply_key = key.clone();
    let weak = Arc::downgrade(view);
    let started = Instant::now();
    session
        .declare_queryable(key)
        .callback(move |q: Query| {
            let Some(view) = weak.upgrade() else { return };
            let stats = ModuleStats::of_view(&view, started.elapsed());
            let body = serde_json::to_vec(&stats).unwrap_or_default();
            if let Err(e) = q.reply(reply_key.as_str(), body).wait() {
                tracing::debug!(error = %e, "stats query not answered");
            }
        })
        .wait()
}

/// Which modules a stats query asks: `ADDRESS` (`team/robot/module`), or fewer segments
/// (`team`, `team/robot`) for every module under them. `None`: every team's modules.
pub fn stats_key(filter: Option<&str>) -> Result<String, ObserveError> {
    let Some(filter) = filter else {
        return Ok(keys::stats_of("*", "*", "*"));
    };
    let parts: Vec<&str> = filter.split('/').collect();
    let valid = |p: &&str| {
        !p.is_empty()
            && p.chars()
                .all(|c| c.is_ascii_alphanumeric() || "_-".contains(c))
    };
    if parts.len() > 3 || !parts.iter().all(|p| *p == "*" || valid(p)) {
        return Err(ObserveError::BadFilter {
            filter: filter.to_owned(),
        });
    }
    let segment = |i: usize| parts.get(i).copied().unwrap_or("*");
    Ok(keys::stats_of(segment(0), segment(1), segment(2)))
}

/// Asks the modules reachable through `connect` that match `filter` once for their
/// counters (see [`StatsProbe::sample`]); with an `operator`'s keys on a secured team.
pub fn query_stats(
    connect: &[String],
    filter: Option<&str>,
    wait: Duration,
    operator: Option<&OperatorKeys>,
) -> Result<Vec<ModuleStats>, ObserveError> {
    let probe = StatsProbe::open(connect, filter, wait, operator)?;
    let found = probe.sample();
    probe.close();
    found
}

/// A Zenoh client that asks modules for their counters, again and again (`--watch`)
/// without joining the team: it runs no ICI and leaves nothing on any board.
pub struct StatsProbe {
    probe: Arc<slate_zenoh::ZenohTransport>,
    key: String,
    connect: Vec<String>,
    wait: Duration,
}

impl StatsProbe {
    /// Opens the client; `filter` (see [`stats_key`]) says which modules to ask, `wait`
    /// how long each [`sample`](Self::sample) may wait for them. A secured team's
    /// modules listen only on tls/ endpoints and answer only members: the client then
    /// needs an `operator`'s keys, as every live verb does.
    pub fn open(
        connect: &[String],
        filter: Option<&str>,
        wait: Duration,
        operator: Option<&OperatorKeys>,
    ) -> Result<StatsProbe, ObserveError> {
        let key = stats_key(filter)?;
        let security = operator_security(operator)?;
        let keys = security.zip(operator.map(|k| &k.identity));
        let probe = open_probe(connect, keys)?;
        Ok(StatsProbe {
            probe,
            key,
            connect: connect.to_vec(),
            wait,
        })
    }

    /// Every matching module's counters, sorted by address: once every module alive (by
    /// its liveliness token) has answered, or after `wait` with those that did.
    /// Observers (the CLI's own short-lived modules) are left out. Fails if none answered.
    pub fn sample(&self) -> Result<Vec<ModuleStats>, ObserveError> {
        let deadline = Instant::now() + self.wait;
        let expected: BTreeSet<String> = alive_within(&self.probe, self.wait)
            .iter()
            .filter(|a| !is_observer(a) && matches(&self.key, a))
            .map(ToString::to_string)
            .collect();
        let mut found: Vec<ModuleStats> = Vec::new();
        while Instant::now() < deadline {
            let left = deadline.saturating_duration_since(Instant::now());
            found = ask(&self.probe, &self.key, left.min(Duration::from_secs(1)));
            let have: BTreeSet<&str> = found.iter().map(|s| s.address.as_str()).collect();
            if !found.is_empty() && expected.iter().all(|a| have.contains(a.as_str())) {
                break;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        if found.is_empty() {
            return Err(ObserveError::NoModules {
                endpoints: self.connect.join(", "),
                seconds: self.wait.as_secs_f64(),
            });
        }
        Ok(found)
    }

    /// Leaves the network.
    pub fn close(&self) {
        self.probe.close();
    }
}

impl Drop for StatsProbe {
    fn drop(&mut self) {
        self.close();
    }
}

/// Does the stats key pattern `key` cover `address`'s key?
fn matches(key: &str, address: &Address) -> bool {
    let own = keys::stats(address);
    let (p, k): (Vec<&str>, Vec<&str>) = (key.split('/').collect(), own.split('/').collect());
    p.len() == k.len() && p.iter().zip(&k).all(|(p, k)| *p == "*" || p == k)
}

/// One query on `key`; the answers that parse, observers left out, sorted by address.
fn ask(probe: &slate_zenoh::ZenohTransport, key: &str, timeout: Duration) -> Vec<ModuleStats> {
    // Every matching queryable, one per module (not Zenoh's "best matching" one).
    let Ok(replies) = probe
        .session()
        .get(key)
        .target(QueryTarget::All)
        .timeout(timeout)
        .wait()
    else {
        return Vec::new();
    };
    let mut out: Vec<ModuleStats> = Vec::new();
    while let Ok(reply) = replies.recv() {
        let Ok(sample) = reply.result() else { continue };
        let bytes = sample.payload().to_bytes();
        match serde_json::from_slice::<ModuleStats>(&bytes) {
            Ok(s) if !Address::new(&s.address).is_ok_and(|a| is_observer(&a)) => out.push(s),
            Ok(_) => {}
            Err(e) => tracing::debug!(error = %e, "a stats answer did not parse"),
        }
    }
    out.sort_by(|a, b| a.address.cmp(&b.address));
    out.dedup_by(|a, b| a.address == b.address);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn a(s: &str) -> Address {
        Address::new(s).unwrap()
    }

    #[test]
    fn a_filter_of_fewer_segments_asks_every_module_under_it() {
        assert_eq!(stats_key(None).unwrap(), "slate/stats/*/*/*");
        assert_eq!(stats_key(Some("t")).unwrap(), "slate/stats/t/*/*");
        assert_eq!(stats_key(Some("t/r1")).unwrap(), "slate/stats/t/r1/*");
        let nav = stats_key(Some("t/r1/nav")).unwrap();
        assert!(matches(&nav, &a("t/r1/nav")));
        assert!(!matches(&nav, &a("t/r1/cam")));
        assert!(matches(&stats_key(Some("t")).unwrap(), &a("t/r2/cam")));
    }

    #[test]
    fn a_malformed_filter_is_refused_not_sent() {
        for bad in ["t/r1/nav/x", "t//nav", "t/r 1", "", "slate/**"] {
            assert!(
                matches!(stats_key(Some(bad)), Err(ObserveError::BadFilter { .. })),
                "{bad:?}"
            );
        }
    }

    #[test]
    fn a_link_adds_up_its_kinds() {
        let mut s = IciStats::default();
        s.traffic
            .entry((LinkKind::Team, MsgKind::Report))
            .or_default()
            .sent(10);
        s.traffic
            .entry((LinkKind::Team, MsgKind::Heartbeat))
            .or_default()
            .sent(3);
        s.traffic
            .entry((LinkKind::Robot, MsgKind::Report))
            .or_default()
            .received(7);
        let m = ModuleStats::of(
            &a("t/r1/nav"),
            &s,
            &[a("t/r2/loco")],
            Duration::from_secs(2),
        );
        assert_eq!(m.link("team").sent_bytes, 13);
        assert_eq!(m.link("team").sent_msgs, 2);
        assert_eq!(m.link("robot").recv_bytes, 7);
        assert_eq!(m.peers, ["t/r2/loco"]);
        let back: ModuleStats = serde_json::from_slice(&serde_json::to_vec(&m).unwrap()).unwrap();
        assert_eq!(back, m);
    }
}
