//! The wire version and the limits every decoder enforces (and every encoder respects).

/// The wire format version this crate writes and reads.
pub const VERSION: u8 = 1;

/// Largest message, in bytes.
pub const MAX_MESSAGE_BYTES: usize = 64 * 1024;

/// Most items in one list: assertions of a report, entries of one dictionary table in
/// one message, classes, attributes of a class.
pub const MAX_ITEMS: usize = 4096;

/// Longest name in bytes: object, class and attribute names, addresses, units, plan
/// names, references, rejection reasons and trigger details.
pub const MAX_NAME_BYTES: usize = 1024;

/// Longest text in bytes (string values, plan source text); the message limit applies too.
pub const MAX_TEXT_BYTES: usize = MAX_MESSAGE_BYTES;

/// Most vector elements in one message (all vectors together).
pub const MAX_ELEMENTS: usize = 65_536;

/// Most entries in one dictionary table (objects, attributes, classes, addresses) of
/// one source; interned ids are below this.
pub const MAX_IDS: usize = 65_536;

/// Most sources whose dictionaries one decoder keeps; a new source beyond this takes the
/// slot of the source heard least recently.
pub const MAX_SOURCES: usize = 4096;

/// Most names one source's dictionary holds, all tables together (objects, attributes,
/// classes, addresses): a message that would take it past this is refused
/// ([`DecodeError::TooManyNames`](crate::DecodeError::TooManyNames)), so that one source
/// cannot make a receiver hold up to 4 x [`MAX_IDS`] names of up to [`MAX_NAME_BYTES`]
/// each. A sender never forgets a name until it restarts, so this is what one module may
/// name in its lifetime; the demo's modules name a few hundred at most.
pub const MAX_NAMES_PER_SOURCE: usize = 16_384;

/// Most names one decoder holds of all its sources together: past it, the sources heard
/// least recently give up their dictionaries (and announce their names again when next
/// they speak), so that [`MAX_SOURCES`] sources cannot make a receiver hold
/// [`MAX_NAMES_PER_SOURCE`] names each. 262 144 names of at most [`MAX_NAME_BYTES`] is
/// at most 256 MiB; the demo's 8 robots (about 50 modules of a few hundred names) hold
/// some 15 000, its 24 robots some 45 000.
pub const MAX_NAMES: usize = 262_144;
