//! `Packet` and `Ref`, and the conversion of values between Python and slate.
//!
//! Python to slate: `None`, `bool`, `int` (64-bit), `float`, `str`, `slate.Ref`, and a
//! `list` or `tuple` of numbers (a vector of reals). slate to Python: the same, vectors as
//! tuples of floats. The core never converts types; the binding converts one thing only:
//! an `int` written where the attribute is declared `real` becomes a float
//! ([`coerce`], [`retry_as_real`]), because Python code writes `2` for `2.0` all the time.

use std::sync::Arc;
use std::time::Duration;

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyFloat, PyInt, PyList, PyString, PyTuple};
use slate_model::{
    Address, Board, MAX_TIME, Packet, Timestamp, Update, Value, ValueError, ValueType, WriteError,
};

use crate::errors::{self, Kind};

/// A token naming another object: the value of a `ref` attribute.
///
/// References are names, not pointers: they mean the same on every board, and may name an
/// object that does not exist (yet, or any more).
#[pyclass(module = "slate", name = "Ref", frozen, eq, hash)]
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub(crate) struct Reference {
    /// The name of the object referred to.
    #[pyo3(get)]
    name: String,
}

#[pymethods]
impl Reference {
    #[new]
    fn new(name: String) -> Self {
        Reference { name }
    }

    fn __repr__(&self) -> String {
        format!("Ref({})", quote(&self.name))
    }

    fn __str__(&self) -> &str {
        &self.name
    }
}

/// An attribute packet: `value, accuracy, confidence, timestamp, source`.
///
/// Boards return packets from `read`; an on-read active function may return one to
/// replace what the read returns. `timestamp` is in seconds since the Unix epoch, to the
/// microsecond; `stamp` is the full hybrid-clock stamp, an int that orders every write a
/// board makes, even several at one instant (see `stamp`).
#[pyclass(module = "slate", name = "Packet", frozen)]
#[derive(Clone, Debug)]
pub(crate) struct PyPacket {
    pub(crate) inner: Packet,
}

#[pymethods]
impl PyPacket {
    /// A packet. Returned by an on-read function, a packet without `timestamp` or `source`
    /// keeps those of the packet being read.
    #[new]
    #[pyo3(signature = (value, accuracy=0.0, confidence=1.0, timestamp=None, source=None))]
    fn new(
        value: &Bound<'_, PyAny>,
        accuracy: f64,
        confidence: f64,
        timestamp: Option<f64>,
        source: Option<&str>,
    ) -> PyResult<Self> {
        let py = value.py();
        check_quality(py, accuracy, confidence)?;
        Ok(PyPacket {
            inner: Packet {
                value: to_value(value)?,
                accuracy,
                confidence,
                timestamp: timestamp.map_or(Ok(Timestamp::ZERO), |t| to_timestamp(py, t))?,
                source: source.map_or(Ok(Address::unknown()), |s| to_address(py, s))?,
            },
        })
    }

    /// The value: `None`, `int`, `float`, `bool`, `str`, `Ref` or a tuple of floats.
    #[getter]
    fn value<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        from_value(py, &self.inner.value)
    }

    /// Potential deviation of the value, in the attribute's unit.
    #[getter]
    fn accuracy(&self) -> f64 {
        self.inner.accuracy
    }

    /// Probability in [0, 1] that the value is right.
    #[getter]
    fn confidence(&self) -> f64 {
        self.inner.confidence
    }

    /// When it was written, in seconds since the Unix epoch (0.0: never written).
    #[getter]
    fn timestamp(&self) -> f64 {
        self.inner.timestamp.as_secs_f64()
    }

    /// The full hybrid logical clock stamp, an int: microseconds since the Unix epoch in
    /// the high bits, a counter in the low 12 bits (`stamp >> 12` is the microseconds).
    /// Writes made at one instant share `timestamp` but not `stamp`: a later write (and a
    /// write made after receiving a packet) always has a greater stamp. `latest` keeps the
    /// packet with the greatest `(stamp, source)`. 0: never written.
    #[getter]
    fn stamp(&self) -> u64 {
        self.inner.timestamp.raw()
    }

    /// The module that wrote it (`team/robot/module`).
    #[getter]
    fn source(&self) -> String {
        self.inner.source.to_string()
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<PyPacket>()
            .is_ok_and(|o| o.get().inner == self.inner)
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Packet(value={}, accuracy={:?}, confidence={:?}, timestamp={:?}, source={})",
            repr_value(py, &self.inner.value),
            self.inner.accuracy,
            self.inner.confidence,
            self.inner.timestamp.as_secs_f64(),
            quote(self.inner.source.as_str())
        )
    }
}

/// `text` quoted as Python's `repr` quotes a `str`.
pub(crate) fn quote(text: &str) -> String {
    let q = if text.contains('\'') && !text.contains('"') {
        '"'
    } else {
        '\''
    };
    let mut out = String::with_capacity(text.len() + 2);
    out.push(q);
    for c in text.chars() {
        match c {
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if c == q => {
                out.push('\\');
                out.push(c);
            }
            c => out.push(c),
        }
    }
    out.push(q);
    out
}

/// An optional text as Python's `repr` shows it.
pub(crate) fn quote_opt(text: Option<&str>) -> String {
    text.map_or_else(|| "None".to_owned(), quote)
}

/// A list of texts as Python's `repr` shows it.
pub(crate) fn quote_list(texts: &[String]) -> String {
    let items: Vec<String> = texts.iter().map(|t| quote(t)).collect();
    format!("[{}]", items.join(", "))
}

/// A value as Python's `repr` shows it.
pub(crate) fn repr_value(py: Python<'_>, value: &Value) -> String {
    from_value(py, value)
        .and_then(|v| v.repr().map(|r| r.to_string()))
        .unwrap_or_else(|_| value.to_string())
}

/// Converts a Python object into a slate value.
pub(crate) fn to_value(obj: &Bound<'_, PyAny>) -> PyResult<Value> {
    if let Ok(f) = obj.cast::<PyFloat>() {
        return Ok(Value::Real(f.value()));
    }
    if let Ok(b) = obj.cast::<PyBool>() {
        return Ok(Value::Bool(b.is_true()));
    }
    if obj.is_instance_of::<PyInt>() {
        return obj.extract::<i64>().map(Value::Int).map_err(|_| {
            errors::new(obj.py(), Kind::ValueType, "integer does not fit in 64 bits")
        });
    }
    if let Ok(s) = obj.cast::<PyString>() {
        return Ok(Value::Str(Arc::from(&*s.to_cow()?)));
    }
    if let Ok(r) = obj.cast::<Reference>() {
        return Ok(Value::Ref(Arc::from(r.get().name.as_str())));
    }
    if obj.is_none() {
        return Ok(Value::None);
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        return to_vector(obj);
    }
    Err(errors::new(
        obj.py(),
        Kind::ValueType,
        format!(
            "cannot store a {} in a slate attribute: use int, float, bool, str, slate.Ref, \
             a list of numbers (a vector) or None",
            type_name(obj)
        ),
    ))
}

fn to_vector(obj: &Bound<'_, PyAny>) -> PyResult<Value> {
    let mut out = Vec::with_capacity(obj.len()?);
    for item in obj.try_iter()? {
        let item = item?;
        if item.is_instance_of::<PyBool>()
            || !(item.is_instance_of::<PyFloat>() || item.is_instance_of::<PyInt>())
        {
            return Err(errors::new(
                obj.py(),
                Kind::ValueType,
                format!(
                    "a vector holds numbers only, not a {}: write a list of floats",
                    type_name(&item)
                ),
            ));
        }
        out.push(item.extract::<f64>()?);
    }
    Ok(Value::Vector(Arc::from(out)))
}

fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type()
        .name()
        .map_or_else(|_| "value".to_owned(), |n| n.to_string())
}

/// Converts a slate value into a Python object.
pub(crate) fn from_value<'py>(py: Python<'py>, value: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match value {
        Value::Real(x) => PyFloat::new(py, *x).into_any(),
        Value::Int(i) => i.into_pyobject(py)?.into_any(),
        Value::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        Value::Str(s) => PyString::new(py, s).into_any(),
        Value::Ref(r) => Bound::new(py, Reference::new(r.to_string()))?.into_any(),
        Value::Vector(v) => PyTuple::new(py, v.iter().copied())?.into_any(),
        _ => py.None().into_bound(py),
    })
}

/// An update from the keyword arguments of `write`.
pub(crate) fn to_update(
    value: &Bound<'_, PyAny>,
    accuracy: Option<f64>,
    confidence: Option<f64>,
    timestamp: Option<f64>,
    source: Option<&str>,
) -> PyResult<Update> {
    let py = value.py();
    Ok(Update {
        value: to_value(value)?,
        accuracy,
        confidence,
        timestamp: timestamp.map(|t| to_timestamp(py, t)).transpose()?,
        source: source.map(|s| to_address(py, s)).transpose()?,
    })
}

/// A timestamp given in seconds: finite, not negative, and no later than a stamp holds
/// ([`MAX_TIME`], in 2112), never saturated.
pub(crate) fn to_timestamp(py: Python<'_>, seconds: f64) -> PyResult<Timestamp> {
    Duration::try_from_secs_f64(seconds)
        .ok()
        .filter(|d| *d <= MAX_TIME)
        .map(Timestamp::from_duration)
        .ok_or_else(|| {
            errors::new(
                py,
                Kind::InvalidPacket,
                format!(
                    "timestamp {seconds} must be seconds since the Unix epoch, from 0 to {:.0} \
                     (the year 2112, the last a stamp holds)",
                    MAX_TIME.as_secs_f64()
                ),
            )
        })
}

pub(crate) fn to_address(py: Python<'_>, text: &str) -> PyResult<Address> {
    Address::new(text).map_err(|e| errors::new(py, Kind::Address, e.to_string()))
}

/// The checks the board makes on accuracy and confidence, for packets made in Python.
fn check_quality(py: Python<'_>, accuracy: f64, confidence: f64) -> PyResult<()> {
    if !(accuracy.is_finite() && accuracy >= 0.0) {
        return Err(errors::invalid(py, &ValueError::Accuracy(accuracy), None));
    }
    if !(0.0..=1.0).contains(&confidence) {
        return Err(errors::invalid(
            py,
            &ValueError::Confidence(confidence),
            None,
        ));
    }
    Ok(())
}

/// `value` made to fit a declared type: an int becomes a real where a real is declared.
pub(crate) fn coerce(value: Value, declared: Option<ValueType>) -> Value {
    match (value, declared) {
        (Value::Int(i), Some(ValueType::Real)) => Value::Real(i as f64),
        (v, _) => v,
    }
}

/// Runs a write; if it was refused only because an int went to a `real` attribute, runs it
/// again with the int as a real. The refused write stored nothing, so this is exact, and
/// it costs nothing unless an int is written.
pub(crate) fn retry_as_real(
    update: Update,
    mut write: impl FnMut(Update) -> Result<u64, WriteError>,
) -> Result<u64, WriteError> {
    let Value::Int(i) = update.value else {
        return write(update);
    };
    let again = update.clone();
    match write(update) {
        Err(WriteError::Invalid {
            source:
                ValueError::WrongType {
                    expected: ValueType::Real,
                    ..
                },
            ..
        }) => write(Update {
            value: Value::Real(i as f64),
            ..again
        }),
        other => other,
    }
}

/// A declared type from its name in the slate language: `int`, `real`, `bool`, `string`,
/// `ref`, `vec<N>`.
pub(crate) fn parse_type(py: Python<'_>, name: &str) -> PyResult<ValueType> {
    let vector = name
        .strip_prefix("vec<")
        .and_then(|r| r.strip_suffix('>'))
        .map(|n| n.trim().parse::<u16>());
    Ok(match (name, vector) {
        ("int", _) => ValueType::Int,
        ("real", _) => ValueType::Real,
        ("bool", _) => ValueType::Bool,
        ("string", _) => ValueType::Str,
        ("ref", _) => ValueType::Ref,
        (_, Some(Ok(n))) if n >= 1 => ValueType::Vector(n),
        _ => {
            return Err(errors::new(
                py,
                Kind::Define,
                format!(
                    "unknown type {name:?}: use int, real, bool, string, ref or vec<N> (N >= 1)"
                ),
            ));
        }
    })
}

/// The declared type of `object.attr` (an object's or a class's attribute), if known.
pub(crate) fn declared_type(board: &Board, object: &str, attr: &str) -> Option<ValueType> {
    let info = board.info(object)?;
    let class = if info.is_class { info.name } else { info.class };
    class_attr_type(board, &class, attr)
}

/// The declared type of `attr` in `class` or its ancestors (the board's own flattened
/// declarations: one lookup, no walk of the class chain here).
pub(crate) fn class_attr_type(board: &Board, class: &str, attr: &str) -> Option<ValueType> {
    board.attr_decl(class, attr).map(|d| d.ty)
}
