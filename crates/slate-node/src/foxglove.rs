//! The Foxglove WebSocket server of a node (`slate node --foxglove ADDR`,
//! `docs/foxglove.md`): the board live in Foxglove, beside a team's ROS topics.
//!
//! One channel per class, `/slate/class/CLASS`, with the JSON schema and the JSON messages
//! a recording has (`record::class_batch_schema`, a list of packets): each packet written
//! to an object of the class is one message, a list of that one packet. Objects with a `position` vector are
//! also drawn on `/slate/scene` (a `foxglove.SceneUpdate`: one cube per object, named after
//! it). Channels are advertised for every class the board has when the server starts, and
//! for a class defined later at its first packet.
//!
//! A client that subscribes to a channel is first sent, to it alone, the latest value of
//! every attribute the channel carries (the class's objects' packets, or every object's
//! position on the scene), so that it shows the board at once rather than from the next
//! write on.
//!
//! A thread drains a bounded watch of the board (as the recorder does): a writer never
//! waits for Foxglove; when the thread falls a whole queue behind, changes are dropped,
//! counted and logged as a warning. The foxglove crate sends a message only to the
//! clients subscribed to its channel.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use foxglove::messages::{
    Color, CubePrimitive, Pose, Quaternion, SceneEntity, SceneUpdate, Timestamp, Vector3,
};
use foxglove::websocket::{ChannelView, Client, ServerListener};
use foxglove::{
    Channel, ChannelBuilder, Context, Encode, PartialMetadata, RawChannel, Schema, WebSocketServer,
    WebSocketServerHandle,
};
use slate_model::{Board, ChangeItem, Filter, Gather, Packet, RevisedItem};

use crate::inspect::Classes;
use crate::record::{PacketMessage, class_batch_schema, topic};

/// Change items that may wait for the Foxglove thread before writers drop changes.
const QUEUE: usize = 1 << 14;

/// How long the thread waits for a change before it looks at its stop flag.
const POLL: Duration = Duration::from_millis(100);

/// The topic of the scene: objects with a `position`, as cubes.
pub const SCENE_TOPIC: &str = "/slate/scene";

/// Why the Foxglove server did not start.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum FoxgloveError {
    /// The server could not listen (the port is taken, the address is not this host's).
    #[error(
        "cannot serve Foxglove on {addr}: {error} (choose another port, or 127.0.0.1:0 for any free one)"
    )]
    Listen {
        /// The address asked for.
        addr: SocketAddr,
        /// Why.
        error: String,
    },
    /// The board refused the watch.
    #[error("cannot watch the board for Foxglove: {0}")]
    Watch(#[from] slate_model::LookupError),
    /// The thread could not be started.
    #[error("cannot start the Foxglove thread: {0}")]
    Thread(std::io::Error),
}

/// A running Foxglove server and the thread that feeds it.
pub(crate) struct Foxglove {
    server: Option<WebSocketServerHandle>,
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Foxglove {
    /// Serves `board` on `addr` (port 0: any free port, see [`Foxglove::addr`]).
    pub fn start(addr: SocketAddr, board: &Arc<Board>) -> Result<Foxglove, FoxgloveError> {
        let ctx = Context::new();
        let watch = board.watch_gathered(Filter::all(), QUEUE)?;
        let mut feed = Feed::new(&ctx, board.clone(), watch);
        feed.advertise_classes();
        let latest = Arc::new(Latest {
            board: board.clone(),
            ctx: ctx.clone(),
        });
        let server = WebSocketServer::new()
            .name(format!("slate node {}", board.address()))
            .listener(latest)
            .bind(addr.ip().to_string(), addr.port())
            .context(&ctx)
            .start_blocking()
            .map_err(|e| FoxgloveError::Listen {
                addr,
                error: e.to_string(),
            })?;
        let bound = SocketAddr::new(addr.ip(), server.port());
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::Builder::new()
            .name("slate-foxglove".into())
            .spawn(move || feed.run(&flag))
            .map_err(FoxgloveError::Thread)?;
        tracing::info!("Foxglove WebSocket server on ws://{bound}");
        Ok(Foxglove {
            server: Some(server),
            addr: bound,
            stop,
            thread: Some(thread),
        })
    }

    /// Where it listens.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Stops the thread, then the server (its clients are disconnected).
    pub fn stop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        if let Some(s) = self.server.take() {
            drop(s.stop());
        }
    }
}

impl Drop for Foxglove {
    fn drop(&mut self) {
        self.stop();
    }
}

/// The thread's state: the board's watch and a channel per class seen.
struct Feed {
    ctx: Arc<Context>,
    board: Arc<Board>,
    watch: Gather,
    /// The items taken from the watch (its block goes back to the writers each time).
    taken: Vec<RevisedItem>,
    /// Changes dropped so far, as last logged.
    dropped: u64,
    channels: HashMap<Arc<str>, Arc<RawChannel>>,
    scene: Channel<SceneUpdate>,
    buf: Vec<u8>,
}

impl Feed {
    fn new(ctx: &Arc<Context>, board: Arc<Board>, watch: Gather) -> Feed {
        Feed {
            ctx: ctx.clone(),
            scene: ChannelBuilder::new(SCENE_TOPIC).context(ctx).build(),
            board,
            watch,
            taken: Vec::new(),
            dropped: 0,
            channels: HashMap::new(),
            buf: Vec::new(),
        }
    }

    /// A channel for every class the board has now.
    fn advertise_classes(&mut self) {
        let classes = Classes::of(&self.board);
        let names: Vec<String> = classes.defs().map(|d| d.name.clone()).collect();
        for name in names {
            self.channel(&classes, &Arc::from(name.as_str()));
        }
    }

    fn run(mut self, stop: &AtomicBool) {
        while !stop.load(Ordering::Acquire) {
            if !self.watch.wait(POLL) {
                self.note_dropped();
                continue;
            }
            let mut taken = std::mem::take(&mut self.taken);
            self.watch.take(&mut taken);
            for (revision, item) in taken.drain(..) {
                if let ChangeItem::Write {
                    object,
                    attr,
                    packet,
                } = item
                {
                    self.packet(&object, &attr, &packet, revision);
                }
            }
            self.taken = taken;
        }
    }

    /// Logs the changes dropped since it last did (the thread fell a queue behind).
    fn note_dropped(&mut self) {
        let dropped = self.watch.dropped();
        if dropped > self.dropped {
            tracing::warn!(
                "Foxglove fell behind the board: {} changes not sent ({dropped} in all)",
                dropped - self.dropped
            );
            self.dropped = dropped;
        }
    }

    /// The channel of `class`, made (and advertised) on first use. A class the board
    /// does not define (yet) gets no channel.
    fn channel(&mut self, classes: &Classes, class: &Arc<str>) -> Option<Arc<RawChannel>> {
        if let Some(c) = self.channels.get(class) {
            return Some(c.clone());
        }
        classes.defs().find(|d| *d.name == **class)?;
        let schema = serde_json::to_vec(&class_batch_schema(classes, class)).ok()?;
        let built = ChannelBuilder::new(format!("{}{class}", topic::CLASS_PREFIX))
            .message_encoding("json")
            .schema(Schema::new(&**class, "jsonschema", schema))
            .context(&self.ctx)
            .build_raw();
        match built {
            Ok(c) => {
                self.channels.insert(class.clone(), c.clone());
                Some(c)
            }
            Err(e) => {
                tracing::warn!("no Foxglove channel for class {class}: {e}");
                None
            }
        }
    }

    /// A packet on its class's channel, and on the scene for a `position`.
    fn packet(&mut self, object: &str, attr: &str, packet: &Packet, revision: u64) {
        let Some(info) = self.board.info(object) else {
            return;
        };
        let class: Arc<str> = if info.is_class {
            info.name.clone()
        } else {
            info.class.clone()
        };
        let channel = match self.channels.get(&class) {
            Some(c) => c.clone(),
            None => match self.channel(&Classes::of(&self.board), &class) {
                Some(c) => c,
                None => return,
            },
        };
        self.buf.clear();
        PacketMessage::new(object, attr, packet, revision).write_alone(&mut self.buf);
        channel.log_with_meta(&self.buf, meta(packet));
        if attr == "position" && !info.is_class {
            self.scene(object, packet);
        }
    }

    /// An object's cube on the scene, at its position (2 or 3 numbers).
    fn scene(&self, object: &str, packet: &Packet) {
        if let Some(update) = scene_update(object, packet) {
            self.scene.log(&update);
        }
    }
}

/// Sends a subscribing client the latest values of its channel (see the module's doc).
struct Latest {
    board: Arc<Board>,
    ctx: Arc<Context>,
}

impl ServerListener for Latest {
    fn on_subscribe(&self, client: Client, channel: ChannelView) {
        let Some(raw) = self.ctx.get_channel_by_topic(channel.topic()) else {
            return;
        };
        let sink = client.sink_id();
        if channel.topic() == SCENE_TOPIC {
            let mut buf = Vec::new();
            for (object, packet) in self.positions() {
                buf.clear();
                let Some(update) = scene_update(&object, &packet) else {
                    continue;
                };
                if update.encode(&mut buf).is_ok() {
                    raw.log_with_meta_to_sink(&buf, meta(&packet), sink);
                }
            }
        } else if let Some(class) = channel.topic().strip_prefix(topic::CLASS_PREFIX) {
            let mut buf = Vec::new();
            for (object, attr, packet, revision) in self.values_of(class) {
                buf.clear();
                PacketMessage::new(&object, &attr, &packet, revision).write_alone(&mut buf);
                raw.log_with_meta_to_sink(&buf, meta(&packet), sink);
            }
        }
    }
}

impl Latest {
    /// Every packet the class `class` itself and its own objects (not its subclasses')
    /// hold, as the feed sends them on the class's channel. One short snapshot.
    fn values_of(&self, class: &str) -> Vec<(Arc<str>, Arc<str>, Packet, u64)> {
        let snap = self.board.snapshot();
        let mut ids: Vec<_> = snap.instances(class).unwrap_or_default();
        ids.extend(snap.id_of(class));
        let mut out = Vec::new();
        for id in ids {
            let Some(info) = snap.info(id) else { continue };
            let own = info.is_class || *info.class == *class;
            if own {
                let values = snap.own_values(id).into_iter();
                out.extend(values.map(|(attr, p, rev)| (info.name.clone(), attr, p, rev)));
            }
        }
        out
    }

    /// Every object's `position` packet. One short snapshot.
    fn positions(&self) -> Vec<(Arc<str>, Packet)> {
        let snap = self.board.snapshot();
        let ids = snap.instances("Thing").unwrap_or_default();
        ids.into_iter()
            .filter_map(|id| {
                let name = snap.name_of(id)?;
                let p = snap.read(&name, "position").ok()?;
                Some((name, p))
            })
            .collect()
    }
}

/// An object's cube on the scene at its `position` packet (2 or 3 numbers), or `None`.
fn scene_update(object: &str, packet: &Packet) -> Option<SceneUpdate> {
    let (x, y, z) = match packet.value.as_vector()? {
        [x, y] => (*x, *y, 0.0),
        [x, y, z] => (*x, *y, *z),
        _ => return None,
    };
    let stamp = packet.timestamp.physical();
    let cube = CubePrimitive {
        pose: Some(Pose {
            position: Some(Vector3 { x, y, z }),
            orientation: Some(Quaternion {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                w: 1.0,
            }),
        }),
        size: Some(Vector3 {
            x: 1.0,
            y: 1.0,
            z: 1.0,
        }),
        color: Some(Color {
            r: 0.2,
            g: 0.6,
            b: 1.0,
            a: 0.8,
        }),
    };
    let entity = SceneEntity {
        timestamp: Some(Timestamp::new(
            u32::try_from(stamp.as_secs()).unwrap_or(u32::MAX),
            stamp.subsec_nanos(),
        )),
        frame_id: "slate".to_owned(),
        id: object.to_owned(),
        cubes: vec![cube],
        ..SceneEntity::default()
    };
    Some(SceneUpdate {
        deletions: Vec::new(),
        entities: vec![entity],
    })
}

/// A message's log time: the packet's stamp (when its source wrote it), so Foxglove
/// plots a value against when it was written, wherever it was read.
fn meta(packet: &Packet) -> PartialMetadata {
    let stamp = u64::try_from(packet.timestamp.physical().as_nanos()).unwrap_or(u64::MAX);
    PartialMetadata {
        log_time: Some(stamp),
    }
}
