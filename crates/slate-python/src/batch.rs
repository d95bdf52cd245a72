//! `Batch`: an atomic group of writes, creations and deletions, as a context manager.

use std::sync::Arc;

use parking_lot::Mutex;
use pyo3::prelude::*;
use slate_model::{Board, NewObject, Update, Value, ValueType};

use crate::board::new_object;
use crate::errors::{self, Kind};
use crate::packet::{self, to_update};

/// One operation of a batch.
enum Op {
    Write(String, String, Update),
    Create(NewObject),
    Delete(String),
}

/// An atomic batch: operations are collected, then applied all together or not at all.
///
/// `with board.batch() as tx:` commits when the block ends normally; an exception leaving
/// the block discards the batch (nothing is applied) and propagates. A failing operation
/// raises its own exception (`ValueTypeError`, `UnknownObjectError`, ...) at commit, with
/// `index` set to its position, and nothing is applied.
#[pyclass(module = "slate", name = "Batch", frozen)]
pub(crate) struct PyBatch {
    board: Arc<Board>,
    /// `None` once committed or discarded.
    ops: Mutex<Option<Vec<Op>>>,
    revision: Mutex<Option<u64>>,
}

impl PyBatch {
    pub(crate) fn new(board: Arc<Board>) -> Self {
        PyBatch {
            board,
            ops: Mutex::new(Some(Vec::new())),
            revision: Mutex::new(None),
        }
    }

    fn push(&self, py: Python<'_>, op: Op) -> PyResult<()> {
        match self.ops.lock().as_mut() {
            Some(ops) => {
                ops.push(op);
                Ok(())
            }
            None => Err(errors::new(
                py,
                Kind::Slate,
                "this batch is over (committed or discarded); start a new one",
            )),
        }
    }

    /// The declared type of `object.attr`, the object perhaps created earlier in this batch.
    fn declared_type(&self, py: Python<'_>, object: &str, attr: &str) -> Option<ValueType> {
        let created = self.ops.lock().as_ref().and_then(|ops| {
            ops.iter().rev().find_map(|op| match op {
                Op::Create(spec) if spec.name == object => Some(spec.class.clone()),
                _ => None,
            })
        });
        let board = &self.board;
        py.detach(|| match created {
            Some(class) => packet::class_attr_type(board, &class, attr),
            None => packet::declared_type(board, object, attr),
        })
    }
}

#[pymethods]
impl PyBatch {
    /// Adds a write (same arguments as `Board.write`).
    #[pyo3(signature = (object, attr, value, *, accuracy=None, confidence=None, timestamp=None, source=None))]
    #[allow(clippy::too_many_arguments)]
    fn write(
        &self,
        py: Python<'_>,
        object: String,
        attr: String,
        value: &Bound<'_, PyAny>,
        accuracy: Option<f64>,
        confidence: Option<f64>,
        timestamp: Option<f64>,
        source: Option<&str>,
    ) -> PyResult<()> {
        let mut update = to_update(value, accuracy, confidence, timestamp, source)?;
        if matches!(update.value, Value::Int(_)) {
            let declared = self.declared_type(py, &object, &attr);
            update.value = packet::coerce(update.value, declared);
        }
        self.push(py, Op::Write(object, attr, update))
    }

    /// Adds the creation of an object (same arguments as `Board.create`).
    #[pyo3(signature = (class_name, name, *, context=None, owner=None))]
    fn create(
        &self,
        py: Python<'_>,
        class_name: &str,
        name: &str,
        context: Option<&str>,
        owner: Option<&str>,
    ) -> PyResult<()> {
        let spec = new_object(py, class_name, name, context, owner)?;
        self.push(py, Op::Create(spec))
    }

    /// Adds the deletion of an object.
    fn delete(&self, py: Python<'_>, name: String) -> PyResult<()> {
        self.push(py, Op::Delete(name))
    }

    /// Applies every operation, or none; returns the batch's revision.
    fn commit(&self, py: Python<'_>) -> PyResult<u64> {
        let ops = self.ops.lock().take().ok_or_else(|| {
            errors::new(
                py,
                Kind::Slate,
                "this batch is over (committed or discarded); start a new one",
            )
        })?;
        let board = &self.board;
        let revision = py
            .detach(|| {
                let mut batch = board.batch();
                for op in ops {
                    match op {
                        Op::Write(o, a, u) => drop(batch.write(&o, &a, u)),
                        Op::Create(spec) => drop(batch.create_with(spec)),
                        Op::Delete(name) => drop(batch.delete(&name)),
                    }
                }
                batch.commit()
            })
            .map_err(|e| errors::batch(py, e))?;
        *self.revision.lock() = Some(revision);
        Ok(revision)
    }

    /// Drops every operation; nothing is applied.
    fn discard(&self) {
        self.ops.lock().take();
    }

    /// The revision of the committed batch (`None` before the commit).
    #[getter]
    fn revision(&self) -> Option<u64> {
        *self.revision.lock()
    }

    fn __len__(&self) -> usize {
        self.ops.lock().as_ref().map_or(0, Vec::len)
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    /// Commits if the block ended normally, discards if an exception left it.
    #[pyo3(signature = (exc_type=None, exc_value=None, traceback=None))]
    fn __exit__(
        &self,
        py: Python<'_>,
        exc_type: Option<&Bound<'_, PyAny>>,
        exc_value: Option<&Bound<'_, PyAny>>,
        traceback: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<bool> {
        let _ = (exc_value, traceback);
        if exc_type.is_some_and(|t| !t.is_none()) {
            self.discard();
        } else if self.ops.lock().is_some() {
            self.commit(py)?;
        }
        Ok(false)
    }
}
