//! The receiver's side: one `Decoder` for every source a module hears.

use rustc_hash::FxHashMap;

use slate_model::Address;

use crate::bits::BitReader;
use crate::classes::read_classes;
use crate::control::{read_ack, read_catch_up, read_heartbeat, read_plan};
use crate::message::Kind;
use crate::names::{Section, SourceDict, View, read_section};
use crate::report::{ReportReader, read_report};
use crate::{
    DecodeError, DecodeStats, MAX_MESSAGE_BYTES, MAX_NAMES, MAX_NAMES_PER_SOURCE, MAX_SOURCES,
    Message, Names, Schema, VERSION,
};

/// Turns bytes back into messages, for every source a module hears.
///
/// The decoder keeps one name dictionary per source (keyed by the address the
/// transport says the bytes came from). A message is decoded completely or not at all:
/// on any error nothing of it is applied and the error is counted in
/// [`stats`](Decoder::stats). A names section whose epoch differs from the one known
/// for that source means the source restarted: its old dictionary is dropped.
///
/// At most [`MAX_SOURCES`] dictionaries are kept (or the bound given to
/// [`with_max_sources`](Decoder::with_max_sources)). A new source that finds the table full
/// takes the slot of the source heard least recently (short-lived modules, like the
/// CLI's observers, come and go): that is counted ([`DecodeStats::evicted`]) and named
/// once by [`take_evicted`](Decoder::take_evicted); the evicted source's next message
/// that uses its names is refused as [`DecodeError::UnknownName`], which asks it to
/// announce them again. A new source is never refused for want of room.
///
/// The names of all sources together are bounded too ([`MAX_NAMES`], or
/// [`with_max_total_names`](Decoder::with_max_total_names)): a message whose names would
/// pass it makes the sources heard least recently give up their dictionaries first, in
/// the same way (counted, the last named).
#[derive(Debug)]
pub struct Decoder {
    sources: FxHashMap<Address, Heard>,
    /// Counts the messages decoded: the "time" of [`Heard::last`].
    clock: u64,
    /// The source last evicted, until taken.
    evicted: Option<Address>,
    /// How many dictionaries it keeps.
    max_sources: usize,
    /// How many names one source's dictionary may hold.
    max_names: usize,
    /// How many names all dictionaries together may hold.
    max_total: usize,
    /// How many they hold.
    total: usize,
    stats: DecodeStats,
}

/// One source's dictionary, and when it was last heard.
#[derive(Debug, Default)]
struct Heard {
    dict: SourceDict,
    /// [`Decoder::clock`] at the last message accepted from the source.
    last: u64,
}

impl Default for Decoder {
    fn default() -> Self {
        Decoder::with_max_sources(MAX_SOURCES)
    }
}

impl Decoder {
    /// A decoder that knows no source yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// A decoder that keeps at most `max` sources' dictionaries (at least one).
    pub fn with_max_sources(max: usize) -> Self {
        Decoder {
            sources: FxHashMap::default(),
            clock: 0,
            evicted: None,
            max_sources: max.max(1),
            max_names: MAX_NAMES_PER_SOURCE,
            max_total: MAX_NAMES,
            total: 0,
            stats: DecodeStats::default(),
        }
    }

    /// The same decoder, holding at most `max` names per source (all tables together;
    /// [`MAX_NAMES_PER_SOURCE`] by default): a message that would take its source's
    /// dictionary past it is refused whole, as [`DecodeError::TooManyNames`].
    pub fn with_max_names(mut self, max: usize) -> Self {
        self.max_names = max;
        self.max_total = self.max_total.max(max);
        self
    }

    /// The same decoder, holding at most `max` names of all sources together (at least
    /// its bound per source; [`MAX_NAMES`] by default).
    pub fn with_max_total_names(mut self, max: usize) -> Self {
        self.max_total = max.max(self.max_names);
        self
    }

    /// The names it holds, of all sources together.
    pub fn names(&self) -> usize {
        self.total
    }

    /// Decodes one message from `from`. Values are unpacked against `schema`, which must
    /// hold the same class definitions as the sender's for the classes it reports.
    pub fn decode(
        &mut self,
        from: &Address,
        bytes: &[u8],
        schema: &Schema,
    ) -> Result<Message, DecodeError> {
        let result = self.read(from, bytes, schema);
        self.stats.record(&result);
        if result.is_ok() {
            self.clock += 1;
            if let Some(heard) = self.sources.get_mut(from) {
                heard.last = self.clock;
            }
        }
        result
    }

    /// The source whose dictionary was last dropped to make room for a new one, once:
    /// a source still alive will have to announce its names again.
    pub fn take_evicted(&mut self) -> Option<Address> {
        self.evicted.take()
    }

    /// Counters of accepted and rejected messages.
    pub fn stats(&self) -> DecodeStats {
        self.stats
    }

    /// Does the decoder hold names announced by `from`?
    pub fn knows(&self, from: &Address) -> bool {
        self.sources.contains_key(from)
    }

    /// Drops what `from` announced (the source is gone, or restarted).
    pub fn forget(&mut self, from: &Address) {
        if let Some(gone) = self.sources.remove(from) {
            self.total -= gone.dict.len();
        }
    }

    fn read(
        &mut self,
        from: &Address,
        bytes: &[u8],
        schema: &Schema,
    ) -> Result<Message, DecodeError> {
        if bytes.len() > MAX_MESSAGE_BYTES {
            return Err(DecodeError::TooLarge {
                what: "message bytes",
                len: bytes.len() as u64,
                max: MAX_MESSAGE_BYTES as u64,
            });
        }
        let mut r = BitReader::new(bytes);
        let kind = read_header(&mut r)?;
        let (msg, section) = self.read_body(kind, &mut r, from, schema)?;
        r.finish()?;
        if let Some(section) = section {
            self.check_names(from, &section)?;
            self.apply(from, section);
        }
        Ok(msg)
    }

    /// Reads the body of a message of `kind`, with the names section it carries.
    fn read_body(
        &self,
        kind: Kind,
        r: &mut BitReader,
        from: &Address,
        schema: &Schema,
    ) -> Result<(Message, Option<Section>), DecodeError> {
        let base = self.sources.get(from).map(|h| &h.dict);
        Ok(match kind {
            Kind::Report | Kind::CatchUpAnswer => {
                let (report, section) = read_report(ReportReader {
                    r,
                    from,
                    base,
                    schema,
                })?;
                match kind {
                    Kind::Report => (Message::Report(report), section),
                    _ => (Message::CatchUpAnswer(report), section),
                }
            }
            Kind::Names => {
                let section = read_section(r, base)?;
                (Message::Names(names_of(&section, base)?), Some(section))
            }
            other => (read_simple(other, r)?, None),
        })
    }

    /// Refuses `section` if it would take `from`'s dictionary past the names one source
    /// may have.
    fn check_names(&self, from: &Address, section: &Section) -> Result<(), DecodeError> {
        let base = self.sources.get(from).map(|h| &h.dict);
        let names = SourceDict::len_with(base, section);
        if names <= self.max_names {
            return Ok(());
        }
        Err(DecodeError::TooManyNames {
            names: names as u64,
            max: self.max_names as u64,
        })
    }

    /// Applies a decoded names section, making room for a new source, and for its names
    /// among all sources', if needed.
    fn apply(&mut self, from: &Address, section: Section) {
        if !self.sources.contains_key(from) && self.sources.len() >= self.max_sources {
            self.evict_least_recent(from);
        }
        let base = self.sources.get(from).map(|h| &h.dict);
        let (before, after) = (
            base.map_or(0, SourceDict::len),
            SourceDict::len_with(base, &section),
        );
        // At most `max_names` (checked) of `max_total`: the others can always make room.
        while self.total - before + after > self.max_total && self.evict_least_recent(from) {}
        let heard = self.sources.entry(from.clone()).or_default();
        heard.dict.apply(section);
        self.total = self.total - before + heard.dict.len();
    }

    /// Drops the dictionary of the source heard least recently other than `keep` (a scan:
    /// it happens only when the table or the names are full); false if there is none.
    fn evict_least_recent(&mut self, keep: &Address) -> bool {
        let oldest = self
            .sources
            .iter()
            .filter(|(a, _)| *a != keep)
            .min_by_key(|(_, h)| h.last);
        let Some(gone) = oldest.map(|(a, _)| a.clone()) else {
            return false;
        };
        if let Some(heard) = self.sources.remove(&gone) {
            self.total -= heard.dict.len();
        }
        self.stats.evicted += 1;
        self.evicted = Some(gone);
        true
    }
}

/// Reads the 1-byte header: version in the high 4 bits, kind in the low 4.
fn read_header(r: &mut BitReader) -> Result<Kind, DecodeError> {
    let version = r.bits(4)? as u8;
    let kind = r.bits(4)? as u8;
    if version != VERSION {
        return Err(DecodeError::BadVersion(version));
    }
    Kind::from_number(kind).ok_or(DecodeError::UnknownKind(kind))
}

/// The entries a `Names` message announced, in order.
fn names_of(section: &Section, base: Option<&SourceDict>) -> Result<Names, DecodeError> {
    let view = View::new(base, Some(section));
    let objects = section
        .objects
        .iter()
        .map(|id| Ok(view.object((*id).into())?.entry.clone()))
        .collect::<Result<_, DecodeError>>()?;
    let attrs = section
        .attrs
        .iter()
        .map(|id| view.attr((*id).into()).cloned())
        .collect::<Result<_, _>>()?;
    Ok(Names { objects, attrs })
}

/// Messages that need no dictionary.
fn read_simple(kind: Kind, r: &mut BitReader) -> Result<Message, DecodeError> {
    Ok(match kind {
        Kind::Classes => Message::Classes(read_classes(r)?),
        Kind::Plan => Message::Plan(read_plan(r)?),
        Kind::PlanAck => Message::PlanAck(read_ack(r)?),
        Kind::PlanCancel => Message::PlanCancel { circuit: r.uvar()? },
        Kind::CatchUpRequest => Message::CatchUpRequest(read_catch_up(r)?),
        Kind::Heartbeat => Message::Heartbeat(read_heartbeat(r)?),
        // Read by `Decoder::read`, never here.
        Kind::Report | Kind::CatchUpAnswer | Kind::Names => {
            return Err(DecodeError::UnknownKind(kind as u8));
        }
    })
}
