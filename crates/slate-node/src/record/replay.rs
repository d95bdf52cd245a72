//! Reading a recording back into a board (`slate play`): each message of a file, in
//! order, as what it did to the recorded board; a file cut off by a crash is read up to
//! its last complete chunk.

use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::time::Duration;

use mcap::read::Options;
use serde_json::Value as Json;
use slate_model::{
    Address, AttrDecl, Board, ClassDef, Context, DefaultPacket, MergePolicy, NewObject, Packet,
    ReportPolicy, Timestamp, Update, Value, ValueType,
};

use super::topic;

/// Why a recording cannot be read.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The file cannot be read.
    #[error("cannot read the recording {}: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// The file is not MCAP (or its first record is damaged).
    #[error("{} is not an MCAP recording: {why}", path.display())]
    NotMcap {
        /// The file.
        path: PathBuf,
        /// Why.
        why: String,
    },
}

/// What one message did to the recorded board.
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// A class was defined (or redefined).
    Class(ClassDef),
    /// An object was created.
    Create(NewObject),
    /// An object was on the board when the file began.
    Exists(NewObject),
    /// An object was deleted.
    Delete(String),
    /// A packet was written to `object.attr`; its value is JSON until the class says
    /// its type ([`Recording::apply`]).
    Packet {
        /// Object (or class, for a class-level write).
        object: String,
        /// Attribute.
        attr: String,
        /// The value as recorded.
        value: Json,
        /// The packet, without its value.
        packet: Packet,
    },
    /// A message of another channel (plans, circuits, liveliness, events, counters).
    Other {
        /// Its topic.
        topic: String,
        /// Its JSON.
        json: Json,
    },
}

/// One message: when it was recorded, and what it did.
#[derive(Clone, Debug, PartialEq)]
pub struct Timed {
    /// The recording board's time when it was recorded (since the Unix epoch).
    pub time: Duration,
    /// What it did.
    pub step: Step,
}

/// A recording read into memory.
#[derive(Clone, Debug, Default)]
pub struct Recording {
    /// The recording board's address, if the file says it.
    pub address: Option<String>,
    /// Its messages, in the file's order.
    pub steps: Vec<Timed>,
    /// Messages that could not be understood (skipped).
    pub skipped: u64,
    /// False when the file was cut off (no footer: a crash); it was read up to its last
    /// complete record.
    pub complete: bool,
}

impl Recording {
    /// Reads a file: every message up to the end, or up to the last complete record of a
    /// file cut off by a crash.
    pub fn read(path: &Path) -> Result<Recording, ReplayError> {
        let raw = Raw::read(path)?;
        let mut recording = Recording {
            address: raw.address,
            complete: raw.complete,
            ..Recording::default()
        };
        for m in raw.messages {
            let json = serde_json::from_slice(&m.data).unwrap_or(Json::Null);
            match step(&m.topic, json) {
                Some(step) => recording.steps.push(Timed {
                    time: Duration::from_nanos(m.log_time),
                    step,
                }),
                None => recording.skipped += 1,
            }
        }
        Ok(recording)
    }

    /// When the recording begins and ends (the first and last message's time).
    pub fn span(&self) -> Option<(Duration, Duration)> {
        Some((self.steps.first()?.time, self.steps.last()?.time))
    }

    /// Applies one step to `board`: defines, creates, deletes, merges the packet (its
    /// stamp and source kept). False if the board refused it (a class defined
    /// differently, a packet older than the one it holds...).
    pub fn apply(board: &Board, step: &Step) -> bool {
        match step {
            Step::Class(def) => {
                board.class_def(&def.name).as_ref() == Some(def)
                    || board.define(def.clone()).is_ok()
            }
            Step::Create(spec) | Step::Exists(spec) => {
                board.info(&spec.name).is_some() || board.create_with(spec.clone()).is_ok()
            }
            Step::Delete(name) => board.delete(name).is_ok(),
            Step::Packet {
                object,
                attr,
                value,
                packet,
            } => {
                let Some(value) = typed_value(board, object, attr, value) else {
                    return false;
                };
                let packet = Packet {
                    value,
                    ..packet.clone()
                };
                board.merge(object, attr, packet).is_ok()
            }
            Step::Other { .. } => true,
        }
    }

    /// Applies one step as the writes of the module whose board this is, to publish a
    /// recording onto a live team (`slate play --onto`): an object is created owned by
    /// that module, and a packet is written again as its own write (stamped now, that
    /// module its source, the recorded accuracy and confidence kept). Classes and
    /// deletions are applied as [`apply`](Recording::apply) does. False if the board
    /// refused it (an object another module already holds under that name is written to,
    /// not created).
    pub fn apply_as_writer(board: &Board, step: &Step) -> bool {
        match step {
            Step::Create(spec) | Step::Exists(spec) => {
                let own = spec.clone().owner(board.address().clone());
                board.info(&spec.name).is_some() || board.create_with(own).is_ok()
            }
            Step::Packet {
                object,
                attr,
                value,
                packet,
            } => {
                let Some(value) = typed_value(board, object, attr, value) else {
                    return false;
                };
                let update = Update::new(value)
                    .accuracy(packet.accuracy)
                    .confidence(packet.confidence);
                board.write(object, attr, update).is_ok()
            }
            other => Recording::apply(board, other),
        }
    }
}

/// One message of a recording, a class channel's message split into its packets.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RawMessage {
    /// Its channel's topic (`/slate/class/Vehicle`, `/slate/objects`...).
    pub topic: String,
    /// When the recording board handled it, in nanoseconds since the Unix epoch (a
    /// packet: the time of the message that holds it).
    pub log_time: u64,
    /// Its JSON, as bytes (a packet: its own, as an item of the message's `packets`).
    pub data: Vec<u8>,
}

/// A recording's messages as the file holds them, a class channel's message split into
/// its packets, for readers that want the JSON of each (Python's `slate.Recording`)
/// rather than what it did to the board. Files recorded before class channels held lists
/// of packets (one packet a message, no `packets`) read the same.
#[derive(Clone, Debug, Default)]
pub struct Raw {
    /// The recording board's address, if the file says it.
    pub address: Option<String>,
    /// Every message up to the end, or up to the last complete record.
    pub messages: Vec<RawMessage>,
    /// False when the file was cut off (no footer: a crash).
    pub complete: bool,
}

impl Raw {
    /// Reads a file whole: every message up to the end, or up to the last complete
    /// record of a file cut off by a crash.
    pub fn read(path: &Path) -> Result<Raw, ReplayError> {
        let bytes = std::fs::read(path).map_err(|error| ReplayError::Read {
            path: path.to_owned(),
            error,
        })?;
        let not_mcap = |why: String| ReplayError::NotMcap {
            path: path.to_owned(),
            why,
        };
        if !bytes.starts_with(mcap::MAGIC) {
            return Err(not_mcap("it does not begin with MCAP's magic bytes".into()));
        }
        let stream = mcap::MessageStream::new_with_options(&bytes, Options::IgnoreEndMagic.into())
            .map_err(|e| not_mcap(e.to_string()))?;
        let mut raw = Raw {
            address: address(&bytes),
            complete: bytes.ends_with(mcap::MAGIC),
            messages: Vec::new(),
        };
        for message in stream {
            let Ok(m) = message else {
                raw.complete = false;
                break;
            };
            let topic = &m.channel.topic;
            if topic.starts_with(topic::CLASS_PREFIX)
                && let Some(packets) = packets(&m.data)
            {
                raw.messages
                    .extend(packets.into_iter().map(|data| RawMessage {
                        topic: topic.clone(),
                        log_time: m.log_time,
                        data,
                    }));
                continue;
            }
            raw.messages.push(RawMessage {
                topic: topic.clone(),
                log_time: m.log_time,
                data: m.data.into_owned(),
            });
        }
        Ok(raw)
    }
}

/// The packets of a class channel's message, each as its JSON; `None` for a message of
/// one packet (a file recorded before messages held lists) or not JSON.
fn packets(data: &[u8]) -> Option<Vec<Vec<u8>>> {
    let Ok(Json::Object(mut j)) = serde_json::from_slice(data) else {
        return None;
    };
    let Some(Json::Array(packets)) = j.remove("packets") else {
        return None;
    };
    Some(
        packets
            .iter()
            .map(|p| serde_json::to_vec(p).unwrap_or_default())
            .collect(),
    )
}

/// The `address` of the file's `slate` metadata record.
fn address(bytes: &[u8]) -> Option<String> {
    mcap::read::LinearReader::new_with_options(bytes, Options::IgnoreEndMagic.into())
        .ok()?
        .map_while(Result::ok)
        .find_map(|r| match r {
            mcap::records::Record::Metadata(m) if m.name == super::METADATA => {
                m.metadata.get("address").cloned()
            }
            _ => None,
        })
}

/// The step of a message on `topic`, or `None` if it is not understood.
fn step(topic: &str, j: Json) -> Option<Step> {
    if let Some(_class) = topic.strip_prefix(topic::CLASS_PREFIX) {
        return packet(&j);
    }
    match topic {
        topic::CLASSES => class_def(&j).map(Step::Class),
        topic::OBJECTS => object(&j),
        _ => Some(Step::Other {
            topic: topic.to_owned(),
            json: j,
        }),
    }
}

fn packet(j: &Json) -> Option<Step> {
    let attr = j["attr"].as_str()?.to_owned();
    let value = j["values"].get(&attr)?.clone();
    let packet = packet_meta(j)?;
    Some(Step::Packet {
        object: j["object"].as_str()?.to_owned(),
        attr,
        value,
        packet,
    })
}

fn object(j: &Json) -> Option<Step> {
    let name = j["object"].as_str()?;
    if j["op"] == "delete" {
        return Some(Step::Delete(name.to_owned()));
    }
    let mut spec = NewObject::new(j["class"].as_str()?, name);
    if let Some(context) = j["context"].as_str() {
        spec = spec.context(Context::from_str(context).ok()?);
    }
    if let Some(owner) = j["owner"].as_str() {
        spec = spec.owner(Address::new(owner).ok()?);
    }
    Some(if j["op"] == "exists" {
        Step::Exists(spec)
    } else {
        Step::Create(spec)
    })
}

/// A class definition from its `/slate/classes` message.
pub fn class_def(j: &Json) -> Option<ClassDef> {
    let mut def = ClassDef::new(j["name"].as_str()?).parent(j["parent"].as_str()?);
    for a in j["attrs"].as_array()? {
        def = def.attr(attr_decl(a)?);
    }
    Some(def)
}

fn attr_decl(a: &Json) -> Option<AttrDecl> {
    let ty = value_type(a["type"].as_str()?)?;
    let mut decl = AttrDecl::new(a["name"].as_str()?, ty);
    decl.unit = a["unit"].as_str().map(str::to_owned);
    decl.bounds = a["bounds"]
        .as_array()
        .and_then(|b| Some((b.first()?.as_f64()?, b.get(1)?.as_f64()?)));
    decl.resolution = a["resolution"].as_f64();
    decl.merge = MergePolicy::from_str(a["merge"].as_str().unwrap_or("latest")).ok()?;
    decl.report = report_policy(&a["report"]);
    decl.guarded = a["guarded"].as_bool().unwrap_or(false);
    decl.default = match &a["default"] {
        Json::Null => None,
        d => Some(DefaultPacket {
            value: value_of(&d["value"], ty)?,
            accuracy: d["accuracy"].as_f64()?,
            confidence: d["confidence"].as_f64()?,
        }),
    };
    Some(decl)
}

fn report_policy(r: &Json) -> ReportPolicy {
    let secs = |key: &str| {
        r[key]
            .as_f64()
            .and_then(|s| Duration::try_from_secs_f64(s).ok())
    };
    ReportPolicy {
        min_interval: secs("min_interval"),
        heartbeat: secs("heartbeat"),
        deadband: r["deadband"].as_f64(),
        on_accuracy: r["on_accuracy"].as_bool().unwrap_or(false),
    }
}

/// A type as the class messages write it (`int`, `real`, `vec<2>`...).
fn value_type(text: &str) -> Option<ValueType> {
    Some(match text {
        "int" => ValueType::Int,
        "real" => ValueType::Real,
        "bool" => ValueType::Bool,
        "string" => ValueType::Str,
        "ref" => ValueType::Ref,
        other => ValueType::Vector(
            other
                .strip_prefix("vec<")?
                .strip_suffix('>')?
                .parse()
                .ok()?,
        ),
    })
}

/// A recorded value as the type `board` declares for `object.attr`; `None` when the
/// board does not know the attribute or the value is not of its type.
fn typed_value(board: &Board, object: &str, attr: &str, value: &Json) -> Option<Value> {
    declared_type(board, object, attr).and_then(|ty| value_of(value, ty))
}

/// The type `object.attr` is declared with on `board` (an object's class chain, or a
/// class's own, for a class-level write).
pub(crate) fn declared_type(board: &Board, object: &str, attr: &str) -> Option<ValueType> {
    let info = board.info(object)?;
    let class = if info.is_class {
        &info.name
    } else {
        &info.class
    };
    board.attr_decl(class, attr).map(|d| d.ty)
}

/// A recorded packet's accuracy, confidence, stamp (`hlc`) and source, its value left
/// `None`: the reader types the value (`value_of`) once it knows the attribute's type.
pub(crate) fn packet_meta(j: &Json) -> Option<Packet> {
    Some(Packet {
        value: Value::None,
        accuracy: j["accuracy"].as_f64()?,
        confidence: j["confidence"].as_f64()?,
        timestamp: Timestamp::from_raw(j["hlc"].as_u64()?),
        source: Address::new(j["source"].as_str()?).ok()?,
    })
}

/// A recorded JSON value as a value of type `ty` (`null`: cleared).
pub(crate) fn value_of(j: &Json, ty: ValueType) -> Option<Value> {
    Some(match (ty, j) {
        (_, Json::Null) => Value::None,
        (ValueType::Int, j) => Value::Int(j.as_i64()?),
        (ValueType::Real, j) => Value::Real(j.as_f64()?),
        (ValueType::Bool, j) => Value::Bool(j.as_bool()?),
        (ValueType::Str, j) => Value::Str(j.as_str()?.into()),
        (ValueType::Ref, j) => Value::Ref(j.as_str()?.into()),
        (ValueType::Vector(_), j) => Value::Vector(
            j.as_array()?
                .iter()
                .map(Json::as_f64)
                .collect::<Option<Vec<f64>>>()?
                .into(),
        ),
    })
}

/// A board's objects with their own packets, as JSON (`slate play`'s summary, and what
/// tests compare between a recorded board and its replay): `{OBJECT: {"class", "context",
/// "owner", "attrs": {ATTR: {"value", "accuracy", "confidence", "hlc", "source"}}}}`.
pub fn board_state(board: &Board) -> Json {
    let snap = board.snapshot();
    let mut out = serde_json::Map::new();
    for id in snap.objects() {
        let Some(info) = snap.info(id).filter(|i| !i.is_class) else {
            continue;
        };
        let attrs: serde_json::Map<String, Json> = snap
            .own_values(id)
            .into_iter()
            .map(|(attr, p, _)| {
                let j = serde_json::json!({
                    "value": super::message::value(&p.value), "accuracy": p.accuracy,
                    "confidence": p.confidence, "hlc": p.timestamp.raw(),
                    "source": p.source.as_str(),
                });
                (attr.to_string(), j)
            })
            .collect();
        let j = serde_json::json!({
            "class": &*info.class, "context": info.context.to_string(),
            "owner": info.owner.as_str(), "attrs": attrs,
        });
        out.insert(info.name.to_string(), j);
    }
    Json::Object(out)
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;

    /// A file with one message on the `Vehicle` channel per entry of `data`.
    fn file_of(path: &Path, data: &[&str]) {
        let mut w = mcap::Writer::new(std::io::BufWriter::new(
            std::fs::File::create(path).unwrap(),
        ))
        .unwrap();
        let schema = w.add_schema("Vehicle", "jsonschema", b"{}").unwrap();
        let channel = w
            .add_channel(schema, "/slate/class/Vehicle", "json", &BTreeMap::new())
            .unwrap();
        for (i, d) in data.iter().enumerate() {
            let header = mcap::records::MessageHeader {
                channel_id: channel,
                sequence: i as u32,
                log_time: 1_000 + i as u64,
                publish_time: 1_000 + i as u64,
            };
            w.write_to_known_channel(&header, d.as_bytes()).unwrap();
        }
        w.finish().unwrap();
    }

    fn packet(speed: f64) -> String {
        format!(
            r#"{{"object":"gsr","attr":"speed","values":{{"speed":{speed}}},"accuracy":0.0,"confidence":1.0,"hlc":{},"time":1.0,"source":"t/r1/nav","revision":3}}"#,
            (speed as u64 + 1) << 16
        )
    }

    #[test]
    fn a_class_message_reads_as_its_packets_and_an_older_files_one_packet_as_one() {
        let dir = slate_testing::temp_dir("replay-batches");
        let path = dir.join("mixed.mcap");
        let batch = format!(r#"{{"packets":[{},{}]}}"#, packet(2.0), packet(3.0));
        // The first message as files were recorded before session 16: one packet.
        file_of(&path, &[&packet(1.0), &batch]);
        let raw = Raw::read(&path).unwrap();
        let speeds: Vec<(u64, Option<f64>)> = raw
            .messages
            .iter()
            .map(|m| {
                let j: Json = serde_json::from_slice(&m.data).unwrap();
                (m.log_time, j["values"]["speed"].as_f64())
            })
            .collect();
        assert_eq!(
            speeds,
            [(1_000, Some(1.0)), (1_001, Some(2.0)), (1_001, Some(3.0))]
        );
        let steps = Recording::read(&path).unwrap().steps;
        let values: Vec<Option<f64>> = steps
            .iter()
            .filter_map(|t| match &t.step {
                Step::Packet { value, .. } => Some(value.as_f64()),
                _ => None,
            })
            .collect();
        assert_eq!(values, [Some(1.0), Some(2.0), Some(3.0)]);
    }
}
