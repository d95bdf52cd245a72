//! Python exceptions mirroring the core's error enums.
//!
//! Exceptions are grouped by what is wrong, not by which call raised it: a missing object is
//! `UnknownObjectError` from `read`, `write`, `delete` or `watch` alike. Each one also derives
//! from the builtin exception a Python programmer would try first (`TypeError` for a value
//! of the wrong type, `ValueError` for a bad packet, `LookupError` for a missing name).
//!
//! ```text
//! SlateError
//! ├── UnknownObjectError (LookupError)       no object or class of that name
//! │   └── UnknownClassError                  no class of that name
//! ├── UnknownAttributeError (LookupError)    the class declares no such attribute
//! ├── ReadError                              a read failed otherwise
//! ├── WriteError                             a write was refused (also: not the owner,
//! │                                            older than the stored packet, stamp ahead)
//! │   ├── ValueTypeError (TypeError)         the value's type is not the declared one
//! │   └── InvalidPacketError (ValueError)    not finite, or a bad accuracy/confidence/bound
//! │       ├── AccuracyError                  accuracy negative or not finite
//! │       ├── ConfidenceError                confidence outside [0, 1]
//! │       └── OutOfBoundsError               outside the declared bounds
//! ├── ChainError                             a chain of active functions was cut
//! ├── DefineError, CreateError, DeleteError  the other board operations
//! ├── LoadError                              a .slate source did not load (diagnostics)
//! ├── ClockError                             the clock cannot be moved like that
//! ├── AddressError (ValueError)              not a team/robot/module address
//! ├── NodeError                              a node did not start (network, config, board)
//! └── PlanError                              a plan could not be sent or cancelled
//! ```

use pyo3::IntoPyObjectExt;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyList, PyTuple, PyType};
use slate_model::{
    BatchError, ClockError, CreateError, DefineError, DeleteError, LookupError, ReadError,
    ValueError, WriteError,
};
use slate_plans::{Diagnostic, LoadError, Severity, Stage};

use crate::packet::quote;

/// The exception classes, in the order of [`SPECS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    Slate,
    UnknownObject,
    UnknownClass,
    UnknownAttribute,
    Read,
    Write,
    ValueType,
    InvalidPacket,
    Accuracy,
    Confidence,
    OutOfBounds,
    Chain,
    Define,
    Create,
    Delete,
    Load,
    Clock,
    Address,
    Node,
    Plan,
}

/// A base of an exception class: one of ours, or a builtin.
enum Base {
    Ours(Kind),
    Builtin(&'static str),
}

/// Name, bases and docstring of each class, parents before children.
const SPECS: &[(Kind, &str, &[Base], &str)] = &[
    (
        Kind::Slate,
        "SlateError",
        &[Base::Builtin("Exception")],
        "Base class of every error slate raises.",
    ),
    (
        Kind::UnknownObject,
        "UnknownObjectError",
        &[Base::Ours(Kind::Slate), Base::Builtin("LookupError")],
        "No object or class of that name exists on the board.",
    ),
    (
        Kind::UnknownClass,
        "UnknownClassError",
        &[Base::Ours(Kind::UnknownObject)],
        "No class of that name exists on the board.",
    ),
    (
        Kind::UnknownAttribute,
        "UnknownAttributeError",
        &[Base::Ours(Kind::Slate), Base::Builtin("LookupError")],
        "The object's class (and its ancestors) declare no attribute of that name.",
    ),
    (
        Kind::Read,
        "ReadError",
        &[Base::Ours(Kind::Slate)],
        "A read failed for another reason than a missing object or attribute.",
    ),
    (
        Kind::Write,
        "WriteError",
        &[Base::Ours(Kind::Slate)],
        "A write was refused; nothing was stored.",
    ),
    (
        Kind::ValueType,
        "ValueTypeError",
        &[Base::Ours(Kind::Write), Base::Builtin("TypeError")],
        "The value's type is not the attribute's declared type (or not a slate value at all).",
    ),
    (
        Kind::InvalidPacket,
        "InvalidPacketError",
        &[Base::Ours(Kind::Write), Base::Builtin("ValueError")],
        "The value or packet does not fit: not finite, bad accuracy, confidence or bounds.",
    ),
    (
        Kind::Accuracy,
        "AccuracyError",
        &[Base::Ours(Kind::InvalidPacket)],
        "Accuracy is negative or not finite.",
    ),
    (
        Kind::Confidence,
        "ConfidenceError",
        &[Base::Ours(Kind::InvalidPacket)],
        "Confidence is outside [0, 1].",
    ),
    (
        Kind::OutOfBounds,
        "OutOfBoundsError",
        &[Base::Ours(Kind::InvalidPacket)],
        "The value lies outside the attribute's declared bounds.",
    ),
    (
        Kind::Chain,
        "ChainError",
        &[Base::Ours(Kind::Slate)],
        "A chain of active functions was cut: too deep, or a cycle.",
    ),
    (
        Kind::Define,
        "DefineError",
        &[Base::Ours(Kind::Slate)],
        "A class definition was refused (bad name, conflict, unknown parent, bad declaration).",
    ),
    (
        Kind::Create,
        "CreateError",
        &[Base::Ours(Kind::Slate)],
        "An object could not be created (bad name, or the name exists).",
    ),
    (
        Kind::Delete,
        "DeleteError",
        &[Base::Ours(Kind::Slate)],
        "An object or class could not be deleted.",
    ),
    (
        Kind::Load,
        "LoadError",
        &[Base::Ours(Kind::Slate)],
        "A .slate source did not load; nothing of it was applied. `diagnostics` lists every \
         problem; `file`, `line` and `column` locate the first.",
    ),
    (
        Kind::Clock,
        "ClockError",
        &[Base::Ours(Kind::Slate)],
        "The clock cannot be moved like that (a system clock, backwards, or past 2112).",
    ),
    (
        Kind::Address,
        "AddressError",
        &[Base::Ours(Kind::Slate), Base::Builtin("ValueError")],
        "Not a module address of the form team/robot/module.",
    ),
    (
        Kind::Node,
        "NodeError",
        &[Base::Ours(Kind::Slate)],
        "A node did not start: the network, its board or its sources refused.",
    ),
    (
        Kind::Plan,
        "PlanError",
        &[Base::Ours(Kind::Slate)],
        "A plan could not be sent or cancelled: not one plan, or the circuit refused it.",
    ),
];

static CLASSES: PyOnceLock<Vec<Py<PyType>>> = PyOnceLock::new();

fn classes(py: Python<'_>) -> &Vec<Py<PyType>> {
    // `register` fills the cell when the module is imported, before any error is raised.
    CLASSES.get_or_init(py, || make_classes(py).unwrap_or_default())
}

fn make_classes(py: Python<'_>) -> PyResult<Vec<Py<PyType>>> {
    let builtins = py.import("builtins")?;
    let type_ = builtins.getattr("type")?;
    let mut made: Vec<Py<PyType>> = Vec::with_capacity(SPECS.len());
    for (kind, name, bases, doc) in SPECS {
        debug_assert_eq!(*kind as usize, made.len());
        let bases = bases
            .iter()
            .map(|b| match b {
                Base::Ours(k) => Ok(made[*k as usize].bind(py).clone().into_any()),
                Base::Builtin(n) => builtins.getattr(*n),
            })
            .collect::<PyResult<Vec<_>>>()?;
        let dict = PyDict::new(py);
        dict.set_item("__doc__", *doc)?;
        dict.set_item("__module__", "slate")?;
        let class = type_.call1((*name, PyTuple::new(py, bases)?, dict))?;
        made.push(class.cast_into::<PyType>()?.unbind());
    }
    Ok(made)
}

/// Adds the exception classes to the module.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    let made = make_classes(py)?;
    let made = CLASSES.get_or_init(py, || made);
    for ((_, name, ..), class) in SPECS.iter().zip(made) {
        m.add(*name, class.bind(py))?;
    }
    Ok(())
}

/// An exception of class `kind` with `message`.
pub(crate) fn new(py: Python<'_>, kind: Kind, message: impl Into<String>) -> PyErr {
    match classes(py).get(kind as usize) {
        Some(class) => PyErr::from_type(class.bind(py).clone(), message.into()),
        None => pyo3::exceptions::PyRuntimeError::new_err(message.into()),
    }
}

/// An exception with attributes set on it.
fn with_attrs(
    py: Python<'_>,
    kind: Kind,
    message: String,
    attrs: &[(&str, Bound<'_, PyAny>)],
) -> PyErr {
    let Some(class) = classes(py).get(kind as usize) else {
        return pyo3::exceptions::PyRuntimeError::new_err(message);
    };
    let made = class.bind(py).call1((message,)).and_then(|e| {
        for (name, value) in attrs {
            e.setattr(*name, value)?;
        }
        Ok(e)
    });
    match made {
        Ok(e) => PyErr::from_value(e),
        Err(e) => e,
    }
}

/// The class for a value or packet that does not fit.
fn invalid_kind(e: &ValueError) -> Kind {
    match e {
        ValueError::WrongType { .. } => Kind::ValueType,
        ValueError::Accuracy(_) => Kind::Accuracy,
        ValueError::Confidence(_) => Kind::Confidence,
        ValueError::OutOfBounds { .. } => Kind::OutOfBounds,
        _ => Kind::InvalidPacket,
    }
}

/// A value error, with the message the board gives (prefixed by `object.attr` if known).
pub(crate) fn invalid(py: Python<'_>, e: &ValueError, message: Option<String>) -> PyErr {
    new(
        py,
        invalid_kind(e),
        message.unwrap_or_else(|| e.to_string()),
    )
}

fn write_kind(e: &WriteError) -> Kind {
    match e {
        WriteError::UnknownObject(_) => Kind::UnknownObject,
        WriteError::UnknownAttribute { .. } => Kind::UnknownAttribute,
        WriteError::Invalid { source, .. } => invalid_kind(source),
        WriteError::Chain(_) => Kind::Chain,
        // Refused because every other board would refuse the packet (a non-owner's write
        // to an `owned` attribute, a stamp older than the stored packet or too far ahead),
        // a guarded attribute, and what later versions add.
        _ => Kind::Write,
    }
}

pub(crate) fn write(py: Python<'_>, e: WriteError) -> PyErr {
    new(py, write_kind(&e), e.to_string())
}

fn read_kind(e: &ReadError) -> Kind {
    match e {
        ReadError::UnknownObject(_) => Kind::UnknownObject,
        ReadError::UnknownAttribute { .. } => Kind::UnknownAttribute,
        ReadError::Chain(_) => Kind::Chain,
        _ => Kind::Read,
    }
}

pub(crate) fn read(py: Python<'_>, e: ReadError) -> PyErr {
    new(py, read_kind(&e), e.to_string())
}

fn create_kind(e: &CreateError) -> Kind {
    match e {
        CreateError::UnknownClass(_) => Kind::UnknownClass,
        _ => Kind::Create,
    }
}

pub(crate) fn create(py: Python<'_>, e: CreateError) -> PyErr {
    new(py, create_kind(&e), e.to_string())
}

fn delete_kind(e: &DeleteError) -> Kind {
    match e {
        DeleteError::UnknownObject(_) => Kind::UnknownObject,
        _ => Kind::Delete,
    }
}

pub(crate) fn delete(py: Python<'_>, e: DeleteError) -> PyErr {
    new(py, delete_kind(&e), e.to_string())
}

pub(crate) fn lookup(py: Python<'_>, e: LookupError) -> PyErr {
    let kind = match &e {
        LookupError::UnknownObject(_) => Kind::UnknownObject,
        LookupError::UnknownClass(_) => Kind::UnknownClass,
        LookupError::UnknownAttribute { .. } => Kind::UnknownAttribute,
        _ => Kind::Slate,
    };
    new(py, kind, e.to_string())
}

pub(crate) fn define(py: Python<'_>, e: DefineError) -> PyErr {
    new(py, Kind::Define, e.to_string())
}

pub(crate) fn clock(py: Python<'_>, e: ClockError) -> PyErr {
    new(py, Kind::Clock, e.to_string())
}

/// A failed batch: the exception of the operation that failed, with its `index`.
pub(crate) fn batch(py: Python<'_>, e: BatchError) -> PyErr {
    let (kind, index) = match &e {
        BatchError::Write { index, source } => (write_kind(source), Some(*index)),
        BatchError::Create { index, source } => (create_kind(source), Some(*index)),
        BatchError::Delete { index, source } => (delete_kind(source), Some(*index)),
        _ => (Kind::Write, None),
    };
    let index = index.map_or_else(|| py.None().into_bound(py), |i| bound(py, i));
    with_attrs(py, kind, e.to_string(), &[("index", index)])
}

fn bound<'py, T: IntoPyObject<'py>>(py: Python<'py>, v: T) -> Bound<'py, PyAny> {
    v.into_bound_py_any(py)
        .unwrap_or_else(|_| py.None().into_bound(py))
}

/// One problem in a .slate source, with its position.
#[pyclass(module = "slate", name = "Diagnostic", frozen)]
#[derive(Clone, Debug)]
pub(crate) struct PyDiagnostic {
    /// The file name (or `"<source>"` for text).
    #[pyo3(get)]
    file: String,
    /// 1-based line.
    #[pyo3(get)]
    line: u32,
    /// 1-based column.
    #[pyo3(get)]
    column: u32,
    /// What is wrong.
    #[pyo3(get)]
    message: String,
    /// `"error"` or `"warning"`.
    #[pyo3(get)]
    severity: &'static str,
    /// Which stage found it: `"lex"`, `"parse"` or `"check"`.
    #[pyo3(get)]
    stage: &'static str,
}

#[pymethods]
impl PyDiagnostic {
    fn __repr__(&self) -> String {
        format!(
            "Diagnostic({}, line={}, column={}, severity={}, message={})",
            quote(&self.file),
            self.line,
            self.column,
            quote(self.severity),
            quote(&self.message)
        )
    }

    fn __str__(&self) -> String {
        format!(
            "{}:{}:{}: {}: {}",
            self.file, self.line, self.column, self.severity, self.message
        )
    }
}

impl PyDiagnostic {
    fn new(file: &str, d: &Diagnostic) -> Self {
        PyDiagnostic {
            file: file.to_owned(),
            line: d.span.line,
            column: d.span.col,
            message: d.message.clone(),
            severity: match d.severity {
                Severity::Warning => "warning",
                _ => "error",
            },
            stage: match d.stage {
                Stage::Lex => "lex",
                Stage::Parse => "parse",
                _ => "check",
            },
        }
    }
}

/// A failed load: `LoadError` with the rendered diagnostics as its message, and
/// `diagnostics`, `file`, `line`, `column` (of the first error) as attributes.
pub(crate) fn load(py: Python<'_>, file: &str, e: LoadError) -> PyErr {
    let diags: Vec<PyDiagnostic> = e
        .diagnostics
        .iter()
        .map(|d| PyDiagnostic::new(file, d))
        .collect();
    let first = diags
        .iter()
        .find(|d| d.severity == "error")
        .or(diags.first());
    let (line, column) = first.map_or((0, 0), |d| (d.line, d.column));
    let list = diags
        .into_iter()
        .map(|d| Bound::new(py, d).map(Bound::into_any))
        .collect::<PyResult<Vec<_>>>()
        .and_then(|v| PyList::new(py, v));
    let list = match list {
        Ok(l) => l.into_any(),
        Err(e) => return e,
    };
    with_attrs(
        py,
        Kind::Load,
        e.rendered,
        &[
            ("diagnostics", list),
            ("file", bound(py, file)),
            ("line", bound(py, line)),
            ("column", bound(py, column)),
        ],
    )
}
