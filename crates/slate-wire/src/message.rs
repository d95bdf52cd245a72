//! The messages slate sends, as plain data. How they look in bytes is `docs/wire.md`.

use std::sync::Arc;

use slate_model::{Address, ClassDef, Context, ObjectInfo, Packet};

/// One message of the wire format.
#[derive(Clone, Debug, PartialEq)]
pub enum Message {
    /// A batch of assertions from one source.
    Report(Report),
    /// Dictionary entries of the sender (objects and attributes it will refer to).
    Names(Names),
    /// Class definitions, in full.
    Classes(Vec<ClassDef>),
    /// A plan sent to a module on a virtual circuit.
    Plan(Plan),
    /// A step of a plan's progress, sent back to its origin.
    PlanAck(PlanAck),
    /// The origin cancels the plan on this circuit.
    PlanCancel {
        /// The circuit.
        circuit: u64,
    },
    /// A receiver asks a source to bring it up to date.
    CatchUpRequest(CatchUpRequest),
    /// A source's current state (not its history): `seq` is the stream position it is
    /// current as of, and the items are its current packets.
    CatchUpAnswer(Report),
    /// Liveliness of a source.
    Heartbeat(Heartbeat),
}

/// A batch of `(object, attribute, packet)` assertions from one source.
///
/// On the wire, names are interned and values are bit-packed from the schema, so a
/// decoded packet's value is within half a resolution of the one sent (see `docs/wire.md`).
/// A packet's `source` is the sender unless it says otherwise; the sender's own address
/// travels in the transport's envelope, not in the bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// The source's per-stream sequence number: receivers detect gaps and loss with it.
    /// Streams start at 1; 0 means "nothing yet".
    pub seq: u64,
    /// The assertions, in order.
    pub items: Vec<Assertion>,
}

/// One assertion of a report: an object's attribute has this packet.
#[derive(Clone, Debug, PartialEq)]
pub struct Assertion {
    /// The object (or class, for a class-level value).
    pub object: ObjectEntry,
    /// The attribute.
    pub attr: Arc<str>,
    /// The packet.
    pub packet: Packet,
}

/// An assertion's parts, wherever a sender keeps them: [`Encoder::encode_report`]
/// reads them through this. An [`Assertion`] is one; a sender may keep its own kind
/// (the ICI keeps an object's entry and attribute once for all its packets).
///
/// [`Encoder::encode_report`]: crate::Encoder::encode_report
pub trait AssertionParts {
    /// The object (or class, for a class-level value).
    fn object(&self) -> &ObjectEntry;
    /// The attribute.
    fn attr(&self) -> &Arc<str>;
    /// The packet.
    fn packet(&self) -> &Packet;
}

impl AssertionParts for Assertion {
    fn object(&self) -> &ObjectEntry {
        &self.object
    }

    fn attr(&self) -> &Arc<str> {
        &self.attr
    }

    fn packet(&self) -> &Packet {
        &self.packet
    }
}

impl<T: AssertionParts + ?Sized> AssertionParts for &T {
    fn object(&self) -> &ObjectEntry {
        (**self).object()
    }

    fn attr(&self) -> &Arc<str> {
        (**self).attr()
    }

    fn packet(&self) -> &Packet {
        (**self).packet()
    }
}

/// What a receiver needs to know about an object to create its copy: name, class,
/// context, owner. This is what a sender's dictionary entry announces.
///
/// For a class-level value (the "object" is a class), `class` is the class itself.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct ObjectEntry {
    /// Object name.
    pub name: Arc<str>,
    /// Class whose declarations the object's attributes follow.
    pub class: Arc<str>,
    /// Context.
    pub context: Context,
    /// Owning module.
    pub owner: Address,
}

impl ObjectEntry {
    /// An entry of an object in `class`, SURROUNDINGS, owner unknown.
    pub fn new(name: &str, class: &str) -> Self {
        ObjectEntry {
            name: name.into(),
            class: class.into(),
            context: Context::default(),
            owner: Address::unknown(),
        }
    }

    /// Sets the context.
    pub fn context(mut self, context: Context) -> Self {
        self.context = context;
        self
    }

    /// Sets the owner.
    pub fn owner(mut self, owner: Address) -> Self {
        self.owner = owner;
        self
    }

    /// Is this a class (a class-level value)?
    pub fn is_class(&self) -> bool {
        self.name == self.class
    }
}

impl From<&ObjectInfo> for ObjectEntry {
    fn from(info: &ObjectInfo) -> Self {
        let class = if info.is_class {
            info.name.clone()
        } else {
            info.class.clone()
        };
        ObjectEntry {
            name: info.name.clone(),
            class,
            context: info.context,
            owner: info.owner.clone(),
        }
    }
}

/// Dictionary entries announced by the sender.
///
/// Reports announce what they need by themselves; send `Names` explicitly to announce
/// objects ahead of any value (for example a newly created object). The entries'
/// classes and owners, and the sender's timestamp epoch, go along as needed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Names {
    /// Objects.
    pub objects: Vec<ObjectEntry>,
    /// Attribute names.
    pub attrs: Vec<Arc<str>>,
}

/// A plan sent to a module on a virtual circuit.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Virtual-circuit id chosen by the origin; acks and cancels name it.
    pub circuit: u64,
    /// Plan name.
    pub name: String,
    /// The plan in the slate language.
    pub source_text: String,
    /// Destination module.
    pub to: Address,
    /// The module whose plan it is, on whose authority it runs: the module that sent it,
    /// or, for a plan sent on by a plan received, that plan's origin. Acks go to the
    /// module that sent it (the transport's sender).
    pub origin: Address,
}

/// A step of a plan's progress on a circuit.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanAck {
    /// The circuit.
    pub circuit: u64,
    /// Step number on this circuit, from 1: the origin orders and deduplicates acks with it.
    pub seq: u64,
    /// What happened.
    pub step: PlanStep,
}

/// What happened to a plan (paper p.3: the virtual circuit's acknowledgements).
#[derive(Clone, Debug, PartialEq)]
pub enum PlanStep {
    /// The destination received the plan.
    Received,
    /// The plan checked and was installed.
    Accepted,
    /// The plan was refused.
    Rejected {
        /// Why.
        reason: String,
    },
    /// Its initiation condition became true.
    Initiated,
    /// Its action ran.
    Triggered {
        /// Did the action succeed?
        ok: bool,
        /// What it did, or why it failed.
        detail: String,
    },
    /// Its termination condition became true.
    Terminated,
    /// It was cancelled by the origin.
    Cancelled,
    /// The destination is gone (failed or unreachable).
    DestinationLost,
}

/// A receiver asks a source to bring it up to date.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CatchUpRequest {
    /// The receiver has the source's stream up to this sequence number (0: nothing).
    pub have_seq: u64,
    /// The receiver misses dictionary entries: the source should re-announce its names
    /// ([`Encoder::reset_announcements`](crate::Encoder::reset_announcements)).
    pub needs_names: bool,
    /// The receiver misses class definitions: the source should send `Classes`.
    pub needs_classes: bool,
}

/// Liveliness of a source: its stream position and a few counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Heartbeat {
    /// The source's current sequence number.
    pub seq: u64,
    /// Messages the source has sent.
    pub sent: u64,
    /// Messages the source has received and accepted.
    pub received: u64,
    /// Messages the source has received and rejected.
    pub rejected: u64,
}

/// The kind of a message, as numbered in the header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    Report = 1,
    Names = 2,
    Classes = 3,
    Plan = 4,
    PlanAck = 5,
    PlanCancel = 6,
    CatchUpRequest = 7,
    CatchUpAnswer = 8,
    Heartbeat = 9,
}

impl Kind {
    const ALL: [Kind; 9] = [
        Kind::Report,
        Kind::Names,
        Kind::Classes,
        Kind::Plan,
        Kind::PlanAck,
        Kind::PlanCancel,
        Kind::CatchUpRequest,
        Kind::CatchUpAnswer,
        Kind::Heartbeat,
    ];

    /// The kind numbered `n`, if any.
    pub fn from_number(n: u8) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| *k as u8 == n)
    }
}

impl Message {
    /// The header's kind for this message.
    pub(crate) fn kind(&self) -> Kind {
        match self {
            Message::Report(_) => Kind::Report,
            Message::Names(_) => Kind::Names,
            Message::Classes(_) => Kind::Classes,
            Message::Plan(_) => Kind::Plan,
            Message::PlanAck(_) => Kind::PlanAck,
            Message::PlanCancel { .. } => Kind::PlanCancel,
            Message::CatchUpRequest(_) => Kind::CatchUpRequest,
            Message::CatchUpAnswer(_) => Kind::CatchUpAnswer,
            Message::Heartbeat(_) => Kind::Heartbeat,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_are_numbered_from_one() {
        assert_eq!(Kind::from_number(1), Some(Kind::Report));
        assert_eq!(Kind::from_number(9), Some(Kind::Heartbeat));
        assert_eq!(Kind::from_number(0), None);
        assert_eq!(Kind::from_number(10), None);
    }

    #[test]
    fn a_class_is_its_own_class_on_the_wire() {
        assert!(ObjectEntry::new("Obstacle", "Obstacle").is_class());
        assert!(!ObjectEntry::new("r1", "Rock").is_class());
    }
}
