//! Plans: loading `.slate` sources through the plan engine, plan status, and the reports
//! and plans the engine sends out.

use std::sync::{Arc, Weak};
use std::time::Duration;

use crossbeam_channel::Receiver;
use parking_lot::Mutex;
use pyo3::exceptions::{PyOSError, PyTypeError};
use pyo3::prelude::*;
use pyo3::types::PyString;
use slate_model::Board;
use slate_plans::{Engine, Outgoing, PlanStatus};

use crate::errors::{self, Kind};
use crate::packet::{PyPacket, quote, quote_list, quote_opt, repr_value};
use crate::stream;

/// A source to load: its name for diagnostics, and its text.
pub(crate) struct Source {
    pub name: String,
    pub text: String,
}

/// What `Board.load` was given: a path (`os.PathLike`, or a `str` with no newline, `{` or
/// `;`), or source text (any other `str`).
pub(crate) fn source(obj: &Bound<'_, PyAny>, name: Option<String>) -> PyResult<Source> {
    let py = obj.py();
    if let Ok(s) = obj.cast::<PyString>() {
        // `to_cow`: the abi3 build (CPython >= 3.9) has no borrowed `to_str` before 3.10.
        let s = s.to_cow()?;
        if s.contains(['\n', '{', ';']) {
            return Ok(Source {
                name: name.unwrap_or_else(|| "<source>".to_owned()),
                text: s.into_owned(),
            });
        }
    }
    let fspath = py.import("os")?.getattr("fspath")?;
    let path: String = fspath
        .call1((obj,))
        .and_then(|p| p.extract())
        .map_err(|_| {
            PyTypeError::new_err(
                "load() takes slate source text (a str), or a path (a str or os.PathLike)",
            )
        })?;
    let text =
        py.detach(|| std::fs::read_to_string(&path))
            .map_err(|e| match e.raw_os_error() {
                Some(code) => PyOSError::new_err((code, e.to_string(), path.clone())),
                None => PyOSError::new_err(format!("{path}: {e}")),
            })?;
    Ok(Source {
        name: name.unwrap_or(path),
        text,
    })
}

/// Loads a source into the engine's board, with the GIL released (loading installs plans,
/// which may act at once and run active functions).
pub(crate) fn load(py: Python<'_>, engine: &Engine, src: Source) -> PyResult<Loaded> {
    let Source { name, text } = src;
    match py.detach(|| engine.load(&name, &text)) {
        Ok(l) => Ok(Loaded {
            classes: l.classes,
            objects: l.objects,
            rules: l.rules,
            plans: l.plans,
        }),
        Err(e) => Err(errors::load(py, &name, e)),
    }
}

/// What a `load` added to the board.
#[pyclass(module = "slate", name = "Loaded", frozen, get_all)]
pub(crate) struct Loaded {
    /// Classes defined (identical ones already there included).
    classes: Vec<String>,
    /// Objects created.
    objects: Vec<String>,
    /// Number of `on write` rules attached.
    rules: usize,
    /// Plans installed.
    plans: Vec<String>,
}

#[pymethods]
impl Loaded {
    fn __repr__(&self) -> String {
        format!(
            "Loaded(classes={}, objects={}, rules={}, plans={})",
            quote_list(&self.classes),
            quote_list(&self.objects),
            self.rules,
            quote_list(&self.plans)
        )
    }
}

/// A plan installed on a board: a live view of its progress (each property reads the
/// engine's current state).
#[pyclass(module = "slate", name = "Plan", frozen)]
pub(crate) struct Plan {
    engine: Engine,
    /// The plan's name (also the name of its object, of class `Plan`, on the board).
    #[pyo3(get)]
    name: String,
}

impl Plan {
    pub(crate) fn new(engine: Engine, name: String) -> Self {
        Plan { engine, name }
    }

    fn status(&self, py: Python<'_>) -> PyResult<PlanStatus> {
        py.detach(|| self.engine.status(&self.name)).ok_or_else(|| {
            errors::new(
                py,
                Kind::UnknownObject,
                format!("no plan named {}", self.name),
            )
        })
    }
}

#[pymethods]
impl Plan {
    /// `"pending"`, `"active"`, `"terminated"` or `"cancelled"`.
    #[getter]
    fn state(&self, py: Python<'_>) -> PyResult<&'static str> {
        Ok(self.status(py)?.state.name())
    }

    /// Times the action has run.
    #[getter]
    fn fired(&self, py: Python<'_>) -> PyResult<u64> {
        Ok(self.status(py)?.fired)
    }

    /// Why the last action or evaluation failed, or `None`.
    #[getter]
    fn last_error(&self, py: Python<'_>) -> PyResult<Option<String>> {
        Ok(self.status(py)?.last_error)
    }

    /// Cancels the plan: it never acts again.
    fn cancel(&self, py: Python<'_>) -> bool {
        py.detach(|| self.engine.cancel(&self.name))
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        match self.status(py) {
            Ok(s) => format!(
                "Plan({}, state={}, fired={}, last_error={})",
                quote(&s.name),
                quote(s.state.name()),
                s.fired,
                quote_opt(s.last_error.as_deref())
            ),
            Err(_) => format!("Plan({})", quote(&self.name)),
        }
    }
}

/// One reported assertion: `object.attr` is `packet`.
#[pyclass(module = "slate", name = "ReportItem", frozen, get_all)]
pub(crate) struct ReportItem {
    /// Object (or class) name.
    object: String,
    /// Attribute name.
    attr: String,
    /// The packet, as the board read it when the report was made.
    packet: PyPacket,
}

#[pymethods]
impl ReportItem {
    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "ReportItem({}, {}, {})",
            quote(&self.object),
            quote(&self.attr),
            repr_value(py, &self.packet.inner.value)
        )
    }
}

/// A report made by a plan's or rule's `report` action, for the network to carry.
#[pyclass(module = "slate", name = "Report", frozen, get_all)]
pub(crate) struct Report {
    /// The plan or rule that made it.
    origin: String,
    /// Destination address, or `None` for every interested board.
    to: Option<String>,
    /// The assertions.
    items: Vec<Py<ReportItem>>,
}

#[pymethods]
impl Report {
    fn __repr__(&self, py: Python<'_>) -> String {
        let items: Vec<String> = self.items.iter().map(|i| i.get().__repr__(py)).collect();
        format!(
            "Report(origin={}, to={}, items=[{}])",
            quote(&self.origin),
            quote_opt(self.to.as_deref()),
            items.join(", ")
        )
    }
}

/// A plan sent to another module by a `send` action.
#[pyclass(module = "slate", name = "PlanMessage", frozen, get_all)]
pub(crate) struct PlanMessage {
    /// The plan that sent it.
    origin: String,
    /// The plan's name.
    name: String,
    /// Its slate source text.
    text: String,
    /// Destination address.
    to: String,
}

#[pymethods]
impl PlanMessage {
    fn __repr__(&self) -> String {
        format!(
            "PlanMessage(origin={}, name={}, to={})",
            quote(&self.origin),
            quote(&self.name),
            quote(&self.to)
        )
    }
}

fn outgoing_to_py(py: Python<'_>, msg: Outgoing) -> PyResult<Py<PyAny>> {
    Ok(match msg {
        Outgoing::Report(r) => {
            let items = r
                .items
                .into_iter()
                .map(|i| {
                    Py::new(
                        py,
                        ReportItem {
                            object: i.object.to_string(),
                            attr: i.attr.to_string(),
                            packet: PyPacket { inner: i.packet },
                        },
                    )
                })
                .collect::<PyResult<_>>()?;
            let report = Report {
                origin: r.origin,
                to: r.to.map(|a| a.to_string()),
                items,
            };
            Py::new(py, report)?.into_any()
        }
        Outgoing::Plan(p) => {
            let message = PlanMessage {
                origin: p.origin,
                name: p.name,
                text: p.text,
                to: p.to.to_string(),
            };
            Py::new(py, message)?.into_any()
        }
    })
}

/// A subscription to what the board's plans and rules send out: `Report` and
/// `PlanMessage` objects, for the network (the node) to carry.
///
/// Iterating waits for the next message (with the GIL released); with a `timeout`, the
/// iteration stops when none comes within it.
#[pyclass(module = "slate", name = "Outbox", frozen)]
pub(crate) struct Outbox {
    rx: Mutex<Option<Arc<Receiver<Outgoing>>>>,
    board: Weak<Board>,
    timeout: Option<Duration>,
}

impl Outbox {
    pub(crate) fn new(rx: Receiver<Outgoing>, board: &Arc<Board>, t: Option<Duration>) -> Self {
        Outbox {
            rx: Mutex::new(Some(Arc::new(rx))),
            board: Arc::downgrade(board),
            timeout: t,
        }
    }

    fn next_item(&self, py: Python<'_>, timeout: Option<Duration>) -> PyResult<Option<Py<PyAny>>> {
        let Some(rx) = self.rx.lock().clone() else {
            return Ok(None);
        };
        let alive = || self.rx.lock().is_some() && self.board.strong_count() > 0;
        stream::next_from(py, &rx, timeout, &alive)?
            .map(|m| outgoing_to_py(py, m))
            .transpose()
    }

    /// Messages already waiting, without blocking.
    fn waiting(&self, py: Python<'_>) -> PyResult<Vec<Py<PyAny>>> {
        let Some(rx) = self.rx.lock().clone() else {
            return Ok(Vec::new());
        };
        rx.try_iter().map(|m| outgoing_to_py(py, m)).collect()
    }

    fn unsubscribe(&self) {
        self.rx.lock().take();
    }
}

stream::subscription_methods!(Outbox, Py<PyAny>, {});
