//! `Watch`: an iterator over a board's changes, and the `Change` items it yields.

use std::sync::{Arc, Weak};
use std::time::Duration;

use crossbeam_channel::RecvTimeoutError;
use parking_lot::Mutex;
use pyo3::prelude::*;
use slate_model::{Board, ChangeItem, Watch};

use crate::packet::{PyPacket, quote, quote_opt, repr_value};
use crate::stream;

/// A subscription to the changes of a board that match a filter.
///
/// Iterating waits for the next change (with the GIL released); with a `timeout`, the
/// iteration stops when no change comes within it. Every write is one change, every
/// batch one change with all its items, in revision order. Changes made before the watch
/// was created are not seen. `close()` (or leaving a `with` block) unsubscribes.
#[pyclass(module = "slate", name = "Watch", frozen)]
pub(crate) struct PyWatch {
    inner: Mutex<Option<Arc<Watch>>>,
    board: Weak<Board>,
    timeout: Option<Duration>,
}

impl PyWatch {
    pub(crate) fn new(watch: Watch, board: &Arc<Board>, timeout: Option<Duration>) -> Self {
        PyWatch {
            inner: Mutex::new(Some(Arc::new(watch))),
            board: Arc::downgrade(board),
            timeout,
        }
    }

    fn watch(&self) -> Option<Arc<Watch>> {
        self.inner.lock().clone()
    }

    fn next_item(&self, py: Python<'_>, timeout: Option<Duration>) -> PyResult<Option<Change>> {
        let Some(watch) = self.watch() else {
            return Ok(None);
        };
        let alive = || self.inner.lock().is_some() && self.board.strong_count() > 0;
        let change = stream::next(
            py,
            timeout,
            &alive,
            || watch.try_recv(),
            |slice| watch.recv_timeout(slice).ok_or(RecvTimeoutError::Timeout),
        )?;
        change.map(|c| Change::new(py, c)).transpose()
    }

    /// Changes already waiting, without blocking.
    fn waiting(&self, py: Python<'_>) -> PyResult<Vec<Change>> {
        let Some(watch) = self.watch() else {
            return Ok(Vec::new());
        };
        std::iter::from_fn(|| watch.try_recv())
            .map(|c| Change::new(py, c))
            .collect()
    }

    fn unsubscribe(&self) {
        self.inner.lock().take();
    }
}

stream::subscription_methods!(PyWatch, Change, {
    /// Number of changes waiting.
    #[getter]
    fn pending(&self) -> usize {
        self.inner.lock().as_ref().map_or(0, |w| w.pending())
    }
});

/// The changes one revision made (a write, or a whole batch) that match a watch.
#[pyclass(module = "slate", name = "Change", frozen)]
pub(crate) struct Change {
    /// The board revision of the change.
    #[pyo3(get)]
    revision: u64,
    /// What changed, in the order it was applied.
    #[pyo3(get)]
    items: Vec<Py<PyChangeItem>>,
}

impl Change {
    fn new(py: Python<'_>, c: slate_model::Change) -> PyResult<Self> {
        let items = c
            .items
            .into_iter()
            .map(|i| Py::new(py, PyChangeItem::from(i)))
            .collect::<PyResult<_>>()?;
        Ok(Change {
            revision: c.revision,
            items,
        })
    }
}

#[pymethods]
impl Change {
    fn __repr__(&self, py: Python<'_>) -> String {
        let items: Vec<String> = self.items.iter().map(|i| i.get().__repr__(py)).collect();
        format!(
            "Change(revision={}, items=[{}])",
            self.revision,
            items.join(", ")
        )
    }
}

/// One item of a change: an attribute written, or an object created or deleted.
///
/// The names are the board's own shared strings (no copy per item: a watch of a busy
/// attribute makes one item per update); each is made a Python `str` when read.
#[pyclass(module = "slate", name = "ChangeItem", frozen)]
pub(crate) struct PyChangeItem {
    /// `"write"`, `"create"` or `"delete"`.
    #[pyo3(get)]
    kind: &'static str,
    object: Arc<str>,
    attr: Option<Arc<str>>,
    class_name: Option<Arc<str>>,
    packet: Option<PyPacket>,
}

impl From<ChangeItem> for PyChangeItem {
    fn from(item: ChangeItem) -> Self {
        let (kind, object, attr, class_name, packet) = match item {
            ChangeItem::Write {
                object,
                attr,
                packet,
            } => (
                "write",
                object,
                Some(attr),
                None,
                Some(PyPacket { inner: packet }),
            ),
            ChangeItem::Create { object, class } => ("create", object, None, Some(class), None),
            ChangeItem::Delete { object, class } => ("delete", object, None, Some(class), None),
        };
        PyChangeItem {
            kind,
            object,
            attr,
            class_name,
            packet,
        }
    }
}

#[pymethods]
impl PyChangeItem {
    /// The object (or class, for a class-level write).
    #[getter]
    fn object(&self) -> &str {
        &self.object
    }

    /// The attribute written (`None` for creations and deletions).
    #[getter]
    fn attr(&self) -> Option<&str> {
        self.attr.as_deref()
    }

    /// The class of the object created or deleted (`None` for writes).
    #[getter]
    fn class_name(&self) -> Option<&str> {
        self.class_name.as_deref()
    }

    /// The packet stored (`None` for creations and deletions).
    #[getter]
    fn packet(&self) -> Option<PyPacket> {
        self.packet.clone()
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        match (&self.attr, &self.packet, &self.class_name) {
            (Some(attr), Some(p), _) => format!(
                "ChangeItem('write', {}.{} = {})",
                self.object,
                attr,
                repr_value(py, &p.inner.value)
            ),
            (_, _, class) => format!(
                "ChangeItem({}, {}, class_name={})",
                quote(self.kind),
                quote(&self.object),
                quote_opt(class.as_deref())
            ),
        }
    }
}
