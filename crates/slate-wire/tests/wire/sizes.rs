//! The headline numbers: bytes of typical messages, measured and (for the targets)
//! asserted. Sizes are deterministic. Print the table of `docs/wire.md` with
//! `cargo test -p slate-wire --test wire sizes -- --nocapture`.

use slate_model::Timestamp;
use slate_wire::{
    Encoder, Heartbeat, Message, Names, ObjectEntry, Plan, PlanAck, PlanStep, Report, Schema,
};

use crate::support::*;

/// One hour after the epoch, at 10 reports a second: a sender in steady state.
const HOUR_US: u64 = 3_600_000_000;
const SEQ: u64 = 36_000;

const TRACKED_ATTRS: [&str; 4] = ["range", "level", "depth", "width"];

fn tracked(i: usize) -> ObjectEntry {
    ObjectEntry::new(&format!("t{i}"), "Tracked").owner(nav())
}

/// 100 updates of 100 different objects: one of four attributes each, values in
/// 0..1000, accuracy and confidence not the defaults, timestamps spread over a second
/// (10 ms apart with microsecond jitter, some with a logical counter).
pub(crate) fn batch_of_100(seq: u64, start_us: u64, rng: &mut Rng) -> Report {
    let items = (0..100usize)
        .map(|i| {
            let jitter = rng.next() % 1000;
            let logical = if i.is_multiple_of(10) { 1 } else { 0 };
            let t = at(start_us + i as u64 * 10_000 + jitter, logical);
            let p = packet(
                (rng.real(0.0, 1000.0) * 100.0).round() / 100.0,
                rng.real(0.01, 1.0),
                rng.real(0.5, 1.0),
                t,
            );
            assertion(&tracked(i), TRACKED_ATTRS[i % 4], p)
        })
        .collect();
    report(seq, items)
}

/// A robot pose: x, y, heading, speed, each with accuracy and confidence, one timestamp.
pub(crate) fn pose_report(seq: u64, t: Timestamp) -> Report {
    let r = robot();
    let items = vec![
        assertion(&r, "x", packet(1234.56, 0.05, 0.9, t)),
        assertion(&r, "y", packet(-8765.43, 0.05, 0.9, t)),
        assertion(&r, "heading", packet(1.234, 0.01, 0.8, t)),
        assertion(&r, "speed", packet(3.21, 0.1, 0.95, t)),
    ];
    report(seq, items)
}

fn single(seq: u64, t: Timestamp) -> Report {
    report(
        seq,
        vec![assertion(
            &tracked(0),
            "range",
            packet(123.45, 0.05, 0.9, t),
        )],
    )
}

fn size(encoder: &mut Encoder, msg: Message, schema: &Schema) -> usize {
    encoder.encode(&msg, schema).unwrap().len()
}

fn plan_200() -> Message {
    let mut text = String::from("plan approach { when any o: Obstacle where o.range < 5 ");
    while text.len() < 199 {
        text.push_str("and o.confidence > 0.5 ");
    }
    text.truncate(199);
    text.push('}');
    Message::Plan(Plan {
        circuit: 12,
        name: "approach".into(),
        source_text: text,
        to: addr("team/r2/exec"),
        origin: addr("team/base/console"),
    })
}

/// Every measured size, in the order of the table in `docs/wire.md`.
fn measure() -> Vec<(&'static str, usize, &'static str)> {
    let schema = schema();
    let mut enc = Encoder::new(nav());
    let mut rng = Rng(7);
    let first_single = size(&mut enc, Message::Report(single(1, at(0, 0))), &schema);
    let single_steady = size(
        &mut enc,
        Message::Report(single(SEQ, at(HOUR_US, 0))),
        &schema,
    );
    size(
        &mut enc,
        Message::Report(batch_of_100(2, 0, &mut rng)),
        &schema,
    );
    let batch = size(
        &mut enc,
        Message::Report(batch_of_100(SEQ, HOUR_US, &mut rng)),
        &schema,
    );
    let first_pose = size(&mut enc, Message::Report(pose_report(3, at(0, 0))), &schema);
    let pose = size(
        &mut enc,
        Message::Report(pose_report(SEQ, at(HOUR_US, 0))),
        &schema,
    );
    let names_one = size(&mut enc, names(&[tracked(100)]), &schema);
    let ten: Vec<ObjectEntry> = (101..111).map(tracked).collect();
    let names_ten = size(&mut enc, names(&ten), &schema);
    let mut fresh = Encoder::new(nav());
    let names_first = size(&mut fresh, names(&[tracked(0)]), &schema);
    let ack = |step| {
        Message::PlanAck(PlanAck {
            circuit: 12,
            seq: 2,
            step,
        })
    };
    let heartbeat = Heartbeat {
        seq: SEQ,
        sent: 36_500,
        received: 12_000,
        rejected: 3,
    };
    vec![
        (
            "report, 1 update, names announced",
            single_steady,
            "steady state",
        ),
        (
            "report, 1 update, first (names inline)",
            first_single,
            "+ epoch, class, owner, object, attribute",
        ),
        (
            "report, batch of 100 updates",
            batch,
            "target <= 1000 (10 B/update)",
        ),
        (
            "report, robot pose (x, y, heading, speed)",
            pose,
            "target <= 32",
        ),
        ("report, robot pose, first (names inline)", first_pose, ""),
        ("names, 1 object (class known)", names_one, ""),
        ("names, 10 objects (class known)", names_ten, ""),
        (
            "names, 1 object, first (epoch, class, owner)",
            names_first,
            "",
        ),
        (
            "plan, 200-byte text",
            size(&mut enc, plan_200(), &schema),
            "",
        ),
        (
            "plan ack, accepted",
            size(&mut enc, ack(PlanStep::Accepted), &schema),
            "",
        ),
        (
            "plan ack, triggered ok",
            size(
                &mut enc,
                ack(PlanStep::Triggered {
                    ok: true,
                    detail: String::new(),
                }),
                &schema,
            ),
            "",
        ),
        (
            "plan cancel",
            size(&mut enc, Message::PlanCancel { circuit: 12 }, &schema),
            "",
        ),
        (
            "heartbeat",
            size(&mut enc, Message::Heartbeat(heartbeat), &schema),
            "",
        ),
        (
            "classes, Robot and Tracked",
            size(&mut enc, Message::Classes(classes()), &schema),
            "",
        ),
    ]
}

fn names(objects: &[ObjectEntry]) -> Message {
    Message::Names(Names {
        objects: objects.to_vec(),
        attrs: Vec::new(),
    })
}

#[test]
fn typical_messages_meet_the_size_targets() {
    let sizes = measure();
    println!("| message | bytes | note |\n|---|---:|---|");
    for (what, bytes, note) in &sizes {
        println!("| {what} | {bytes} | {note} |");
    }
    let batch = sizes[2].1;
    println!("batch of 100: {:.2} bytes per update", batch as f64 / 100.0);
    assert!(batch <= 1000, "batch of 100 takes {batch} bytes");
    assert!(sizes[3].1 <= 32, "pose report takes {} bytes", sizes[3].1);
    assert!(sizes[0].1 <= 16, "single update takes {} bytes", sizes[0].1);
}

#[test]
fn sizes_do_not_depend_on_the_run() {
    assert_eq!(measure(), measure());
}

#[test]
fn a_batch_of_100_comes_back_within_resolution() {
    let schema = schema();
    let mut rng = Rng(11);
    let sent = batch_of_100(5, HOUR_US, &mut rng);
    let bytes = Encoder::new(nav())
        .encode(&Message::Report(sent.clone()), &schema)
        .unwrap();
    let Ok(Message::Report(got)) = slate_wire::Decoder::new().decode(&nav(), &bytes, &schema)
    else {
        panic!("batch did not decode");
    };
    assert_close(&schema, &sent, &got);
}
