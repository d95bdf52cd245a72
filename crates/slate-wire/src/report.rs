//! The report body (also the catch-up answer's): names inline when new, then the
//! assertions bit-packed against the schema.

use std::sync::Arc;

use slate_model::{Address, Packet, Timestamp, Value};
use smallvec::SmallVec;

use crate::bits::{BitReader, BitWriter, width};
use crate::dictionary::{Dictionary, Resolved};
use crate::error::check_len;
use crate::names::{Announce, Section, SourceDict, View, read_section, write_section};
use crate::quant::{read_accuracy, read_confidence, write_accuracy, write_confidence};
use crate::schema::AttrSchema;
use crate::value::{check_quality, check_value};
use crate::{
    Assertion, AssertionParts, DecodeError, EncodeError, MAX_ELEMENTS, MAX_ITEMS, ObjectEntry,
    Report, Schema,
};

/// Bits of the id-width fields.
const WIDTH_BITS: u32 = 5;
/// Widest id: ids are below `MAX_IDS` = 2^16.
const MAX_WIDTH: u64 = 16;
const LOGICAL_BITS: u32 = slate_model::LOGICAL_BITS;
/// Largest physical time (µs) a timestamp holds.
const MAX_PHYSICAL: u64 = u64::MAX >> LOGICAL_BITS;

/// One assertion, resolved for writing.
struct Entry<'a> {
    object: u32,
    attr: u32,
    /// The packet's source, if it is not the sender.
    source: Option<u32>,
    schema: Arc<AttrSchema>,
    packet: &'a Packet,
}

/// Report-wide flags.
#[derive(Clone, Copy, Debug, Default)]
struct Flags {
    names: bool,
    /// Every packet has the base timestamp: no per-entry timestamps.
    uniform: bool,
    /// Some value is `none`: every entry has a none bit.
    nones: bool,
    /// Some packet's source is not the sender: every entry has a source bit.
    foreign: bool,
}

impl Flags {
    fn of(entries: &[Entry], base: Option<Timestamp>, ann: &Announce) -> Self {
        Flags {
            names: !ann.is_empty(),
            uniform: entries.iter().all(|e| Some(e.packet.timestamp) == base),
            nones: entries.iter().any(|e| e.packet.value.is_none()),
            foreign: entries.iter().any(|e| e.source.is_some()),
        }
    }

    fn write(self, w: &mut BitWriter) {
        for flag in [self.names, self.uniform, self.nones, self.foreign] {
            w.bit(flag);
        }
    }

    fn read(r: &mut BitReader) -> Result<Self, DecodeError> {
        let bits = r.bits(4)?;
        Ok(Flags {
            names: bits & 8 != 0,
            uniform: bits & 4 != 0,
            nones: bits & 2 != 0,
            foreign: bits & 1 != 0,
        })
    }
}

/// Writes a report body: position `seq`, then `items`. Interns (and announces) what it
/// names in `dict`; the caller commits or rolls back the dictionary. Returns whether it
/// announced anything.
pub(crate) fn write_report<'a, A: AssertionParts + 'a>(
    w: &mut BitWriter,
    seq: u64,
    items: impl ExactSizeIterator<Item = &'a A>,
    dict: &mut Dictionary,
    me: &Address,
    schema: &Schema,
) -> Result<bool, EncodeError> {
    let mut ann = Announce::default();
    let entries = resolve_all(items, dict, me, schema, &mut ann)?;
    let base = entries.iter().map(|e| e.packet.timestamp).min();
    let epoch = base.map(|b| dict.epoch_for(b, &mut ann));
    check_len("names in a message", ann.max_len(), MAX_ITEMS)?;
    let flags = Flags::of(&entries, base, &ann);
    w.uvar(seq);
    flags.write(w);
    if flags.names {
        write_section(w, &ann);
    }
    w.uvar(entries.len() as u64);
    if let (Some(base), Some(epoch)) = (base, epoch) {
        write_entries(w, &entries, flags, base, epoch);
    }
    Ok(!ann.is_empty())
}

/// A report's entries: an occasional report holds one or two, inline.
type Entries<'a> = SmallVec<[Entry<'a>; 2]>;

/// Resolves every assertion, within the item and vector-element limits.
fn resolve_all<'a, A: AssertionParts + 'a>(
    items: impl ExactSizeIterator<Item = &'a A>,
    dict: &mut Dictionary,
    me: &Address,
    schema: &Schema,
    ann: &mut Announce,
) -> Result<Entries<'a>, EncodeError> {
    check_len("assertions in a report", items.len(), MAX_ITEMS)?;
    let mut entries = Entries::with_capacity(items.len());
    for a in items {
        entries.push(resolve(a, dict, me, schema, ann)?);
    }
    let elements = entries
        .iter()
        .map(|e| e.packet.value.as_vector().map_or(0, <[f64]>::len));
    check_len(
        "vector elements in the message",
        elements.sum(),
        MAX_ELEMENTS,
    )?;
    Ok(entries)
}

/// Checks an assertion against the schema and interns its names.
fn resolve<'a>(
    a: &'a impl AssertionParts,
    dict: &mut Dictionary,
    me: &Address,
    schema: &Schema,
    ann: &mut Announce,
) -> Result<Entry<'a>, EncodeError> {
    let (entry, name, p) = (a.object(), a.attr(), a.packet());
    let (object, attr, attr_schema) = match dict.recall(entry, name, schema) {
        Some(r) => (r.object, r.attr, r.schema.clone()),
        None => {
            let object = dict.object(entry, schema, false, ann)?;
            let attr_schema = declared(entry, name, schema)?.clone();
            let attr = dict.attr(name, false, ann)?;
            let resolved = Resolved {
                object,
                attr,
                schema: attr_schema.clone(),
            };
            dict.remember(entry, name, schema, resolved);
            (object, attr, attr_schema)
        }
    };
    check_value(&p.value, &attr_schema.decl)
        .and_then(|()| check_quality(p.accuracy, p.confidence))
        .map_err(|source| EncodeError::Invalid {
            object: entry.name.to_string(),
            attr: name.to_string(),
            source,
        })?;
    let source = (p.source != *me)
        .then(|| dict.addr(&p.source, ann))
        .transpose()?;
    Ok(Entry {
        object,
        attr,
        source,
        schema: attr_schema,
        packet: p,
    })
}

/// The declaration of `object.attr`.
fn declared<'a>(
    object: &ObjectEntry,
    attr: &str,
    schema: &'a Schema,
) -> Result<&'a Arc<AttrSchema>, EncodeError> {
    let class = schema.class(&object.class);
    class
        .and_then(|c| c.attr(attr))
        .ok_or_else(|| EncodeError::UnknownAttr {
            object: object.name.to_string(),
            attr: attr.to_string(),
        })
}

/// Writes the id widths, the base timestamp and the entries.
fn write_entries(w: &mut BitWriter, entries: &[Entry], flags: Flags, base: Timestamp, epoch: u64) {
    let max_object = entries.iter().map(|e| e.object).max().unwrap_or(0);
    let max_attr = entries.iter().map(|e| e.attr).max().unwrap_or(0);
    let (object_bits, attr_bits) = (width(max_object.into()), width(max_attr.into()));
    w.bits(object_bits.into(), WIDTH_BITS);
    w.bits(attr_bits.into(), WIDTH_BITS);
    let base_us = base.raw() >> LOGICAL_BITS;
    w.ivar(base_us as i64 - epoch as i64);
    write_logical(w, base);
    for (i, e) in entries.iter().enumerate() {
        let same = i > 0 && entries[i - 1].object == e.object;
        if i > 0 {
            w.bit(same);
        }
        if !same {
            w.bits(e.object.into(), object_bits);
        }
        w.bits(e.attr.into(), attr_bits);
        write_packet(w, e, flags, base_us);
    }
}

/// Writes one entry's packet: source, value, accuracy, confidence, timestamp.
fn write_packet(w: &mut BitWriter, e: &Entry, flags: Flags, base_us: u64) {
    let (p, s) = (e.packet, &*e.schema);
    if flags.foreign {
        w.bit(e.source.is_some());
        e.source.iter().for_each(|id| w.uvar((*id).into()));
    }
    if flags.nones {
        w.bit(p.value.is_none());
    }
    if !p.value.is_none() {
        s.codec.write(w, &p.value);
    }
    w.bit(p.accuracy != s.default_accuracy);
    if p.accuracy != s.default_accuracy {
        write_accuracy(w, p.accuracy, s.accuracy_scale);
    }
    w.bit(p.confidence != s.default_confidence);
    if p.confidence != s.default_confidence {
        write_confidence(w, p.confidence);
    }
    if !flags.uniform {
        w.uvar((p.timestamp.raw() >> LOGICAL_BITS) - base_us);
        write_logical(w, p.timestamp);
    }
}

/// The logical counter: a 0 bit when it is zero, else a 1 bit and its 12 bits.
fn write_logical(w: &mut BitWriter, t: Timestamp) {
    let logical = t.logical();
    w.bit(logical != 0);
    if logical != 0 {
        w.bits(logical, LOGICAL_BITS);
    }
}

fn read_logical(r: &mut BitReader) -> Result<u64, DecodeError> {
    if r.bit()? {
        r.bits(LOGICAL_BITS)
    } else {
        Ok(0)
    }
}

/// What reading a report needs: the message, the sender, its dictionary, the schema.
pub(crate) struct ReportReader<'a, 'b> {
    pub r: &'b mut BitReader<'a>,
    pub from: &'b Address,
    pub base: Option<&'b SourceDict>,
    pub schema: &'b Schema,
}

/// Reads a report body; returns it with the names section it carried (to apply once
/// the whole message has decoded).
pub(crate) fn read_report(rr: ReportReader) -> Result<(Report, Option<Section>), DecodeError> {
    let r = rr.r;
    let seq = r.uvar()?;
    let flags = Flags::read(r)?;
    let section = if flags.names {
        Some(read_section(r, rr.base)?)
    } else {
        None
    };
    let view = View::new(rr.base, section.as_ref());
    let n = r.count("assertions in a report", MAX_ITEMS)?;
    let items = if n == 0 {
        Vec::new()
    } else {
        let mut er = EntryReader::start(r, view, rr.schema, flags)?;
        let mut items = Vec::with_capacity(n);
        for i in 0..n {
            items.push(er.entry(r, i, rr.from)?);
        }
        items
    };
    Ok((Report { seq, items }, section))
}

/// Reads entries, remembering the previous object.
struct EntryReader<'a> {
    view: View<'a>,
    schema: &'a Schema,
    flags: Flags,
    object_bits: u32,
    attr_bits: u32,
    base_us: u64,
    base_logical: u64,
    object: u64,
}

impl<'a> EntryReader<'a> {
    fn start(
        r: &mut BitReader,
        view: View<'a>,
        schema: &'a Schema,
        flags: Flags,
    ) -> Result<Self, DecodeError> {
        let object_bits = read_width(r)?;
        let attr_bits = read_width(r)?;
        let offset = r.ivar()?;
        let base_us = view
            .epoch_us()?
            .checked_add_signed(offset)
            .filter(|us| *us <= MAX_PHYSICAL);
        Ok(EntryReader {
            view,
            schema,
            flags,
            object_bits,
            attr_bits,
            base_us: base_us.ok_or(DecodeError::BadValue("timestamp out of range"))?,
            base_logical: read_logical(r)?,
            object: 0,
        })
    }

    fn entry(
        &mut self,
        r: &mut BitReader,
        i: usize,
        from: &Address,
    ) -> Result<Assertion, DecodeError> {
        if i == 0 || !r.bit()? {
            self.object = r.bits(self.object_bits)?;
        }
        let known = self.view.object(self.object)?;
        let attr = self.view.attr(r.bits(self.attr_bits)?)?;
        let mismatch = || DecodeError::SchemaMismatch {
            object: known.entry.name.to_string(),
            class: known.entry.class.to_string(),
        };
        let class = self
            .schema
            .class(&known.entry.class)
            .filter(|c| c.fingerprint == known.fingerprint);
        let attr_schema = class.and_then(|c| c.attr(attr)).ok_or_else(mismatch)?;
        let packet = self.packet(r, attr_schema, from)?;
        Ok(Assertion {
            object: known.entry.clone(),
            attr: attr.clone(),
            packet,
        })
    }

    fn packet(
        &self,
        r: &mut BitReader,
        s: &AttrSchema,
        from: &Address,
    ) -> Result<Packet, DecodeError> {
        let foreign = self.flags.foreign && r.bit()?;
        let source = if foreign {
            self.view.addr(r.uvar()?)?.clone()
        } else {
            from.clone()
        };
        let value = self.value(r, s)?;
        let accuracy = or_default(r, s.default_accuracy, |r| {
            read_accuracy(r, s.accuracy_scale)
        })?;
        let confidence = or_default(r, s.default_confidence, read_confidence)?;
        Ok(Packet {
            value,
            accuracy,
            confidence,
            timestamp: self.timestamp(r)?,
            source,
        })
    }

    /// Reads a value (or its absence), which must fit the declaration.
    fn value(&self, r: &mut BitReader, s: &AttrSchema) -> Result<Value, DecodeError> {
        let none = self.flags.nones && r.bit()?;
        let value = if none { Value::None } else { s.codec.read(r)? };
        check_value(&value, &s.decl)
            .map_err(|_| DecodeError::BadValue("value outside its declaration"))?;
        Ok(value)
    }

    fn timestamp(&self, r: &mut BitReader) -> Result<Timestamp, DecodeError> {
        if self.flags.uniform {
            return Ok(Timestamp::from_raw(
                (self.base_us << LOGICAL_BITS) | self.base_logical,
            ));
        }
        let us = self
            .base_us
            .checked_add(r.uvar()?)
            .filter(|us| *us <= MAX_PHYSICAL);
        let us = us.ok_or(DecodeError::BadValue("timestamp out of range"))?;
        Ok(Timestamp::from_raw((us << LOGICAL_BITS) | read_logical(r)?))
    }
}

/// A field after a flag bit: 0 means the declared default, 1 that the field follows.
fn or_default(
    r: &mut BitReader,
    default: f64,
    read: impl FnOnce(&mut BitReader) -> Result<f64, DecodeError>,
) -> Result<f64, DecodeError> {
    if r.bit()? { read(r) } else { Ok(default) }
}

fn read_width(r: &mut BitReader) -> Result<u32, DecodeError> {
    let bits = r.bits(WIDTH_BITS)?;
    if bits > MAX_WIDTH {
        return Err(DecodeError::BadValue("id width over 16 bits"));
    }
    Ok(bits as u32)
}
