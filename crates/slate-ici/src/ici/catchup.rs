//! Catch-up: a receiver that lost track of a source (a gap, a late join, a restart, a
//! missed name or class) asks for the source's *current* state, not its history. The
//! answer is the packets the source wrote and those of the objects it owns (and every
//! fused estimate it holds), filtered by the receiver's interest and, off the robot,
//! by the export policy; then the list of the objects it owns, so the receiver can
//! create the ones it lacks and delete the ones that are gone.

use std::collections::BTreeSet;
use std::sync::Arc;

use slate_model::{Address, ClassDef, Context, ObjectInfo, Packet, Query, THING};
use slate_wire::{Assertion, CatchUpRequest, Message, ObjectEntry, Report};

use super::classes::ClassSet;
use super::frame::{Frame, Listed, ObjectList};
use super::module::MODULE_CLASS;
use super::state::{Origin, Peer, Request, State};
use crate::{LinkKind, MsgKind};

/// Class definitions per `Classes` message.
const CLASSES_PER_MESSAGE: usize = 32;

/// Who a current state is for.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Audience<'a> {
    /// One peer, by a reliable send (today's catch-up; with the team protocol on, the
    /// robot link and observers).
    Peer(&'a Address),
    /// Every listener of the team, once, through the robot stream (2.6), on behalf of
    /// the robots named (their segments): packets others wrote to objects their
    /// modules own go too.
    Team(&'a [Arc<str>]),
}

impl Audience<'_> {
    /// The link the answer is encoded for.
    fn link(self, me: &Address) -> LinkKind {
        match self {
            Audience::Peer(peer) => LinkKind::between(me, peer),
            Audience::Team(_) => LinkKind::Team,
        }
    }

    /// Is `owner` a module the answer is for (a module of a robot asking)?
    fn owns(self, owner: &Address) -> bool {
        match self {
            Audience::Peer(peer) => owner == peer,
            Audience::Team(robots) => robots.iter().any(|r| **r == *owner.robot()),
        }
    }

    /// The context an object has on the receivers' boards: SELF off its owner's robot
    /// is SYSTEM. A team answer goes to other robots, so this robot's SELF is SYSTEM.
    fn context_of(self, context: Context, owner: &Address, me: &Address) -> Context {
        match self {
            Audience::Peer(peer) => State::context_on(context, owner, peer),
            Audience::Team(_) => {
                let here = LinkKind::between(owner, me) == LinkKind::Robot;
                if here && context == Context::Self_ {
                    Context::System
                } else {
                    context
                }
            }
        }
    }
}

impl State {
    /// Asks `source` for its current state, unless a request that covers this is out.
    pub fn request_catch_up(&mut self, source: &Address, names: bool, classes: bool) {
        if self.refuses_new_module(source) {
            return;
        }
        let now = self.now;
        let p = self.peer(source);
        let prev = p.catch_up;
        if prev.is_some_and(|r| (r.names || !names) && (r.classes || !classes)) {
            return;
        }
        let req = Request {
            since: now,
            names: names || prev.is_some_and(|r| r.names),
            classes: classes || prev.is_some_and(|r| r.classes),
        };
        p.catch_up = Some(req);
        tracing::debug!(me = %self.me, %source, names = req.names, classes = req.classes, at = ?now, "catch-up asked");
        self.catch_up_changed(source);
        self.stats.catch_up.requested += 1;
        self.send_request(source, req);
    }

    /// Sends (or re-sends) a request.
    /// With the team protocol on, a team source is asked through its robot stream
    /// (a `Nack` entry `what = state`), not by a request of its own.
    pub fn send_request(&mut self, source: &Address, req: Request) {
        let names = req.names || !self.decoder.knows(source);
        if self.team_state_ask(source, names, req.classes) {
            return;
        }
        let have = self.peers.get(source).map_or(0, |p| p.stream.have());
        let msg = Message::CatchUpRequest(CatchUpRequest {
            have_seq: have,
            needs_names: req.names || !self.decoder.knows(source),
            needs_classes: req.classes,
        });
        self.send_message(source, &msg);
    }

    /// Encodes a message with the stream encoder of `to`'s link and sends it reliably.
    pub(super) fn send_message(&mut self, to: &Address, msg: &Message) -> bool {
        let link = LinkKind::between(&self.me, to);
        let Some(out) = self.out.get_mut(&link) else {
            return false;
        };
        match out.encoder.encode(msg, &self.catalog.schema) {
            Ok(bytes) => {
                self.send_to(to, MsgKind::of_message(msg), &bytes);
                true
            }
            Err(e) => {
                self.stats.reports.encode_errors += 1;
                tracing::warn!(to = %to, error = %e, "message not encoded");
                false
            }
        }
    }

    // ----- the source's side -----

    /// Answers a request with the current state: at once, unless this module answered
    /// `from` less than its link's heartbeat interval ago, or the answer bytes sent it
    /// are not paid off yet (`max_answer_bytes_per_requester` a second). Then the request
    /// waits (merged with any other that came meanwhile) and one answer goes when both
    /// are over ([`State::deferred_answers`]): a peer that asks again and again, or never
    /// reads what it asked for, costs one current state per interval at most, and a
    /// bounded number of bytes a second.
    pub fn on_request(&mut self, from: &Address, req: CatchUpRequest) {
        let now = self.now;
        if self.peers.get(from).is_some_and(|p| self.answer_waits(p)) {
            self.stats.catch_up.over_budget += u64::from(self.over_budget(from));
            let p = self.peer(from);
            p.deferred = Some(match p.deferred {
                Some(d) => CatchUpRequest {
                    have_seq: d.have_seq.min(req.have_seq),
                    needs_names: d.needs_names || req.needs_names,
                    needs_classes: d.needs_classes || req.needs_classes,
                },
                None => req,
            });
            self.stats.catch_up.deferred += 1;
            self.peer_timers.insert(from.clone());
            tracing::debug!(me = %self.me, %from, at = ?now, "catch-up answer deferred");
            return;
        }
        self.peer(from).answered = Some(now);
        self.answer(from, req);
    }

    /// Must an answer to `p` wait: answered less than their link's heartbeat interval
    /// ago, or the answer bytes sent it not paid off yet?
    fn answer_waits(&self, p: &Peer) -> bool {
        let rate = self.config.max_answer_bytes_per_requester;
        self.answered_lately(p) || p.answer_bytes.owes(self.now, rate)
    }

    /// Does an answer to `from` wait for its answer bytes alone?
    fn over_budget(&self, from: &Address) -> bool {
        let rate = self.config.max_answer_bytes_per_requester;
        self.peers
            .get(from)
            .is_some_and(|p| !self.answered_lately(p) && p.answer_bytes.owes(self.now, rate))
    }

    /// Did this module answer `p` less than their link's heartbeat interval ago?
    fn answered_lately(&self, p: &Peer) -> bool {
        let interval = self.config.link(p.link).heartbeat;
        p.answered
            .is_some_and(|t| self.now.saturating_sub(t) < interval)
    }

    /// The earliest instant at which `p`'s deferred answer may go
    /// ([`Self::deferred_answers`]): once its interval has passed (now, if it has and its
    /// answer bytes still wait to be paid off).
    pub(crate) fn deferred_answer_due(&self, p: &Peer) -> std::time::Duration {
        let interval = self.config.link(p.link).heartbeat;
        match p.answered {
            Some(t) if self.answered_lately(p) => t + interval,
            _ => std::time::Duration::ZERO,
        }
    }

    /// Answers the requests that waited for their peer's interval to pass.
    pub fn deferred_answers(&mut self) {
        let due: Vec<Address> = self
            .peers_with_timers()
            .filter(|(_, p)| p.deferred.is_some() && !self.answer_waits(p))
            .map(|(a, _)| a.clone())
            .collect();
        let now = self.now;
        self.tick_again |= !due.is_empty();
        for peer in due {
            let p = self.peer(&peer);
            let req = p.deferred.take();
            p.answered = Some(now);
            if let Some(req) = req.filter(|_| p.up) {
                tracing::debug!(me = %self.me, %peer, at = ?now, "deferred catch-up answered");
                self.answer(&peer, req);
            }
        }
    }

    /// This module's team export changed: its current state goes to the other robots
    /// as an answer no one asked for (merged with any pending request, with the team
    /// protocol on; to each team peer up, without it). Otherwise what it wrote before
    /// the change would never reach them: reports carry writes only, and no receiver
    /// knows to ask. The answer's object list sweeps what is no longer exported.
    pub(crate) fn team_export_changed(&mut self) {
        if self.config.team_protocol.is_some() {
            return self.team_answer_unasked();
        }
        let peers: Vec<Address> = self
            .peers
            .iter()
            .filter(|(_, p)| p.up && p.link == LinkKind::Team && !p.observer)
            .map(|(a, _)| a.clone())
            .collect();
        for peer in peers {
            self.answer_state(Audience::Peer(&peer), false, false);
        }
    }

    /// Sends `from` the current state.
    fn answer(&mut self, from: &Address, req: CatchUpRequest) {
        tracing::debug!(me = %self.me, %from, at = ?self.now, "catch-up answered");
        self.answer_state(Audience::Peer(from), req.needs_names, req.needs_classes);
    }

    /// Sends `to` the current state (names re-announced, class definitions first, if
    /// asked): the packets, then the object list that completes it.
    pub(super) fn answer_state(&mut self, to: Audience<'_>, names: bool, classes: bool) {
        self.stats.catch_up.answered += 1;
        self.refresh_catalog();
        let link = to.link(&self.me);
        let (items, objects, revision) = self.current_state(to, link);
        // The writes the state holds that are not reported yet are reported now, ahead
        // of the answer, whose position then covers them: were they reported after it,
        // above its position, a receiver would refuse them as older than what the
        // answer brought, and lose every update of a lossless class in between. (Before
        // the names are announced again: the answer must carry them, not a report.)
        self.drain_changes_to(revision);
        if names && let Some(out) = self.out.get_mut(&link) {
            out.encoder.reset_announcements();
        }
        if classes {
            self.send_classes(to);
        }
        let seq = self.out.get(&link).map_or(0, |o| o.seq);
        for chunk in items.chunks(self.config.max_report_items.max(1)) {
            self.send_answer(to, seq, chunk);
        }
        self.send_object_list(to, seq, objects);
    }

    /// Hands a part of an answer on: a reliable send to one peer, or into the robot
    /// stream as a state answer for the whole team.
    fn deliver_answer(&mut self, to: Audience<'_>, kind: MsgKind, bytes: &[u8]) {
        match to {
            Audience::Peer(peer) => {
                let now = self.now;
                let rate = self.config.max_answer_bytes_per_requester;
                self.peer(peer).answer_bytes.charge(bytes.len(), now, rate);
                self.send_to(peer, kind, bytes);
            }
            Audience::Team(_) => self.team_state_out(bytes),
        }
    }

    fn send_classes(&mut self, to: Audience<'_>) {
        let defs: Vec<ClassDef> = self
            .board
            .class_defs()
            .into_iter()
            // Every board has the built-in classes already (and their guarded flags do not
            // travel): sending them could only make a conflict.
            .filter(|d| !slate_model::is_builtin(&d.name))
            .collect();
        for chunk in defs.chunks(CLASSES_PER_MESSAGE) {
            if self.send_encoded(to, &Message::Classes(chunk.to_vec())) {
                self.stats.catch_up.classes_sent += chunk.len() as u64;
            }
        }
    }

    /// Encodes a message with the encoder of `to`'s link and delivers it.
    fn send_encoded(&mut self, to: Audience<'_>, msg: &Message) -> bool {
        let Some(out) = self.out.get_mut(&to.link(&self.me)) else {
            return false;
        };
        match out.encoder.encode(msg, &self.catalog.schema) {
            Ok(bytes) => {
                self.deliver_answer(to, MsgKind::of_message(msg), &bytes);
                true
            }
            Err(e) => {
                self.stats.reports.encode_errors += 1;
                tracing::warn!(error = %e, "message not encoded");
                false
            }
        }
    }

    /// One part of an answer; a part that does not encode is split until the faulty
    /// packet is isolated and dropped.
    pub(super) fn send_answer(&mut self, to: Audience<'_>, seq: u64, items: &[Assertion]) {
        let msg = Message::CatchUpAnswer(Report {
            seq,
            items: items.to_vec(),
        });
        let Some(out) = self.out.get_mut(&to.link(&self.me)) else {
            return;
        };
        match out.encoder.encode(&msg, &self.catalog.schema) {
            Ok(bytes) => self.deliver_answer(to, MsgKind::CatchUpAnswer, &bytes),
            Err(_) if items.len() > 1 => {
                let (a, b) = items.split_at(items.len() / 2);
                self.send_answer(to, seq, a);
                self.send_answer(to, seq, b);
            }
            Err(e) => {
                self.stats.reports.encode_errors += 1;
                tracing::warn!(object = %items[0].object.name, error = %e, "packet left out of a catch-up");
            }
        }
    }

    /// What `to` is to hold of this board: packets, and the objects this board owns,
    /// and the board revision they were read at.
    /// A team answer is filtered by the union of the remote robots' interests (all,
    /// until it is known), so its object list is right for every receiver's sweep.
    fn current_state(
        &self,
        to: Audience<'_>,
        link: LinkKind,
    ) -> (Vec<Assertion>, Vec<Listed>, u64) {
        let interest = match to {
            Audience::Peer(peer) => self.peers.get(peer).and_then(|p| p.interest.clone()),
            Audience::Team(_) => self.team_remote_interest(),
        };
        let interest = interest.unwrap_or_else(ClassSet::all);
        let (mut items, mut objects) = (Vec::new(), Vec::new());
        let snap = self.board.snapshot();
        let revision = snap.revision();
        for id in snap.objects() {
            let Some(info) = snap.info(id) else { continue };
            let entry = ObjectEntry::from(&info);
            if &*entry.class == MODULE_CLASS
                || !self.answer_wants(&interest, link, &info, &entry, to)
            {
                continue;
            }
            let owned = !info.is_class && info.owner == self.me;
            if owned {
                objects.push(self.listing(&info));
            }
            let values = snap.own_values(id).into_iter().map(|(a, p, _)| (a, p));
            for (attr, packet) in values.filter(|(_, p)| self.relays(&info, owned, p, to)) {
                items.push(Assertion {
                    object: entry.clone(),
                    attr,
                    packet,
                });
            }
            for (attr, packet) in self.fusion.estimates(&info.name) {
                items.push(Assertion {
                    object: entry.clone(),
                    attr,
                    packet,
                });
            }
        }
        (items, objects, revision)
    }

    /// Does a catch-up answer to `to` carry this packet? This module's own, all packets
    /// of the objects it owns, and (having no owner to relay them) class-level values and
    /// what a restarted module's previous incarnation wrote; and what others wrote to the
    /// objects `to` owns (a team answer: objects owned by modules of the robots asking):
    /// a restarted owner lost them, and their writer may be gone (an operator's `slate
    /// put`). Never the fusion of a `fused` attribute (its source is unknown): the
    /// estimates go instead.
    fn relays(&self, info: &ObjectInfo, owned: bool, packet: &Packet, to: Audience<'_>) -> bool {
        let ours = packet.source == self.me || owned || info.is_class || self.orphan(packet);
        let theirs = !info.is_class && to.owns(&info.owner) && packet.source != info.owner;
        (ours || theirs) && !packet.source.is_unknown()
    }

    fn listing(&self, info: &ObjectInfo) -> Listed {
        Listed {
            name: info.name.clone(),
            class: info.class.clone(),
            fingerprint: self.catalog.schema.fingerprint(&info.class).unwrap_or(0),
            context: info.context,
        }
    }

    fn answer_wants(
        &self,
        interest: &ClassSet,
        link: LinkKind,
        info: &ObjectInfo,
        entry: &ObjectEntry,
        to: Audience<'_>,
    ) -> bool {
        let Some(lineage) = self.catalog.lineage(&entry.class) else {
            return false;
        };
        let export = &self.config.export;
        let team = link == LinkKind::Team;
        if info.is_class {
            return interest.relates_to_class(&lineage, &self.catalog)
                && (!team || export.relates_to_class(&lineage, &self.catalog));
        }
        let context = to.context_of(info.context, &info.owner, &self.me);
        interest.contains(&lineage, context) && (!team || export.contains(&lineage, info.context))
    }

    /// Was the packet written by a previous incarnation of a module that restarted?
    pub fn orphan(&self, packet: &Packet) -> bool {
        self.before_incarnation(&packet.source, packet.timestamp)
    }

    /// Re-publishes what a restarted module's previous incarnation wrote, as this board
    /// holds it: the module itself no longer has it, and some boards may have missed it.
    pub fn relay_orphans(&mut self, source: &Address) {
        let mut found = Vec::new();
        {
            let snap = self.board.snapshot();
            for id in snap.objects() {
                let Some(name) = snap.name_of(id) else {
                    continue;
                };
                for (attr, packet, _) in snap.own_values(id) {
                    if packet.source == *source && self.orphan(&packet) {
                        found.push((name.clone(), attr, packet));
                    }
                }
                for (attr, packet) in self.fusion.estimates(&name) {
                    if packet.source == *source && self.orphan(&packet) {
                        found.push((name.clone(), attr, packet));
                    }
                }
            }
        }
        let items: Vec<_> = found
            .into_iter()
            .filter_map(|(o, a, p)| self.value_item(&o, &a, p))
            .collect();
        self.flush(&items);
    }

    /// Ends the answer with the owned objects, cut to fit one message if need be.
    fn send_object_list(&mut self, to: Audience<'_>, seq: u64, mut objects: Vec<Listed>) {
        let stamp = self.board.clock().now();
        let mut complete = objects.len() <= slate_wire::MAX_ITEMS;
        objects.truncate(slate_wire::MAX_ITEMS);
        loop {
            let list = ObjectList {
                seq,
                stamp,
                complete,
                objects: objects.clone(),
            };
            let bytes = Frame::ObjectList(list).encode();
            if bytes.len() <= slate_wire::MAX_MESSAGE_BYTES || objects.is_empty() {
                self.deliver_answer(to, MsgKind::ObjectList, &bytes);
                return;
            }
            complete = false;
            objects.truncate(objects.len() / 2);
        }
    }

    // ----- the receiver's side -----

    /// The end of an answer: complete the catch-up, create what is listed, sweep what
    /// is not. If a part of the answer was refused, ask again instead.
    pub fn on_object_list(&mut self, from: &Address, list: ObjectList) {
        let now = self.now;
        if self.before_incarnation(from, list.stamp) {
            self.stats.rejects.stale += 1;
            return;
        }
        let p = self.peer(from);
        // Does this list answer the request outstanding (made before the list was)?
        let pending = p.catch_up;
        let current = pending.is_none_or(|r| list.stamp.physical() >= r.since);
        if current {
            p.catch_up = None;
        } else {
            tracing::debug!(%from, at = ?now, stamp = ?list.stamp, "an answer made before the request outstanding");
        }
        if std::mem::take(&mut p.failed) {
            if current {
                let (names, classes) = pending.map_or((true, false), |r| (r.names, r.classes));
                self.request_catch_up(from, names, classes);
            }
            return;
        }
        p.stream.caught_up(list.seq, now);
        p.caught_up = true;
        tracing::debug!(me = %self.me, %from, objects = list.objects.len(), at = ?now, "caught up");
        self.catch_up_changed(from);
        self.stats.catch_up.completed += 1;
        for l in &list.objects {
            self.listed(
                from,
                l,
                Origin {
                    seq: Some(list.seq),
                    stamp: list.stamp,
                },
            );
        }
        if list.complete {
            self.sweep(from, &list);
        }
        self.release_plans(from);
    }

    /// Deletes the objects `from` owns that this board models but the list does not
    /// hold, unless this board heard of them after the list was made. An object heard
    /// of from another module after the list was made is checked again with a new list.
    fn sweep(&mut self, from: &Address, list: &ObjectList) {
        let listed: BTreeSet<&str> = list.objects.iter().map(|l| &*l.name).collect();
        let query = Query::class(THING).owner(from.clone());
        let ids = self.board.query(&query).unwrap_or_default();
        let names: Vec<Arc<str>> = ids
            .into_iter()
            .filter_map(|id| self.board.name_of(id))
            .collect();
        let mut recheck = false;
        for name in names.into_iter().filter(|n| !listed.contains(&**n)) {
            let origin = self.origins.get(&name).copied();
            let newer = origin.is_some_and(|o| match o.seq {
                Some(seq) => seq > list.seq,
                None => o.stamp >= list.stamp,
            });
            recheck |= newer && origin.is_some_and(|o| o.seq.is_none());
            if !newer && self.models(&name) {
                self.remote_delete(from, name, list.stamp);
            }
        }
        if recheck {
            self.request_catch_up(from, false, false);
        }
    }

    /// Does this board model the object it holds under `name`?
    fn models(&mut self, name: &str) -> bool {
        let Some(info) = self.board.info(name) else {
            return false;
        };
        let Some(lineage) = self.lineage(&info.class) else {
            return false;
        };
        self.config.interest.contains(&lineage, info.context)
    }
}

#[cfg(test)]
mod tests {
    use slate_testing::addr;

    use super::*;

    #[test]
    fn a_deferred_request_is_answered_once_its_interval_is_over_by_the_timers_alone() {
        use super::super::team::test_state::{START, alone};
        let (_net, mut st) = alone("t/r1/nav", crate::IciConfig::default());
        let from = addr("t/r1/cam");
        st.now = START;
        st.peer(&from).up = true;
        st.on_request(&from, CatchUpRequest::default());
        st.on_request(&from, CatchUpRequest::default());
        let stats = |st: &State| (st.stats.catch_up.answered, st.stats.catch_up.deferred);
        assert_eq!(stats(&st), (1, 1));
        assert!(st.peers[&from].hello_unanswered.is_none(), "no other timer");
        let due = st.deferred_answer_due(&st.peers[&from]);
        assert!(st.next_tick() <= due, "the timers know the answer is due");
        st.now = due;
        st.tick();
        assert_eq!(stats(&st), (2, 1), "answered by the tick");
    }

    #[test]
    fn a_team_answer_relays_others_packets_on_objects_of_every_robot_asking() {
        let robots: Vec<Arc<str>> = vec!["r1".into(), "r2".into()];
        let team = Audience::Team(&robots);
        assert!(team.owns(&addr("t/r1/m0")));
        assert!(team.owns(&addr("t/r2/m5")));
        assert!(!team.owns(&addr("t/r3/m0")), "a robot that did not ask");
    }

    #[test]
    fn a_peer_answer_relays_others_packets_on_objects_of_that_peer_only() {
        let peer = addr("t/r1/m0");
        let to = Audience::Peer(&peer);
        assert!(to.owns(&peer));
        assert!(!to.owns(&addr("t/r1/m1")));
    }

    #[test]
    fn this_robots_self_objects_are_system_in_a_team_answer() {
        let me = addr("t/r0/m0");
        let team = Audience::Team(&[]);
        let own = team.context_of(Context::Self_, &addr("t/r0/m1"), &me);
        assert_eq!(own, Context::System);
        let held = team.context_of(Context::Surroundings, &addr("t/r0/m1"), &me);
        assert_eq!(held, Context::Surroundings);
        assert_eq!(team.link(&me), LinkKind::Team);
    }
}
