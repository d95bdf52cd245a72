//! The recorder thread: drains the board's bounded watch, its events and the engine's,
//! polls the plan circuits and the transport's counters, and writes each as a message.

use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;
use parking_lot::Mutex;
use rustc_hash::FxHashMap;
use serde_json::{Value as Json, json};
use slate_ici::{MODULE_CLASS, PlanCircuits, Transport};
use slate_model::{
    Board, BoardEvent, ChangeItem, ClassDef, Filter, Gather, ObjectInfo, Packet, RevisedItem, Value,
};
use slate_plans::PlanEvent;

use super::file::{Entry, Files};
use super::topic::{
    CIRCUITS, CLASS_PREFIX, CLASSES, EVENTS, LINKS, LIVELINESS, OBJECTS, PLANS, RECORDER,
};
use super::{RecordConfig, RecordError, RecordStats, message, schema};
use crate::inspect::Classes;
use crate::view::View;

/// How long the thread waits for a change before it looks at everything else.
const POLL: Duration = Duration::from_millis(20);
/// How often the plan circuits are asked for new steps.
const CIRCUITS_EVERY: Duration = Duration::from_millis(100);
/// Once a change has come, how long the thread lets the next ones gather before it takes
/// them: the packets that come meanwhile go out together, and a writer seldom finds the
/// thread asleep on the watch (waking it is a system call in the writer's thread). The
/// watch holds at most the configured queue's items, so a busy board does not starve
/// the events, the flushes and the stop.
const GATHER: Duration = Duration::from_millis(2);
/// The most packets one class channel's message holds, and about the most bytes of JSON.
const BATCH_PACKETS: usize = 512;
const BATCH_BYTES: usize = 64 << 10;

/// Everything the thread reads, and the files it writes.
pub struct Tap {
    board: Arc<Board>,
    circuits: Arc<PlanCircuits>,
    transport: Arc<dyn Transport>,
    watch: Gather,
    /// The items taken from the watch (its block goes back to the writers each time).
    taken: Vec<RevisedItem>,
    board_events: Receiver<BoardEvent>,
    plan_events: Receiver<PlanEvent>,
    files: Files,
    config: RecordConfig,
    /// The class definitions recorded in the open file.
    classes: BTreeMap<String, ClassDef>,
    tree: Classes,
    /// The board as recorded so far: what a new file starts with. Looked up at every
    /// packet (Fx: 7 % of the recorder's time went to SipHash on the names; the ICI
    /// keys its own objects the same way).
    mirror: FxHashMap<Arc<str>, Mirrored>,
    /// Steps recorded per circuit (`true`: sent by this module).
    steps: HashMap<(bool, u64, String), usize>,
    /// The last `alive` of each Module object.
    alive: HashMap<Arc<str>, bool>,
    stats: Arc<Mutex<RecordStats>>,
    /// The packets waiting to go out as one message on their class's channel.
    batch: Batch,
    /// Packets recorded so far, in every file.
    packets: u64,
    /// The revision of the last snapshot: changes up to it are in it, and are skipped.
    snapshot_revision: u64,
    flushed: Instant,
    counted: Instant,
    polled: Instant,
}

impl Tap {
    /// Subscribes to everything and creates the first file (the caller's thread, so a
    /// file that cannot be created is the caller's error).
    pub fn new(
        view: &View,
        config: RecordConfig,
        stats: Arc<Mutex<RecordStats>>,
    ) -> Result<Tap, RecordError> {
        let board = view.board.clone();
        let watch = board.watch_gathered(Filter::all(), config.queue)?;
        let now = Instant::now();
        let mut tap = Tap {
            board_events: board.events(),
            plan_events: view.engine.events(),
            tree: Classes::of(&board),
            files: Files::create(config.clone(), board.address().as_str())?,
            circuits: view.circuits.clone(),
            transport: view.transport.clone(),
            watch,
            taken: Vec::new(),
            board,
            config,
            classes: BTreeMap::new(),
            mirror: FxHashMap::default(),
            steps: HashMap::new(),
            alive: HashMap::new(),
            stats,
            batch: Batch::default(),
            packets: 0,
            snapshot_revision: 0,
            flushed: now,
            counted: now,
            polled: now,
        };
        tap.snapshot_revision = tap.mirror_board();
        Ok(tap)
    }

    /// Records until `stop`, then what is waiting, and finishes the file. An error ends
    /// the recording (the node goes on): it is logged and kept in the stats.
    pub fn run(mut self, stop: &AtomicBool) -> Result<(), RecordError> {
        let result = self.record(stop);
        if let Err(e) = &result {
            tracing::error!("recording stopped: {e}");
            self.stats.lock().failed = Some(e.to_string());
        }
        result
    }

    fn record(&mut self, stop: &AtomicBool) -> Result<(), RecordError> {
        self.begin_file()?;
        loop {
            let stopping = stop.load(Ordering::Acquire);
            self.changes(stopping)?;
            self.events()?;
            self.periodic(stopping)?;
            self.rotate_if_due()?;
            self.publish_stats();
            if stopping {
                self.counters()?;
                self.files.finish()?;
                self.publish_stats();
                return Ok(());
            }
        }
    }

    /// Handles the changes waiting, waiting [`POLL`] for one (not when `stopping`).
    fn changes(&mut self, stopping: bool) -> Result<(), RecordError> {
        if !stopping {
            if !self.watch.wait(POLL) {
                return Ok(());
            }
            if self.watch.pending() < BATCH_PACKETS {
                std::thread::sleep(GATHER);
            }
        }
        let mut taken = std::mem::take(&mut self.taken);
        self.watch.take(&mut taken);
        let result = taken.drain(..).try_for_each(|(revision, item)| {
            self.item(revision, item)?;
            self.rotate_if_due()
        });
        self.taken = taken;
        result?;
        self.send_batch()
    }

    fn rotate_if_due(&mut self) -> Result<(), RecordError> {
        if self.files.rotation_due() {
            self.send_batch()?;
            self.files.rotate()?;
            self.begin_file()?;
        }
        Ok(())
    }

    fn events(&mut self) -> Result<(), RecordError> {
        while let Ok(e) = self.board_events.try_recv() {
            let now = self.now();
            self.fixed(
                EVENTS,
                "slate.BoardEvent",
                &message::board_event(&e),
                now,
                now,
            )?;
        }
        while let Ok(e) = self.plan_events.try_recv() {
            let now = self.now();
            self.fixed(PLANS, "slate.PlanEvent", &message::plan_event(&e), now, now)?;
        }
        Ok(())
    }

    /// Circuits, counters and flushes, each when due (all of them when stopping).
    fn periodic(&mut self, stopping: bool) -> Result<(), RecordError> {
        if stopping || self.polled.elapsed() >= CIRCUITS_EVERY {
            self.polled = Instant::now();
            self.circuit_steps()?;
        }
        if self.counted.elapsed() >= self.config.stats_every {
            self.counted = Instant::now();
            self.refresh_classes()?;
            self.counters()?;
        }
        if self.flushed.elapsed() >= self.config.flush_every {
            self.flushed = Instant::now();
            self.send_batch()?;
            self.files.flush()?;
        }
        Ok(())
    }

    /// A new file holds the state it starts from, as recorded so far: the classes, each
    /// object (`exists`) with its packets, and the circuits' steps. Each file replays on
    /// its own.
    fn begin_file(&mut self) -> Result<(), RecordError> {
        self.classes.clear();
        self.steps.clear();
        self.refresh_classes()?;
        let mut objects: Vec<(Arc<str>, Mirrored)> = self
            .mirror
            .iter()
            .map(|(name, m)| (name.clone(), m.clone()))
            .collect();
        objects.sort_by(|a, b| a.0.cmp(&b.0));
        for (object, m) in objects {
            self.exists(&object, &m)?;
            for (attr, (packet, revision)) in &m.values {
                self.write_packet(&object, &m.channel, attr, packet, *revision)?;
            }
        }
        Ok(())
    }

    fn exists(&mut self, object: &str, m: &Mirrored) -> Result<(), RecordError> {
        let (Some(context), Some(owner)) = (&m.context, &m.owner) else {
            return Ok(()); // a class: its definition is on /slate/classes
        };
        let j = json!({
            "op": "exists", "object": object, "class": &*m.channel,
            "context": context, "owner": owner,
        });
        let now = self.now();
        self.fixed(OBJECTS, "slate.ObjectEvent", &j, now, now)
    }

    /// Fills the mirror from one snapshot of the board (every object and class with its
    /// own packets); its revision. The changes already waiting in the watch up to it are
    /// in it, and are skipped.
    fn mirror_board(&mut self) -> u64 {
        let snap = self.board.snapshot();
        for id in snap.objects() {
            let Some(info) = snap.info(id) else { continue };
            let values = snap
                .own_values(id)
                .into_iter()
                .map(|(a, p, r)| (a, (p, r)))
                .collect();
            let m = if info.is_class {
                Mirrored::class(info.name.clone())
            } else {
                Mirrored::object(&info)
            };
            if !self.wanted(&info.name, &m.channel) {
                continue;
            }
            self.mirror.insert(info.name, Mirrored { values, ..m });
        }
        snap.revision()
    }

    fn item(&mut self, revision: u64, item: ChangeItem) -> Result<(), RecordError> {
        if revision <= self.snapshot_revision {
            return Ok(());
        }
        match item {
            ChangeItem::Write {
                object,
                attr,
                packet,
            } => self.packet(&object, &attr, &packet, revision),
            ChangeItem::Create { object, class } => self.created("create", object, class),
            ChangeItem::Delete { object, class } => self.created("delete", object, class),
        }
    }

    /// An object created or deleted. A creation checks its class's definition first: a
    /// class can be redefined only while it has no instances, so a new instance is where
    /// a redefinition shows.
    fn created(&mut self, op: &str, object: Arc<str>, class: Arc<str>) -> Result<(), RecordError> {
        if op == "create" && self.classes.get(&*class) != self.board.class_def(&class).as_ref() {
            self.refresh_classes()?;
        }
        if !self.wanted(&object, &class) {
            return Ok(());
        }
        let mut j = json!({ "op": op, "object": &*object, "class": &*class });
        if op == "create" {
            let info = self.board.info(&object).filter(|i| i.class == class);
            let m = info.map_or_else(|| Mirrored::class(class.clone()), |i| Mirrored::object(&i));
            if let (Some(context), Some(owner)) = (&m.context, &m.owner) {
                j["context"] = json!(context);
                j["owner"] = json!(owner);
            }
            self.mirror.insert(object, m);
        } else {
            self.mirror.remove(&object);
            self.alive.remove(&object);
        }
        let now = self.now();
        self.fixed(OBJECTS, "slate.ObjectEvent", &j, now, now)
    }

    /// A packet on its class's channel (and on the liveliness channel, for a module's
    /// `alive`).
    fn packet(
        &mut self,
        object: &Arc<str>,
        attr: &Arc<str>,
        packet: &Packet,
        revision: u64,
    ) -> Result<(), RecordError> {
        let channel = self.channel_of_object(object);
        if !self.wanted(object, &channel) {
            return Ok(());
        }
        if let Some(m) = self.mirror.get_mut(object) {
            m.values.insert(attr.clone(), (packet.clone(), revision));
        }
        self.write_packet(object, &channel, attr, packet, revision)?;
        if &*channel == MODULE_CLASS && &**attr == "alive" {
            self.liveliness(object, &packet.value)?;
        }
        Ok(())
    }

    /// Adds a packet to the batch of its class's channel, sending the batch first if it
    /// is another channel's (messages stay in the order of the changes) and after if it
    /// is full.
    fn write_packet(
        &mut self,
        object: &str,
        channel: &Arc<str>,
        attr: &str,
        packet: &Packet,
        revision: u64,
    ) -> Result<(), RecordError> {
        if !self.classes.contains_key(&**channel) {
            self.refresh_classes()?;
        }
        if self.batch.channel.as_ref().is_some_and(|c| c != channel) {
            self.send_batch()?;
        }
        if self.batch.count == 0 {
            let log_time = self.now();
            self.batch
                .begin(channel, log_time, nanos(packet.timestamp.physical()));
        }
        self.batch
            .push(&message::PacketMessage::new(object, attr, packet, revision));
        if self.batch.count >= BATCH_PACKETS || self.batch.buf.len() >= BATCH_BYTES {
            self.send_batch()?;
        }
        Ok(())
    }

    /// Writes the waiting packets as one message on their class's channel.
    fn send_batch(&mut self) -> Result<(), RecordError> {
        let Some(channel) = self.batch.channel.take() else {
            return Ok(());
        };
        self.batch.buf.extend_from_slice(message::LIST_CLOSE);
        let topic = format!("{CLASS_PREFIX}{channel}");
        let entry = Entry {
            topic: &topic,
            schema: &channel,
            data: &self.batch.buf,
            log_time: self.batch.log_time,
            publish_time: self.batch.publish_time,
        };
        let tree = &self.tree;
        self.files
            .write(&entry, || schema::class_batch_schema(tree, &channel))?;
        self.packets += self.batch.count as u64;
        self.batch.count = 0;
        Ok(())
    }

    /// Is `object` (on the channel of `class`) to be recorded: no `only` patterns, or
    /// one names it or a class of its lineage?
    fn wanted(&self, object: &str, class: &str) -> bool {
        let only = &self.config.only;
        only.is_empty()
            || only.iter().any(|p| p == object)
            || self
                .tree
                .lineage(class)
                .iter()
                .any(|c| only.iter().any(|p| p == c))
    }

    /// The channel of an object's packets: its class's (the class's own, for a class).
    /// An object the mirror lacks (its creation was dropped) is looked up on the board.
    fn channel_of_object(&mut self, object: &Arc<str>) -> Arc<str> {
        if let Some(m) = self.mirror.get(object) {
            return m.channel.clone();
        }
        let m = match self.board.info(object) {
            Some(info) if info.is_class => Mirrored::class(info.name),
            Some(info) => Mirrored::object(&info),
            None => Mirrored::class(slate_model::THING.into()),
        };
        let channel = m.channel.clone();
        self.mirror.insert(object.clone(), m);
        channel
    }

    fn liveliness(&mut self, object: &Arc<str>, value: &Value) -> Result<(), RecordError> {
        let Value::Bool(alive) = *value else {
            return Ok(());
        };
        if self.alive.insert(object.clone(), alive) == Some(alive) {
            return Ok(());
        }
        let module = match self.board.read(object, "address").map(|p| p.value) {
            Ok(Value::Str(s)) => s.to_string(),
            _ => object.to_string(),
        };
        let j = json!({ "object": &**object, "module": module, "alive": alive });
        let now = self.now();
        self.fixed(LIVELINESS, "slate.Liveliness", &j, now, now)
    }

    /// Records the class definitions that are new or changed since the file began.
    fn refresh_classes(&mut self) -> Result<(), RecordError> {
        let defs = self.board.class_defs();
        if defs.iter().all(|d| self.classes.get(&d.name) == Some(d)) {
            return Ok(());
        }
        // Packets waiting were written under the definitions recorded so far: they go on
        // the channels of those.
        self.send_batch()?;
        self.tree = Classes::of(&self.board);
        let redefined = defs
            .iter()
            .any(|d| self.classes.get(&d.name).is_some_and(|old| old != d));
        if redefined {
            self.files.forget_channels(CLASS_PREFIX);
        }
        for def in defs {
            if self.classes.get(&def.name) == Some(&def) {
                continue;
            }
            let now = self.now();
            self.fixed(
                CLASSES,
                "slate.ClassDef",
                &message::class_def(&def),
                now,
                now,
            )?;
            self.classes.insert(def.name.clone(), def);
        }
        Ok(())
    }

    /// New steps on the plan circuits this module opened (`sent`) and serves
    /// (`received`).
    fn circuit_steps(&mut self) -> Result<(), RecordError> {
        for (sent, circuits) in [
            (true, self.circuits.sent()),
            (false, self.circuits.received()),
        ] {
            for c in circuits {
                let key = (sent, c.circuit, c.peer.to_string());
                let seen = self.steps.get(&key).copied().unwrap_or(0);
                let direction = if sent { "sent" } else { "received" };
                for step in c.steps.iter().skip(seen) {
                    let j = message::circuit_step(direction, &c, step);
                    let now = self.now();
                    self.fixed(CIRCUITS, "slate.CircuitStep", &j, now, now)?;
                }
                self.steps.insert(key, c.steps.len().max(seen));
            }
        }
        Ok(())
    }

    /// The transport's counters by link and message kind, and the recorder's own (the
    /// packets waiting sent first, so that they count).
    fn counters(&mut self) -> Result<(), RecordError> {
        self.send_batch()?;
        let now = self.now();
        for ((link, kind), t) in self.transport.stats().traffic {
            let j = json!({
                "link": link.name(), "kind": kind.name(),
                "sent_msgs": t.sent_msgs, "sent_bytes": t.sent_bytes,
                "recv_msgs": t.recv_msgs, "recv_bytes": t.recv_bytes,
            });
            self.fixed(LINKS, "slate.LinkStats", &j, now, now)?;
        }
        let j = json!({
            "messages": self.files.messages(), "packets": self.packets,
            "bytes": self.files.bytes(), "dropped": self.watch.dropped(),
            "files": self.files.files(),
        });
        self.fixed(RECORDER, "slate.RecorderStats", &j, now, now)
    }

    fn publish_stats(&self) {
        let mut stats = self.stats.lock();
        stats.messages = self.files.messages();
        stats.packets = self.packets;
        stats.bytes = self.files.bytes();
        stats.dropped = self.watch.dropped();
        stats.files = self.files.files();
        stats.by_topic.clone_from(self.files.by_topic());
    }

    /// A message on a fixed channel, after the packets waiting (they came first).
    fn fixed(
        &mut self,
        topic: &str,
        schema_name: &str,
        j: &Json,
        log_time: u64,
        publish_time: u64,
    ) -> Result<(), RecordError> {
        self.send_batch()?;
        let data = serde_json::to_vec(j).unwrap_or_default();
        let entry = Entry {
            topic,
            schema: schema_name,
            data: &data,
            log_time,
            publish_time,
        };
        self.files
            .write(&entry, || schema::fixed_schema(topic).unwrap_or_default())
    }

    /// The board's time, in nanoseconds since the Unix epoch.
    fn now(&self) -> u64 {
        nanos(self.board.clock().physical())
    }
}

/// The packets of one class channel waiting to go out as one message
/// ([`message::LIST_OPEN`]), each as [`message::PacketMessage`] writes it.
#[derive(Default)]
struct Batch {
    /// Their class (`None`: no packet waits).
    channel: Option<Arc<str>>,
    /// The message so far, without its closing `]}`.
    buf: Vec<u8>,
    count: usize,
    /// When the first was handled (the message's log time) and its stamp (its publish
    /// time).
    log_time: u64,
    publish_time: u64,
}

impl Batch {
    fn begin(&mut self, channel: &Arc<str>, log_time: u64, publish_time: u64) {
        self.channel = Some(channel.clone());
        self.buf.clear();
        self.buf.extend_from_slice(message::LIST_OPEN);
        self.log_time = log_time;
        self.publish_time = publish_time;
    }

    fn push(&mut self, packet: &message::PacketMessage) {
        if self.count > 0 {
            self.buf.push(b',');
        }
        packet.write(&mut self.buf);
        self.count += 1;
    }
}

/// An object (or class) as recorded: its channel, context and owner (none for a class),
/// and its own latest packets with the revision of each.
#[derive(Clone)]
struct Mirrored {
    channel: Arc<str>,
    context: Option<String>,
    owner: Option<String>,
    values: BTreeMap<Arc<str>, (Packet, u64)>,
}

impl Mirrored {
    fn class(name: Arc<str>) -> Self {
        Mirrored {
            channel: name,
            context: None,
            owner: None,
            values: BTreeMap::new(),
        }
    }

    fn object(info: &ObjectInfo) -> Self {
        Mirrored {
            channel: info.class.clone(),
            context: Some(info.context.to_string()),
            owner: Some(info.owner.to_string()),
            values: BTreeMap::new(),
        }
    }
}

fn nanos(d: Duration) -> u64 {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}
