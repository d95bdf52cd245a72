//! Many sources: the decoder's per-source dictionaries are bounded, and the slots of
//! sources not heard for longest are reclaimed for new ones (counted, named).

use slate_model::Address;
use slate_wire::{DecodeError, Decoder, Encoder, MAX_SOURCES, Message, ObjectEntry};

use crate::support::*;

/// Module `i` of a team, each on its own robot.
fn source(i: usize) -> Address {
    addr(&format!("team/r{i}/cli"))
}

/// A report of `from`'s own robot pose, stamped by `from`.
fn pose_of(from: &Address, seq: u64) -> Message {
    let mut p = packet(1.5, 0.1, 0.9, at(seq * 1000, 0));
    p.source = from.clone();
    let robot = ObjectEntry::new("r1", "Robot").owner(from.clone());
    Message::Report(report(seq, vec![assertion(&robot, "x", p)]))
}

#[test]
fn five_thousand_sources_in_turn_are_all_decoded() {
    let schema = schema();
    let mut decoder = Decoder::new();
    for i in 0..5000 {
        let from = source(i);
        let bytes = Encoder::new(from.clone())
            .encode(&pose_of(&from, 1), &schema)
            .unwrap();
        let got = decoder.decode(&from, &bytes, &schema);
        assert!(got.is_ok(), "source {i}: {got:?}");
    }
    let stats = decoder.stats();
    assert_eq!(stats.accepted, 5000);
    assert_eq!(stats.evicted, (5000 - MAX_SOURCES) as u64);
}

#[test]
fn the_source_heard_least_recently_gives_up_its_slot_and_is_named() {
    let schema = schema();
    let mut decoder = Decoder::new();
    let mut encoders: Vec<Encoder> = (0..=MAX_SOURCES).map(|i| Encoder::new(source(i))).collect();
    let mut send = |decoder: &mut Decoder, i: usize, seq: u64| {
        let bytes = encoders[i].encode(&pose_of(&source(i), seq), &schema);
        decoder.decode(&source(i), &bytes.unwrap(), &schema)
    };
    for i in 0..MAX_SOURCES {
        send(&mut decoder, i, 1).unwrap();
    }
    send(&mut decoder, 0, 2).expect("source 0 heard again: now the most recent");
    assert_eq!(decoder.take_evicted(), None, "nothing evicted yet");
    send(&mut decoder, MAX_SOURCES, 1).expect("a new source finds a slot");
    assert_eq!(
        decoder.take_evicted(),
        Some(source(1)),
        "the least recently heard"
    );
    assert_eq!(decoder.take_evicted(), None, "taken once");
    assert!(decoder.knows(&source(0)) && !decoder.knows(&source(1)));
    assert!(
        matches!(
            send(&mut decoder, 1, 2),
            Err(DecodeError::UnknownName { .. })
        ),
        "its next report asks for its names again"
    );
    assert_eq!(decoder.stats().evicted, 1);
}

#[test]
fn a_decoder_given_a_smaller_table_keeps_that_many_sources() {
    let schema = schema();
    let mut decoder = Decoder::with_max_sources(3);
    for i in 0..10 {
        let from = source(i);
        let bytes = Encoder::new(from.clone())
            .encode(&pose_of(&from, 1), &schema)
            .unwrap();
        assert!(decoder.decode(&from, &bytes, &schema).is_ok(), "source {i}");
    }
    assert_eq!(decoder.stats().evicted, 7);
}

/// A report of `from`'s object `name`, stamped by `from`.
fn object_of(from: &Address, name: &str, seq: u64) -> Message {
    let mut p = packet(1.5, 0.1, 0.9, at(seq * 1000, 0));
    p.source = from.clone();
    let object = ObjectEntry::new(name, "Robot").owner(from.clone());
    Message::Report(report(seq, vec![assertion(&object, "x", p)]))
}

#[test]
fn a_source_naming_more_than_its_bound_is_refused_and_counted_and_keeps_what_it_had() {
    let schema = schema();
    let mut decoder = Decoder::new().with_max_names(10);
    let evil = source(9);
    let mut encoder = Encoder::new(evil.clone());
    let mut send = |decoder: &mut Decoder, name: &str, seq: u64| {
        let bytes = encoder.encode(&object_of(&evil, name, seq), &schema);
        decoder.decode(&evil, &bytes.unwrap(), &schema)
    };
    let accepted = (0..30)
        .take_while(|i| send(&mut decoder, &format!("o{i}"), *i + 1).is_ok())
        .count();
    assert!((1..30).contains(&accepted), "{accepted} accepted");
    let refused = send(&mut decoder, "another", 99);
    assert!(
        matches!(refused, Err(DecodeError::TooManyNames { max: 10, .. })),
        "{refused:?}"
    );
    let stats = decoder.stats();
    assert_eq!(stats.too_many_names, 2);
    assert_eq!(
        stats.rejected(),
        0,
        "well formed: refused by a bound, not rejected"
    );
    // What it named before still decodes; another source is not held to its count.
    assert!(send(&mut decoder, "o0", 100).is_ok());
    let other = source(1);
    let bytes = Encoder::new(other.clone()).encode(&pose_of(&other, 1), &schema);
    assert!(decoder.decode(&other, &bytes.unwrap(), &schema).is_ok());
}

#[test]
fn names_are_bounded_in_total_across_sources_and_the_least_recent_give_way() {
    // Issue 17, bounded in total: 50 sources, each naming up to 8 objects (and its
    // address, class and attribute), against a decoder holding at most 60 names in all.
    // The total never passes it; sources heard least recently give up their names (and
    // are named, so they announce them again); the source just heard always decodes.
    let schema = schema();
    let mut decoder = Decoder::new().with_max_names(20).with_max_total_names(60);
    let mut encoders: Vec<Encoder> = (0..50).map(|i| Encoder::new(source(i))).collect();
    for round in 0..8u64 {
        for (i, encoder) in encoders.iter_mut().enumerate() {
            let from = source(i);
            let bytes = encoder.encode(&object_of(&from, &format!("o{round}"), round + 1), &schema);
            let got = decoder.decode(&from, &bytes.unwrap(), &schema);
            assert!(
                matches!(got, Ok(_) | Err(DecodeError::UnknownName { .. })),
                "source {i}, round {round}: {got:?}"
            );
            assert!(decoder.names() <= 60, "{} names held", decoder.names());
        }
    }
    assert!(decoder.stats().evicted >= 40, "{:?}", decoder.stats());
    let last = source(49);
    assert!(decoder.knows(&last));
}
