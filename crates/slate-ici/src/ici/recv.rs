//! Incoming: decode, check interest and tombstones, create objects on receipt, and
//! queue merges (or fusion) for the board.

use std::collections::BTreeSet;
use std::sync::Arc;
use std::time::Duration;

use slate_model::{
    Address, ClassDef, Context, DefineError, MergePolicy, NewObject, Packet, Timestamp,
};
use slate_wire::{Assertion, DecodeError, Heartbeat, Message, ObjectEntry, Report};

use super::frame::{Frame, Hello, Lifecycle, Listed};
use super::module::MODULE_CLASS;
use super::ops::BoardOp;
use super::state::{Known, Origin, State};
use super::stream::Inbound;
use crate::{LinkKind, MsgKind};

/// Plan messages held per sender while this board catches up with it, at most
/// (`hold_plan`).
const MAX_HELD_PLANS: usize = 16;

impl State {
    /// A message from `from`. Team frames and repairs are counted by inner kind when
    /// they are decoded (`on_team`), so the messages inside them count once.
    pub fn on_message(&mut self, from: &Address, bytes: &[u8]) {
        let kind = MsgKind::of(bytes);
        if !matches!(kind, MsgKind::TeamFrame | MsgKind::TeamRepair) {
            self.stats
                .received(LinkKind::between(&self.me, from), kind, bytes.len());
        }
        self.on_inner(from, kind, bytes);
    }

    /// A message from `from`, counted already (by itself, or as part of its team frame).
    pub(crate) fn on_inner(&mut self, from: &Address, kind: MsgKind, bytes: &[u8]) {
        if *from == self.me || self.refuses_new_module(from) {
            return;
        }
        self.heard(from);
        if kind != MsgKind::Heartbeat {
            self.heard_saying(from);
        }
        match kind {
            MsgKind::Hello | MsgKind::Lifecycle | MsgKind::ObjectList => self.on_frame(from, bytes),
            k if super::team::is_team_kind(k) => self.on_team(from, bytes),
            _ => self.on_wire(from, kind, bytes),
        }
    }

    /// Anything from a peer shows it alive.
    pub(crate) fn heard(&mut self, from: &Address) {
        let now = self.now;
        let timeout = self.config.link(LinkKind::between(&self.me, from)).timeout;
        let p = self.peer(from);
        p.last_heard = now;
        let came_up = !std::mem::replace(&mut p.up, true);
        let alive = p.alive == Some(true);
        let fresh = alive && now.saturating_sub(p.seen_written) < timeout / 2;
        if came_up {
            self.catch_up_changed(from);
        }
        if fresh {
            return;
        }
        if !alive {
            self.stats.liveliness.found += 1;
            self.plans.push(super::PlanEvent::Peer(from.clone(), true));
        }
        self.set_alive(from, true);
    }

    /// Writes a peer's `Module` object.
    pub fn set_alive(&mut self, peer: &Address, alive: bool) {
        let now = self.now;
        let p = self.peer(peer);
        p.alive = Some(alive);
        p.seen_written = now;
        let last_seen = p.last_heard;
        if alive {
            let deadline = self.deadline(&self.peers[peer]);
            self.timeouts_from = self.timeouts_from.min(deadline);
            self.dead.remove(peer);
        } else {
            self.dead.insert(peer.clone());
            self.forget_from = Duration::ZERO;
        }
        self.ops.push(BoardOp::Module {
            peer: peer.clone(),
            alive,
            last_seen,
        });
    }

    fn on_frame(&mut self, from: &Address, bytes: &[u8]) {
        match Frame::decode(bytes) {
            Ok(Frame::Hello(h)) => self.on_hello(from, h),
            Ok(Frame::Lifecycle(l)) => self.on_lifecycle(from, l),
            Ok(Frame::ObjectList(o)) => self.on_object_list(from, o),
            Err(e) => {
                self.stats.rejects.frames += 1;
                tracing::debug!(from = %from, error = %e, "frame refused");
            }
        }
    }

    pub(super) fn on_wire(&mut self, from: &Address, kind: MsgKind, bytes: &[u8]) {
        let msg = match self.decode(from, bytes) {
            Ok(msg) => msg,
            Err(DecodeError::UnknownName { .. }) if self.keep_undecoded(from, kind, bytes) => {
                return;
            }
            Err(e) => return self.decode_failed(from, kind, &e),
        };
        match msg {
            Message::Report(r) => self.on_report(from, r),
            Message::CatchUpAnswer(r) => self.apply_items(from, r.items, None),
            Message::Classes(defs) => self.on_classes(from, defs),
            Message::CatchUpRequest(req) => self.on_request(from, req),
            Message::Heartbeat(h) => self.on_heartbeat(from, h),
            Message::Names(_) => {}
            plan @ (Message::Plan(_) | Message::PlanCancel { .. }) if self.holds_plans_of(from) => {
                self.hold_plan(from, plan);
            }
            plan @ (Message::Plan(_) | Message::PlanAck(_) | Message::PlanCancel { .. }) => {
                if let Message::Plan(p) = &plan {
                    tracing::debug!(me = %self.me, %from, circuit = p.circuit, "plan received");
                }
                self.plans
                    .push(super::PlanEvent::Message(from.clone(), plan));
            }
        }
    }

    /// Must a plan from `from` wait for this board to catch up with it? A plan may name
    /// its sender's objects, which a board learns by catching up with the sender: one
    /// that arrives first (sent as this module appeared, or sent again to it after a
    /// restart, both just before the sender answers its catch-up) would be rejected for
    /// a name it was about to know. So it waits, in order with the sender's other plan
    /// messages, until the catch-up completes, or at most the link's timeout (then it
    /// goes as it is). Only where catch-up is per pair: with the team protocol on, a team
    /// peer's state comes through its robot's stream.
    fn holds_plans_of(&self, from: &Address) -> bool {
        if self.robot_speaks_on(LinkKind::between(&self.me, from)) {
            return false;
        }
        let now = self.now;
        self.peers
            .get(from)
            .is_some_and(|p| !p.caught_up && p.hold_plans_until.is_none_or(|until| now < until))
    }

    fn hold_plan(&mut self, from: &Address, plan: Message) {
        let now = self.now;
        let timeout = self.config.link(LinkKind::between(&self.me, from)).timeout;
        let me = self.me.clone();
        let p = self.peer(from);
        p.hold_plans_until.get_or_insert(now + timeout);
        p.held_plans.push(plan);
        tracing::debug!(%me, %from, held = p.held_plans.len(), at = ?now, "plan held until this board has caught up with its sender");
        let full = p.held_plans.len() >= MAX_HELD_PLANS;
        self.stats.catch_up.plans_held += 1;
        self.plans_held_from = self.plans_held_from.min(now + timeout);
        if full {
            // A sender of that many plans at once is not waiting for its state to
            // arrive: they go (to the plans' own bounded queue) rather than pile up here.
            self.release_plans(from);
        }
    }

    /// Lets `from`'s held plan messages go, in the order they came.
    pub(super) fn release_plans(&mut self, from: &Address) {
        let Some(p) = self.peers.get_mut(from) else {
            return;
        };
        for plan in std::mem::take(&mut p.held_plans) {
            self.plans
                .push(super::PlanEvent::Message(from.clone(), plan));
        }
    }

    /// Decodes against the catalog, refreshed once if the board has learned a class.
    fn decode(&mut self, from: &Address, bytes: &[u8]) -> Result<Message, DecodeError> {
        let msg = match self.decoder.decode(from, bytes, &self.catalog.schema) {
            Err(DecodeError::SchemaMismatch { class, .. }) if !self.catalog.knows(&class) => {
                self.refresh_catalog();
                self.decoder.decode(from, bytes, &self.catalog.schema)
            }
            other => other,
        };
        self.warn_if_evicted_alive();
        msg
    }

    /// The decoder's table of sources is full of live modules if it had to evict one
    /// this board holds alive (dead modules' names are dropped when they are forgotten):
    /// say so.
    fn warn_if_evicted_alive(&mut self) {
        let Some(gone) = self.decoder.take_evicted() else {
            return;
        };
        if self.peers.get(&gone).is_some_and(|p| p.alive == Some(true)) {
            tracing::warn!(
                evicted = %gone,
                max = self.config.max_sources,
                "more live modules than the decoder holds names for: the one heard least \
                 recently must announce its names again (fewer modules per team, or raise \
                 the ICI's max_sources)"
            );
        }
    }

    /// A refused message: ask its source for what was missing (names, classes).
    fn decode_failed(&mut self, from: &Address, kind: MsgKind, e: &DecodeError) {
        tracing::debug!(me = %self.me, %from, %kind, error = %e, at = ?self.now, "message refused");
        let (names, classes) = match e {
            DecodeError::UnknownName { .. } => (true, false),
            DecodeError::SchemaMismatch { class, .. } => (false, !self.conflicts_with(from, class)),
            DecodeError::TooManyNames { .. } => return self.refuse_names(from),
            _ => return,
        };
        if !(names || classes) {
            return;
        }
        if kind == MsgKind::CatchUpAnswer {
            self.peer(from).failed = true;
        }
        self.request_catch_up(from, names, classes);
    }

    fn on_report(&mut self, from: &Address, r: Report) {
        let old = r
            .items
            .iter()
            .any(|a| a.packet.source == *from && self.before_incarnation(from, a.packet.timestamp));
        if old {
            // A late message of the source's previous incarnation: its names may have
            // replaced the new incarnation's in the decoder, so start those afresh.
            self.stats.rejects.stale += 1;
            self.decoder.forget(from);
            self.request_catch_up(from, true, false);
            return;
        }
        let newest = r
            .items
            .iter()
            .filter(|a| a.packet.source == *from)
            .map(|a| a.packet.timestamp)
            .max();
        if self.take_position(from, r.seq, newest) {
            self.apply_items(from, r.items, Some(r.seq));
        }
    }

    fn on_heartbeat(&mut self, from: &Address, h: Heartbeat) {
        let now = self.now;
        let p = self.peer(from);
        p.stream.announce(h.seq, now);
        p.top = p.top.max(h.seq);
        self.catch_up_changed(from);
    }

    fn on_hello(&mut self, from: &Address, hello: Hello) {
        if self
            .peer(from)
            .incarnation
            .is_some_and(|i| hello.incarnation < i)
        {
            // A late hello of the incarnation before a restart.
            self.stats.rejects.stale += 1;
            return;
        }
        // Replies say it too: an observer's own hello may be lost, and it may be gone
        // before it says hello again.
        self.peer(from).observer = hello.observer;
        // A dead observer is forgotten at once (`forget_due`).
        self.forget_from = Duration::ZERO;
        if !hello.reply {
            let p = self.peer(from);
            p.priority = hello.priority;
            p.listener = hello.listener;
        }
        if hello.reply {
            // It heard this module's hello; what else it says of itself came with its own.
            self.peer(from).hello_unanswered = None;
            return;
        }
        self.hello(from, true);
        let restarted = self.take_incarnation(from, hello.incarnation);
        let p = self.peer(from);
        let new_interest = p.interest.as_ref() != Some(&hello.interest);
        p.interest = Some(hello.interest);
        if new_interest && p.link == LinkKind::Robot {
            // A member's interest is part of its robot's hello.
            self.team_hello_changed();
        }
        if restarted {
            self.member_restarted(from);
            // The new incarnation knows nothing of this module yet (a restart quick
            // enough not to show as the peer going down tells no one to say hello).
            self.send_hello(from);
            self.request_catch_up(from, true, false);
            self.relay_orphans(from);
        }
    }

    /// Takes a source's incarnation (from its hello, or its robot's): did it restart?
    /// Another incarnation than the one heard before; or the first heard from a source
    /// whose stream this board followed before that incarnation began (the previous
    /// incarnation's hellos were lost): its positions and the objects heard on it must
    /// not stand for the new incarnation's.
    pub(crate) fn take_incarnation(&mut self, from: &Address, incarnation: u64) -> bool {
        let p = self.peer(from);
        let restarted = match p.incarnation {
            Some(i) => i != incarnation,
            None => p.newest.is_some_and(|t| t.raw() < incarnation),
        };
        p.incarnation = Some(incarnation);
        restarted
    }

    /// The restart rule: what was known of a source's previous incarnation (stream
    /// position, names, catch-up, the origins of its objects) is forgotten, and a fence
    /// keeps its late messages from being read as the new incarnation's. Shared by the
    /// module hello and the robot hello's member list.
    pub(crate) fn member_restarted(&mut self, from: &Address) {
        let fence_until = self.now + self.config.link(LinkKind::between(&self.me, from)).timeout;
        let p = self.peer(from);
        p.put_up_fence(fence_until);
        p.stream = Inbound::default();
        p.newest = None;
        p.catch_up = None;
        p.caught_up = false;
        p.hold_plans_until = None;
        self.stats.liveliness.restarts += 1;
        self.decoder.forget(from);
        self.forget_origins(from);
    }

    /// A restarted source owns only what its new incarnation lists: what this board
    /// heard from its previous one no longer shields objects from the sweep.
    fn forget_origins(&mut self, owner: &Address) {
        let board = &self.board;
        self.origins
            .retain(|name, _| board.info(name).is_none_or(|i| i.owner != *owner));
    }

    fn on_classes(&mut self, from: &Address, defs: Vec<ClassDef>) {
        let mut found = Vec::new();
        for def in defs.into_iter().filter(|d| d.name != MODULE_CLASS) {
            let name: Arc<str> = def.name.as_str().into();
            match self.board.define(def) {
                Ok(_) => {}
                Err(DefineError::Conflict { .. }) => {
                    self.stats.rejects.class_conflicts += 1;
                    if self.conflicts.insert((name.clone(), from.clone())) {
                        found.push(name);
                    }
                }
                Err(e) => tracing::debug!(class = %name, error = %e, "class not defined"),
            }
        }
        self.refresh_catalog();
        self.class_conflicts_found(from, &found);
    }

    /// Reports conflicts newly found with `from` (once per peer and class), and sends it
    /// this board's definitions of those classes: it may hold no object of them, and
    /// would never ask for them, yet its board must say so too.
    fn class_conflicts_found(&mut self, from: &Address, classes: &[Arc<str>]) {
        for class in classes {
            self.board.report_class_conflict(class, from);
        }
        let mine: Vec<ClassDef> = classes
            .iter()
            .filter_map(|c| self.board.class_def(c))
            .collect();
        if !mine.is_empty() {
            self.send_message(from, &Message::Classes(mine));
        }
    }

    fn on_lifecycle(&mut self, from: &Address, l: Lifecycle) {
        let stamps = || {
            let created = l.created.iter().map(|(_, t)| *t);
            created.chain(l.deleted.iter().map(|(_, t)| *t))
        };
        if stamps().any(|t| self.before_incarnation(from, t)) {
            self.stats.rejects.stale += 1;
            return;
        }
        // A frame that later ones overtook may delete an object its owner has made
        // again since (in order, the deletion would have come first).
        let late = self.peer(from).stream.overtaken(l.seq);
        if !self.take_position(from, l.seq, stamps().max()) {
            return;
        }
        for (listed, stamp) in l.created {
            self.listed(
                from,
                &listed,
                Origin {
                    seq: Some(l.seq),
                    stamp,
                },
            );
        }
        let deletes = !l.deleted.is_empty();
        for (name, stamp) in l.deleted {
            self.remote_delete(from, name, stamp);
        }
        if late && deletes {
            // Which object it was cannot be told here: delete, and ask the owner what
            // exists now.
            self.request_catch_up(from, false, false);
        }
    }

    /// Takes position `seq` of `from`'s stream, whose own newest stamp is `newest`;
    /// false (counted) for a duplicate, or for a position a restart's fence refuses
    /// ([`Peer::fenced`](super::state::Peer::fenced)).
    fn take_position(&mut self, from: &Address, seq: u64, newest: Option<Timestamp>) -> bool {
        let now = self.now;
        let p = self.peer(from);
        if p.fenced(seq, now) {
            self.stats.rejects.stale += 1;
            return false;
        }
        if !p.stream.receive(seq, now) {
            self.stats.rejects.duplicates += 1;
            return false;
        }
        p.newest = p.newest.max(newest);
        p.top = p.top.max(seq);
        self.catch_up_changed(from);
        true
    }

    /// Was something stamped `stamp` by `from` made before its current incarnation
    /// started (a late message of the incarnation before a restart)? Never for
    /// `Timestamp::ZERO`, the stamp of initial values from files, which every incarnation
    /// writes alike.
    pub fn before_incarnation(&self, from: &Address, stamp: Timestamp) -> bool {
        let incarnation = self.peers.get(from).and_then(|p| p.incarnation);
        incarnation.is_some_and(|i| super::state::predates(stamp, i))
    }

    /// An object its owner says exists: create it if this board models it and holds
    /// the same definition of its class.
    pub fn listed(&mut self, from: &Address, listed: &Listed, origin: Origin) {
        if !self.same_class(from, &listed.class, listed.fingerprint) {
            return;
        }
        let entry = ObjectEntry::new(&listed.name, &listed.class)
            .context(listed.context)
            .owner(from.clone());
        let Some(context) = self.interested(from, &entry) else {
            return;
        };
        self.ensure(from, &entry, context, origin, &mut BTreeSet::new());
    }

    /// Does this board define `class` as the sender does? If it does not know the
    /// class, or knows another, it asks for the sender's definitions (which tells a
    /// conflict from a missing class).
    fn same_class(&mut self, from: &Address, class: &str, fingerprint: u32) -> bool {
        if self.catalog.schema.fingerprint(class) != Some(fingerprint) {
            self.refresh_catalog();
        }
        if self.catalog.schema.fingerprint(class) == Some(fingerprint) {
            return true;
        }
        if self.conflicts_with(from, class) {
            self.stats.rejects.object_conflicts += 1;
        } else {
            self.peer(from).failed = true;
            self.request_catch_up(from, false, true);
        }
        false
    }

    /// The owner deleted an object.
    pub fn remote_delete(&mut self, owner: &Address, name: Arc<str>, stamp: Timestamp) {
        let max = self.config.max_tombstones;
        self.tombstones
            .bury(name.clone(), owner.clone(), stamp, max);
        self.origins.remove(&name);
        self.known.clear();
        self.ops.push(BoardOp::Delete {
            object: name,
            owner: owner.clone(),
        });
    }

    // ----- assertions -----

    /// Applies a report's (or catch-up answer's) assertions; `seq` is the stream
    /// position of a report.
    pub fn apply_items(&mut self, from: &Address, items: Vec<Assertion>, seq: Option<u64>) {
        let mut ensured = BTreeSet::new();
        for a in items {
            self.apply_item(from, a, seq, &mut ensured);
        }
    }

    fn apply_item(
        &mut self,
        from: &Address,
        a: Assertion,
        seq: Option<u64>,
        ensured: &mut BTreeSet<Arc<str>>,
    ) {
        let known = self.known.get(&a.object.name, &a.attr);
        if let Some(k) = known.filter(|k| k.entry == a.object) {
            let (merge, key) = (k.merge, k.key);
            return self.merge_item(&a.object, a.attr, merge, Some(key), a.packet);
        }
        let Some(context) = self.interested(from, &a.object) else {
            return;
        };
        if !a.object.is_class() {
            let origin = Origin {
                seq: seq.filter(|_| *from == a.object.owner),
                stamp: a.packet.timestamp,
            };
            if !self.ensure(from, &a.object, context, origin, ensured) {
                return;
            }
        }
        let Some(merge) = self.catalog.decl(&a.object.class, &a.attr).map(|d| d.merge) else {
            self.stats.rejects.invalid += 1;
            return;
        };
        // An object the board holds (not one whose creation is queued): remembered.
        let key = (!a.object.is_class())
            .then(|| self.board.key(&a.object.name, &a.attr).ok())
            .flatten();
        if let Some(key) = key {
            let known = Known {
                entry: a.object.clone(),
                merge,
                key,
            };
            self.known.insert(&a.object.name, &a.attr, known);
        }
        self.merge_item(&a.object, a.attr, merge, key, a.packet);
    }

    /// The context the object takes on this board, if this board models it.
    fn interested(&mut self, from: &Address, entry: &ObjectEntry) -> Option<Context> {
        if &*entry.class == MODULE_CLASS {
            return None;
        }
        let Some(lineage) = self.lineage(&entry.class) else {
            if !self.conflicts_with(from, &entry.class) {
                self.peer(from).failed = true;
                self.request_catch_up(from, false, true);
            }
            return None;
        };
        let context = State::context_on(entry.context, &entry.owner, &self.me);
        let interest = &self.config.interest;
        let wanted = if entry.is_class() {
            interest.relates_to_class(&lineage, &self.catalog)
        } else {
            interest.contains(&lineage, context)
        };
        if !wanted {
            self.stats.rejects.uninterested += 1;
        }
        wanted.then_some(context)
    }

    /// Makes sure the object exists (queues its creation); false if it must not.
    fn ensure(
        &mut self,
        from: &Address,
        entry: &ObjectEntry,
        context: Context,
        origin: Origin,
        ensured: &mut BTreeSet<Arc<str>>,
    ) -> bool {
        if ensured.contains(&entry.name) {
            return true;
        }
        if let Some(same) = self.board.is_instance_of(&entry.name, &entry.class) {
            if !same {
                self.stats.rejects.object_conflicts += 1;
            }
            return same;
        }
        if !self.may_create(from, entry, origin.stamp) {
            self.stats.rejects.stale += 1;
            return false;
        }
        let spec = NewObject::new(&entry.class, &entry.name)
            .context(context)
            .owner(entry.owner.clone());
        self.ops.push(BoardOp::Ensure(spec));
        self.origins.insert(entry.name.clone(), origin);
        ensured.insert(entry.name.clone());
        if *from != entry.owner && !entry.owner.is_unknown() {
            // Heard of it from another module: let its owner confirm it exists.
            self.request_catch_up(&entry.owner, false, false);
        }
        true
    }

    /// May an object this board lacks be created from what `from` said at `stamp`?
    /// Never an object this board owns (it deleted it); a deleted one only by its owner,
    /// after the deletion.
    fn may_create(&self, from: &Address, entry: &ObjectEntry, stamp: Timestamp) -> bool {
        if entry.owner == self.me {
            return false;
        }
        match self.tombstones.get(&entry.name) {
            Some((_, deleted)) => *from == entry.owner && stamp > *deleted,
            None => true,
        }
    }

    fn merge_item(
        &mut self,
        entry: &ObjectEntry,
        attr: Arc<str>,
        merge: MergePolicy,
        board_key: Option<slate_model::Key>,
        packet: Packet,
    ) {
        let object = &entry.name;
        if merge == MergePolicy::Confident {
            let key = (object.clone(), attr.clone());
            if self
                .best
                .get(&key)
                .is_none_or(|b| super::send::better(&packet, b))
            {
                self.best.insert(key, packet.clone());
            }
        }
        if merge != MergePolicy::Fused {
            self.ops.push(BoardOp::Merge {
                object: object.clone(),
                attr,
                key: board_key,
                packet,
            });
            return;
        }
        // Merges check stamps and writers on the board; a fused estimate is kept here
        // instead.
        if self.board.admit_stamp(object, &attr, &packet).is_err() {
            self.stats.rejects.future += 1;
            return;
        }
        let writer = &packet.source;
        let admitted = self
            .board
            .admit_write(&entry.class, object, Some(&attr), writer, true);
        if admitted.is_err() {
            self.stats.merges.unauthorised += 1;
            return;
        }
        let key = (object.clone(), attr);
        if self.fusion.update(key.clone(), packet) {
            self.stats.merges.fused += 1;
            self.ops.push(BoardOp::Fuse(key));
        } else {
            self.stats.merges.kept += 1;
        }
    }
}
