//! `Recording`: an MCAP recording of a board (docs/recording.md) read back, iterated as
//! `RecordedPacket`s (every packet written) and `RecordedEvent`s (everything else:
//! objects, classes, plan events, circuit steps, liveliness, board events, counters).

use std::path::PathBuf;
use std::sync::Arc;

use parking_lot::Mutex;
use pyo3::prelude::*;
use pyo3::types::PyString;
use serde_json::Value as Json;
use slate_node::record::{Raw, RawMessage, ReplayError, topic};

use crate::packet::quote;

/// A recording read into memory: `Recording("run.mcap")`. A file cut off by a crash is
/// read up to its last complete chunk (`complete` is then false).
#[pyclass(module = "slate", name = "Recording", frozen)]
pub(crate) struct PyRecording {
    /// The file.
    #[pyo3(get)]
    path: String,
    /// The recording board's address, if the file says it.
    #[pyo3(get)]
    address: Option<String>,
    /// False when the file was cut off (no footer: a crash).
    #[pyo3(get)]
    complete: bool,
    messages: Arc<Vec<RawMessage>>,
}

/// Which messages an iterator yields.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Only {
    All,
    Packets,
    Events,
}

#[pymethods]
impl PyRecording {
    #[new]
    fn new(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let raw = py.detach(|| Raw::read(&path)).map_err(|e| match e {
            ReplayError::Read { .. } => pyo3::exceptions::PyOSError::new_err(e.to_string()),
            _ => pyo3::exceptions::PyValueError::new_err(e.to_string()),
        })?;
        Ok(PyRecording {
            path: path.display().to_string(),
            address: raw.address,
            complete: raw.complete,
            messages: Arc::new(raw.messages),
        })
    }

    /// Every packet and event, in the file's order (a class channel's message yields
    /// each packet it holds).
    fn __iter__(&self) -> RecordingIter {
        self.iter(Only::All)
    }

    /// The packets only, in the file's order.
    fn packets(&self) -> RecordingIter {
        self.iter(Only::Packets)
    }

    /// Everything but the packets, in the file's order.
    fn events(&self) -> RecordingIter {
        self.iter(Only::Events)
    }

    /// The number of packets and events.
    fn __len__(&self) -> usize {
        self.messages.len()
    }

    fn __repr__(&self) -> String {
        let cut = if self.complete { "" } else { ", cut off" };
        format!(
            "Recording({}, {} messages{cut})",
            quote(&self.path),
            self.messages.len()
        )
    }
}

impl PyRecording {
    fn iter(&self, only: Only) -> RecordingIter {
        RecordingIter {
            messages: self.messages.clone(),
            next: Mutex::new(0),
            only,
        }
    }
}

/// An iterator over a recording's messages.
#[pyclass(module = "slate", name = "RecordingIter", frozen)]
pub(crate) struct RecordingIter {
    messages: Arc<Vec<RawMessage>>,
    next: Mutex<usize>,
    only: Only,
}

#[pymethods]
impl RecordingIter {
    fn __iter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    fn __next__(&self, py: Python<'_>) -> PyResult<Option<Py<PyAny>>> {
        let mut next = self.next.lock();
        while let Some(m) = self.messages.get(*next) {
            *next += 1;
            let is_packet = m.topic.starts_with(topic::CLASS_PREFIX);
            let wanted = match self.only {
                Only::All => true,
                Only::Packets => is_packet,
                Only::Events => !is_packet,
            };
            if !wanted {
                continue;
            }
            let json: Json = serde_json::from_slice(&m.data).unwrap_or(Json::Null);
            let time = m.log_time as f64 / 1e9;
            if is_packet && let Some(p) = RecordedPacket::of(py, time, &json)? {
                return Ok(Some(Py::new(py, p)?.into_any()));
            }
            let event = RecordedEvent::of(py, time, &m.topic, &json)?;
            return Ok(Some(Py::new(py, event)?.into_any()));
        }
        Ok(None)
    }
}

/// JSON as the Python value `json.loads` makes of it.
fn to_python(py: Python<'_>, j: &Json) -> PyResult<Py<PyAny>> {
    let json = py.import("json")?;
    let text = PyString::new(py, &j.to_string());
    Ok(json.call_method1("loads", (text,))?.unbind())
}

/// A packet as recorded: written to `object.attr`, with its value, quality, stamp and
/// source.
#[pyclass(module = "slate", name = "RecordedPacket", frozen, get_all)]
pub(crate) struct RecordedPacket {
    /// When the recording board handled the message that holds it (seconds since the
    /// Unix epoch).
    time: f64,
    /// The object (or class, for a class-level write).
    object: String,
    /// The attribute.
    attr: String,
    /// The value as JSON makes it: int, float, bool, str (a reference is its object's
    /// name), list of floats, or None (cleared).
    value: Py<PyAny>,
    accuracy: f64,
    confidence: f64,
    /// The packet's stamp, seconds since the Unix epoch.
    timestamp: f64,
    /// The full hybrid-clock stamp (as `Packet.stamp`).
    stamp: u64,
    /// The module that wrote it.
    source: String,
    /// The recording board's revision of the change.
    revision: u64,
}

impl RecordedPacket {
    /// The packet of a class channel's message; `None` if the message is not one.
    fn of(py: Python<'_>, time: f64, j: &Json) -> PyResult<Option<Self>> {
        let (Some(object), Some(attr)) = (j["object"].as_str(), j["attr"].as_str()) else {
            return Ok(None);
        };
        let (Some(accuracy), Some(confidence), Some(stamp)) = (
            j["accuracy"].as_f64(),
            j["confidence"].as_f64(),
            j["hlc"].as_u64(),
        ) else {
            return Ok(None);
        };
        Ok(Some(RecordedPacket {
            time,
            object: object.to_owned(),
            attr: attr.to_owned(),
            value: to_python(py, &j["values"][attr])?,
            accuracy,
            confidence,
            timestamp: j["time"].as_f64().unwrap_or(0.0),
            stamp,
            source: j["source"].as_str().unwrap_or_default().to_owned(),
            revision: j["revision"].as_u64().unwrap_or(0),
        }))
    }
}

#[pymethods]
impl RecordedPacket {
    fn __repr__(&self, py: Python<'_>) -> String {
        let value = self
            .value
            .bind(py)
            .repr()
            .map_or_else(|_| "?".to_owned(), |r| r.to_string());
        format!(
            "RecordedPacket({}.{} = {value}, source={})",
            self.object,
            self.attr,
            quote(&self.source)
        )
    }
}

/// Any other message: an object created or deleted, a class definition, a plan event, a
/// circuit step, a liveliness change, a board event, the counters.
#[pyclass(module = "slate", name = "RecordedEvent", frozen, get_all)]
pub(crate) struct RecordedEvent {
    /// When the recording board handled it (seconds since the Unix epoch).
    time: f64,
    /// Its channel (`/slate/objects`, `/slate/plans`...).
    topic: String,
    /// The channel's last name: `objects`, `classes`, `plans`, `circuits`, `liveliness`,
    /// `events`, `links` or `recorder`.
    kind: String,
    /// The message's JSON as a dict (docs/recording.md lists its fields).
    data: Py<PyAny>,
}

impl RecordedEvent {
    fn of(py: Python<'_>, time: f64, topic: &str, j: &Json) -> PyResult<Self> {
        Ok(RecordedEvent {
            time,
            topic: topic.to_owned(),
            kind: topic.rsplit('/').next().unwrap_or(topic).to_owned(),
            data: to_python(py, j)?,
        })
    }
}

#[pymethods]
impl RecordedEvent {
    fn __repr__(&self, py: Python<'_>) -> String {
        let data = self
            .data
            .bind(py)
            .repr()
            .map_or_else(|_| "?".to_owned(), |r| r.to_string());
        format!("RecordedEvent({}, {data})", quote(&self.kind))
    }
}
