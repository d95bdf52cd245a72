//! Every message kind comes back; names are announced once; catch-up recovers.

use slate_model::{AttrDecl, ClassDef, Context, Value, ValueType};
use slate_wire::{
    Assertion, CatchUpRequest, DecodeError, Decoder, EncodeError, Encoder, Heartbeat, Message,
    Names, ObjectEntry, Plan, PlanAck, PlanStep, Report, Schema,
};

use crate::support::*;

fn decode_report(decoder: &mut Decoder, bytes: &[u8], schema: &Schema) -> Report {
    match decoder.decode(&nav(), bytes, schema) {
        Ok(Message::Report(r)) | Ok(Message::CatchUpAnswer(r)) => r,
        other => panic!("expected a report, got {other:?}"),
    }
}

/// A new encoder at nav, and its encodings of poses 1 and 2 (the first names the
/// object and attributes, the second need not).
fn two_poses(schema: &Schema) -> (Encoder, Vec<u8>, Vec<u8>) {
    let mut encoder = Encoder::new(nav());
    let first = encoder.encode(&Message::Report(pose(1)), schema).unwrap();
    let second = encoder.encode(&Message::Report(pose(2)), schema).unwrap();
    (encoder, first, second)
}

fn pose(seq: u64) -> Report {
    let t = at(3_600_000_000, 0);
    let r = robot();
    report(
        seq,
        vec![
            assertion(&r, "x", packet(1234.567, 0.05, 0.9, t)),
            assertion(&r, "y", packet(-8765.432, 0.05, 0.9, t)),
            assertion(&r, "heading", packet(1.2345, 0.01, 0.8, t)),
            assertion(&r, "speed", packet(3.21, 0.1, 0.95, t)),
        ],
    )
}

#[test]
fn a_report_comes_back_within_resolution() {
    let schema = schema();
    let sent = pose(1);
    let bytes = Encoder::new(nav())
        .encode(&Message::Report(sent.clone()), &schema)
        .unwrap();
    let got = decode_report(&mut Decoder::new(), &bytes, &schema);
    assert_close(&schema, &sent, &got);
    assert_eq!(
        got.items[0].packet.source,
        nav(),
        "the source comes from the envelope"
    );
}

#[test]
fn small_messages_come_back_exactly() {
    let messages = [
        Message::Plan(Plan {
            circuit: 42,
            name: "search".into(),
            source_text: "plan search { when any o: Obstacle then set self.speed = 0 }".into(),
            to: addr("team/r2/exec"),
            origin: addr("team/base/console"),
        }),
        Message::PlanAck(PlanAck {
            circuit: 42,
            seq: 3,
            step: PlanStep::Triggered {
                ok: false,
                detail: "r2.speed is owned".into(),
            },
        }),
        Message::PlanCancel { circuit: u64::MAX },
        Message::CatchUpRequest(CatchUpRequest {
            have_seq: 17,
            needs_names: true,
            needs_classes: false,
        }),
        Message::Heartbeat(Heartbeat {
            seq: 9,
            sent: 100,
            received: 50,
            rejected: 1,
        }),
        Message::Classes(classes()),
        Message::Names(Names {
            objects: vec![robot()],
            attrs: vec!["x".into(), "speed".into()],
        }),
    ];
    let schema = schema();
    let mut encoder = Encoder::new(nav());
    let mut decoder = Decoder::new();
    for msg in messages {
        let bytes = encoder.encode(&msg, &schema).unwrap();
        assert_eq!(decoder.decode(&nav(), &bytes, &schema), Ok(msg));
    }
    assert_eq!(decoder.stats().accepted, 7);
}

#[test]
fn names_are_announced_once_and_again_after_a_reset() {
    let schema = schema();
    let (mut encoder, first, second) = two_poses(&schema);
    assert!(
        second.len() + 10 < first.len(),
        "{} vs {}",
        second.len(),
        first.len()
    );
    encoder.reset_announcements();
    let third = encoder.encode(&Message::Report(pose(3)), &schema).unwrap();
    assert_eq!(third.len(), first.len());
}

#[test]
fn the_encoder_says_which_message_announced_names() {
    let schema = schema();
    let mut encoder = Encoder::new(nav());
    let encode = |e: &mut Encoder, msg: &Message| e.encode(msg, &schema).unwrap();
    encode(&mut encoder, &Message::Report(pose(1)));
    assert!(
        encoder.announced(),
        "the first report names what it reports"
    );
    encode(&mut encoder, &Message::Report(pose(2)));
    assert!(!encoder.announced(), "the same names again");
    let heartbeat = Message::Heartbeat(Heartbeat::default());
    encoder.reset_announcements();
    encode(&mut encoder, &heartbeat);
    assert!(!encoder.announced(), "a heartbeat names nothing");
    encode(&mut encoder, &Message::Report(pose(3)));
    assert!(encoder.announced(), "after a reset");
    let unknown = report(
        4,
        vec![assertion(
            &robot(),
            "no_such_attr",
            packet(1.0, 0.1, 0.9, at(3_600_000_000, 0)),
        )],
    );
    assert!(encoder.encode(&Message::Report(unknown), &schema).is_err());
    assert!(
        !encoder.announced(),
        "a message that did not encode announced nothing"
    );
}

#[test]
fn a_receiver_that_missed_the_names_catches_up() {
    let schema = schema();
    let (mut source, _lost, second) = two_poses(&schema);
    let mut late = Decoder::new();
    let err = late.decode(&nav(), &second, &schema).unwrap_err();
    assert!(matches!(err, DecodeError::UnknownName { .. }), "{err}");
    assert_eq!(late.stats().unknown_name, 1);

    let ask = CatchUpRequest {
        have_seq: 0,
        needs_names: true,
        needs_classes: false,
    };
    let bytes = Encoder::new(addr("team/r2/nav"))
        .encode(&Message::CatchUpRequest(ask), &schema)
        .unwrap();
    let Ok(Message::CatchUpRequest(request)) =
        Decoder::new().decode(&addr("team/r2/nav"), &bytes, &schema)
    else {
        panic!("catch-up request did not decode");
    };
    if request.needs_names {
        source.reset_announcements();
    }
    let answer = source
        .encode(&Message::CatchUpAnswer(pose(2)), &schema)
        .unwrap();
    let state = decode_report(&mut late, &answer, &schema);
    assert_eq!(state.seq, 2);
    let third = source.encode(&Message::Report(pose(3)), &schema).unwrap();
    assert_eq!(decode_report(&mut late, &third, &schema).seq, 3);
}

#[test]
fn a_different_class_definition_is_a_schema_mismatch_not_garbage() {
    let sender = schema();
    let mut changed = classes();
    changed[0].attrs[3] = AttrDecl::new("speed", ValueType::Real)
        .bounds(0.0, 30.0)
        .resolution(0.01);
    let receiver = Schema::new(&changed);
    let bytes = Encoder::new(nav())
        .encode(&Message::Report(pose(1)), &sender)
        .unwrap();
    let mut decoder = Decoder::new();
    let err = decoder.decode(&nav(), &bytes, &receiver).unwrap_err();
    assert_eq!(
        err,
        DecodeError::SchemaMismatch {
            object: "r1".into(),
            class: "Robot".into()
        }
    );
    assert_eq!(decoder.stats().schema_mismatch, 1);
    assert!(
        !decoder.knows(&nav()),
        "nothing of a rejected message is applied"
    );
    let missing = Schema::new(&changed[1..]);
    assert!(matches!(
        decoder.decode(&nav(), &bytes, &missing),
        Err(DecodeError::SchemaMismatch { .. })
    ));
}

#[test]
fn a_failed_encode_announces_nothing() {
    let schema = schema();
    let mut encoder = Encoder::new(nav());
    let mut bad = pose(1);
    bad.items[3].packet.value = Value::Real(25.0);
    let err = encoder.encode(&Message::Report(bad), &schema).unwrap_err();
    assert!(matches!(err, EncodeError::Invalid { .. }), "{err}");
    let bytes = encoder.encode(&Message::Report(pose(2)), &schema).unwrap();
    assert_close(
        &schema,
        &pose(2),
        &decode_report(&mut Decoder::new(), &bytes, &schema),
    );
}

#[test]
fn encoding_refuses_what_the_schema_does_not_declare() {
    let schema = schema();
    let mut encoder = Encoder::new(nav());
    let t = at(0, 0);
    let stranger = report(
        1,
        vec![assertion(
            &ObjectEntry::new("u", "Ufo"),
            "x",
            packet(1.0, 0.0, 1.0, t),
        )],
    );
    assert!(matches!(
        encoder.encode(&Message::Report(stranger), &schema),
        Err(EncodeError::UnknownClass { .. })
    ));
    let undeclared = report(
        1,
        vec![assertion(&robot(), "altitude", packet(1.0, 0.0, 1.0, t))],
    );
    assert!(matches!(
        encoder.encode(&Message::Report(undeclared), &schema),
        Err(EncodeError::UnknownAttr { .. })
    ));
    let wrong_type = report(1, vec![assertion(&robot(), "x", packet(1, 0.0, 1.0, t))]);
    assert!(matches!(
        encoder.encode(&Message::Report(wrong_type), &schema),
        Err(EncodeError::Invalid { .. })
    ));
    let bad_confidence = report(1, vec![assertion(&robot(), "x", packet(1.0, 0.0, 1.5, t))]);
    assert!(matches!(
        encoder.encode(&Message::Report(bad_confidence), &schema),
        Err(EncodeError::Invalid { .. })
    ));
}

#[test]
fn class_level_values_none_and_foreign_sources_roundtrip() {
    let schema = schema();
    let t = at(5_000, 3);
    let mut relayed = packet(2.5, 0.0, 1.0, at(4_000, 0));
    relayed.source = addr("team/r2/nav");
    let mut anonymous = packet(Value::None, 0.0, 1.0, t);
    anonymous.source = slate_model::Address::unknown();
    let sent = report(
        7,
        vec![
            assertion(
                &ObjectEntry::new("Robot", "Robot"),
                "speed",
                packet(1.0, 0.0, 1.0, t),
            ),
            assertion(&robot(), "speed", relayed),
            assertion(&robot(), "x", packet(Value::None, 0.0, 1.0, t)),
            assertion(
                &ObjectEntry::new("t1", "Tracked").context(Context::System),
                "range",
                anonymous,
            ),
        ],
    );
    let bytes = Encoder::new(nav())
        .encode(&Message::Report(sent.clone()), &schema)
        .unwrap();
    let got = decode_report(&mut Decoder::new(), &bytes, &schema);
    assert_close(&schema, &sent, &got);
    assert!(got.items[0].object.is_class());
}

#[test]
fn one_message_may_not_give_an_object_two_entries() {
    let schema = schema();
    let t = at(0, 0);
    let twice = report(
        1,
        vec![
            assertion(&robot(), "x", packet(1.0, 0.0, 1.0, t)),
            assertion(
                &robot().context(Context::System),
                "y",
                packet(1.0, 0.0, 1.0, t),
            ),
        ],
    );
    let err = Encoder::new(nav())
        .encode(&Message::Report(twice), &schema)
        .unwrap_err();
    assert_eq!(err, EncodeError::ConflictingEntry("r1".into()));
}

#[test]
fn a_changed_entry_is_announced_again_under_the_same_id() {
    let schema = schema();
    let mut encoder = Encoder::new(nav());
    let mut decoder = Decoder::new();
    let t = at(0, 0);
    for context in [Context::Surroundings, Context::System] {
        let object = robot().context(context);
        let sent = report(1, vec![assertion(&object, "x", packet(1.0, 0.0, 1.0, t))]);
        let bytes = encoder.encode(&Message::Report(sent), &schema).unwrap();
        assert_eq!(
            decode_report(&mut decoder, &bytes, &schema).items[0].object,
            object
        );
    }
}

#[test]
fn a_restarted_source_replaces_its_dictionary() {
    let schema = schema();
    let mut decoder = Decoder::new();
    let mut old = Encoder::new(nav());
    decode_report(
        &mut decoder,
        &old.encode(&Message::Report(pose(1)), &schema).unwrap(),
        &schema,
    );
    let late = old.encode(&Message::Report(pose(2)), &schema).unwrap();

    let mut restarted = Encoder::new(nav());
    let t = at(7_200_000_000, 0);
    let t9 = ObjectEntry::new("t9", "Tracked");
    let tracked = report(1, vec![assertion(&t9, "range", packet(5.0, 0.0, 1.0, t))]);
    let bytes = restarted
        .encode(&Message::Report(tracked), &schema)
        .unwrap();
    assert_eq!(
        decode_report(&mut decoder, &bytes, &schema).items[0].object,
        t9
    );
    assert_ne!(
        restarted.epoch(),
        old.epoch(),
        "the epoch tells incarnations apart"
    );
    assert!(
        decoder.decode(&nav(), &late, &schema).is_err(),
        "the old names are gone"
    );
}

#[test]
fn unbounded_and_special_values_roundtrip() {
    let classes = vec![
        ClassDef::new("Misc")
            .attr(AttrDecl::new("n", ValueType::Int))
            .attr(AttrDecl::new("k", ValueType::Int).bounds(-5.0, 5.0))
            .attr(AttrDecl::new("r", ValueType::Real))
            .attr(AttrDecl::new("b", ValueType::Bool))
            .attr(AttrDecl::new("s", ValueType::Str))
            .attr(AttrDecl::new("to", ValueType::Ref))
            .attr(AttrDecl::new("v", ValueType::Vector(3))),
    ];
    let schema = Schema::new(&classes);
    let m = ObjectEntry::new("m", "Misc");
    let t = at(1, 0);
    let values: [(&str, Value); 7] = [
        ("n", Value::Int(i64::MIN)),
        ("k", Value::Int(-5)),
        ("r", Value::Real(1e-300)),
        ("b", Value::Bool(true)),
        ("s", Value::from("héllo wörld")),
        ("to", Value::reference("r1")),
        ("v", Value::from([0.1, -2.0, 1e9])),
    ];
    let items = values
        .into_iter()
        .map(|(a, v)| assertion(&m, a, packet(v, 1e12, 0.0, t)))
        .collect();
    let sent = report(u64::MAX, items);
    let bytes = Encoder::new(nav())
        .encode(&Message::Report(sent.clone()), &schema)
        .unwrap();
    assert_eq!(
        decode_report(&mut Decoder::new(), &bytes, &schema),
        sent,
        "all exact here"
    );
}

// An encoder remembers what it resolved for the same names (the same `Arc`s, as a
// board hands out); these send one report's names again and again.

#[test]
fn remembered_names_are_announced_again_after_a_reset() {
    let (schema, msg) = (schema(), Message::Report(pose(1)));
    let mut encoder = Encoder::new(nav());
    let first = encoder.encode(&msg, &schema).unwrap();
    let second = encoder.encode(&msg, &schema).unwrap();
    assert!(second.len() + 10 < first.len());
    encoder.reset_announcements();
    let third = encoder.encode(&msg, &schema).unwrap();
    assert_eq!(third.len(), first.len());
    decode_report(&mut Decoder::new(), &third, &schema);
}

#[test]
fn a_remembered_object_with_a_changed_entry_is_announced_again() {
    let schema = schema();
    let mut encoder = Encoder::new(nav());
    let mut decoder = Decoder::new();
    let mut sent = pose(1);
    for context in [Context::Surroundings, Context::System] {
        for a in &mut sent.items {
            a.object.context = context; // same name, same Arc
        }
        let bytes = encoder.encode(&Message::Report(sent.clone()), &schema);
        let got = decode_report(&mut decoder, &bytes.unwrap(), &schema);
        assert_eq!(got.items[0].object.context, context);
    }
}

#[test]
fn remembered_names_are_resolved_again_against_another_schema() {
    let sent = Message::Report(pose(1));
    let mut changed = classes();
    changed[0].attrs[3] = AttrDecl::new("speed", ValueType::Real)
        .bounds(0.0, 30.0)
        .resolution(0.5);
    let (old, new) = (schema(), Schema::new(&changed));
    let mut encoder = Encoder::new(nav());
    let mut decoder = Decoder::new();
    decode_report(&mut decoder, &encoder.encode(&sent, &old).unwrap(), &old);
    let bytes = encoder.encode(&sent, &new).unwrap();
    let got = decode_report(&mut decoder, &bytes, &new);
    assert_eq!(
        got.items[3].packet.value,
        Value::Real(3.0),
        "on the new grid"
    );
}

#[test]
fn a_failed_encode_leaves_nothing_remembered_as_announced() {
    let schema = schema();
    let mut encoder = Encoder::new(nav());
    let good = pose(1);
    let mut bad = good.clone();
    bad.items[3].packet.value = Value::Real(25.0);
    assert!(encoder.encode(&Message::Report(bad), &schema).is_err());
    let bytes = encoder.encode(&Message::Report(good), &schema).unwrap();
    decode_report(&mut Decoder::new(), &bytes, &schema);
}

#[test]
fn a_report_from_references_is_the_report_itself() {
    let schema = schema();
    let (mut by_value, mut by_ref) = (Encoder::new(nav()), Encoder::new(nav()));
    for seq in 1..=3 {
        let sent = pose(seq);
        let refs: Vec<&Assertion> = sent.items.iter().collect();
        let bytes = by_ref.encode_report(seq, &refs, &schema).unwrap();
        let expected = by_value.encode(&Message::Report(sent), &schema).unwrap();
        assert_eq!(bytes, expected, "report {seq}");
    }
    let mut bad = pose(4);
    bad.items[3].packet.value = Value::Real(25.0);
    let refs: Vec<&Assertion> = bad.items.iter().collect();
    assert!(by_ref.encode_report(4, &refs, &schema).is_err());
}
