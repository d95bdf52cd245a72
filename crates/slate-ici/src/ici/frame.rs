//! The ICI's own frames, beside the slate-wire messages: hello (incarnation and
//! interest), lifecycle (object creations and deletions on a source's stream), and
//! the object list that ends a catch-up answer. Byte layouts are in `docs/ici.md`.
//!
//! The first byte's high nibble is 0 (slate-wire messages have version 1 there), the low
//! nibble the frame kind. Fields are byte-aligned LEB128 varints and length-prefixed
//! UTF-8. Decoding checks every length against the bytes left and never panics.

use std::sync::Arc;

use slate_model::{Context, Timestamp};

use super::classes::{ALL_CONTEXTS, ClassSet};

const HELLO: u8 = 1;
const LIFECYCLE: u8 = 2;
const OBJECT_LIST: u8 = 3;
/// The most items a count may announce (also checked against the bytes left).
pub(crate) const MAX_ITEMS: u64 = slate_wire::MAX_ITEMS as u64;
/// The longest string, in bytes.
pub(crate) const MAX_NAME: u64 = slate_wire::MAX_NAME_BYTES as u64;

/// A module's hello: which incarnation it is and what it models; `reply` when it
/// answers the other's hello (a hello that is not a reply is answered by one, so its
/// sender knows it was heard); `observer` when its sender is a short-lived observer, to
/// be forgotten as soon as it leaves.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Hello {
    pub incarnation: u64,
    pub interest: ClassSet,
    pub reply: bool,
    pub observer: bool,
}

/// The bits of a hello's flags byte.
const HELLO_REPLY: u8 = 1;
const HELLO_OBSERVER: u8 = 2;

/// An object as a source lists it: name, class (with the fingerprint of its
/// definition, as slate-wire computes it), context on the source's board.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Listed {
    pub name: Arc<str>,
    pub class: Arc<str>,
    pub fingerprint: u32,
    pub context: Context,
}

/// Creations and deletions of objects the source owns, numbered on its stream.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Lifecycle {
    pub seq: u64,
    pub created: Vec<(Listed, Timestamp)>,
    pub deleted: Vec<(Arc<str>, Timestamp)>,
}

/// Every object the source owns that the receiver is to hold, as of `stamp` and
/// stream position `seq`. Ends a catch-up answer.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ObjectList {
    pub seq: u64,
    pub stamp: Timestamp,
    /// False when the list had to be cut at the item limit (then nothing is swept).
    pub complete: bool,
    pub objects: Vec<Listed>,
}

#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Frame {
    Hello(Hello),
    Lifecycle(Lifecycle),
    ObjectList(ObjectList),
}

/// A frame that could not be read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub(crate) enum FrameError {
    /// The bytes end inside a field.
    #[error("frame truncated")]
    Truncated,
    /// A field holds what its layout forbids; the text says which.
    #[error("bad frame: {0}")]
    Bad(&'static str),
}

// ----- writing -----

/// Appends fields to a frame (shared with the team protocol's frames, `team/frame.rs`).
#[derive(Default)]
pub(crate) struct Writer(pub(crate) Vec<u8>);

impl Writer {
    /// An unsigned LEB128 varint.
    pub(crate) fn var(&mut self, mut v: u64) {
        loop {
            let byte = (v & 0x7f) as u8;
            v >>= 7;
            if v == 0 {
                self.0.push(byte);
                return;
            }
            self.0.push(byte | 0x80);
        }
    }

    /// A length-prefixed UTF-8 string.
    pub(crate) fn str(&mut self, s: &str) {
        self.var(s.len() as u64);
        self.0.extend_from_slice(s.as_bytes());
    }

    fn listed(&mut self, l: &Listed) {
        self.str(&l.name);
        self.str(&l.class);
        self.0.extend_from_slice(&l.fingerprint.to_be_bytes());
        self.0.push(context_code(l.context));
    }
}

fn context_code(c: Context) -> u8 {
    match c {
        Context::Self_ => 0,
        Context::Surroundings => 1,
        Context::System => 2,
    }
}

impl Frame {
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::default();
        match self {
            Frame::Hello(h) => {
                w.0.push(HELLO);
                w.var(h.incarnation);
                w.var(h.interest.rules().len() as u64);
                for (class, mask) in h.interest.rules() {
                    w.str(class);
                    w.0.push(*mask);
                }
                let observer = if h.observer { HELLO_OBSERVER } else { 0 };
                w.0.push(u8::from(h.reply) | observer);
            }
            Frame::Lifecycle(l) => write_lifecycle(&mut w, l),
            Frame::ObjectList(o) => {
                w.0.push(OBJECT_LIST);
                w.var(o.seq);
                w.var(o.stamp.raw());
                w.0.push(u8::from(o.complete));
                w.var(o.objects.len() as u64);
                o.objects.iter().for_each(|l| w.listed(l));
            }
        }
        w.0
    }

    pub fn decode(bytes: &[u8]) -> Result<Frame, FrameError> {
        let mut r = Reader { bytes, at: 0 };
        let frame = match r.byte()? {
            HELLO => Frame::Hello(read_hello(&mut r)?),
            LIFECYCLE => Frame::Lifecycle(read_lifecycle(&mut r)?),
            OBJECT_LIST => Frame::ObjectList(read_object_list(&mut r)?),
            _ => return Err(FrameError::Bad("unknown frame kind")),
        };
        if r.at != bytes.len() {
            return Err(FrameError::Bad("trailing bytes"));
        }
        Ok(frame)
    }
}

fn write_lifecycle(w: &mut Writer, l: &Lifecycle) {
    w.0.push(LIFECYCLE);
    w.var(l.seq);
    w.var(l.created.len() as u64);
    for (listed, ts) in &l.created {
        w.listed(listed);
        w.var(ts.raw());
    }
    w.var(l.deleted.len() as u64);
    for (name, ts) in &l.deleted {
        w.str(name);
        w.var(ts.raw());
    }
}

// ----- reading -----

/// Reads fields of a frame, checking each against the bytes left (shared with the team
/// protocol's frames, `team/frame.rs`).
pub(crate) struct Reader<'a> {
    pub(crate) bytes: &'a [u8],
    /// The next byte to read.
    pub(crate) at: usize,
}

impl<'a> Reader<'a> {
    pub(crate) fn byte(&mut self) -> Result<u8, FrameError> {
        let b = *self.bytes.get(self.at).ok_or(FrameError::Truncated)?;
        self.at += 1;
        Ok(b)
    }

    pub(crate) fn var(&mut self) -> Result<u64, FrameError> {
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let b = self.byte()?;
            let part = u64::from(b & 0x7f);
            if shift == 63 && part > 1 {
                return Err(FrameError::Bad("varint overflow"));
            }
            v |= part << shift;
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err(FrameError::Bad("varint overflow"))
    }

    /// A count, checked against the limit and against the bytes left (each item takes
    /// at least one byte).
    pub(crate) fn count(&mut self) -> Result<usize, FrameError> {
        let n = self.var()?;
        if n > MAX_ITEMS || n > (self.bytes.len() - self.at) as u64 {
            return Err(FrameError::Bad("count too large"));
        }
        Ok(n as usize)
    }

    /// An identifier (class or object name).
    pub(crate) fn name(&mut self) -> Result<Arc<str>, FrameError> {
        let text = self.text()?;
        if !is_identifier(text) {
            return Err(FrameError::Bad("name is not an identifier"));
        }
        Ok(text.into())
    }

    /// A length-prefixed UTF-8 string of at most `MAX_NAME` bytes.
    pub(crate) fn text(&mut self) -> Result<&'a str, FrameError> {
        let len = self.var()?;
        if len > MAX_NAME {
            return Err(FrameError::Bad("name too long"));
        }
        let end = self
            .at
            .checked_add(len as usize)
            .ok_or(FrameError::Truncated)?;
        let raw = self.bytes.get(self.at..end).ok_or(FrameError::Truncated)?;
        let text = std::str::from_utf8(raw).map_err(|_| FrameError::Bad("name is not UTF-8"))?;
        self.at = end;
        Ok(text)
    }

    fn context(&mut self) -> Result<Context, FrameError> {
        match self.byte()? {
            0 => Ok(Context::Self_),
            1 => Ok(Context::Surroundings),
            2 => Ok(Context::System),
            _ => Err(FrameError::Bad("context")),
        }
    }

    fn fingerprint(&mut self) -> Result<u32, FrameError> {
        let mut b = [0u8; 4];
        for x in &mut b {
            *x = self.byte()?;
        }
        Ok(u32::from_be_bytes(b))
    }

    fn listed(&mut self) -> Result<Listed, FrameError> {
        Ok(Listed {
            name: self.name()?,
            class: self.name()?,
            fingerprint: self.fingerprint()?,
            context: self.context()?,
        })
    }
}

fn is_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// A class set as every frame carries it: a count, then each class's name and context
/// mask (at least one context, no unknown bit).
pub(crate) fn read_class_set(r: &mut Reader<'_>) -> Result<ClassSet, FrameError> {
    let mut set = ClassSet::none();
    for _ in 0..r.count()? {
        let class = r.name()?;
        let mask = r.byte()?;
        if mask == 0 || mask & !ALL_CONTEXTS != 0 {
            return Err(FrameError::Bad("context mask"));
        }
        set = set.with(&class, mask);
    }
    Ok(set)
}

fn read_hello(r: &mut Reader<'_>) -> Result<Hello, FrameError> {
    let incarnation = r.var()?;
    let interest = read_class_set(r)?;
    let flags = r.byte()?;
    if flags & !(HELLO_REPLY | HELLO_OBSERVER) != 0 {
        return Err(FrameError::Bad("hello flags"));
    }
    Ok(Hello {
        incarnation,
        interest,
        reply: flags & HELLO_REPLY != 0,
        observer: flags & HELLO_OBSERVER != 0,
    })
}

fn read_lifecycle(r: &mut Reader<'_>) -> Result<Lifecycle, FrameError> {
    let seq = r.var()?;
    let mut created = Vec::new();
    for _ in 0..r.count()? {
        created.push((r.listed()?, Timestamp::from_raw(r.var()?)));
    }
    let mut deleted = Vec::new();
    for _ in 0..r.count()? {
        deleted.push((r.name()?, Timestamp::from_raw(r.var()?)));
    }
    Ok(Lifecycle {
        seq,
        created,
        deleted,
    })
}

fn read_object_list(r: &mut Reader<'_>) -> Result<ObjectList, FrameError> {
    let seq = r.var()?;
    let stamp = Timestamp::from_raw(r.var()?);
    let complete = match r.byte()? {
        0 => false,
        1 => true,
        _ => return Err(FrameError::Bad("flag")),
    };
    let mut objects = Vec::new();
    for _ in 0..r.count()? {
        objects.push(r.listed()?);
    }
    Ok(ObjectList {
        seq,
        stamp,
        complete,
        objects,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn listed(name: &str) -> Listed {
        Listed {
            name: name.into(),
            class: "Rock".into(),
            fingerprint: 0xdead_beef,
            context: Context::System,
        }
    }

    fn samples() -> Vec<Frame> {
        vec![
            Frame::Hello(Hello {
                incarnation: u64::MAX,
                interest: ClassSet::none()
                    .class("Vehicle")
                    .class_in("Rock", &[Context::Self_]),
                reply: true,
                observer: false,
            }),
            Frame::Lifecycle(Lifecycle {
                seq: 300,
                created: vec![(listed("r1"), Timestamp::from_raw(1 << 40))],
                deleted: vec![("r0".into(), Timestamp::from_raw(5))],
            }),
            Frame::ObjectList(ObjectList {
                seq: 7,
                stamp: Timestamp::from_raw(99),
                complete: true,
                objects: vec![listed("a"), listed("b")],
            }),
        ]
    }

    #[test]
    fn frames_round_trip() {
        for f in samples() {
            assert_eq!(Frame::decode(&f.encode()), Ok(f));
        }
    }

    #[test]
    fn an_observers_hello_says_so_and_unknown_flags_are_refused() {
        let hello = |reply, observer| Hello {
            incarnation: 3,
            interest: ClassSet::none(),
            reply,
            observer,
        };
        for (reply, observer) in [(false, true), (true, true), (false, false)] {
            let f = Frame::Hello(hello(reply, observer));
            assert_eq!(Frame::decode(&f.encode()), Ok(f));
        }
        let mut bytes = Frame::Hello(hello(false, true)).encode();
        *bytes.last_mut().unwrap() |= 4;
        assert!(Frame::decode(&bytes).is_err());
    }

    #[test]
    fn frames_start_with_version_zero_and_their_kind() {
        let kinds: Vec<u8> = samples().iter().map(|f| f.encode()[0]).collect();
        assert_eq!(kinds, [1, 2, 3]);
    }

    #[test]
    fn truncated_and_trailing_frames_are_refused() {
        for f in samples() {
            let bytes = f.encode();
            for n in 0..bytes.len() {
                assert!(Frame::decode(&bytes[..n]).is_err(), "{f:?} cut at {n}");
            }
            let mut long = bytes.clone();
            long.push(0);
            assert!(Frame::decode(&long).is_err());
        }
    }

    proptest! {
        #[test]
        fn any_bytes_decode_or_fail_without_panicking(bytes in proptest::collection::vec(any::<u8>(), 0..64)) {
            let _ = Frame::decode(&bytes);
        }

        #[test]
        fn mutated_frames_never_panic(i in 0usize..3, at in 0usize..64, byte in any::<u8>()) {
            let mut bytes = samples()[i].encode();
            let at = at % bytes.len();
            bytes[at] = byte;
            let _ = Frame::decode(&bytes);
        }
    }
}
