//! Golden vectors: the exact bytes of typical messages, in `tests/golden/*.hex`. A test
//! fails when the encoding drifts. After an intended format change, regenerate with
//! `SLATE_BLESS=1 cargo test -p slate-wire --test wire golden` and review the diff.

use std::path::PathBuf;

use slate_wire::{CatchUpRequest, Decoder, Encoder, Heartbeat, Message, Names, PlanAck, PlanStep};

use crate::sizes::{batch_of_100, pose_report};
use crate::support::*;

/// The golden messages, encoded in this order by one encoder (names announced by the
/// first are not repeated by the next).
pub(crate) fn cases() -> Vec<(&'static str, Vec<u8>)> {
    let schema = schema();
    let mut enc = Encoder::new(nav());
    let mut encode = |msg: Message| enc.encode(&msg, &schema).unwrap();
    let ack = PlanAck {
        circuit: 12,
        seq: 2,
        step: PlanStep::Rejected {
            reason: "unknown class Ufo".into(),
        },
    };
    vec![
        (
            "pose_first",
            encode(Message::Report(pose_report(1, at(0, 0)))),
        ),
        (
            "pose_steady",
            encode(Message::Report(pose_report(36_000, at(3_600_000_000, 0)))),
        ),
        ("batch_small", encode(Message::Report(small_batch()))),
        (
            "names",
            encode(Message::Names(Names {
                objects: vec![robot()],
                attrs: vec!["speed".into()],
            })),
        ),
        ("classes", encode(Message::Classes(classes()))),
        ("plan_ack", encode(Message::PlanAck(ack))),
        ("plan_cancel", encode(Message::PlanCancel { circuit: 12 })),
        (
            "catch_up_request",
            encode(Message::CatchUpRequest(CatchUpRequest {
                have_seq: 41,
                needs_names: true,
                needs_classes: false,
            })),
        ),
        (
            "catch_up_answer",
            encode(Message::CatchUpAnswer(pose_report(42, at(1_000, 7)))),
        ),
        (
            "heartbeat",
            encode(Message::Heartbeat(Heartbeat {
                seq: 42,
                sent: 50,
                received: 20,
                rejected: 1,
            })),
        ),
    ]
}

/// Five updates of the batch fixture (timestamps, logical counters, grouping).
fn small_batch() -> slate_wire::Report {
    let mut r = batch_of_100(2, 1_000_000, &mut Rng(3));
    r.items.truncate(5);
    r
}

fn path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(format!("{name}.hex"))
}

/// Hex, 16 bytes a line.
fn to_hex(bytes: &[u8]) -> String {
    bytes
        .chunks(16)
        .map(|line| {
            line.iter()
                .map(|b| format!("{b:02x}"))
                .collect::<Vec<_>>()
                .join(" ")
                + "\n"
        })
        .collect()
}

fn from_hex(text: &str) -> Vec<u8> {
    text.lines()
        .filter(|l| !l.starts_with('#'))
        .flat_map(|l| l.split_whitespace())
        .map(|b| u8::from_str_radix(b, 16).unwrap())
        .collect()
}

#[test]
fn encodings_match_the_golden_vectors() {
    let bless = std::env::var_os("SLATE_BLESS").is_some_and(|v| v == "1");
    for (name, bytes) in cases() {
        let file = path(name);
        if bless {
            let text = format!(
                "# {name}: {} bytes (SLATE_BLESS=1 regenerates)\n{}",
                bytes.len(),
                to_hex(&bytes)
            );
            std::fs::write(&file, text).unwrap();
            continue;
        }
        let text = std::fs::read_to_string(&file).unwrap_or_else(|e| {
            panic!(
                "{}: {e}; run with SLATE_BLESS=1 to create it",
                file.display()
            )
        });
        assert_eq!(
            to_hex(&from_hex(&text)),
            to_hex(&bytes),
            "{name} drifted from {}",
            file.display()
        );
    }
}

#[test]
fn golden_vectors_decode_in_sequence() {
    let schema = schema();
    let mut decoder = Decoder::new();
    for (name, bytes) in cases() {
        let result = decoder.decode(&nav(), &bytes, &schema);
        assert!(result.is_ok(), "{name}: {result:?}");
    }
    assert_eq!(decoder.stats().rejected(), 0);
}
