//! `Board`: the SBIPs from Python.
//!
//! GIL rule: every call into the board or its plan engine releases the GIL first. A thread
//! may hold the board's read lock while it waits for the GIL (the plan engine evaluating a
//! condition in a snapshot runs Python on-read functions), and the engine holds its own lock
//! while its actions run Python on-write functions; a Python thread that kept the GIL while
//! it queued for either lock (a read queues behind a waiting writer) would deadlock. Releasing
//! the GIL costs about 30 ns, a sixth of a read.

use std::str::FromStr;
use std::sync::{Arc, OnceLock};

use parking_lot::Mutex;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::gc::PyVisit;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyCFunction, PyDict, PyInt, PyTuple};
use pyo3::{PyTraverseError, intern};
use slate_model::{
    AttrDecl, Board, ClassDef, Context, DEFAULT_MAX_DEPTH, Filter, MAX_NESTED_FUNCTIONS, NewObject,
    Query, Trigger,
};
use slate_plans::Engine;

use crate::active::PyActiveFn;
use crate::batch::PyBatch;
use crate::clock::{PyClock, clock_of_kind};
use crate::engine::{self, Loaded, Outbox, Plan};
use crate::errors::{self, Kind};
use crate::events::Events;
use crate::packet::{self, PyPacket, quote, to_address, to_update};
use crate::stream;
use crate::watch::PyWatch;

/// A module's blackboard: classes, objects, and attribute packets.
///
/// `Board(clock="manual")` for tests and simulations; `address="team/r1/nav"` names the
/// module (the source of its writes). Classes, objects, rules and plans come from `load`.
/// Every method is thread-safe; blocking ones release the GIL.
#[pyclass(module = "slate", name = "Board", frozen)]
pub(crate) struct PyBoard {
    board: Arc<Board>,
    engine: OnceLock<Engine>,
    /// Python active functions, held here too so that the garbage collector sees them.
    fns: Mutex<Vec<Arc<PyActiveFn>>>,
}

impl PyBoard {
    /// The core board.
    pub(crate) fn inner(&self) -> &Arc<Board> {
        &self.board
    }

    /// A board at `address` on the system clock, for a node given none.
    pub(crate) fn for_node(address: slate_model::Address) -> Self {
        PyBoard {
            board: Arc::new(Board::builder().address(address).build()),
            engine: OnceLock::new(),
            fns: Mutex::new(Vec::new()),
        }
    }

    /// Runs a board call with the GIL released (see the module's GIL rule).
    fn without_gil<T: Send>(&self, py: Python<'_>, f: impl FnOnce(&Board) -> T + Send) -> T {
        py.detach(|| f(&self.board))
    }

    /// The plan engine, created on first use (it defines the `Plan` class and watches
    /// every change, so boards without plans do without it). On the system clock it
    /// runs a timer thread for plan deadlines (a manual clock runs them as it moves); the
    /// thread ends with the engine.
    pub(crate) fn engine(&self, py: Python<'_>) -> &Engine {
        if let Some(e) = self.engine.get() {
            return e;
        }
        py.detach(|| {
            self.engine.get_or_init(|| {
                let engine = Engine::new(&self.board);
                if !self.board.clock().is_manual() {
                    drop(engine.run_timers());
                }
                engine
            })
        })
    }

    fn attach(
        &self,
        py: Python<'_>,
        target: &str,
        attr: &str,
        trigger: Trigger,
        f: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        if !f.is_callable() {
            return Err(PyTypeError::new_err(format!(
                "an active function must be callable, not {}",
                f.get_type().name()?
            )));
        }
        let fn_name = f
            .getattr(intern!(py, "__qualname__"))
            .and_then(|n| n.extract::<String>())
            .unwrap_or_else(|_| "python function".to_owned());
        let declared = self.without_gil(py, |b| packet::declared_type(b, target, attr));
        let name = format!("{fn_name} ({target}.{attr} on {trigger})");
        let active = Arc::new(PyActiveFn::new(
            name,
            f.clone().unbind(),
            declared,
            Arc::downgrade(&self.board),
        ));
        let board = &self.board;
        let attached = active.clone();
        py.detach(|| board.attach(target, attr, trigger, attached))
            .map_err(|e| errors::lookup(py, e))?;
        self.fns.lock().push(active);
        Ok(())
    }

    /// `fn` attached, or a decorator that attaches what it decorates.
    fn attach_or_decorate<'py>(
        slf: &Bound<'py, Self>,
        target: &str,
        attr: &str,
        trigger: Trigger,
        f: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let py = slf.py();
        if let Some(f) = f {
            slf.get().attach(py, target, attr, trigger, &f)?;
            return Ok(f);
        }
        let board: Py<PyBoard> = slf.clone().unbind();
        let (target, attr) = (target.to_owned(), attr.to_owned());
        let decorator = move |args: &Bound<'_, PyTuple>, _: Option<&Bound<'_, PyDict>>| {
            let f = args.get_item(0)?;
            board.get().attach(args.py(), &target, &attr, trigger, &f)?;
            Ok::<_, PyErr>(f.unbind())
        };
        Ok(PyCFunction::new_closure(py, Some(c"attach"), None, decorator)?.into_any())
    }
}

/// A `max_depth` given from Python: an int from 0 to [`MAX_NESTED_FUNCTIONS`] (deeper
/// chains could not run anyway: one thread nests no more functions than that).
fn checked_max_depth(depth: &Bound<'_, PyAny>) -> PyResult<usize> {
    let what = || format!("from 0 to {MAX_NESTED_FUNCTIONS} (default {DEFAULT_MAX_DEPTH})");
    if !depth.is_instance_of::<PyInt>() || depth.is_instance_of::<PyBool>() {
        return Err(PyTypeError::new_err(format!(
            "max_depth must be an int {}, not {}",
            what(),
            depth.get_type().name()?
        )));
    }
    depth
        .extract::<usize>()
        .ok()
        .filter(|d| *d <= MAX_NESTED_FUNCTIONS)
        .ok_or_else(|| PyValueError::new_err(format!("max_depth must be {}, not {depth}", what())))
}

fn parse_context(context: Option<&str>) -> PyResult<Option<Context>> {
    context
        .map(|c| Context::from_str(c).map_err(PyValueError::new_err))
        .transpose()
}

pub(crate) fn new_object(
    py: Python<'_>,
    class_name: &str,
    name: &str,
    context: Option<&str>,
    owner: Option<&str>,
) -> PyResult<NewObject> {
    let mut spec = NewObject::new(class_name, name);
    if let Some(c) = parse_context(context)? {
        spec = spec.context(c);
    }
    if let Some(o) = owner {
        spec = spec.owner(to_address(py, o)?);
    }
    Ok(spec)
}

#[pymethods]
impl PyBoard {
    /// A board. `clock`: `"system"` (default), `"manual"`, or a `Clock` to share with
    /// other boards. `address`: the module, `team/robot/module`. `max_depth`: the deepest
    /// chain of active functions allowed, an int from 0 to 128 (default 8).
    #[new]
    #[pyo3(signature = (clock=None, address=None, max_depth=None))]
    fn new(
        py: Python<'_>,
        clock: Option<&Bound<'_, PyAny>>,
        address: Option<&str>,
        max_depth: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let max_depth = max_depth.map(checked_max_depth).transpose()?;
        let clock = match clock {
            None => slate_model::Clock::system(),
            Some(c) => match c.cast::<PyClock>() {
                Ok(c) => c.get().inner.clone(),
                Err(_) => clock_of_kind(
                    py,
                    &c.extract::<String>().map_err(|_| {
                        PyTypeError::new_err(
                            "clock must be \"system\", \"manual\" or a slate.Clock",
                        )
                    })?,
                )?,
            },
        };
        let mut builder = Board::builder()
            .clock(clock)
            .max_depth(max_depth.unwrap_or(DEFAULT_MAX_DEPTH));
        if let Some(a) = address {
            builder = builder.address(to_address(py, a)?);
        }
        Ok(PyBoard {
            board: Arc::new(builder.build()),
            engine: OnceLock::new(),
            fns: Mutex::new(Vec::new()),
        })
    }

    /// The module this board belongs to: the source of its writes.
    #[getter]
    fn address(&self) -> String {
        self.board.address().to_string()
    }

    /// The board's clock.
    #[getter]
    fn clock(&self) -> PyClock {
        PyClock {
            inner: self.board.clock().clone(),
        }
    }

    /// The current revision: +1 with every write, batch, creation and deletion.
    #[getter]
    fn revision(&self, py: Python<'_>) -> u64 {
        self.without_gil(py, Board::revision)
    }

    /// Loads classes, objects, rules and plans from a `.slate` source: a path
    /// (`os.PathLike`, or a `str` without newline, `{` or `;`) or source text (any other
    /// `str`). `name` names the source in diagnostics. Raises `LoadError` (nothing applied)
    /// with every diagnostic, and `OSError` if the file cannot be read.
    #[pyo3(signature = (source, *, name=None))]
    fn load(
        &self,
        py: Python<'_>,
        source: &Bound<'_, PyAny>,
        name: Option<String>,
    ) -> PyResult<Loaded> {
        let src = engine::source(source, name)?;
        engine::load(py, self.engine(py), src)
    }

    /// Defines a class with typed attributes (`{"speed": "real", "position": "vec<2>"}`;
    /// types as in the slate language), child of `parent` (default `Thing`). Defining an
    /// identical class again does nothing; a different one raises `DefineError`. Units,
    /// bounds, defaults and policies are declared with `load`.
    #[pyo3(signature = (name, attrs=None, *, parent=None))]
    fn define(
        &self,
        py: Python<'_>,
        name: &str,
        attrs: Option<&Bound<'_, PyDict>>,
        parent: Option<&str>,
    ) -> PyResult<()> {
        let mut def = ClassDef::new(name);
        if let Some(p) = parent {
            def = def.parent(p);
        }
        for (attr, ty) in attrs.into_iter().flatten() {
            let (attr, ty) = (attr.extract::<String>()?, ty.extract::<String>()?);
            def = def.attr(AttrDecl::new(&attr, packet::parse_type(py, &ty)?));
        }
        let board = &self.board;
        py.detach(|| board.define(def))
            .map(|_| ())
            .map_err(|e| errors::define(py, e))
    }

    /// Creates an object of a class. `context`: `"self"`, `"surroundings"` (default) or
    /// `"system"`; `owner`: the owning module (default: this board's address).
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
        let board = &self.board;
        py.detach(|| board.create_with(spec))
            .map(|_| ())
            .map_err(|e| errors::create(py, e))
    }

    /// Deletes an object; returns the revision. References to it become dangling.
    fn delete(&self, py: Python<'_>, name: &str) -> PyResult<u64> {
        let board = &self.board;
        py.detach(|| board.delete(name))
            .map_err(|e| errors::delete(py, e))
    }

    /// Deletes a class that has no instances and no subclasses (delete those first);
    /// its name is then free for a new definition. Raises `DeleteError` (in use, an
    /// object, or `Thing`) or `UnknownObjectError`.
    fn delete_class(&self, py: Python<'_>, name: &str) -> PyResult<()> {
        let board = &self.board;
        py.detach(|| board.delete_class(name))
            .map_err(|e| errors::delete(py, e))
    }

    /// Reads an attribute: the object's own packet, else its class chain's, else the
    /// declared default; on-read functions may change what is returned.
    fn read(&self, py: Python<'_>, object: &str, attr: &str) -> PyResult<PyPacket> {
        self.without_gil(py, |b| b.read(object, attr))
            .map(|inner| PyPacket { inner })
            .map_err(|e| errors::read(py, e))
    }

    /// Writes an attribute and returns the revision. Fields left out come from the
    /// declared default packet, the board's clock and its address. An int written to a
    /// `real` attribute is stored as a float; any other type mismatch raises
    /// `ValueTypeError`.
    #[pyo3(signature = (object, attr, value, *, accuracy=None, confidence=None, timestamp=None, source=None))]
    #[allow(clippy::too_many_arguments)]
    fn write(
        &self,
        py: Python<'_>,
        object: &str,
        attr: &str,
        value: &Bound<'_, PyAny>,
        accuracy: Option<f64>,
        confidence: Option<f64>,
        timestamp: Option<f64>,
        source: Option<&str>,
    ) -> PyResult<u64> {
        let update = to_update(value, accuracy, confidence, timestamp, source)?;
        let board = &self.board;
        py.detach(|| packet::retry_as_real(update, |u| board.write(object, attr, u)))
            .map_err(|e| errors::write(py, e))
    }

    /// An atomic batch of writes, creations and deletions: `with board.batch() as tx:`
    /// commits when the block ends normally and applies nothing if an exception leaves it.
    fn batch(&self) -> PyBatch {
        PyBatch::new(self.board.clone())
    }

    /// Names of the instances of a class and its subclasses, optionally only those in one
    /// context or owned by one module.
    #[pyo3(signature = (class_name, *, context=None, owner=None))]
    fn instances(
        &self,
        py: Python<'_>,
        class_name: &str,
        context: Option<&str>,
        owner: Option<&str>,
    ) -> PyResult<Vec<String>> {
        let mut query = Query::class(class_name);
        if let Some(c) = parse_context(context)? {
            query = query.context(c);
        }
        if let Some(o) = owner {
            query = query.owner(to_address(py, o)?);
        }
        self.without_gil(py, |b| {
            let snap = b.snapshot();
            snap.query(&query).map(|ids| {
                ids.into_iter()
                    .filter_map(|id| snap.name_of(id).map(|n| n.to_string()))
                    .collect()
            })
        })
        .map_err(|e| errors::lookup(py, e))
    }

    /// What the board knows about an object or class, or `None` if it does not exist.
    fn info(&self, py: Python<'_>, name: &str) -> Option<Info> {
        self.without_gil(py, |b| b.info(name)).map(|i| Info {
            name: i.name.to_string(),
            class_name: i.class.to_string(),
            is_class: i.is_class,
            context: i.context.name(),
            owner: i.owner.to_string(),
        })
    }

    fn __contains__(&self, py: Python<'_>, name: &str) -> bool {
        self.without_gil(py, |b| b.info(name).is_some())
    }

    /// Attaches `fn(call)` to run after `target.attr` is written (`target`: a class, for
    /// every instance and subclass, or one object). Without `fn`, returns a decorator.
    /// An exception raised by `fn` is reported as a `"function_failed"` event; the write
    /// stands.
    #[pyo3(signature = (target, attr, r#fn=None))]
    fn on_write<'py>(
        slf: &Bound<'py, Self>,
        target: &str,
        attr: &str,
        r#fn: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        Self::attach_or_decorate(slf, target, attr, Trigger::Write, r#fn)
    }

    /// Attaches `fn(call)` to run when `target.attr` is read; what it returns (a value or
    /// a `Packet`; `None` keeps the packet) replaces what the read returns. Without `fn`,
    /// returns a decorator.
    #[pyo3(signature = (target, attr, r#fn=None))]
    fn on_read<'py>(
        slf: &Bound<'py, Self>,
        target: &str,
        attr: &str,
        r#fn: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        Self::attach_or_decorate(slf, target, attr, Trigger::Read, r#fn)
    }

    /// Watches changes: of a class (its subclasses and instances) or an object (and
    /// class-level writes that change what it reads) named `target`, of an attribute
    /// `attr`, or of everything. With `timeout`, iteration stops after that many seconds
    /// without a change.
    #[pyo3(signature = (target=None, attr=None, *, timeout=None))]
    fn watch(
        &self,
        py: Python<'_>,
        target: Option<&str>,
        attr: Option<&str>,
        timeout: Option<f64>,
    ) -> PyResult<PyWatch> {
        let timeout = stream::timeout(timeout)?;
        let board = &self.board;
        let watch = py.detach(|| {
            let mut filter = match target {
                None => Filter::all(),
                Some(t) if board.info(t).is_some_and(|i| i.is_class) => Filter::class(t),
                Some(t) => Filter::object(t),
            };
            if let Some(a) = attr {
                filter = filter.attr(a);
            }
            board.watch(filter)
        });
        let watch = watch.map_err(|e| errors::lookup(py, e))?;
        Ok(PyWatch::new(watch, &self.board, timeout))
    }

    /// Subscribes to the board's own events: failed active functions and cut chains.
    #[pyo3(signature = (*, timeout=None))]
    fn events(&self, timeout: Option<f64>) -> PyResult<Events> {
        let timeout = stream::timeout(timeout)?;
        Ok(Events::board(self.board.events(), &self.board, timeout))
    }

    /// Subscribes to the progress events of every plan.
    #[pyo3(signature = (*, timeout=None))]
    fn plan_events(&self, py: Python<'_>, timeout: Option<f64>) -> PyResult<Events> {
        let timeout = stream::timeout(timeout)?;
        let rx = self.engine(py).events();
        Ok(Events::plans(rx, &self.board, timeout))
    }

    /// Subscribes to the reports and plans the board's plans and rules send out.
    #[pyo3(signature = (*, timeout=None))]
    fn outgoing(&self, py: Python<'_>, timeout: Option<f64>) -> PyResult<Outbox> {
        let timeout = stream::timeout(timeout)?;
        let rx = self.engine(py).outgoing();
        Ok(Outbox::new(rx, &self.board, timeout))
    }

    /// The plan of that name (a live view of its state). Raises `UnknownObjectError`.
    fn plan(&self, py: Python<'_>, name: &str) -> PyResult<Plan> {
        let engine = self.engine(py);
        if py.detach(|| engine.status(name)).is_none() {
            return Err(errors::new(
                py,
                Kind::UnknownObject,
                format!("no plan named {name}"),
            ));
        }
        Ok(Plan::new(engine.clone(), name.to_owned()))
    }

    /// Every plan, in installation order.
    fn plans(&self, py: Python<'_>) -> Vec<Plan> {
        let engine = self.engine(py);
        py.detach(|| engine.plans())
            .into_iter()
            .map(|s| Plan::new(engine.clone(), s.name))
            .collect()
    }

    /// Counters: revision, objects, classes, function_failures, chain_cuts.
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.without_gil(py, Board::stats);
        let d = PyDict::new(py);
        d.set_item("revision", s.revision)?;
        d.set_item("objects", s.objects)?;
        d.set_item("classes", s.classes)?;
        d.set_item("function_failures", s.function_failures)?;
        d.set_item("chain_cuts", s.chain_cuts)?;
        Ok(d)
    }

    /// The class tree, declarations, objects and their packets, as indented text.
    fn dump(&self, py: Python<'_>) -> String {
        self.without_gil(py, Board::dump)
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        let s = self.without_gil(py, Board::stats);
        format!(
            "Board(address={}, revision={}, objects={}, classes={})",
            quote(self.board.address().as_str()),
            s.revision,
            s.objects,
            s.classes
        )
    }

    fn __traverse__(&self, visit: PyVisit<'_>) -> Result<(), PyTraverseError> {
        if let Some(fns) = self.fns.try_lock() {
            for f in fns.iter() {
                f.traverse(&visit)?;
            }
        }
        Ok(())
    }

    fn __clear__(&self) {
        let fns = std::mem::take(&mut *self.fns.lock());
        for f in fns {
            drop(f.clear());
        }
    }
}

/// What a board knows about an object or class.
#[pyclass(module = "slate", name = "Info", frozen, get_all)]
pub(crate) struct Info {
    /// Its name.
    name: String,
    /// Its class (for a class: its parent class).
    class_name: String,
    /// Is it a class?
    is_class: bool,
    /// `"self"`, `"surroundings"` or `"system"`.
    context: &'static str,
    /// The owning module.
    owner: String,
}

#[pymethods]
impl Info {
    fn __repr__(&self) -> String {
        format!(
            "Info(name={}, class_name={}, is_class={}, context={}, owner={})",
            quote(&self.name),
            quote(&self.class_name),
            if self.is_class { "True" } else { "False" },
            quote(self.context),
            quote(&self.owner)
        )
    }
}
