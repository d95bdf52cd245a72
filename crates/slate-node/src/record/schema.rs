//! The JSON schemas of a recording's channels: one per class, derived from its
//! declaration (inherited attributes included), so Foxglove and any MCAP reader can plot
//! attributes without slate; and one for each of the fixed channels (`docs/recording.md`).

use serde_json::{Value as Json, json};
use slate_model::{AttrDecl, ValueType};

use crate::inspect::Classes;

/// The dialect every schema declares.
const DIALECT: &str = "https://json-schema.org/draft/2020-12/schema";

/// The schema of a recording's class channel: `{"packets": [PACKET, ...]}`, the packets
/// of the class written one after another (in the order of the changes), each as
/// [`class_schema`] types it.
pub fn class_batch_schema(classes: &Classes, class: &str) -> Json {
    let mut packet = class_schema(classes, class);
    if let Some(p) = packet.as_object_mut() {
        p.remove("$schema");
        p.remove("title");
    }
    json!({
        "$schema": DIALECT,
        "title": class,
        "description": format!("packets written to objects of the slate class {class}, in order; each packet's value is under values.ATTR"),
        "type": "object",
        "properties": {
            "packets": {"type": "array", "items": packet, "minItems": 1},
        },
        "required": ["packets"],
    })
}

/// The schema of one packet of a class (a live Foxglove channel's message, an item of a
/// recording's): its value under `values.ATTR` (the attribute's declared type, `null`
/// for a value cleared), beside the object, the attribute's name and the packet's
/// accuracy, confidence, stamp and source. A class the tree does not know gets the
/// fields without typed values.
pub fn class_schema(classes: &Classes, class: &str) -> Json {
    let values: serde_json::Map<String, Json> = classes
        .attributes(class)
        .into_iter()
        .filter_map(|attr| classes.decl(class, attr))
        .map(|decl| (decl.name.clone(), attr_schema(decl)))
        .collect();
    json!({
        "$schema": DIALECT,
        "title": class,
        "description": format!("packets written to objects of the slate class {class}: the value is under values.ATTR"),
        "type": "object",
        "properties": {
            "object": {"type": "string", "description": "object (or class, for a class-level write)"},
            "attr": {"type": "string", "description": "the attribute written"},
            "values": {"type": "object", "properties": values},
            "accuracy": {"type": "number", "minimum": 0},
            "confidence": {"type": "number", "minimum": 0, "maximum": 1},
            "hlc": {"type": "integer", "description": "the packet's hybrid logical timestamp, raw 64 bits"},
            "time": {"type": "number", "description": "the timestamp's physical part, seconds since the Unix epoch"},
            "source": {"type": "string", "description": "the module that wrote the packet"},
            "revision": {"type": "integer", "description": "the recording board's revision of the change"},
        },
        "required": ["object", "attr", "values", "accuracy", "confidence", "hlc", "time", "source"],
    })
}

/// One attribute's value: its type (or null), bounds and unit.
fn attr_schema(decl: &AttrDecl) -> Json {
    let mut schema = match decl.ty {
        ValueType::Int => json!({"type": ["integer", "null"]}),
        ValueType::Real => json!({"type": ["number", "null"]}),
        ValueType::Bool => json!({"type": ["boolean", "null"]}),
        ValueType::Str => json!({"type": ["string", "null"]}),
        ValueType::Ref => json!({"type": ["string", "null"], "description": "names an object"}),
        ValueType::Vector(n) => json!({
            "type": ["array", "null"],
            "items": {"type": "number"},
            "minItems": n,
            "maxItems": n,
        }),
    };
    if let (Some((lo, hi)), ValueType::Int | ValueType::Real) = (decl.bounds, decl.ty) {
        schema["minimum"] = json!(lo);
        schema["maximum"] = json!(hi);
    }
    if let Some(unit) = &decl.unit {
        schema["description"] = json!(format!("in {unit}"));
    }
    schema
}

/// A fixed channel's schema: an object with these typed fields, all required but those
/// marked optional with a trailing `?`.
fn fixed(title: &str, description: &str, fields: &[(&str, &str)]) -> Json {
    let properties: serde_json::Map<String, Json> = fields
        .iter()
        .map(|(name, ty)| (name.trim_end_matches('?').to_owned(), json!({ "type": ty })))
        .collect();
    let required: Vec<&str> = fields
        .iter()
        .map(|(name, _)| *name)
        .filter(|name| !name.ends_with('?'))
        .collect();
    json!({
        "$schema": DIALECT,
        "title": title,
        "description": description,
        "type": "object",
        "properties": properties,
        "required": required,
    })
}

/// The schema of a fixed channel, by topic.
pub fn fixed_schema(topic: &str) -> Option<Json> {
    use super::topic as tap;
    Some(match topic {
        tap::CLASSES => class_def(),
        tap::OBJECTS => object_event(),
        tap::PLANS => plan_event(),
        tap::CIRCUITS => circuit_step(),
        tap::LIVELINESS => liveliness(),
        tap::EVENTS => board_event(),
        tap::LINKS => link_stats(),
        tap::RECORDER => recorder_stats(),
        _ => return None,
    })
}

/// `/slate/classes`: a class definition, as the board holds it.
pub fn class_def() -> Json {
    fixed(
        "slate.ClassDef",
        "a class definition: its parent and the attributes it declares (not the inherited ones)",
        &[("name", "string"), ("parent", "string"), ("attrs", "array")],
    )
}

/// `/slate/objects`: an object created, deleted, or found at the start of a file.
pub fn object_event() -> Json {
    fixed(
        "slate.ObjectEvent",
        "op is create, delete, or exists (the object was on the board when the file began)",
        &[
            ("op", "string"),
            ("object", "string"),
            ("class", "string"),
            ("context?", "string"),
            ("owner?", "string"),
        ],
    )
}

/// `/slate/plans`: the plan engine's events.
pub fn plan_event() -> Json {
    fixed(
        "slate.PlanEvent",
        "event is installed, initiated, triggered, terminated, cancelled or failed",
        &[
            ("event", "string"),
            ("plan", "string"),
            ("fired?", "integer"),
            ("error?", "string"),
        ],
    )
}

/// `/slate/circuits`: a step of a plan circuit, sent (by a destination) or heard (by an
/// origin).
pub fn circuit_step() -> Json {
    fixed(
        "slate.CircuitStep",
        "one acknowledgement on a plan circuit; direction is sent (this module is the plan's origin) or received",
        &[
            ("direction", "string"),
            ("circuit", "integer"),
            ("plan", "string"),
            ("peer", "string"),
            ("step", "string"),
            ("detail", "string"),
            ("state", "string"),
        ],
    )
}

/// `/slate/liveliness`: a module going up or down, as the board's `Module` objects say.
pub fn liveliness() -> Json {
    fixed(
        "slate.Liveliness",
        "a Module object's alive attribute changed",
        &[
            ("object", "string"),
            ("module", "string"),
            ("alive", "boolean"),
        ],
    )
}

/// `/slate/events`: what the board reports about itself (failed active functions, cut
/// chains, refused stamps, class conflicts).
pub fn board_event() -> Json {
    fixed(
        "slate.BoardEvent",
        "kind is function_failed, chain_cut, future_stamp, class_conflict or other",
        &[("kind", "string"), ("text", "string")],
    )
}

/// `/slate/links`: a link's traffic counters since the node started, at a fixed interval.
pub fn link_stats() -> Json {
    fixed(
        "slate.LinkStats",
        "the transport's counters of one link kind and message kind since the node started",
        &[
            ("link", "string"),
            ("kind", "string"),
            ("sent_msgs", "integer"),
            ("sent_bytes", "integer"),
            ("recv_msgs", "integer"),
            ("recv_bytes", "integer"),
        ],
    )
}

/// `/slate/recorder`: the recorder's own counters, at the same interval.
pub fn recorder_stats() -> Json {
    fixed(
        "slate.RecorderStats",
        "messages, packets and bytes written so far, changes dropped because the recorder fell behind",
        &[
            ("messages", "integer"),
            ("packets", "integer"),
            ("bytes", "integer"),
            ("dropped", "integer"),
            ("files", "integer"),
        ],
    )
}

#[cfg(test)]
mod tests {
    use slate_model::{Board, ClassDef};

    use super::*;

    fn classes() -> Classes {
        let board = Board::new();
        let vehicle = ClassDef::new("Vehicle")
            .attr(
                AttrDecl::new("speed", ValueType::Real)
                    .unit("m/s")
                    .bounds(0.0, 10.0),
            )
            .attr(AttrDecl::new("mode", ValueType::Str));
        let ugv = ClassDef::new("Ugv")
            .parent("Vehicle")
            .attr(AttrDecl::new("pos", ValueType::Vector(2)))
            .attr(AttrDecl::new("wheels", ValueType::Int));
        board.define(vehicle).unwrap();
        board.define(ugv).unwrap();
        Classes::of(&board)
    }

    #[test]
    fn a_class_schema_types_every_attribute_it_declares_or_inherits() {
        let schema = class_schema(&classes(), "Ugv");
        let values = &schema["properties"]["values"]["properties"];
        assert_eq!(values["speed"]["type"], json!(["number", "null"]));
        assert_eq!(values["speed"]["description"], "in m/s");
        assert_eq!(
            (
                values["speed"]["minimum"].as_f64(),
                values["speed"]["maximum"].as_f64()
            ),
            (Some(0.0), Some(10.0))
        );
        assert_eq!(values["mode"]["type"], json!(["string", "null"]));
        assert_eq!(values["wheels"]["type"], json!(["integer", "null"]));
        assert_eq!(values["pos"]["type"], json!(["array", "null"]));
        assert_eq!(
            (
                values["pos"]["minItems"].as_u64(),
                values["pos"]["maxItems"].as_u64()
            ),
            (Some(2), Some(2))
        );
        assert_eq!(schema["title"], "Ugv");
        assert_eq!(schema["$schema"], DIALECT);
        let required = schema["required"].as_array().unwrap();
        assert!(required.contains(&json!("source")) && required.contains(&json!("hlc")));
    }

    #[test]
    fn a_parent_class_schema_has_only_its_own_attributes() {
        let schema = class_schema(&classes(), "Vehicle");
        let values = schema["properties"]["values"]["properties"]
            .as_object()
            .unwrap();
        let mut names: Vec<&str> = values.keys().map(String::as_str).collect();
        names.sort_unstable();
        assert_eq!(names, ["mode", "speed"]);
    }

    #[test]
    fn a_recorded_class_channel_holds_a_list_of_packets_of_the_class() {
        let batch = class_batch_schema(&classes(), "Ugv");
        assert_eq!(batch["title"], "Ugv");
        assert_eq!(batch["required"], json!(["packets"]));
        let item = &batch["properties"]["packets"]["items"];
        let mut packet = class_schema(&classes(), "Ugv");
        packet.as_object_mut().unwrap().remove("$schema");
        packet.as_object_mut().unwrap().remove("title");
        assert_eq!(item, &packet);
    }

    #[test]
    fn fixed_schemas_mark_optional_fields_as_not_required() {
        let schema = plan_event();
        assert_eq!(schema["required"], json!(["event", "plan"]));
        assert_eq!(schema["properties"]["fired"]["type"], "integer");
    }
}
