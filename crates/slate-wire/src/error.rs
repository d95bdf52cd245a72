//! Errors of encoding and decoding, and the decoder's rejection counters.

use slate_model::ValueError;

use crate::VERSION;

/// Why a message could not be decoded. The decoder's state is unchanged by a rejected
/// message: nothing of it is applied, not even the names it announced.
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DecodeError {
    /// The input ended in the middle of a field (or was empty).
    #[error("message truncated")]
    Truncated,
    /// The header's version is not the one this decoder reads.
    #[error("unsupported wire version {0} (this decoder reads version {VERSION})")]
    BadVersion(u8),
    /// The header's message kind is not one of this version's.
    #[error("unknown message kind {0}")]
    UnknownKind(u8),
    /// A size is over its limit: the message, a count, a string, a dictionary.
    #[error("{what} is {len}, more than the limit {max}")]
    TooLarge {
        /// What was too large.
        what: &'static str,
        /// Its size (bytes or items).
        len: u64,
        /// The limit.
        max: u64,
    },
    /// The message uses an interned id (or the timestamp epoch) that this source never
    /// announced to us, or whose announcement was lost: ask the source to catch up.
    #[error("unknown {table} id {id} from this source (announcement missed: ask it to catch up)")]
    UnknownName {
        /// Which dictionary: `object`, `attribute`, `class`, `address` or `epoch`.
        table: &'static str,
        /// The id.
        id: u64,
    },
    /// The sender encoded an object's values against a class definition that differs
    /// from ours, or that we do not have: its bit-packed values cannot be read.
    #[error(
        "object {object:?}: the sender's definition of class {class:?} differs from ours (or we have none)"
    )]
    SchemaMismatch {
        /// The object.
        object: String,
        /// Its class.
        class: String,
    },
    /// A field holds something not allowed: bad UTF-8, an invalid name or address, a
    /// quantised code beyond its range, a non-finite number, a reserved tag.
    #[error("bad value: {0}")]
    BadValue(&'static str),
    /// Bits remain after the end of the message (non-zero padding or extra bytes).
    #[error("{0} unexpected bits after the end of the message")]
    Trailing(u64),
    /// The names the message announces would take its source's dictionary past the
    /// names one source may have ([`Decoder::with_max_names`](crate::Decoder::with_max_names)).
    #[error(
        "this source would hold {names} names, more than the {max} one source may have (the ICI's max_names_per_source)"
    )]
    TooManyNames {
        /// The names the source's dictionary would hold with the message's.
        names: u64,
        /// The bound.
        max: u64,
    },
}

/// Why a message could not be encoded. The encoder's state is unchanged by a failed
/// encode: nothing is marked as announced.
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EncodeError {
    /// The object's class is not in the schema.
    #[error("object {object:?}: class {class:?} is not in the schema")]
    UnknownClass {
        /// The object.
        object: String,
        /// Its class.
        class: String,
    },
    /// The attribute is not declared by the object's class or its ancestors.
    #[error("object {object:?}: attribute {attr:?} is not declared by its class")]
    UnknownAttr {
        /// The object.
        object: String,
        /// The attribute.
        attr: String,
    },
    /// A packet does not fit its declaration (type, bounds, finiteness, accuracy, confidence).
    #[error("{object}.{attr}: {source}")]
    Invalid {
        /// The object.
        object: String,
        /// The attribute.
        attr: String,
        /// What is wrong.
        source: ValueError,
    },
    /// A name is not an identifier (letters, digits, `_`, not starting with a digit).
    #[error("{0:?} is not a valid name")]
    BadName(String),
    /// One message names the same object with two different entries (class, context
    /// or owner).
    #[error("object {0:?} appears with two different entries in one message")]
    ConflictingEntry(String),
    /// A class definition holds a number the wire cannot carry (not finite).
    #[error("class {class:?}: {reason}")]
    BadClass {
        /// The class.
        class: String,
        /// What is wrong.
        reason: &'static str,
    },
    /// A size is over its limit: the message, a count, a string, a dictionary.
    #[error("{what} is {len}, more than the limit {max}")]
    TooLarge {
        /// What was too large.
        what: &'static str,
        /// Its size (bytes or items).
        len: u64,
        /// The limit.
        max: u64,
    },
}

/// Counters a [`Decoder`](crate::Decoder) keeps: messages accepted, and messages rejected
/// by kind of error.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DecodeStats {
    /// Messages decoded and applied.
    pub accepted: u64,
    /// Rejected: [`DecodeError::Truncated`].
    pub truncated: u64,
    /// Rejected: [`DecodeError::BadVersion`].
    pub bad_version: u64,
    /// Rejected: [`DecodeError::UnknownKind`].
    pub unknown_kind: u64,
    /// Rejected: [`DecodeError::TooLarge`].
    pub too_large: u64,
    /// Rejected: [`DecodeError::UnknownName`].
    pub unknown_name: u64,
    /// Rejected: [`DecodeError::SchemaMismatch`].
    pub schema_mismatch: u64,
    /// Rejected: [`DecodeError::BadValue`].
    pub bad_value: u64,
    /// Rejected: [`DecodeError::Trailing`].
    pub trailing: u64,
    /// Refused: [`DecodeError::TooManyNames`]. Not in [`rejected`](DecodeStats::rejected):
    /// such a message is well formed, a bound refused it (the ICI counts it as over a
    /// limit).
    pub too_many_names: u64,
    /// Not a rejection: sources whose dictionaries were dropped to make room for a new
    /// source (the table holds [`MAX_SOURCES`](crate::MAX_SOURCES)).
    pub evicted: u64,
}

impl DecodeStats {
    /// All rejected messages (malformed, or not readable without names or classes
    /// first): not those refused for too many names.
    pub fn rejected(&self) -> u64 {
        self.truncated
            + self.bad_version
            + self.unknown_kind
            + self.too_large
            + self.unknown_name
            + self.schema_mismatch
            + self.bad_value
            + self.trailing
    }

    /// Counts one decode outcome.
    pub(crate) fn record<T>(&mut self, result: &Result<T, DecodeError>) {
        let counter = match result {
            Ok(_) => &mut self.accepted,
            Err(DecodeError::Truncated) => &mut self.truncated,
            Err(DecodeError::BadVersion(_)) => &mut self.bad_version,
            Err(DecodeError::UnknownKind(_)) => &mut self.unknown_kind,
            Err(DecodeError::TooLarge { .. }) => &mut self.too_large,
            Err(DecodeError::UnknownName { .. }) => &mut self.unknown_name,
            Err(DecodeError::SchemaMismatch { .. }) => &mut self.schema_mismatch,
            Err(DecodeError::BadValue(_)) => &mut self.bad_value,
            Err(DecodeError::Trailing(_)) => &mut self.trailing,
            Err(DecodeError::TooManyNames { .. }) => &mut self.too_many_names,
        };
        *counter += 1;
    }
}

/// A `TooLarge` error if `len > max`.
pub(crate) fn check_len(what: &'static str, len: usize, max: usize) -> Result<(), EncodeError> {
    if len > max {
        return Err(EncodeError::TooLarge {
            what,
            len: len as u64,
            max: max as u64,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_count_each_kind() {
        let mut stats = DecodeStats::default();
        stats.record::<()>(&Ok(()));
        stats.record::<()>(&Err(DecodeError::Truncated));
        stats.record::<()>(&Err(DecodeError::BadValue("x")));
        stats.record::<()>(&Err(DecodeError::BadValue("y")));
        assert_eq!(stats.accepted, 1);
        assert_eq!(stats.bad_value, 2);
        assert_eq!(stats.rejected(), 3);
    }
}
