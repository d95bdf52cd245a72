//! The files of a recording: MCAP, zstd-compressed chunks, rotated by size or age. The
//! `mcap` crate writes the container; this keeps the channels of the open file, counts
//! what it wrote, and starts the next file when the open one is full or old enough.

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use mcap::records::MessageHeader;
use mcap::{Compression, WriteOptions, Writer};

use super::{RecordConfig, RecordError};

/// The MCAP profile recordings declare.
pub const PROFILE: &str = "slate";
/// The metadata record each file holds: the recording board's `address`.
pub const METADATA: &str = "slate";
/// Every channel's message encoding.
pub const MESSAGE_ENCODING: &str = "json";
/// The schema encoding of every channel.
pub const SCHEMA_ENCODING: &str = "jsonschema";

/// A chunk is closed when it holds this many bytes (uncompressed) or when the recorder
/// flushes, whichever comes first.
const CHUNK_BYTES: u64 = 1 << 20;

/// zstd's fastest level but one: the recorder shares the node's cores, and a higher level
/// gains little on JSON this repetitive.
const ZSTD_LEVEL: u32 = 1;

/// zstd compresses in the recorder thread itself, with no worker threads (the `mcap`
/// crate's default is one per CPU): workers cost about 1 250 instructions more per
/// message (callgrind, docs/performance.md) and compete with the node's writers for the
/// cores.
const ZSTD_THREADS: u32 = 0;

/// The path of the `index`th file of a recording at `base`: `base` itself, then
/// `NAME.1.mcap`, `NAME.2.mcap`... beside it.
pub fn rotated_path(base: &Path, index: u32) -> PathBuf {
    if index == 0 {
        return base.to_owned();
    }
    let stem = base
        .file_stem()
        .map_or_else(|| "recording".into(), |s| s.to_string_lossy().into_owned());
    let ext = base
        .extension()
        .map_or_else(|| "mcap".into(), |e| e.to_string_lossy().into_owned());
    base.with_file_name(format!("{stem}.{index}.{ext}"))
}

/// A writer that counts the bytes it is handed (what the file has grown to, give or
/// take the buffer); the count is shared because the MCAP writer owns the writer.
struct Counted {
    inner: BufWriter<File>,
    bytes: Arc<AtomicU64>,
}

impl Write for Counted {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.bytes.fetch_add(n as u64, Ordering::Relaxed);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

impl Seek for Counted {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.inner.seek(pos)
    }
}

/// The open file, its channels, and when it began.
struct Open {
    writer: Writer<Counted>,
    /// What the writer has handed the file so far.
    bytes: Arc<AtomicU64>,
    path: PathBuf,
    /// Channel ids by topic (a class redefined gets a second channel: see
    /// [`Files::forget_channels`]).
    channels: HashMap<String, u16>,
    began: Instant,
}

/// The files of one recording.
pub struct Files {
    config: RecordConfig,
    /// The recording board's address, in each file's `slate` metadata record.
    address: String,
    open: Option<Open>,
    /// Files begun so far.
    index: u32,
    /// Bytes of the files already finished.
    finished_bytes: u64,
    sequence: u32,
    messages: u64,
    /// Messages written so far per topic, in every file.
    by_topic: BTreeMap<String, u64>,
}

/// One message to write.
pub struct Entry<'a> {
    /// The channel's topic.
    pub topic: &'a str,
    /// The schema's name (a class's name, or `slate.X` for a fixed channel).
    pub schema: &'a str,
    /// The message, JSON.
    pub data: &'a [u8],
    /// Nanoseconds since the Unix epoch: when it was recorded, on the board's clock.
    pub log_time: u64,
    /// Nanoseconds since the Unix epoch: when it happened (a packet's stamp), or the log
    /// time.
    pub publish_time: u64,
}

impl Files {
    /// Creates the first file.
    pub fn create(config: RecordConfig, address: &str) -> Result<Files, RecordError> {
        let mut files = Files {
            config,
            address: address.to_owned(),
            open: None,
            index: 0,
            finished_bytes: 0,
            sequence: 0,
            messages: 0,
            by_topic: BTreeMap::new(),
        };
        files.begin()?;
        Ok(files)
    }

    fn begin(&mut self) -> Result<(), RecordError> {
        let path = rotated_path(&self.config.path, self.index);
        let file = File::create(&path).map_err(|error| RecordError::Create {
            path: path.clone(),
            error,
        })?;
        let bytes = Arc::new(AtomicU64::new(0));
        let counted = Counted {
            inner: BufWriter::new(file),
            bytes: bytes.clone(),
        };
        let writer = WriteOptions::new()
            .profile(PROFILE)
            .library(concat!("slate ", env!("CARGO_PKG_VERSION")))
            .compression(Some(Compression::Zstd))
            .compression_level(ZSTD_LEVEL)
            .compression_threads(ZSTD_THREADS)
            .chunk_size(Some(self.chunk_bytes()))
            .create(counted)
            .map_err(|error| RecordError::Mcap {
                path: path.clone(),
                error,
            })?;
        let mut writer = writer;
        let metadata = mcap::records::Metadata {
            name: METADATA.to_owned(),
            metadata: BTreeMap::from([("address".to_owned(), self.address.clone())]),
        };
        writer
            .write_metadata(&metadata)
            .map_err(|error| RecordError::Mcap {
                path: path.clone(),
                error,
            })?;
        self.index += 1;
        self.open = Some(Open {
            writer,
            bytes,
            path,
            channels: HashMap::new(),
            began: Instant::now(),
        });
        Ok(())
    }

    /// Chunks small enough that a file rotated by size holds several.
    fn chunk_bytes(&self) -> u64 {
        self.config
            .max_bytes
            .map_or(CHUNK_BYTES, |max| (max / 8).clamp(1024, CHUNK_BYTES))
    }

    /// Is the open file full or old enough to start the next one?
    pub fn rotation_due(&self) -> bool {
        let Some(open) = &self.open else {
            return false;
        };
        let full = self
            .config
            .max_bytes
            .is_some_and(|max| open.writer_bytes() >= max);
        let old = self
            .config
            .max_duration
            .is_some_and(|max| open.began.elapsed() >= max);
        full || old
    }

    /// Finishes the open file and begins the next.
    pub fn rotate(&mut self) -> Result<(), RecordError> {
        self.finish()?;
        self.begin()
    }

    /// Writes one message, adding its schema and channel to the open file first if new.
    /// `schema` is asked for only then.
    pub fn write(
        &mut self,
        entry: &Entry,
        schema: impl FnOnce() -> serde_json::Value,
    ) -> Result<(), RecordError> {
        let Some(open) = self.open.as_mut() else {
            return Ok(());
        };
        let channel_id = open.channel(entry, schema)?;
        let header = MessageHeader {
            channel_id,
            sequence: self.sequence,
            log_time: entry.log_time,
            publish_time: entry.publish_time,
        };
        self.sequence = self.sequence.wrapping_add(1);
        open.writer
            .write_to_known_channel(&header, entry.data)
            .map_err(|e| open.error(e))?;
        self.messages += 1;
        self.count(entry.topic);
        Ok(())
    }

    fn count(&mut self, topic: &str) {
        match self.by_topic.get_mut(topic) {
            Some(n) => *n += 1,
            None => {
                self.by_topic.insert(topic.to_owned(), 1);
            }
        }
    }

    /// Forgets the open file's channels whose topic starts with `prefix`: the next
    /// message on each adds its schema again (when a class is redefined, its channel and
    /// its subclasses' get a second channel with the new schema).
    pub fn forget_channels(&mut self, prefix: &str) {
        if let Some(open) = self.open.as_mut() {
            open.channels.retain(|t, _| !t.starts_with(prefix));
        }
    }

    /// Closes the open chunk and hands the file what is buffered: a crash after this
    /// loses nothing written before it.
    pub fn flush(&mut self) -> Result<(), RecordError> {
        let Some(open) = self.open.as_mut() else {
            return Ok(());
        };
        open.writer.flush().map_err(|e| open.error(e))
    }

    /// Writes the open file's summary and footer and closes it.
    pub fn finish(&mut self) -> Result<(), RecordError> {
        let Some(mut open) = self.open.take() else {
            return Ok(());
        };
        open.writer.finish().map_err(|e| open.error(e))?;
        let mut counted = open.writer.into_inner();
        counted.flush().map_err(|error| RecordError::Write {
            path: open.path.clone(),
            error,
        })?;
        self.finished_bytes += open.bytes.load(Ordering::Relaxed);
        Ok(())
    }

    /// Messages written so far, in every file.
    pub fn messages(&self) -> u64 {
        self.messages
    }

    /// Messages written so far per topic, in every file.
    pub fn by_topic(&self) -> &BTreeMap<String, u64> {
        &self.by_topic
    }

    /// Bytes written so far, in every file.
    pub fn bytes(&self) -> u64 {
        self.finished_bytes + self.open.as_ref().map_or(0, Open::writer_bytes)
    }

    /// Files begun so far.
    pub fn files(&self) -> u32 {
        self.index
    }
}

impl Open {
    fn writer_bytes(&self) -> u64 {
        self.bytes.load(Ordering::Relaxed)
    }

    fn error(&self, error: mcap::McapError) -> RecordError {
        RecordError::Mcap {
            path: self.path.clone(),
            error,
        }
    }

    fn channel(
        &mut self,
        entry: &Entry,
        schema: impl FnOnce() -> serde_json::Value,
    ) -> Result<u16, RecordError> {
        if let Some(id) = self.channels.get(entry.topic) {
            return Ok(*id);
        }
        let data = serde_json::to_vec(&schema()).unwrap_or_default();
        let schema_id = self
            .writer
            .add_schema(entry.schema, SCHEMA_ENCODING, &data)
            .map_err(|e| self.error(e))?;
        let id = self
            .writer
            .add_channel(schema_id, entry.topic, MESSAGE_ENCODING, &BTreeMap::new())
            .map_err(|e| self.error(e))?;
        self.channels.insert(entry.topic.to_owned(), id);
        Ok(id)
    }
}

impl Drop for Files {
    fn drop(&mut self) {
        if let Err(e) = self.finish() {
            tracing::warn!("recording not finished: {e}");
        }
    }
}
