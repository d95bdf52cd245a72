//! Properties: encode → decode gives the message back (within quantisation), and no
//! input, random or a mutated valid message, makes the decoder panic. 256 cases each by
//! default; fuzz longer with `PROPTEST_CASES=100000 cargo test -p slate-wire --release
//! --test wire props`.

use proptest::prelude::*;
use slate_model::{Address, AttrDecl, Context, Packet, Timestamp, Value, ValueType};
use slate_wire::{
    Assertion, Decoder, Encoder, Message, ObjectEntry, Plan, PlanAck, PlanStep, Report, Schema,
    fuzz_classes, fuzz_decode, fuzz_source,
};

use crate::support::{Rng, assert_close, at};

/// The fuzz schema's objects: name, class, context, owner fixed per index.
fn object(i: u64) -> ObjectEntry {
    let classes = ["Vehicle", "Gsr", "Obstacle"];
    // A class-level value.
    if i == 9 {
        return ObjectEntry::new("Vehicle", "Vehicle");
    }
    let owner = if i.is_multiple_of(2) {
        fuzz_source()
    } else {
        Address::unknown()
    };
    ObjectEntry::new(&format!("o{i}"), classes[i as usize % 3])
        .context(Context::ALL[i as usize % 3])
        .owner(owner)
}

fn attrs_of(class: &str) -> Vec<&'static str> {
    let vehicle = ["x", "y", "heading", "speed", "goal", "mode", "alive"];
    match class {
        "Obstacle" => vec!["observer", "size", "note", "hits", "shape"],
        "Gsr" => vehicle.into_iter().chain(["battery"]).collect(),
        _ => vehicle.to_vec(),
    }
}

fn real(rng: &mut Rng, bounds: Option<(f64, f64)>) -> f64 {
    match bounds {
        Some((lo, hi)) => rng.real(lo, hi).min(hi),
        None if rng.next().is_multiple_of(2) => (rng.next() % 1000) as f64 / 8.0,
        None => rng.real(-1e12, 1e12),
    }
}

fn value(rng: &mut Rng, decl: &AttrDecl) -> Value {
    if rng.next().is_multiple_of(20) {
        return Value::None;
    }
    match decl.ty {
        ValueType::Bool => Value::Bool(rng.next().is_multiple_of(2)),
        ValueType::Int => match decl.bounds {
            Some((lo, hi)) => Value::Int(lo as i64 + (rng.next() % (hi - lo + 1.0) as u64) as i64),
            None => Value::Int(rng.next() as i64 >> (rng.next() % 64)),
        },
        ValueType::Real => Value::Real(real(rng, decl.bounds)),
        ValueType::Vector(n) => (0..n)
            .map(|_| real(rng, decl.bounds))
            .collect::<Vec<_>>()
            .into(),
        ValueType::Str => Value::from("ünïcode ".repeat((rng.next() % 4) as usize)),
        ValueType::Ref => Value::reference(&format!("o{}", rng.next() % 9)),
    }
}

fn packet(rng: &mut Rng, decl: &AttrDecl, base: u64) -> Packet {
    let default = decl.default.as_ref();
    let accuracy = match rng.next() % 4 {
        0 => default.map_or(0.0, |d| d.accuracy),
        1 => 0.0,
        _ => 10f64.powf(rng.real(-6.0, 8.0)),
    };
    let confidence = match rng.next() % 3 {
        0 => default.map_or(1.0, |d| d.confidence),
        _ => rng.real(0.0, 1.0),
    };
    let source = match rng.next() % 6 {
        0 => Address::new("team/r2/relay").unwrap(),
        1 => Address::unknown(),
        _ => fuzz_source(),
    };
    let spread = [0, 1_000, 10_000_000][(rng.next() % 3) as usize];
    Packet {
        value: value(rng, decl),
        accuracy,
        confidence,
        timestamp: at(
            base + rng.next() % (spread + 1),
            rng.next() % 4096 * (rng.next() % 2),
        ),
        source,
    }
}

/// A random valid report over the fuzz schema.
fn random_report(seed: u64, n: usize) -> Report {
    let schema = Schema::new(&fuzz_classes());
    let mut rng = Rng(seed);
    let base = rng.next() % 100_000_000_000;
    let uniform = rng.next().is_multiple_of(3);
    let items = (0..n)
        .map(|_| {
            let object = object(rng.next() % 10);
            let attrs = attrs_of(&object.class);
            let attr = attrs[(rng.next() % attrs.len() as u64) as usize];
            let mut packet = packet(&mut rng, schema.attr(&object.class, attr).unwrap(), base);
            if uniform {
                packet.timestamp = at(base, 0);
            }
            Assertion {
                object,
                attr: attr.into(),
                packet,
            }
        })
        .collect();
    Report {
        seq: rng.next() >> (rng.next() % 64),
        items,
    }
}

fn encode(encoder: &mut Encoder, msg: &Message) -> Vec<u8> {
    encoder.encode(msg, &Schema::new(&fuzz_classes())).unwrap()
}

fn text() -> impl Strategy<Value = String> {
    "\\PC{0,40}"
}

fn step() -> impl Strategy<Value = PlanStep> {
    prop_oneof![
        Just(PlanStep::Received),
        Just(PlanStep::Accepted),
        text().prop_map(|reason| PlanStep::Rejected { reason }),
        Just(PlanStep::Initiated),
        (any::<bool>(), text()).prop_map(|(ok, detail)| PlanStep::Triggered { ok, detail }),
        Just(PlanStep::Terminated),
        Just(PlanStep::Cancelled),
        Just(PlanStep::DestinationLost),
    ]
}

/// Bytes changed by flips, a cut, or an insertion.
fn mutate(mut bytes: Vec<u8>, edits: &[(usize, u8)], cut: Option<usize>) -> Vec<u8> {
    for (at, x) in edits {
        if bytes.is_empty() {
            break;
        }
        let i = at % bytes.len();
        match x % 3 {
            0 => bytes[i] ^= 1 << (x % 8),
            1 => bytes[i] = *x,
            _ => bytes.insert(i, *x),
        }
    }
    if let Some(cut) = cut {
        bytes.truncate(cut % (bytes.len() + 1));
    }
    bytes
}

proptest! {
    #[test]
    fn reports_roundtrip_within_quantisation(seed in any::<u64>(), n in 0usize..40, m in 0usize..10) {
        let schema = Schema::new(&fuzz_classes());
        let mut encoder = Encoder::new(fuzz_source());
        let mut decoder = Decoder::new();
        for (i, sent) in [random_report(seed, n), random_report(seed ^ 1, m)].into_iter().enumerate() {
            let msg = if i == 0 { Message::Report(sent.clone()) } else { Message::CatchUpAnswer(sent.clone()) };
            let bytes = encode(&mut encoder, &msg);
            let got = match decoder.decode(&fuzz_source(), &bytes, &schema) {
                Ok(Message::Report(r) | Message::CatchUpAnswer(r)) => r,
                other => panic!("{other:?}"),
            };
            assert_close(&schema, &sent, &got);
        }
    }

    #[test]
    fn plans_and_acks_roundtrip_exactly(circuit in any::<u64>(), seq in any::<u64>(), name in text(), body in text(), step in step()) {
        let schema = Schema::new(&fuzz_classes());
        let plan = Message::Plan(Plan { circuit, name, source_text: body, to: fuzz_source(), origin: Address::unknown() });
        let ack = Message::PlanAck(PlanAck { circuit, seq, step });
        for msg in [plan, ack] {
            let bytes = encode(&mut Encoder::new(fuzz_source()), &msg);
            prop_assert_eq!(Decoder::new().decode(&fuzz_source(), &bytes, &schema), Ok(msg));
        }
    }

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        fuzz_decode(&bytes);
        let mut with_header = bytes;
        with_header.insert(0, 0x11);
        fuzz_decode(&with_header);
    }

    #[test]
    fn mutated_messages_never_panic(
        seed in any::<u64>(),
        n in 0usize..12,
        edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 0..4),
        cut in proptest::option::of(any::<usize>()),
    ) {
        let mut encoder = Encoder::new(fuzz_source());
        let valid = encode(&mut encoder, &Message::Report(random_report(seed, n)));
        fuzz_decode(&valid);
        fuzz_decode(&mutate(valid, &edits, cut));
        let classes = encode(&mut encoder, &Message::Classes(fuzz_classes()));
        fuzz_decode(&mutate(classes, &edits, cut));
    }
}

#[test]
fn timestamps_far_from_the_epoch_roundtrip() {
    let schema = Schema::new(&fuzz_classes());
    let o = object(0);
    let early = Packet {
        value: Value::Bool(false),
        accuracy: 0.0,
        confidence: 0.2,
        timestamp: Timestamp::from_raw(1),
        source: fuzz_source(),
    };
    let late = Packet {
        timestamp: Timestamp::from_raw(u64::MAX),
        ..early.clone()
    };
    let sent = Report {
        seq: 1,
        items: vec![
            Assertion {
                object: o.clone(),
                attr: "alive".into(),
                packet: late,
            },
            Assertion {
                object: o,
                attr: "alive".into(),
                packet: early,
            },
        ],
    };
    let bytes = encode(
        &mut Encoder::new(fuzz_source()),
        &Message::Report(sent.clone()),
    );
    assert_eq!(
        Decoder::new().decode(&fuzz_source(), &bytes, &schema),
        Ok(Message::Report(sent))
    );
}
