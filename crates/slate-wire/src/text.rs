//! Names and addresses on the wire: identifiers checked on both sides.

use slate_model::Address;

use crate::bits::{BitReader, BitWriter};
use crate::error::check_len;
use crate::{DecodeError, EncodeError, MAX_NAME_BYTES};

/// Is `name` an identifier (letters, digits and `_`, not starting with a digit), as
/// slate requires of class, object and attribute names?
pub(crate) fn valid_name(name: &str) -> bool {
    let mut chars = name.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// Checks a name before writing it.
pub(crate) fn check_name(name: &str) -> Result<(), EncodeError> {
    check_len("name length", name.len(), MAX_NAME_BYTES)?;
    if !valid_name(name) {
        return Err(EncodeError::BadName(name.to_owned()));
    }
    Ok(())
}

/// Reads an identifier.
pub(crate) fn read_name(r: &mut BitReader) -> Result<String, DecodeError> {
    let name = r.str("name length", MAX_NAME_BYTES)?;
    if !valid_name(&name) {
        return Err(DecodeError::BadValue("invalid name"));
    }
    Ok(name)
}

/// Writes an address as text (the unknown address is the empty string).
pub(crate) fn write_address(w: &mut BitWriter, address: &Address) {
    w.str(if address.is_unknown() {
        ""
    } else {
        address.as_str()
    });
}

/// Reads an address written by [`write_address`].
pub(crate) fn read_address(r: &mut BitReader) -> Result<Address, DecodeError> {
    let text = r.str("address length", MAX_NAME_BYTES)?;
    if text.is_empty() {
        return Ok(Address::unknown());
    }
    Address::new(&text).map_err(|_| DecodeError::BadValue("invalid address"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_identifiers() {
        assert!(valid_name("gsr_1") && valid_name("_x"));
        assert!(!valid_name("1gsr") && !valid_name("") && !valid_name("a.b"));
        assert_eq!(check_name("a b"), Err(EncodeError::BadName("a b".into())));
    }

    #[test]
    fn addresses_roundtrip_including_unknown() {
        for a in [Address::unknown(), Address::new("team/r1/nav").unwrap()] {
            let mut w = BitWriter::new();
            write_address(&mut w, &a);
            let bytes = w.finish();
            assert_eq!(read_address(&mut BitReader::new(&bytes)), Ok(a));
        }
        let mut w = BitWriter::new();
        w.str("not an address");
        let bytes = w.finish();
        assert!(read_address(&mut BitReader::new(&bytes)).is_err());
    }
}
