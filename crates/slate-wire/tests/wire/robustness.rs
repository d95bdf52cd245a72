//! Malformed input: every decoder error is typed, counted, and changes nothing.

use slate_model::{AttrDecl, ClassDef, ValueType};
use slate_wire::{DecodeError, Decoder, Encoder, MAX_MESSAGE_BYTES, Message, Plan, Report, Schema};

use crate::golden::cases;
use crate::support::*;

fn decode(bytes: &[u8]) -> Result<Message, DecodeError> {
    Decoder::new().decode(&nav(), bytes, &schema())
}

/// A decoder that has accepted the first `n` golden messages.
fn decoder_after(n: usize) -> Decoder {
    let mut decoder = Decoder::new();
    for (_, bytes) in cases().into_iter().take(n) {
        decoder.decode(&nav(), &bytes, &schema()).unwrap();
    }
    decoder
}

#[test]
fn every_strict_prefix_is_truncated() {
    for (i, (name, bytes)) in cases().into_iter().enumerate() {
        let mut decoder = decoder_after(i);
        for len in 0..bytes.len() {
            let err = decoder
                .decode(&nav(), &bytes[..len], &schema())
                .unwrap_err();
            assert_eq!(err, DecodeError::Truncated, "{name} cut at {len}");
        }
        assert!(
            decoder.decode(&nav(), &bytes, &schema()).is_ok(),
            "{name} whole"
        );
    }
}

#[test]
fn wrong_versions_and_kinds_are_refused() {
    assert_eq!(decode(&[0x29, 0x00]), Err(DecodeError::BadVersion(2)));
    assert_eq!(decode(&[0x01]), Err(DecodeError::BadVersion(0)));
    assert_eq!(decode(&[0x10]), Err(DecodeError::UnknownKind(0)));
    assert_eq!(decode(&[0x1f, 0x00]), Err(DecodeError::UnknownKind(15)));
}

#[test]
fn oversized_input_and_counts_are_refused_before_reading() {
    let huge = vec![0x19; MAX_MESSAGE_BYTES + 1];
    assert!(matches!(
        decode(&huge),
        Err(DecodeError::TooLarge {
            what: "message bytes",
            ..
        })
    ));
    // A report claiming 5000 assertions: seq 1, no flags, count 5000.
    let many = [0x11, 0x01, 0x0c, 0x4e, 0x02, 0x70];
    assert!(
        matches!(decode(&many), Err(DecodeError::TooLarge { .. })),
        "{:?}",
        decode(&many)
    );
}

#[test]
fn a_long_length_claim_allocates_nothing() {
    // A plan whose name claims 1000 bytes, then its text claims 60 000, in 6 bytes.
    let name = [0x14, 0x01, 0xe8, 0x07];
    assert_eq!(decode(&name), Err(DecodeError::Truncated));
    let long_name = [0x14, 0x01, 0x90, 0x4e];
    assert!(matches!(
        decode(&long_name),
        Err(DecodeError::TooLarge {
            what: "plan name length",
            ..
        })
    ));
}

#[test]
fn trailing_bytes_and_padding_are_refused() {
    let (_, mut bytes) = cases()
        .into_iter()
        .find(|(n, _)| *n == "heartbeat")
        .unwrap();
    bytes.push(0);
    assert!(matches!(decode(&bytes), Err(DecodeError::Trailing(_))));
    let cancel = [0x16, 0x0c];
    assert!(decode(&cancel).is_ok());
    assert!(matches!(
        decode(&[0x16, 0x0c, 0x80]),
        Err(DecodeError::Trailing(8))
    ));
}

#[test]
fn bad_strings_and_addresses_are_bad_values() {
    let schema = schema();
    let plan = Plan {
        circuit: 1,
        name: "p".into(),
        source_text: "x".into(),
        to: addr("team/r2/exec"),
        origin: addr("team/base/console"),
    };
    let mut bytes = Encoder::new(nav())
        .encode(&Message::Plan(plan), &schema)
        .unwrap();
    bytes[3] = 0xff; // the name's only byte: not UTF-8
    assert_eq!(
        decode(&bytes),
        Err(DecodeError::BadValue("string is not UTF-8"))
    );
    bytes[3] = b'p';
    bytes[8] = b' '; // inside the destination address
    assert_eq!(
        decode(&bytes),
        Err(DecodeError::BadValue("invalid address"))
    );
}

#[test]
fn zero_bit_vectors_cannot_allocate_without_bound() {
    let flat = AttrDecl::new("v", ValueType::Vector(40_000))
        .bounds(1.0, 1.0)
        .resolution(1.0);
    let schema = Schema::new(&[ClassDef::new("Flat").attr(flat)]);
    let object = slate_wire::ObjectEntry::new("f", "Flat");
    let one = |i: u64| assertion(&object, "v", packet(vec![1.0; 40_000], 0.0, 1.0, at(i, 0)));
    let mut encoder = Encoder::new(nav());
    let bytes = encoder
        .encode(&Message::Report(report(1, vec![one(0)])), &schema)
        .unwrap();
    assert!(bytes.len() < 40, "40 000 zero-bit elements take no room");
    assert!(Decoder::new().decode(&nav(), &bytes, &schema).is_ok());
    let two = Report {
        seq: 2,
        items: vec![one(0), one(1)],
    };
    let err = encoder.encode(&Message::Report(two), &schema).unwrap_err();
    assert!(
        matches!(err, slate_wire::EncodeError::TooLarge { .. }),
        "{err}"
    );
}

#[test]
fn rejections_are_counted_by_kind_and_change_nothing() {
    let schema = schema();
    let mut decoder = Decoder::new();
    let (_, first) = cases().into_iter().next().unwrap();
    let mut corrupt = first.clone();
    corrupt.truncate(first.len() - 1);
    for bytes in [
        &corrupt[..],
        &[0x29][..],
        &[0x1f][..],
        &[0x16, 0x0c, 0x01][..],
    ] {
        assert!(decoder.decode(&nav(), bytes, &schema).is_err());
    }
    assert!(!decoder.knows(&nav()), "no names from a rejected report");
    let stats = decoder.stats();
    assert_eq!(
        (
            stats.truncated,
            stats.bad_version,
            stats.unknown_kind,
            stats.trailing
        ),
        (1, 1, 1, 1)
    );
    assert_eq!((stats.rejected(), stats.accepted), (4, 0));
    assert!(decoder.decode(&nav(), &first, &schema).is_ok());
    assert!(decoder.knows(&nav()));
    decoder.forget(&nav());
    assert!(!decoder.knows(&nav()));
}
