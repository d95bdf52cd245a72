//! The sender's side: one `Encoder` per sending module.

use rustc_hash::FxHashSet;
use std::sync::Arc;

use slate_model::{Address, Timestamp};

use crate::bits::BitWriter;
use crate::classes::{check_classes, write_classes};
use crate::control::{write_ack, write_catch_up, write_heartbeat, write_plan};
use crate::dictionary::Dictionary;
use crate::error::check_len;
use crate::message::Kind;
use crate::names::{Announce, write_section};
use crate::report::write_report;
use crate::{
    AssertionParts, EncodeError, MAX_ITEMS, MAX_MESSAGE_BYTES, Message, Names, ObjectEntry, Schema,
    VERSION,
};

/// Turns messages into bytes for one sending module.
///
/// The encoder owns the sender's name dictionary: it interns object, class, attribute
/// and address names to small ids and announces each entry (inline, at the start of
/// the report that first needs it) exactly once, until
/// [`reset_announcements`](Encoder::reset_announcements). It also chooses the sender's
/// timestamp epoch (the first timestamp it encodes, rounded down to the second).
///
/// A failed encode changes nothing: what it would have announced is not marked.
#[derive(Debug)]
pub struct Encoder {
    address: Address,
    dict: Dictionary,
    /// The last message encoded announced entries ([`Encoder::announced`]).
    announced: bool,
}

impl Encoder {
    /// An encoder for the module at `address` (packets whose source is `address` are
    /// written without one; the receiver learns it from the transport).
    pub fn new(address: Address) -> Self {
        Encoder {
            address,
            dict: Dictionary::default(),
            announced: false,
        }
    }

    /// The sending module's address.
    pub fn address(&self) -> &Address {
        &self.address
    }

    /// The timestamp epoch, once chosen (whole seconds; timestamps travel relative to it).
    pub fn epoch(&self) -> Option<Timestamp> {
        self.dict.epoch()
    }

    /// Did the last message encoded announce entries (names, classes, the epoch)? A
    /// receiver that misses it cannot decode the later messages that use them until it
    /// catches up with `needs_names`: a sender for which no message may be lost sends
    /// this one so that it cannot be.
    pub fn announced(&self) -> bool {
        self.announced
    }

    /// Announces everything again from the next message on (ids and the epoch stay the
    /// same). Call it when a receiver asks to catch up with `needs_names`.
    pub fn reset_announcements(&mut self) {
        self.dict.reset();
    }

    /// Encodes one message: a 1-byte header (version, kind), then the body. Reports
    /// and catch-up answers are packed against `schema`; other messages ignore it.
    pub fn encode(&mut self, msg: &Message, schema: &Schema) -> Result<Vec<u8>, EncodeError> {
        self.message(msg.kind(), |enc, w| enc.write(w, msg, schema))
    }

    /// Encodes a report at position `seq` of these assertions, as
    /// [`encode`](Encoder::encode) does a `Message::Report`, however the sender keeps
    /// them (references to [`Assertion`](crate::Assertion)s, or its own
    /// [`AssertionParts`]): it need not copy them into a [`Report`](crate::Report).
    pub fn encode_report<A: AssertionParts>(
        &mut self,
        seq: u64,
        items: &[A],
        schema: &Schema,
    ) -> Result<Vec<u8>, EncodeError> {
        self.message(Kind::Report, |enc, w| {
            let items = items.iter();
            enc.announced = write_report(w, seq, items, &mut enc.dict, &enc.address, schema)?;
            Ok(())
        })
    }

    /// A message of `kind` whose body `body` writes; the dictionary keeps what it
    /// announced only if the whole message encodes.
    fn message(
        &mut self,
        kind: Kind,
        body: impl FnOnce(&mut Self, &mut BitWriter) -> Result<(), EncodeError>,
    ) -> Result<Vec<u8>, EncodeError> {
        self.announced = false;
        let mut w = BitWriter::new();
        w.bits(VERSION.into(), 4);
        w.bits(kind as u64, 4);
        let result = body(self, &mut w)
            .and_then(|()| check_len("message bytes", w.len_bytes(), MAX_MESSAGE_BYTES));
        match result {
            Ok(()) => {
                self.dict.commit();
                Ok(w.finish())
            }
            Err(e) => {
                self.dict.rollback();
                self.announced = false;
                Err(e)
            }
        }
    }

    fn write(
        &mut self,
        w: &mut BitWriter,
        msg: &Message,
        schema: &Schema,
    ) -> Result<(), EncodeError> {
        match msg {
            Message::Report(r) | Message::CatchUpAnswer(r) => {
                let (items, me) = (r.items.iter(), &self.address);
                self.announced = write_report(w, r.seq, items, &mut self.dict, me, schema)?;
            }
            Message::Names(names) => {
                self.write_names(w, names, schema)?;
                self.announced = true;
            }
            Message::Classes(defs) => {
                check_classes(defs)?;
                write_classes(w, defs);
            }
            Message::Plan(p) => write_plan(w, p)?,
            Message::PlanAck(a) => write_ack(w, a)?,
            Message::PlanCancel { circuit } => w.uvar(*circuit),
            Message::CatchUpRequest(c) => write_catch_up(w, c),
            Message::Heartbeat(h) => write_heartbeat(w, h),
        }
        Ok(())
    }

    /// A `Names` message announces every listed entry (again, if need be), with the
    /// classes, owners and epoch they need that were not announced yet.
    fn write_names(
        &mut self,
        w: &mut BitWriter,
        names: &Names,
        schema: &Schema,
    ) -> Result<(), EncodeError> {
        let objects = distinct(&names.objects, |o: &ObjectEntry| o.name.clone());
        let attrs = distinct(&names.attrs, Arc::clone);
        check_len(
            "names in a message",
            objects.len().max(attrs.len()),
            MAX_ITEMS,
        )?;
        let mut ann = Announce::default();
        self.dict.announce_epoch(&mut ann);
        for name in attrs {
            self.dict.attr(name, true, &mut ann)?;
        }
        for entry in objects {
            self.dict.object(entry, schema, true, &mut ann)?;
        }
        check_len("names in a message", ann.max_len(), MAX_ITEMS)?;
        write_section(w, &ann);
        Ok(())
    }
}

/// The items with distinct keys, first occurrence kept, in order.
fn distinct<T>(items: &[T], key: impl Fn(&T) -> Arc<str>) -> Vec<&T> {
    let mut seen = FxHashSet::default();
    items.iter().filter(|i| seen.insert(key(i))).collect()
}
