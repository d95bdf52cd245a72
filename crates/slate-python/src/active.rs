//! Python callables as active functions, and the `Call` object they receive.
//!
//! The core hands an active function a `&mut Call` that lives only while the function runs;
//! its `read` and `write` continue the chain of active functions (so cycles and deep chains
//! are cut) and, inside a snapshot, read through it. Python code cannot hold a borrowed
//! value, and this crate has no `unsafe`, so the Python `Call` cannot point at it.
//!
//! On the live board (the common case) the Python `Call` holds the board and the call's
//! [`CallToken`] instead, and reads and writes with `Board::read_as` / `write_as` in this
//! thread, with the GIL released. Inside a snapshot there is no token (the snapshot holds
//! the board): while the callable runs in this thread, a scoped *servant* thread holds the
//! `&Call` and performs the callable's reads for it; the Python `Call` sends each request
//! over a channel and waits for the answer with the GIL released.
//!
//! Deadlocks: the callable runs with the GIL, never under the board's lock, except on-read
//! functions run inside a snapshot (the plan engine's), which hold the board's read lock
//! while they wait for the GIL. That is why every board call from Python releases the GIL
//! first (see `board.rs`).

use std::sync::Arc;

use crossbeam_channel::{Receiver, Sender};
use parking_lot::Mutex;
use pyo3::gc::PyVisit;
use pyo3::prelude::*;
use pyo3::{PyTraverseError, intern};
use std::sync::Weak;

use slate_model::{
    ActiveFn, Board, Call, CallToken, FnError, LookupError, Packet, ReadError, Trigger, Update,
    Value, ValueType, WriteError,
};

use crate::errors::{self, Kind};
use crate::packet::{self, PyPacket};

/// A Python callable attached to an attribute.
pub(crate) struct PyActiveFn {
    name: String,
    /// `None` once the garbage collector has cleared it (the board and the callable were
    /// only reachable from each other); the function then does nothing.
    callable: Mutex<Option<Py<PyAny>>>,
    /// The attribute's declared type, to make an int returned by an on-read function a real.
    declared: Option<ValueType>,
    /// The board it is attached to (weak: the board holds the function).
    board: Weak<Board>,
}

impl PyActiveFn {
    pub(crate) fn new(
        name: String,
        callable: Py<PyAny>,
        declared: Option<ValueType>,
        board: Weak<Board>,
    ) -> Self {
        PyActiveFn {
            name,
            callable: Mutex::new(Some(callable)),
            declared,
            board,
        }
    }

    /// Lets the garbage collector see the callable.
    pub(crate) fn traverse(&self, visit: &PyVisit<'_>) -> Result<(), PyTraverseError> {
        match self.callable.try_lock() {
            Some(c) => visit.call(c.as_ref()),
            None => Ok(()),
        }
    }

    /// Drops the callable (breaking a reference cycle through the board).
    pub(crate) fn clear(&self) -> Option<Py<PyAny>> {
        self.callable.lock().take()
    }
}

impl ActiveFn for PyActiveFn {
    fn name(&self) -> &str {
        &self.name
    }

    fn call(&self, call: &mut Call<'_>) -> Result<(), FnError> {
        let returned = match (call.token(), self.board.upgrade()) {
            (Some(token), Some(board)) => self.run_direct(call, board, token)?,
            _ => self.run_served(call)?,
        };
        match returned {
            Some(Returned::Packet(p)) => {
                let p = self.complete(p, call.packet());
                call.set_packet(p);
            }
            Some(Returned::Value(v)) => call.set_value(packet::coerce(v, self.declared)),
            None => {}
        }
        Ok(())
    }
}

/// Runs `f` with the GIL, on any thread. A thread Python did not start (Zenoh's receive
/// threads, the transport's delivery thread: they merge what the network brings and run
/// the on-write functions it triggers) keeps its Python thread state from its first call
/// to its end, instead of one made and destroyed around every call: Python makes each
/// new thread state a frame stack with `mmap` on its first call and unmaps it with the
/// state, so a function run for every merged report cost two system calls, a page fault
/// and a TLB flush of the other cores (13 µs a report, docs/performance.md, *Side by side
/// with the peers*). The thread's Python state (its `threading.local` data) then also
/// lasts from one call to the next, as on a Python thread. One state is left over per
/// such thread that ends (a node's delivery thread, when the node closes): freeing it
/// there would need the GIL while the node's `close` may hold it.
fn attach<R>(f: impl for<'py> FnOnce(Python<'py>) -> R) -> R {
    keep_thread_state();
    Python::attach(f)
}

thread_local! {
    /// Whether this thread was looked at by [`keep_thread_state`].
    static KEPT: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Gives this thread a Python thread state that outlives each call ([`attach`]), once.
#[allow(unsafe_code)]
fn keep_thread_state() {
    if KEPT.with(|k| k.replace(true)) {
        return;
    }
    // SAFETY: `Py_IsInitialized` and `PyGILState_GetThisThreadState` may be called at any
    // time. The thread has no Python state (Python never ran on it), so it does not hold
    // the GIL: `PyGILState_Ensure` makes its state and takes the GIL, and
    // `PyEval_SaveThread` lets go of the GIL, leaving the state with its count at one, so
    // that later `PyGILState_Ensure`/`PyGILState_Release` pairs (pyo3's `attach`) only
    // take and release the GIL with it.
    unsafe {
        if pyo3::ffi::Py_IsInitialized() == 0
            || !pyo3::ffi::PyGILState_GetThisThreadState().is_null()
        {
            return;
        }
        let _ = pyo3::ffi::PyGILState_Ensure();
        pyo3::ffi::PyEval_SaveThread();
    }
}

/// Stack of the servant thread: it may run nested Python functions, so it gets what a
/// Python thread gets by default on Linux.
const SERVANT_STACK: usize = 8 << 20;

impl PyActiveFn {
    /// Runs the callable in this thread; its `Call` reads and writes the live board
    /// inside the chain, with the token.
    fn run_direct(
        &self,
        call: &Call<'_>,
        board: Arc<Board>,
        token: CallToken,
    ) -> Result<Option<Returned>, FnError> {
        let link = Arc::new(Mutex::new(Some(Route::Direct(board, token))));
        let view = view(call, &link);
        let result = attach(|py| self.run(py, view));
        link.lock().take();
        result
    }

    /// Runs the callable in this thread while a scoped servant thread performs its
    /// requests through `call`.
    fn run_served(&self, call: &Call<'_>) -> Result<Option<Returned>, FnError> {
        let (tx, rx) = crossbeam_channel::unbounded();
        let link = Arc::new(Mutex::new(Some(Route::Served(tx))));
        let view = view(call, &link);
        std::thread::scope(|s| {
            std::thread::Builder::new()
                .name("slate-py-call".into())
                .stack_size(SERVANT_STACK)
                .spawn_scoped(s, move || serve(call, &rx))
                .map_err(|e| FnError::Message(format!("cannot start its servant thread: {e}")))?;
            let result = attach(|py| self.run(py, view));
            // The servant ends once the last request in flight is answered.
            link.lock().take();
            result
        })
    }

    /// A packet returned by an on-read function, with the read packet's timestamp and
    /// source where it left them out, and its value fitted to the declared type.
    fn complete(&self, mut p: Packet, read: &Packet) -> Packet {
        if p.timestamp == slate_model::Timestamp::ZERO {
            p.timestamp = read.timestamp;
        }
        if p.source.is_unknown() {
            p.source = read.source.clone();
        }
        p.value = packet::coerce(p.value, self.declared);
        p
    }
}

/// What an on-read callable returned to replace the packet read.
enum Returned {
    Packet(Packet),
    Value(Value),
}

impl PyActiveFn {
    /// Calls the callable with a `Call`; its exception becomes the function's error.
    fn run(&self, py: Python<'_>, view: PyCall) -> Result<Option<Returned>, FnError> {
        let Some(callable) = self.callable.lock().as_ref().map(|c| c.clone_ref(py)) else {
            return Ok(None);
        };
        let trigger = view.trigger;
        let returned = Py::new(py, view)
            .and_then(|call| callable.call1(py, (call,)))
            .map_err(|e| FnError::Message(describe(py, &e)))?;
        let returned = returned.bind(py);
        if trigger != "read" || returned.is_none() {
            return Ok(None);
        }
        if let Ok(p) = returned.cast::<PyPacket>() {
            return Ok(Some(Returned::Packet(p.get().inner.clone())));
        }
        packet::to_value(returned)
            .map(|v| Some(Returned::Value(v)))
            .map_err(|e| FnError::Message(format!("returned {}", describe(py, &e))))
    }
}

/// `ValueError: boom (at file.py:12 in on_speed)`.
fn describe(py: Python<'_>, e: &PyErr) -> String {
    let name = e
        .get_type(py)
        .name()
        .map_or_else(|_| "Exception".to_owned(), |n| n.to_string());
    let text = e.value(py).str().map(|s| s.to_string()).unwrap_or_default();
    let message = if text.is_empty() {
        name
    } else {
        format!("{name}: {text}")
    };
    match e.traceback(py).and_then(|tb| last_frame(py, &tb).ok()) {
        Some(place) => format!("{message} (at {place})"),
        None => message,
    }
}

/// `file:line in function` of the innermost frame of a traceback.
fn last_frame(py: Python<'_>, tb: &Bound<'_, pyo3::types::PyTraceback>) -> PyResult<String> {
    let mut tb = tb.clone().into_any();
    loop {
        let next = tb.getattr(intern!(py, "tb_next"))?;
        if next.is_none() {
            break;
        }
        tb = next;
    }
    let line: u32 = tb.getattr(intern!(py, "tb_lineno"))?.extract()?;
    let code = tb
        .getattr(intern!(py, "tb_frame"))?
        .getattr(intern!(py, "f_code"))?;
    let file: String = code.getattr(intern!(py, "co_filename"))?.extract()?;
    let function: String = code.getattr(intern!(py, "co_name"))?.extract()?;
    Ok(format!("{file}:{line} in {function}"))
}

/// How the Python `Call` reaches the board while its function runs.
#[derive(Clone)]
enum Route {
    /// Directly, inside the chain the token holds.
    Direct(Arc<Board>, CallToken),
    /// Through the servant thread that holds the `&Call`.
    Served(Sender<Request>),
}

/// A request from the Python `Call` to the servant.
enum Request {
    Read(String, String, Sender<Result<Packet, ReadError>>),
    Write(String, String, Update, Sender<Result<u64, WriteError>>),
    Instances(String, Sender<Result<Vec<String>, LookupError>>),
    Exists(String, Sender<bool>),
}

/// Performs requests through the core's `Call` until the Python side hangs up.
fn serve(call: &Call<'_>, rx: &Receiver<Request>) {
    for request in rx {
        match request {
            Request::Read(o, a, reply) => drop(reply.send(call.read(&o, &a))),
            Request::Write(o, a, u, reply) => {
                let done = packet::retry_as_real(u, |u| call.write(&o, &a, u));
                drop(reply.send(done));
            }
            Request::Instances(class, reply) => {
                let names = call.instances(&class).map(|ids| {
                    ids.into_iter()
                        .filter_map(|id| call.name_of(id).map(|n| n.to_string()))
                        .collect()
                });
                drop(reply.send(names));
            }
            Request::Exists(name, reply) => drop(reply.send(call.exists(&name))),
        }
    }
}

/// The call being served, as the Python `Call` sees it.
fn view(call: &Call<'_>, link: &Arc<Mutex<Option<Route>>>) -> PyCall {
    PyCall {
        object: call.object().to_owned(),
        attr: call.attr().to_owned(),
        trigger: match call.trigger() {
            Trigger::Read => "read",
            _ => "write",
        },
        packet: PyPacket {
            inner: call.packet().clone(),
        },
        previous: call.previous().map(|p| PyPacket { inner: p.clone() }),
        revision: call.revision(),
        link: link.clone(),
    }
}

/// What an active function receives: the access that triggered it, and `read`, `write`,
/// `instances` and `exists` on the board within the chain of active functions (a cycle or
/// a chain deeper than the board's limit raises `ChainError`).
///
/// Valid only while the function runs; afterwards its methods raise `SlateError`.
#[pyclass(module = "slate", name = "Call", frozen)]
pub(crate) struct PyCall {
    /// The object (or class) whose attribute was accessed.
    #[pyo3(get)]
    object: String,
    /// The attribute.
    #[pyo3(get)]
    attr: String,
    /// `"write"` (after a write was stored) or `"read"` (the function may return a value
    /// or a Packet to replace what the read returns).
    #[pyo3(get)]
    trigger: &'static str,
    packet: PyPacket,
    previous: Option<PyPacket>,
    /// On write: the board revision of the write (0 on read).
    #[pyo3(get)]
    revision: u64,
    link: Arc<Mutex<Option<Route>>>,
}

impl PyCall {
    /// The route to the board while the function runs; an error afterwards.
    fn route(&self, py: Python<'_>) -> PyResult<Route> {
        self.link.lock().clone().ok_or_else(|| ended(py))
    }
}

fn ended(py: Python<'_>) -> PyErr {
    errors::new(
        py,
        Kind::Slate,
        "this Call is over: use it only while its active function runs",
    )
}

/// Sends a request built around a fresh reply channel to the servant and waits for the
/// answer with the GIL released.
fn ask<T: Send>(
    py: Python<'_>,
    tx: Sender<Request>,
    request: impl FnOnce(Sender<T>) -> Request,
) -> PyResult<T> {
    let (reply, answer) = crossbeam_channel::bounded(1);
    tx.send(request(reply)).map_err(|_| ended(py))?;
    drop(tx);
    py.detach(|| answer.recv()).map_err(|_| ended(py))
}

#[pymethods]
impl PyCall {
    /// On write: the packet stored. On read: the packet to be returned so far.
    #[getter]
    fn packet(&self) -> PyPacket {
        self.packet.clone()
    }

    /// On write: the object's own packet before the write (`None` if it had none).
    #[getter]
    fn previous(&self) -> Option<PyPacket> {
        self.previous.clone()
    }

    /// Reads an attribute (running its on-read functions, within the chain limits).
    fn read(&self, py: Python<'_>, object: String, attr: String) -> PyResult<PyPacket> {
        let read = match self.route(py)? {
            Route::Direct(board, token) => py.detach(|| board.read_as(&token, &object, &attr)),
            Route::Served(tx) => ask(py, tx, |reply| Request::Read(object, attr, reply))?,
        };
        read.map(|inner| PyPacket { inner })
            .map_err(|e| errors::read(py, e))
    }

    /// Writes an attribute (running its on-write functions, within the chain limits);
    /// returns the revision.
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
    ) -> PyResult<u64> {
        let update = packet::to_update(value, accuracy, confidence, timestamp, source)?;
        let done = match self.route(py)? {
            Route::Direct(board, token) => py.detach(|| {
                packet::retry_as_real(update, |u| board.write_as(&token, &object, &attr, u))
            }),
            Route::Served(tx) => ask(py, tx, |reply| Request::Write(object, attr, update, reply))?,
        };
        done.map_err(|e| errors::write(py, e))
    }

    /// Names of the instances of a class and its subclasses.
    fn instances(&self, py: Python<'_>, class_name: String) -> PyResult<Vec<String>> {
        let names = match self.route(py)? {
            Route::Direct(board, _) => py.detach(|| {
                board.instances(&class_name).map(|ids| {
                    ids.into_iter()
                        .filter_map(|id| board.name_of(id).map(|n| n.to_string()))
                        .collect()
                })
            }),
            Route::Served(tx) => ask(py, tx, |reply| Request::Instances(class_name, reply))?,
        };
        names.map_err(|e| errors::lookup(py, e))
    }

    /// Does an object or class of that name exist?
    fn exists(&self, py: Python<'_>, name: String) -> PyResult<bool> {
        match self.route(py)? {
            Route::Direct(board, _) => Ok(py.detach(|| board.info(&name).is_some())),
            Route::Served(tx) => ask(py, tx, |reply| Request::Exists(name, reply)),
        }
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Call(on {} of {}.{}, value={})",
            self.trigger,
            self.object,
            self.attr,
            packet::repr_value(py, &self.packet.inner.value)
        )
    }
}
