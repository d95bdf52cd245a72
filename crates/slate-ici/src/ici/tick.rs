//! Timers, run on every tick of the clock: held values at their trailing edge,
//! attribute heartbeats, module heartbeats, liveliness timeouts, catch-up retries and
//! gaps that stayed open.

use std::time::Duration;

use slate_model::Address;
use slate_wire::{Heartbeat, Message};

use super::classes::ClassSet;
use super::filter::Due;
use super::frame::{Frame, Hello};
use super::ops::BoardOp;
use super::ops::own_packet;
use super::state::{Peer, State};
use super::team::catch_up_retry;
use crate::{LinkKind, MsgKind};

/// Silence after which a transport's down is believed: 2.25 heartbeat periods of the
/// peer's link, two heartbeats missed and a quarter period for their delivery. At 30 %
/// loss one lost heartbeat is common (a one-period rule marked healthy modules dead when
/// Zenoh withdrew a token meanwhile); two in a row less than a third as often (9 %). A
/// robot that died is seen dead after 2.25 s of silence on the team link (1 s heartbeat),
/// or its lease if longer. Exact in nanoseconds, so the timers and the rule agree.
pub(crate) fn down_believed_after(heartbeat: Duration) -> Duration {
    heartbeat * 9 / 4
}

/// How long after a transport's down a message from the module is still taken as sent
/// before it (a quarter of a heartbeat gap: the delivery allowance of
/// [`down_believed_after`]); one heard later shows the down false.
pub(crate) fn down_overtaken_by(heartbeat: Duration) -> Duration {
    heartbeat / 4
}

/// A team link on which a module has said nothing but heartbeats for this many periods
/// is idle: its heartbeats go this many periods apart (1 s grows to 4 s), and receivers
/// stretch the wait before believing its down by as much and its timeout to at least
/// [`IDLE_TIMEOUT_GAPS`] gaps, so a silence takes eight missed heartbeats to kill
/// (docs/ici.md, *Liveliness*). The robot link does not back off: it is cheap, and a
/// robot's own modules rely on its fast detection.
pub(crate) const TEAM_IDLE_PERIODS: u32 = 4;

/// An idle peer's timeout is at least this many of its heartbeat gaps (32 s for 4 s
/// gaps). Five, the library's busy team link's count (5 s for 1 s), was too few: five
/// heartbeats lost in a row come once in about 400 at 30 % loss, and marked healthy
/// idle modules dead on real links; eight, once in about 15 000.
pub(crate) const IDLE_TIMEOUT_GAPS: u32 = 8;

/// A heartbeat gap on `link` of heartbeat `period`: the period, or
/// [`TEAM_IDLE_PERIODS`] of them on an idle team link.
fn idle_gap(link: LinkKind, period: Duration, idle: bool) -> Duration {
    if idle && link == LinkKind::Team {
        period * TEAM_IDLE_PERIODS
    } else {
        period
    }
}

impl State {
    /// Runs whatever is due at `self.now`.
    pub fn tick(&mut self) {
        self.tick_again = false;
        self.flush_lingering();
        self.filter_timers();
        self.heartbeats();
        self.team_tick();
        self.timeouts();
        self.forget_dead();
        self.catch_up_timers();
        self.held_plan_timers();
        self.deferred_answers();
        self.hello_timers();
        self.prune_peer_timers();
    }

    /// The peers of [`State::peer_timers`] (a hello unanswered or an answer deferred, or
    /// neither since the last tick), in the peers' order.
    pub(crate) fn peers_with_timers(&self) -> impl Iterator<Item = (&Address, &Peer)> {
        let peers = &self.peers;
        self.peer_timers
            .iter()
            .filter_map(move |a| peers.get_key_value(a))
    }

    /// Drops from [`State::peer_timers`] the peers gone or with neither timer left.
    fn prune_peer_timers(&mut self) {
        let peers = &self.peers;
        self.peer_timers.retain(|a| {
            peers
                .get(a)
                .is_some_and(|p| p.hello_unanswered.is_some() || p.deferred.is_some())
        });
    }

    /// The earliest instant at which [`tick`](Self::tick) (and the link filters'
    /// timers) may have something to do, if nothing reaches this module before: no
    /// message, no peer's up or down, no change of its board, no call. A tick before it
    /// changes nothing, so a manual clock's move before it need not run the timers
    /// (`Ticker`). Each timer's own due time, or now when one just acted on what a
    /// timer before it in the tick reads (`tick_again`) or cannot say when it will act.
    pub(crate) fn next_tick(&self) -> Duration {
        if self.tick_again {
            return Duration::ZERO;
        }
        let never = Duration::MAX;
        let heartbeat = LinkKind::ALL.into_iter().map(|link| {
            let next = self.next_heartbeat.get(&link);
            next.copied().unwrap_or(Duration::ZERO)
        });
        let filters = [self.filters.next_due(), self.filters.next_link_due()];
        let mut next = heartbeat
            .chain(filters.into_iter().map(|t| t.unwrap_or(never)))
            .min()
            .unwrap_or(never)
            .min(self.timeouts_from)
            .min(self.catch_up_next_tick())
            .min(self.plans_held_from)
            .min(self.team_next_tick());
        next = next.min(self.forget_from);
        for (_, p) in self.peers_with_timers() {
            if let Some(due) = self.hello_due(p) {
                next = next.min(due);
            }
            if p.deferred.is_some() {
                next = next.min(self.deferred_answer_due(p));
            }
        }
        next
    }

    /// When [`Self::catch_up_timers`] next acts if nothing reaches this module: a gap
    /// that waits for its robot's stream (`catch_up_from` is past while one does) waits
    /// for a message that repairs that stream, and that message ticks the module.
    fn catch_up_next_tick(&self) -> Duration {
        match self.catch_up_from > self.now {
            true => self.catch_up_from,
            false => self.catch_up_unheld_from,
        }
    }

    /// Says hello again to the peers that have not answered: a message sent before the
    /// peer's subscriptions reached this module's network is lost without a trace. The
    /// wait doubles with every try, from the link kind's heartbeat interval up to eight
    /// times that (a slow radio's queue must not fill with hellos).
    fn hello_timers(&mut self) {
        let now = self.now;
        let unanswered: Vec<(Address, u32)> = self
            .peers_with_timers()
            .filter(|(_, p)| self.hello_due(p).is_some_and(|due| now >= due))
            .filter_map(|(a, p)| Some((a.clone(), p.hello_unanswered?.1)))
            .collect();
        self.tick_again |= !unanswered.is_empty();
        for (peer, tries) in unanswered {
            self.stats.liveliness.hellos_resent += 1;
            self.hello(&peer, false);
            // (Already in `peer_timers`: it came from there.)
            self.peer(&peer).hello_unanswered = Some((now, tries + 1));
        }
    }

    /// Lets go the plans held for a catch-up that did not complete within the link's
    /// timeout (`recv.rs`, `holds_plans_of`): they are loaded as they are.
    fn held_plan_timers(&mut self) {
        let now = self.now;
        if now < self.plans_held_from {
            return;
        }
        let mut next = Duration::MAX;
        let mut expired = Vec::new();
        for (a, p) in &self.peers {
            let Some(until) = p.hold_plans_until.filter(|_| !p.held_plans.is_empty()) else {
                continue;
            };
            match until <= now {
                true => expired.push(a.clone()),
                false => next = next.min(until),
            }
        }
        self.plans_held_from = next;
        self.tick_again |= !expired.is_empty();
        for peer in expired {
            let held = self.peers[&peer].held_plans.len() as u64;
            self.stats.catch_up.plans_hold_expired += held;
            tracing::debug!(me = %self.me, %peer, held, "plans held for a catch-up that did not come: loaded as they are");
            self.release_plans(&peer);
        }
    }

    fn filter_timers(&mut self) {
        if self.filters.next_due().is_none_or(|t| t > self.now) {
            return;
        }
        let due = self.filters.due(self.now);
        let mut items = Vec::new();
        for d in due {
            let (key, packet) = match d {
                Due::Trailing(key, packet) => {
                    self.stats.reports.trailing += 1;
                    (key, packet)
                }
                Due::Heartbeat(key) => {
                    let current = own_packet(&self.board, &key).filter(|p| p.source == self.me);
                    self.filters.sent(&key, current.clone(), self.now);
                    let Some(packet) = current else { continue };
                    self.stats.reports.heartbeats += 1;
                    (key, packet)
                }
            };
            items.extend(self.value_item(&key.0, &key.1, packet));
        }
        self.flush(&items);
    }

    /// Publishes this module's heartbeat on each link kind where it is due and someone
    /// listens: its stream position, so receivers find a lost tail.
    fn heartbeats(&mut self) {
        for link in LinkKind::ALL {
            let due = self
                .next_heartbeat
                .get(&link)
                .is_none_or(|t| *t <= self.now);
            if !due {
                continue;
            }
            let next = self.now + self.heartbeat_gap(link);
            self.next_heartbeat.insert(link, next);
            // With the team protocol on, the robot heartbeat replaces the module's.
            if self.robot_speaks_on(link) || !self.has_up_peer(link) {
                continue;
            }
            let hb = self.heartbeat(link);
            let Some(out) = self.out.get_mut(&link) else {
                continue;
            };
            if let Ok(bytes) = out
                .encoder
                .encode(&Message::Heartbeat(hb), &self.catalog.schema)
            {
                self.stats.liveliness.heartbeats_sent += 1;
                self.publish(link, MsgKind::Heartbeat, &bytes);
            }
        }
    }

    /// The wait before this module's next heartbeat on `link`: its period, or
    /// [`TEAM_IDLE_PERIODS`] of them while the link is idle (nothing else said for as
    /// many periods).
    fn heartbeat_gap(&self, link: LinkKind) -> Duration {
        let said = self.out.get(&link).map_or(Duration::ZERO, |o| o.said);
        let period = self.config.link(link).heartbeat;
        let idle = self.now.saturating_sub(said) >= period * TEAM_IDLE_PERIODS;
        idle_gap(link, period, idle)
    }

    /// Something other than a heartbeat is published on `link`: the link is busy, and
    /// its next heartbeat comes within one period, on the grid of periods its idle gap
    /// was counted in (a busy link's heartbeats keep the times they had).
    pub(crate) fn said(&mut self, link: LinkKind) {
        let (now, period) = (self.now, self.config.link(link).heartbeat);
        if let Some(o) = self.out.get_mut(&link) {
            o.said = now;
        }
        let next = self.next_heartbeat.entry(link).or_insert(now);
        let ahead = next.saturating_sub(now);
        if !period.is_zero() && ahead > period {
            let whole = (ahead.as_nanos() - 1) / period.as_nanos();
            let back = u64::try_from(whole * period.as_nanos()).unwrap_or(u64::MAX);
            *next = next.saturating_sub(Duration::from_nanos(back));
        }
    }

    /// Something other than a heartbeat is heard from `from`: it is held to its link's
    /// own timeout again, which can bring its deadline nearer.
    pub(crate) fn heard_saying(&mut self, from: &Address) {
        let now = self.now;
        let p = self.peer(from);
        p.said = now;
        if p.alive == Some(true) {
            let deadline = self.deadline(&self.peers[from]);
            self.timeouts_from = self.timeouts_from.min(deadline);
        }
    }

    /// The longest gap between `p`'s heartbeats, as far as this module can tell: its
    /// link's period, or the idle gap once `p` has been heard only by heartbeats for one
    /// period less than [`TEAM_IDLE_PERIODS`] (the sender goes idle at the full count: a
    /// receiver that missed what the sender said judges it idle sooner, never later, and
    /// errs towards patience).
    fn expected_gap(&self, p: &Peer) -> Duration {
        let period = self.config.link(p.link).heartbeat;
        let quiet = p.last_heard.saturating_sub(p.said);
        let idle = quiet >= period * (TEAM_IDLE_PERIODS - 1);
        idle_gap(p.link, period, idle)
    }

    /// `p`'s timeout: its link's, and at least [`IDLE_TIMEOUT_GAPS`] of its heartbeat
    /// gaps while they are stretched ([`Self::expected_gap`]).
    fn timeout_of(&self, p: &Peer) -> Duration {
        let (link, gap) = (self.config.link(p.link), self.expected_gap(p));
        if gap > link.heartbeat {
            link.timeout.max(gap * IDLE_TIMEOUT_GAPS)
        } else {
            link.timeout
        }
    }

    fn heartbeat(&self, link: LinkKind) -> Heartbeat {
        let total = |sent: bool| {
            self.stats
                .traffic
                .values()
                .map(|t| if sent { t.sent_msgs } else { t.recv_msgs })
                .sum()
        };
        let decode = self.decoder.stats();
        Heartbeat {
            seq: self.out.get(&link).map_or(0, |o| o.seq),
            sent: total(true),
            received: total(false),
            rejected: decode.rejected() + self.stats.rejects.frames,
        }
    }

    /// Has `p` been silent past its timeout ([`Self::timeout_of`])?
    fn silent(&self, p: &Peer) -> bool {
        self.now >= self.silent_deadline(p)
    }

    /// Has the transport said `p` went down, with nothing heard from it since, and has it
    /// been silent for [`down_believed_after`] its heartbeat gap ([`Self::expected_gap`])?
    fn down_believed(&self, p: &Peer) -> bool {
        self.down_deadline(p).is_some_and(|at| self.now >= at)
    }

    /// The first instant at which `p`, silent since it was last heard, is past its
    /// timeout ([`Self::timeout_of`]); never, if this module cannot hear it
    /// ([`Self::deaf_to`]).
    fn silent_deadline(&self, p: &Peer) -> Duration {
        if self.deaf_to(p) {
            return Duration::MAX;
        }
        let timeout = self.timeout_of(p);
        p.last_heard
            .saturating_add(timeout)
            .saturating_add(Duration::from_nanos(1))
    }

    /// Does this module hear nothing `p` says on its own? A member that does not listen
    /// to the team link (the team protocol's `Listen`) hears no other robot's module, so
    /// their silence says nothing about them: only the transport's down is believed. (Held
    /// dead by silence, every remote module was lost on such a member, and its names with
    /// it: the next message it did get was refused, and its whole state asked for.)
    fn deaf_to(&self, p: &Peer) -> bool {
        p.link == LinkKind::Team && self.team.listening == Some(false)
    }

    /// The first instant at which the transport's down is believed ([`Self::down_believed`]),
    /// if it said `p` went down and nothing was heard from it since, but what came within
    /// [`down_overtaken_by`] of the down: a module's last messages, sent before it withdrew
    /// its token, can arrive just after its down (Zenoh sends declarations ahead of data).
    fn down_deadline(&self, p: &Peer) -> Option<Duration> {
        let gap = self.expected_gap(p);
        p.down_at
            .filter(|at| p.last_heard <= at.saturating_add(down_overtaken_by(gap)))
            .map(|_| p.last_heard.saturating_add(down_believed_after(gap)))
    }

    /// No earlier than this instant may `p` be found dead if it stays silent.
    pub(super) fn deadline(&self, p: &Peer) -> Duration {
        let silent = self.silent_deadline(p);
        self.down_deadline(p).map_or(silent, |d| d.min(silent))
    }

    /// Peers silent past their link's timeout, or down and silent for
    /// [`down_believed_after`] their link's heartbeat, are dead. The peers are walked only once
    /// the earliest deadline of a live peer has come (`timeouts_from`): hearing a peer
    /// only moves its deadline later, and a peer found alive or said down lowers it.
    fn timeouts(&mut self) {
        if self.now < self.timeouts_from {
            return;
        }
        let mut dead = Vec::new();
        let mut next = Duration::MAX;
        for (a, p) in self.peers.iter().filter(|(_, p)| p.alive == Some(true)) {
            if self.silent(p) || self.down_believed(p) {
                dead.push(a.clone());
            } else {
                next = next.min(self.deadline(p));
            }
        }
        self.timeouts_from = next;
        self.tick_again |= !dead.is_empty();
        for peer in dead {
            self.lost(&peer);
        }
    }

    /// When a dead peer `p` is forgotten: once it is down or silent past its timeout,
    /// and (but an observer, forgotten at once) `forget_dead` after it was last heard.
    fn forget_due(&self, p: &Peer) -> Duration {
        let gone = if p.up {
            self.silent_deadline(p)
        } else {
            Duration::ZERO
        };
        let forgotten = match p.observer {
            true => Duration::ZERO,
            false => p
                .last_heard
                .saturating_add(self.config.forget_dead)
                .saturating_add(Duration::from_nanos(1)),
        };
        gone.max(forgotten)
    }

    /// When the hello an up peer has not answered goes again: the link's heartbeat
    /// interval after it was sent, doubled with every try up to eight times that.
    fn hello_due(&self, p: &Peer) -> Option<Duration> {
        let (sent, tries) = p.hello_unanswered.filter(|_| p.up)?;
        let wait = self.config.link(p.link).heartbeat * (1 << tries.min(3));
        Some(sent.saturating_add(wait))
    }

    /// Forgets the modules dead (and gone) for longer than `forget_dead`, and observers
    /// as soon as they are: their `Module` object is deleted and their entry
    /// (incarnation, stream, names) dropped, so a board holds a bounded number of dead
    /// modules however many came and went, and none that only looked. Gone: the
    /// transport says it is down, or it has been silent past its link's timeout (a
    /// message still in flight when it left shows it up again, and no down follows).
    /// Walks only the dead (`State::dead`), in the peers' order, and only once the
    /// earliest of them is due (`State::forget_from`).
    fn forget_dead(&mut self) {
        let now = self.now;
        if now < self.forget_from {
            return;
        }
        let mut gone = Vec::new();
        let mut next = Duration::MAX;
        for (a, p) in self
            .dead
            .iter()
            .filter_map(|a| Some((a, self.peers.get(a)?)))
        {
            match self.forget_due(p) {
                due if now >= due => gone.push(a.clone()),
                due => next = next.min(due),
            }
        }
        self.forget_from = next;
        self.tick_again |= !gone.is_empty();
        for peer in gone {
            self.decoder.forget(&peer);
            self.dead.remove(&peer);
            self.peers.remove(&peer);
            self.stats.liveliness.forgotten += 1;
            self.ops.push(BoardOp::ForgetModule(peer));
        }
    }

    /// A peer is dead (timeout or the transport's word). Its names stay in the decoder
    /// until it is forgotten (`forget_dead`; an observer at once): a module held dead a
    /// while (a partition, heartbeats stuck behind a radio's backlog) whose later messages
    /// use names it announced before is heard again without asking for its whole state.
    pub fn lost(&mut self, peer: &Address) {
        if let Some(p) = self.peers.get(peer) {
            let silent = self.now.saturating_sub(p.last_heard);
            let down_after_silence = p.down_at.map(|d| d.saturating_sub(p.last_heard));
            tracing::debug!(me = %self.me, %peer, at = ?self.now, ?silent, ?down_after_silence, "module lost");
        }
        self.stats.liveliness.lost += 1;
        self.set_alive(peer, false);
        self.plans.push(super::PlanEvent::Peer(peer.clone(), false));
    }

    /// Re-sends unanswered requests; asks for a catch-up where a gap stayed open. One
    /// walk over the peers finds what is due (a lookup per peer, and the gapped robots'
    /// test for every peer, were the simulator's largest cost at 8 robots); the sends
    /// follow in the peers' order, as they were found.
    fn catch_up_timers(&mut self) {
        let (now, grace) = (self.now, self.config.gap_grace);
        if now < self.catch_up_from {
            return;
        }
        // A member's inner gap waits while its robot stream is being repaired.
        let gapped = self.team_gapped_robots();
        let mut due = Vec::new();
        let (mut next, mut unheld) = (Duration::MAX, Duration::MAX);
        for (a, p) in self.peers.iter_mut() {
            if p.catch_up.is_none() && p.stream.gap_since().is_none() {
                continue; // nothing is or becomes due for it (`catch_up_due`)
            }
            let retry = match p.catch_up {
                Some(_) => catch_up_retry(&self.config, &self.me, a),
                None => Duration::ZERO, // not read
            };
            match p.catch_up {
                Some(_) if !p.up => p.catch_up = None,
                Some(mut r) if now.saturating_sub(r.since) >= retry => {
                    r.since = now;
                    p.catch_up = Some(r);
                    due.push((a.clone(), Some(r)));
                }
                Some(_) => {}
                None if p.up
                    && p.stream.gap_age(now).is_some_and(|age| age >= grace)
                    && !gapped.holds(a) =>
                {
                    due.push((a.clone(), None));
                }
                None => {}
            }
            if let Some(at) = catch_up_due(p, retry, grace) {
                next = next.min(at);
                if p.catch_up.is_some() || !gapped.holds(a) {
                    unheld = unheld.min(at);
                }
            }
        }
        // The sends below lower both for the requests they make.
        (self.catch_up_from, self.catch_up_unheld_from) = (next, unheld);
        self.tick_again |= !due.is_empty();
        for (a, retried) in due {
            match retried {
                Some(r) => {
                    self.stats.catch_up.retried += 1;
                    tracing::debug!(me = %self.me, source = %a, at = ?self.now, "catch-up asked again: no answer yet");
                    self.send_request(&a, r);
                }
                None => {
                    self.stats.catch_up.gaps += 1;
                    self.request_catch_up(&a, false, false);
                }
            }
        }
    }

    /// A peer came up or went down, as the transport says. Up is news: greet it and
    /// catch up. Down stops what waits on the peer (its catch-up), and is believed only
    /// once the ICI has heard nothing from the peer for [`down_believed_after`] its link's
    /// heartbeat (now or at a later tick, if nothing is heard after the down):
    /// a transport's down can be false while the peer's messages still arrive (Zenoh
    /// withdraws a liveliness token when a session or route elsewhere fails, and slate's
    /// Zenoh transport says down for a peer that falls behind). A peer still heard stays
    /// alive until it has been silent past its link's timeout ([`timeouts`]).
    /// Liveliness is what the ICI hears (docs/ici.md, *Liveliness*).
    ///
    /// [`timeouts`]: Self::timeouts
    pub fn on_peer(&mut self, peer: &Address, up: bool) {
        if self.refuses_new_module(peer) {
            return;
        }
        let now = self.now;
        // Down, a dead peer is forgotten sooner (`forget_due`).
        self.forget_from = Duration::ZERO;
        let p = self.peer(peer);
        p.up = up;
        p.catch_up = None;
        if !up {
            p.down_at = Some(now);
            let silent = now.saturating_sub(p.last_heard);
            tracing::debug!(me = %self.me, %peer, at = ?now, ?silent, "the transport says down");
            let p = &self.peers[peer];
            if p.alive == Some(true) && self.down_believed(p) {
                self.lost(peer);
            } else {
                // Believed later, if nothing is heard: no later than `timeouts` looks.
                let deadline = self.deadline(p);
                self.timeouts_from = self.timeouts_from.min(deadline);
            }
            return;
        }
        p.down_at = None;
        p.last_heard = now;
        self.catch_up_changed(peer);
        let p = self.peer(peer);
        if p.alive != Some(true) {
            tracing::debug!(me = %self.me, %peer, at = ?now, "module found");
            self.stats.liveliness.found += 1;
            self.set_alive(peer, true);
            self.plans.push(super::PlanEvent::Peer(peer.clone(), true));
        }
        if self.robot_speaks_on(LinkKind::between(&self.me, peer)) {
            // Liveliness only: no per-pair hello or catch-up on the team link (a
            // receiver that lacks the robot hello NACKs it).
            return;
        }
        self.send_hello(peer);
        self.request_catch_up(peer, false, false);
    }

    /// Tells a peer this module's incarnation and interest, until it answers. With the
    /// team protocol on, a team peer learns them from the robot hello instead.
    pub fn send_hello(&mut self, to: &Address) {
        if self.robot_speaks_on(LinkKind::between(&self.me, to)) {
            return self.team_hello_changed();
        }
        let now = self.now;
        self.peer(to).hello_unanswered = Some((now, 0));
        self.peer_timers.insert(to.clone());
        self.hello(to, false);
    }

    /// Sends a hello, or a reply to the peer's (an acknowledgement: without the
    /// interest, which the peer learns from this module's own hello).
    pub fn hello(&mut self, to: &Address, reply: bool) {
        let interest = if reply {
            ClassSet::none()
        } else {
            self.config.interest.clone()
        };
        let (priority, listener) = self.election_flags(to);
        let hello = Hello {
            incarnation: self.incarnation,
            interest,
            reply,
            observer: self.config.observer,
            priority,
            listener,
        };
        self.send_to(to, MsgKind::Hello, &Frame::Hello(hello).encode());
    }

    /// What a hello to `to` says for the gateway election: only on the robot link and
    /// with the team protocol on (otherwise the hello is as before step 7).
    fn election_flags(&self, to: &Address) -> (Option<u8>, bool) {
        let Some(protocol) = &self.config.team_protocol else {
            return (None, false);
        };
        if LinkKind::between(&self.me, to) != LinkKind::Robot {
            return (None, false);
        }
        let listener = protocol.listen != crate::ici::Listen::Never;
        (protocol.priority, listener)
    }
}

/// When [`State::catch_up_timers`] has something to do for `p`: drop a request to a peer
/// that is down (at once), send an unanswered request again, or ask where a gap stayed
/// open. `None`: nothing, until something changes.
fn catch_up_due(p: &Peer, retry: Duration, grace: Duration) -> Option<Duration> {
    match p.catch_up {
        Some(_) if !p.up => Some(Duration::ZERO),
        Some(r) => Some(r.since.saturating_add(retry)),
        None if p.up => p.stream.gap_since().map(|s| s.saturating_add(grace)),
        None => None,
    }
}

impl State {
    /// `peer`'s catch-up or stream changed (a request made, a position taken or
    /// announced, it came up): what it now makes due lowers `catch_up_from`.
    pub(crate) fn catch_up_changed(&mut self, peer: &Address) {
        let retry = catch_up_retry(&self.config, &self.me, peer);
        let grace = self.config.gap_grace;
        if let Some(at) = self
            .peers
            .get(peer)
            .and_then(|p| catch_up_due(p, retry, grace))
        {
            self.catch_up_from = self.catch_up_from.min(at);
            self.catch_up_unheld_from = self.catch_up_unheld_from.min(at);
        }
    }
}
