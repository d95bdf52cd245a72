//! The JSON of each message a recording holds (`docs/recording.md` lists them): a packet
//! on its class's channel, an object created or deleted, a class definition, a plan
//! event, a circuit step, a liveliness change, a board event, link counters.

use serde_json::{Value as Json, json};
use slate_ici::CircuitStatus;
use slate_model::{BoardEvent, ClassDef, Packet, Value};
use slate_plans::PlanEvent;
use slate_wire::PlanStep;

/// A packet's value as JSON: numbers, booleans, text (a reference is its object's name),
/// arrays of reals; `null` when cleared.
pub fn value(value: &Value) -> Json {
    match value {
        Value::None => Json::Null,
        Value::Int(i) => json!(i),
        Value::Real(r) => json!(r),
        Value::Bool(b) => json!(b),
        Value::Str(s) | Value::Ref(s) => json!(&**s),
        Value::Vector(v) => json!(&**v),
    }
}

/// How a class channel's message begins and ends around its packets (a recording's and
/// a live Foxglove channel's): `{"packets": [PACKET, ...]}`.
pub const LIST_OPEN: &[u8] = b"{\"packets\":[";
/// See [`LIST_OPEN`].
pub const LIST_CLOSE: &[u8] = b"]}";

/// A packet written to `object.attr`, as one item of a class channel's message:
/// `{"object", "attr", "values": {ATTR: VALUE}, "accuracy", "confidence", "hlc", "time",
/// "source", "revision"}`.
pub struct PacketMessage<'a> {
    object: &'a str,
    attr: &'a str,
    packet: &'a Packet,
    revision: u64,
}

impl<'a> PacketMessage<'a> {
    /// The message of `p`, written to `object.attr` at `revision`.
    pub fn new(object: &'a str, attr: &'a str, p: &'a Packet, revision: u64) -> Self {
        PacketMessage {
            object,
            attr,
            packet: p,
            revision,
        }
    }

    /// Appends a class channel's message of this packet alone to `out`.
    pub fn write_alone(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(LIST_OPEN);
        self.write(out);
        out.extend_from_slice(LIST_CLOSE);
    }

    /// Appends the packet's JSON to `out`. Written field by field rather than through
    /// serde's generic path: the recorder writes one per packet the board commits, and
    /// the keys need no escaping. `time` is the stamp's physical part written exactly
    /// (seconds, a decimal point and up to six digits), not the shortest form of an
    /// `f64`.
    pub fn write(&self, out: &mut Vec<u8>) {
        let p = self.packet;
        out.extend_from_slice(b"{\"object\":");
        string(out, self.object);
        out.extend_from_slice(b",\"attr\":");
        string(out, self.attr);
        out.extend_from_slice(b",\"values\":{");
        string(out, self.attr);
        out.push(b':');
        value_json(out, &p.value);
        out.extend_from_slice(b"},\"accuracy\":");
        real(out, p.accuracy);
        out.extend_from_slice(b",\"confidence\":");
        real(out, p.confidence);
        out.extend_from_slice(b",\"hlc\":");
        integer(out, p.timestamp.raw());
        out.extend_from_slice(b",\"time\":");
        let physical = p.timestamp.physical();
        integer(out, physical.as_secs());
        fraction(out, physical.subsec_micros());
        out.extend_from_slice(b",\"source\":");
        string(out, p.source.as_str());
        out.extend_from_slice(b",\"revision\":");
        integer(out, self.revision);
        out.push(b'}');
    }
}

/// `.` and six digits of microseconds without their trailing zeros (`.125` for
/// 125 000, `.0` for none).
fn fraction(out: &mut Vec<u8>, micros: u32) {
    let mut digits = [b'0'; 6];
    let mut n = micros;
    for d in digits.iter_mut().rev() {
        *d = b'0' + (n % 10) as u8;
        n /= 10;
    }
    let len = digits.iter().rposition(|d| *d != b'0').map_or(1, |i| i + 1);
    out.push(b'.');
    out.extend_from_slice(&digits[..len]);
}

/// A JSON string: copied as it is when nothing in it needs escaping (names, addresses).
fn string(out: &mut Vec<u8>, s: &str) {
    if s.bytes().all(|b| b >= 0x20 && b != b'"' && b != b'\\') {
        out.push(b'"');
        out.extend_from_slice(s.as_bytes());
        out.push(b'"');
    } else {
        // Writing a string into a Vec cannot fail.
        let _ = serde_json::to_writer(&mut *out, s);
    }
}

fn real(out: &mut Vec<u8>, r: f64) {
    use serde_json::ser::{CompactFormatter, Formatter};
    // 0 and 1 are most accuracies and confidences.
    if r == 0.0 && r.is_sign_positive() {
        out.extend_from_slice(b"0.0");
    } else if r == 1.0 {
        out.extend_from_slice(b"1.0");
    } else if r.is_finite() {
        let _ = CompactFormatter.write_f64(out, r);
    } else {
        out.extend_from_slice(b"null");
    }
}

fn integer(out: &mut Vec<u8>, n: u64) {
    use serde_json::ser::{CompactFormatter, Formatter};
    let _ = CompactFormatter.write_u64(out, n);
}

/// A value as [`value`] makes it.
fn value_json(out: &mut Vec<u8>, v: &Value) {
    use serde_json::ser::{CompactFormatter, Formatter};
    match v {
        Value::None => out.extend_from_slice(b"null"),
        Value::Int(i) => {
            let _ = CompactFormatter.write_i64(out, *i);
        }
        Value::Real(r) => real(out, *r),
        Value::Bool(b) => out.extend_from_slice(if *b { b"true" } else { b"false" }),
        Value::Str(s) | Value::Ref(s) => string(out, s),
        Value::Vector(v) => {
            out.push(b'[');
            for (i, x) in v.iter().enumerate() {
                if i > 0 {
                    out.push(b',');
                }
                real(out, *x);
            }
            out.push(b']');
        }
    }
}

/// A class definition, with its attributes' declarations.
pub fn class_def(def: &ClassDef) -> Json {
    let attrs: Vec<Json> = def
        .attrs
        .iter()
        .map(|a| {
            json!({
                "name": a.name,
                "type": a.ty.to_string(),
                "unit": a.unit,
                "bounds": a.bounds.map(|(lo, hi)| [lo, hi]),
                "resolution": a.resolution,
                "default": a.default.as_ref().map(|d| json!({
                    "value": value(&d.value), "accuracy": d.accuracy, "confidence": d.confidence,
                })),
                "merge": a.merge.name(),
                "report": {
                    "min_interval": a.report.min_interval.map(|d| d.as_secs_f64()),
                    "heartbeat": a.report.heartbeat.map(|d| d.as_secs_f64()),
                    "deadband": a.report.deadband,
                    "on_accuracy": a.report.on_accuracy,
                },
                "guarded": a.guarded,
            })
        })
        .collect();
    json!({ "name": def.name, "parent": def.parent, "attrs": attrs })
}

/// A plan engine event.
pub fn plan_event(e: &PlanEvent) -> Json {
    let (event, plan) = match e {
        PlanEvent::Installed { plan } => ("installed", plan),
        PlanEvent::Initiated { plan } => ("initiated", plan),
        PlanEvent::Triggered { plan, .. } => ("triggered", plan),
        PlanEvent::Terminated { plan } => ("terminated", plan),
        PlanEvent::Cancelled { plan } => ("cancelled", plan),
        PlanEvent::Failed { plan, .. } => ("failed", plan),
    };
    let mut j = json!({ "event": event, "plan": plan });
    if let PlanEvent::Triggered { fired, error, .. } = e {
        j["fired"] = json!(fired);
        if let Some(error) = error {
            j["error"] = json!(error);
        }
    }
    if let PlanEvent::Failed { error, .. } = e {
        j["error"] = json!(error);
    }
    j
}

/// One step of a plan circuit.
pub fn circuit_step(direction: &str, circuit: &CircuitStatus, step: &PlanStep) -> Json {
    json!({
        "direction": direction,
        "circuit": circuit.circuit,
        "plan": circuit.name,
        "peer": circuit.peer.as_str(),
        "step": step.kind(),
        "detail": step.detail(),
        "state": step.plan_state(),
    })
}

/// A board event, with its kind and a sentence.
pub fn board_event(e: &BoardEvent) -> Json {
    let kind = match e {
        BoardEvent::FunctionFailed { .. } => "function_failed",
        BoardEvent::ChainCut(_) => "chain_cut",
        BoardEvent::FutureStamp { .. } => "future_stamp",
        BoardEvent::ClassConflict { .. } => "class_conflict",
        BoardEvent::ObjectLimit { .. } => "object_limit",
        BoardEvent::ModuleLimit { .. } => "module_limit",
        BoardEvent::NameLimit { .. } => "name_limit",
        BoardEvent::NotOwner { .. } => "not_owner",
        BoardEvent::Unauthorised { .. } => "unauthorised",
        _ => "other",
    };
    json!({ "kind": kind, "text": crate::monitor::board_event(e) })
}

#[cfg(test)]
mod tests {
    use slate_model::{Address, LOGICAL_BITS, Timestamp};

    use super::*;

    fn packet(value: Value, accuracy: f64, confidence: f64) -> Packet {
        Packet {
            value,
            accuracy,
            confidence,
            // 1 764 150 000.125 s, logical 3.
            timestamp: Timestamp::from_raw((1_764_150_000_125_000 << LOGICAL_BITS) | 3),
            source: Address::new("t/r1/nav").unwrap(),
        }
    }

    fn written(object: &str, attr: &str, p: &Packet) -> Json {
        let mut out = Vec::new();
        PacketMessage::new(object, attr, p, 42).write(&mut out);
        serde_json::from_slice(&out)
            .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&out)))
    }

    #[test]
    fn a_packet_message_is_the_json_of_its_fields() {
        let p = packet(Value::Real(2.5), 0.1, 1.0);
        assert_eq!(
            written("gsr", "speed", &p),
            json!({"object": "gsr", "attr": "speed", "values": {"speed": 2.5},
                   "accuracy": 0.1, "confidence": 1.0, "hlc": p.timestamp.raw(),
                   "time": 1_764_150_000.125, "source": "t/r1/nav", "revision": 42})
        );
    }

    #[test]
    fn every_kind_of_value_and_name_is_written_as_json_reads_it() {
        let cases = [
            (Value::None, Json::Null),
            (Value::Int(-7), json!(-7)),
            (Value::Real(-0.0), json!(-0.0)),
            (Value::Real(1e-300), json!(1e-300)),
            (Value::Bool(true), json!(true)),
            (
                Value::Str("say \"hi\"\n\\ é".into()),
                json!("say \"hi\"\n\\ é"),
            ),
            (Value::Ref("rock".into()), json!("rock")),
            (
                Value::Vector(vec![1.0, 0.0, -2.25].into()),
                json!([1.0, 0.0, -2.25]),
            ),
        ];
        for (v, want) in cases {
            let j = written("o\"1", "a\tb", &packet(v, 0.0, 0.25));
            assert_eq!(j["values"]["a\tb"], want);
            assert_eq!(
                (j["object"].as_str(), j["attr"].as_str()),
                (Some("o\"1"), Some("a\tb"))
            );
            assert_eq!(
                (j["accuracy"].as_f64(), j["confidence"].as_f64()),
                (Some(0.0), Some(0.25))
            );
        }
    }

    #[test]
    fn time_is_the_stamps_physical_part_in_seconds() {
        for (micros, want) in [
            (0, 1_764_150_000.0),
            (1, 1_764_150_000.000_001),
            (500_000, 1_764_150_000.5),
        ] {
            let mut p = packet(Value::Int(1), 0.0, 1.0);
            p.timestamp =
                Timestamp::from_raw(((1_764_150_000_000_000 + micros) << LOGICAL_BITS) | 9);
            assert_eq!(written("o", "a", &p)["time"].as_f64(), Some(want));
        }
    }
}
