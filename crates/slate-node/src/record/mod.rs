//! Recording a node's board in MCAP (`docs/recording.md`): every committed packet on its
//! class's channel, objects created and deleted, class definitions, plan events, circuit
//! steps, liveliness, the board's events and the links' counters.
//!
//! The recorder runs off the write path: the board hands each committed change to a
//! gathering watch ([`Board::watch_gathered`](slate_model::Board::watch_gathered)) in
//! the writer's thread, and a recorder thread takes what waits in it, all at once, into
//! the files. A writer never waits
//! for the recorder; when the recorder falls a whole queue behind, changes are dropped
//! and counted ([`RecordStats::dropped`], and the `/slate/recorder` channel).

mod against;
mod file;
pub(crate) mod message;
mod replay;
mod schema;
mod tap;

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use parking_lot::Mutex;

pub use against::{AgainstError, Firing, PlanTest, test_plans};
pub use file::{MESSAGE_ENCODING, METADATA, PROFILE, SCHEMA_ENCODING, rotated_path};
pub(crate) use message::PacketMessage;
pub use replay::{Raw, RawMessage, Recording, ReplayError, Step, Timed, board_state, class_def};
pub(crate) use replay::{declared_type, packet_meta, value_of};
pub use schema::{class_batch_schema, class_schema};

use crate::view::View;

/// The topics of a recording's channels.
pub mod topic {
    /// Class definitions (`slate.ClassDef`), at the start of each file and when one
    /// appears or changes.
    pub const CLASSES: &str = "/slate/classes";
    /// Objects created, deleted, or on the board when the file began (`slate.ObjectEvent`).
    pub const OBJECTS: &str = "/slate/objects";
    /// The plan engine's events (`slate.PlanEvent`).
    pub const PLANS: &str = "/slate/plans";
    /// Steps on plan circuits (`slate.CircuitStep`).
    pub const CIRCUITS: &str = "/slate/circuits";
    /// Modules going up and down (`slate.Liveliness`).
    pub const LIVELINESS: &str = "/slate/liveliness";
    /// The board's events: failed functions, cut chains, conflicts (`slate.BoardEvent`).
    pub const EVENTS: &str = "/slate/events";
    /// The transport's counters at a fixed interval (`slate.LinkStats`).
    pub const LINKS: &str = "/slate/links";
    /// The recorder's own counters at the same interval (`slate.RecorderStats`).
    pub const RECORDER: &str = "/slate/recorder";
    /// Packets of objects of class `C` (and class-level writes to `C`) are on
    /// `/slate/class/C`, with the schema named `C`: one or more packets a message.
    pub const CLASS_PREFIX: &str = "/slate/class/";
}

/// Where and how a node records.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordConfig {
    /// The first file; the next ones are `NAME.1.mcap`, `NAME.2.mcap`... beside it.
    pub path: PathBuf,
    /// Start the next file once this many bytes are written (`None`: never).
    pub max_bytes: Option<u64>,
    /// Start the next file once the open one is this old (`None`: never).
    pub max_duration: Option<Duration>,
    /// Close the open chunk this often: a crash loses at most this much (and what waits
    /// in the queue).
    pub flush_every: Duration,
    /// Record the links' and the recorder's counters this often.
    pub stats_every: Duration,
    /// Change items (packets written, objects created or deleted) that may wait for the
    /// recorder before writers drop the changes that would go past it.
    pub queue: usize,
    /// Record only the objects named here or of these classes (their subclasses too), and
    /// class-level writes to them; empty: everything. Plans, circuits, liveliness, events
    /// and counters are always recorded.
    pub only: Vec<String>,
}

impl RecordConfig {
    /// Records to `path` with the defaults: a new file every 1 GiB, chunks closed every
    /// second, counters every second, a queue of 65 536 change items.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        RecordConfig {
            path: path.into(),
            max_bytes: Some(1 << 30),
            max_duration: None,
            flush_every: Duration::from_secs(1),
            stats_every: Duration::from_secs(1),
            queue: 1 << 16,
            only: Vec::new(),
        }
    }
}

/// Why a recording could not start or go on.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The file could not be created.
    #[error(
        "cannot create the recording {}: {error} (check that its folder exists and is writable)", path.display()
    )]
    Create {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// Writing to the file failed (a full disk, a removed drive).
    #[error("cannot write the recording {}: {error}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// The MCAP writer refused (it also reports I/O errors this way).
    #[error("cannot write the recording {}: {error}", path.display())]
    Mcap {
        /// The file.
        path: PathBuf,
        /// Why.
        error: mcap::McapError,
    },
    /// The board refused the recorder's watch.
    #[error("cannot watch the board: {0}")]
    Watch(#[from] slate_model::LookupError),
    /// The recorder thread could not be started.
    #[error("cannot start the recorder thread: {0}")]
    Thread(std::io::Error),
}

/// What a recording has done so far.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RecordStats {
    /// Messages written, in every file.
    pub messages: u64,
    /// Packets recorded, in every file (a class channel's message holds one or more).
    pub packets: u64,
    /// Bytes written, in every file.
    pub bytes: u64,
    /// Changes dropped because the recorder was a whole queue behind.
    pub dropped: u64,
    /// Files begun.
    pub files: u32,
    /// Messages written per topic, in every file (their sum is [`Self::messages`]).
    pub by_topic: std::collections::BTreeMap<String, u64>,
    /// Why the recording stopped before it was told to, if it did.
    pub failed: Option<String>,
}

/// A recording in progress: its thread, and the counters it keeps.
pub(crate) struct Recorder {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<Result<(), RecordError>>>,
    stats: Arc<Mutex<RecordStats>>,
}

impl Recorder {
    /// Creates the first file and starts the thread that fills it.
    pub fn start(view: &View, config: RecordConfig) -> Result<Recorder, RecordError> {
        let stats = Arc::new(Mutex::new(RecordStats::default()));
        let tap = tap::Tap::new(view, config, stats.clone())?;
        let stop = Arc::new(AtomicBool::new(false));
        let stopped = stop.clone();
        let thread = std::thread::Builder::new()
            .name("slate-recorder".into())
            .spawn(move || tap.run(&stopped))
            .map_err(RecordError::Thread)?;
        Ok(Recorder {
            stop,
            thread: Some(thread),
            stats,
        })
    }

    /// The counters now.
    pub fn stats(&self) -> RecordStats {
        self.stats.lock().clone()
    }

    /// Records what is waiting, finishes the file (summary and footer) and stops.
    pub fn stop(&mut self) -> Result<RecordStats, RecordError> {
        self.stop.store(true, Ordering::Release);
        if let Some(thread) = self.thread.take() {
            match thread.join() {
                Ok(result) => result?,
                Err(_) => tracing::error!("the recorder thread panicked"),
            }
        }
        Ok(self.stats())
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        if let Err(e) = self.stop() {
            tracing::warn!("{e}");
        }
    }
}
