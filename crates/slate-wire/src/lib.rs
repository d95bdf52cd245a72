//! slate's compact wire format: the bytes boards exchange, derived from the schema.
//!
//! Messages ([`Message`]) are reports of attribute packets, dictionary entries, class
//! definitions, plans and their acknowledgements, catch-up requests and answers, and
//! heartbeats. Each starts with a 1-byte header (version, kind). Reports are packed the
//! way DCCL packs messages: a value with declared bounds and resolution takes exactly
//! the bits its range needs, accuracy and confidence are quantised (and cost one bit
//! when they equal the declared default), timestamps are deltas from a base, and
//! object and attribute names are interned to small ids announced once.
//!
//! An [`Encoder`] belongs to a sending module and owns its dictionary; a [`Decoder`]
//! belongs to a receiving module and keeps one dictionary per source. Both work
//! against a [`Schema`] built from the same class definitions. No I/O here: the
//! transport carries the bytes and the sender's address.
//!
//! ```
//! use slate_model::{Address, AttrDecl, ClassDef, Packet, Timestamp, Value, ValueType};
//! use slate_wire::{Assertion, Decoder, Encoder, Message, ObjectEntry, Report, Schema};
//!
//! let schema = Schema::new(&[ClassDef::new("Vehicle").attr(
//!     AttrDecl::new("speed", ValueType::Real).bounds(0.0, 20.0).resolution(0.01),
//! )]);
//! let nav = Address::new("team/r1/nav")?;
//! let packet = Packet {
//!     value: Value::Real(3.14159),
//!     accuracy: 0.05,
//!     confidence: 0.9,
//!     timestamp: Timestamp::from_raw(7_250_000_000_000_000_000),
//!     source: nav.clone(),
//! };
//! let report = Message::Report(Report {
//!     seq: 1,
//!     items: vec![Assertion {
//!         object: ObjectEntry::new("gsr1", "Vehicle"),
//!         attr: "speed".into(),
//!         packet,
//!     }],
//! });
//!
//! let mut encoder = Encoder::new(nav.clone());
//! let bytes = encoder.encode(&report, &schema)?;
//! let mut decoder = Decoder::new();
//! let Message::Report(back) = decoder.decode(&nav, &bytes, &schema)? else {
//!     unreachable!()
//! };
//! let speed = back.items[0].packet.value.as_f64().unwrap_or_default();
//! assert!((speed - 3.14159).abs() <= 0.005, "within half the resolution");
//!
//! // The names are announced now: the next report of the same attribute is smaller.
//! let again = encoder.encode(&report, &schema)?;
//! assert!(again.len() < bytes.len());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The byte layout, quantisation rules and measured sizes are in `docs/wire.md`.
#![warn(missing_docs)]

mod bits;
mod classes;
mod control;
mod decoder;
mod dictionary;
mod encoder;
mod error;
#[cfg(feature = "testing")]
mod fuzz;
mod limits;
mod message;
mod names;
mod quant;
mod report;
mod schema;
mod step;
mod text;
mod value;

pub use decoder::Decoder;
pub use encoder::Encoder;
pub use error::{DecodeError, DecodeStats, EncodeError};
#[cfg(feature = "testing")]
pub use fuzz::{fuzz_classes, fuzz_decode, fuzz_source};
pub use limits::{
    MAX_ELEMENTS, MAX_IDS, MAX_ITEMS, MAX_MESSAGE_BYTES, MAX_NAME_BYTES, MAX_NAMES,
    MAX_NAMES_PER_SOURCE, MAX_SOURCES, MAX_TEXT_BYTES, VERSION,
};
pub use message::{
    Assertion, AssertionParts, CatchUpRequest, Heartbeat, Message, Names, ObjectEntry, Plan,
    PlanAck, PlanStep, Report,
};
pub use quant::quantise;
pub use schema::Schema;
