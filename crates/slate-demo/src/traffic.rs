//! What the links carried: bytes per robot radio (the team link) and per robot LAN (the
//! robot link), sampled every second for rates and peaks, and bytes per message kind.
//!
//! On the simulator the bytes are what each transmitter was given to send (retransmissions
//! included); on Zenoh, what each ICI sent. A robot's radio carries all its modules'
//! team-link messages (on a real robot they share one radio): the radio is modelled as
//! a queue emptied at the link's budget, so its air rate never exceeds the budget and a
//! burst shows as a backlog (how long a message would wait to go out).

use std::collections::BTreeMap;

use slate_ici::{LinkKind, MsgKind};

use crate::config::{TeamLink, TeamMedium};
use crate::net::Network;
use crate::summary::TeamChannel;
use crate::team::Team;

/// Bytes per (robot or `base`, link kind), cumulative.
pub(crate) type Counts = BTreeMap<(String, LinkKind), u64>;

/// Rates, peaks and radio backlogs of the demo's links so far (the transport's own
/// per-link counts are the transport's `Traffic`).
#[derive(Clone, Debug, Default)]
pub struct LinkRates {
    last: Counts,
    last_t: f64,
    budget_bps: f64,
    backlog_bits: BTreeMap<String, f64>,
    /// Bytes per second over the last sample, per (robot, link kind): on the air for the
    /// team link, offered for the robot link.
    pub rate: BTreeMap<(String, LinkKind), f64>,
    /// Highest one-second air rate of any one radio on the team link, and whose.
    pub peak_radio_bps: (f64, String),
    /// Highest one-second bit rate offered to any one radio (before queueing).
    pub peak_offered_bps: f64,
    /// Longest backlog of any radio, seconds of transmission.
    pub max_backlog_s: f64,
    /// Highest one-second air rate of all team-link radios together.
    pub peak_channel_bps: f64,
    /// Cumulative bytes at the last sample.
    pub total: Counts,
    /// Team-link bytes before launch (the deck phase; 0 without one).
    pub deck_bytes: u64,
}

impl LinkRates {
    /// Accounting for radios of `budget_bps` bit/s.
    pub fn new(budget_bps: u64) -> LinkRates {
        LinkRates {
            budget_bps: budget_bps.max(1) as f64,
            ..LinkRates::default()
        }
    }

    /// Bits per second on the air over the last sample, all team-link radios together.
    pub fn team_bps(&self) -> f64 {
        self.rate
            .iter()
            .filter(|((_, l), _)| *l == LinkKind::Team)
            .map(|(_, r)| r * 8.0)
            .sum()
    }

    /// Samples the counters at world time `t` (call about once a second).
    pub(crate) fn sample(&mut self, net: &Network, team: &Team, t: f64) {
        let now = counts(net, team);
        let dt = t - self.last_t;
        if dt <= 0.0 {
            return;
        }
        let mut channel = 0.0;
        for (key, bytes) in &now {
            let before = self.last.get(key).copied().unwrap_or(0);
            let offered = bytes.saturating_sub(before) as f64 / dt;
            if key.1 == LinkKind::Robot {
                self.rate.insert(key.clone(), offered);
                continue;
            }
            let air_bps = self.radio(&key.0, offered * 8.0, dt);
            self.rate.insert(key.clone(), air_bps / 8.0);
            channel += air_bps;
            self.peak_offered_bps = self.peak_offered_bps.max(offered * 8.0);
            if air_bps > self.peak_radio_bps.0 {
                self.peak_radio_bps = (air_bps, key.0.clone());
            }
        }
        self.peak_channel_bps = self.peak_channel_bps.max(channel);
        self.total = now.clone();
        self.last = now;
        self.last_t = t;
    }

    /// One radio's queue: `offered_bps` more for `dt` seconds; returns the air rate.
    fn radio(&mut self, robot: &str, offered_bps: f64, dt: f64) -> f64 {
        let backlog = self.backlog_bits.entry(robot.to_owned()).or_default();
        *backlog += offered_bps * dt;
        let sent = backlog.min(self.budget_bps * dt);
        *backlog -= sent;
        self.max_backlog_s = self.max_backlog_s.max(*backlog / self.budget_bps);
        sent / dt
    }

    /// Launch: what the team link carried so far was the deck's ([`Self::deck_bytes`]),
    /// on a radio much faster than the budget, so peaks and backlogs start again here
    /// (call right after a [`Self::sample`] at launch).
    pub(crate) fn launch(&mut self) {
        self.deck_bytes = self.bytes(LinkKind::Team);
        self.backlog_bits.clear();
        self.peak_radio_bps = (0.0, String::new());
        self.peak_offered_bps = 0.0;
        self.max_backlog_s = 0.0;
        self.peak_channel_bps = 0.0;
    }

    /// Total bytes on one kind of link.
    pub fn bytes(&self, link: LinkKind) -> u64 {
        self.total
            .iter()
            .filter(|((_, l), _)| *l == link)
            .map(|(_, b)| b)
            .sum()
    }
}

/// The team link's air as the simulator measured it (`None` on Zenoh).
pub(crate) fn team_channel(net: &Network, link: &TeamLink) -> Option<TeamChannel> {
    let (channel, stats, utilisation) = net.team_channel()?;
    let max_queued = stats
        .radios
        .iter()
        .filter(|((_, l), _)| *l == LinkKind::Team)
        .map(|(_, r)| r.max_queued)
        .max()
        .unwrap_or_default();
    let shared = link.medium == TeamMedium::Acoustic;
    Some(TeamChannel {
        medium: link.medium.name().to_owned(),
        utilisation: shared.then_some(utilisation),
        frames_sent: channel.frames_sent,
        frames_lost: channel.frames_lost,
        largest_frame_bytes: channel.largest_frame,
        largest_message_bytes: channel.largest_message,
        max_queued_seconds: max_queued.as_secs_f64(),
        dropped_msgs: channel.dropped,
    })
}

/// Cumulative bytes per (robot, link kind).
fn counts(net: &Network, team: &Team) -> Counts {
    let mut out = Counts::new();
    if let Some(stats) = net.sim_stats() {
        for ((addr, link), radio) in &stats.radios {
            *out.entry((addr.robot().to_owned(), *link)).or_default() += radio.bytes;
        }
    } else if let Some(modules) = net.module_stats() {
        for s in &modules {
            let robot = s.address.split('/').nth(1).unwrap_or_default();
            for link in LinkKind::ALL {
                let sent = s.link(link.name()).sent_bytes;
                *out.entry((robot.to_owned(), link)).or_default() += sent;
            }
        }
    } else {
        for m in &team.modules {
            for link in LinkKind::ALL {
                let sent = m.node.ici().stats().link(link).sent_bytes;
                *out.entry((m.robot.clone(), link)).or_default() += sent;
            }
        }
    }
    out
}

/// Bytes sent per message kind on one kind of link, by every module's ICI (with module
/// processes, as each last answered `slate stats`' query).
pub(crate) fn by_kind(net: &Network, team: &Team, link: LinkKind) -> BTreeMap<MsgKind, u64> {
    let mut out = BTreeMap::new();
    if let Some(modules) = net.module_stats() {
        let rows = modules.iter().flat_map(|s| s.traffic.iter());
        for row in rows.filter(|r| r.link == link.name() && r.sent_bytes > 0) {
            if let Some(kind) = MsgKind::ALL.into_iter().find(|k| k.name() == row.kind) {
                *out.entry(kind).or_default() += row.sent_bytes;
            }
        }
        return out;
    }
    for m in &team.modules {
        for ((l, kind), t) in m.node.ici().stats().traffic {
            if l == link && t.sent_bytes > 0 {
                *out.entry(kind).or_default() += t.sent_bytes;
            }
        }
    }
    out
}

/// Bytes of the team protocol's repairs sent by every module's ICI (0 with it off).
pub(crate) fn team_repair_bytes(team: &Team) -> u64 {
    let each = team
        .modules
        .iter()
        .map(|m| m.node.ici().stats().team.repair_bytes);
    each.sum()
}

/// The longest any module's message waited in its gateway's queue, seconds (0 with
/// the team protocol off).
pub(crate) fn team_queue_max_seconds(team: &Team) -> f64 {
    let each = team
        .modules
        .iter()
        .map(|m| m.node.ici().stats().team.queue_max_wait);
    each.max().unwrap_or_default().as_secs_f64()
}
