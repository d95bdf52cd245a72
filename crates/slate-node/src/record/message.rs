//! The JSON of each message a recording holds (`docs/recording.md` lists them): a packet
//! on its class's channel, an object created or deleted, a class definition, a plan
//! event, a circuit step, a liveliness change, a board event, link counters.

use serde::Serialize;
use serde::ser::{SerializeMap, Serializer};
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

/// A packet written to `object.attr`, for the channel of the object's class, serialised
/// straight from the packet (no intermediate JSON tree: this runs once per change).
#[derive(Serialize)]
pub struct PacketMessage<'a> {
    object: &'a str,
    attr: &'a str,
    values: OneValue<'a>,
    accuracy: f64,
    confidence: f64,
    hlc: u64,
    time: f64,
    source: &'a str,
    revision: u64,
}

impl<'a> PacketMessage<'a> {
    /// The message of `p`, written to `object.attr` at `revision`.
    pub fn new(object: &'a str, attr: &'a str, p: &'a Packet, revision: u64) -> Self {
        PacketMessage {
            object,
            attr,
            values: OneValue {
                attr,
                value: &p.value,
            },
            accuracy: p.accuracy,
            confidence: p.confidence,
            hlc: p.timestamp.raw(),
            time: p.timestamp.as_secs_f64(),
            source: p.source.as_str(),
            revision,
        }
    }
}

/// `{ATTR: VALUE}`.
struct OneValue<'a> {
    attr: &'a str,
    value: &'a Value,
}

impl Serialize for OneValue<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(Some(1))?;
        map.serialize_entry(self.attr, &JsonValue(self.value))?;
        map.end()
    }
}

/// A value as [`value`] writes it.
struct JsonValue<'a>(&'a Value);

impl Serialize for JsonValue<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self.0 {
            Value::None => s.serialize_unit(),
            Value::Int(i) => s.serialize_i64(*i),
            Value::Real(r) => s.serialize_f64(*r),
            Value::Bool(b) => s.serialize_bool(*b),
            Value::Str(t) | Value::Ref(t) => s.serialize_str(t),
            Value::Vector(v) => v.serialize(s),
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
