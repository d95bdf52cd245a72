//! `Node`: a board on the network (its ICI over Zenoh, its plan circuits), `PlanHandle`
//! (a plan sent, and its acknowledgements as they arrive) and `Ack`.

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;
use parking_lot::Mutex;
use pyo3::prelude::*;
use pyo3::types::PyString;
use slate_ici::LOST_WAIT;
use slate_model::{Address, Board};
use slate_node::{Node, RecordConfig, StateConfig};
use slate_wire::PlanStep;
use slate_zenoh::{Mode, ZenohConfig};

use crate::board::PyBoard;
use crate::errors::{self, Kind};
use crate::packet::{quote, to_address};
use crate::stream;

/// One module on the network: a board, its plan engine, its ICI over Zenoh and its plan
/// circuits. `Node("team/r1/nav", connect=["tcp/127.0.0.1:7447"])`; a `with` block closes
/// it. Without `board=`, it makes a board at its address on the system clock.
#[pyclass(module = "slate", name = "Node", frozen)]
pub(crate) struct PyNode {
    node: Arc<Node>,
    board: Py<PyBoard>,
}

/// The Zenoh settings from the keyword arguments.
fn zenoh(
    py: Python<'_>,
    mode: &str,
    listen: Vec<String>,
    connect: Vec<String>,
) -> PyResult<ZenohConfig> {
    let mode = match mode {
        "peer" => Mode::Peer,
        "router" => Mode::Router,
        "client" => Mode::Client,
        other => {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "mode {} is not \"peer\", \"router\" or \"client\"",
                quote(other)
            )));
        }
    };
    let _ = py;
    for (key, list) in [("listen", &listen), ("connect", &connect)] {
        for e in list {
            slate_zenoh::check_endpoint(e)
                .map_err(|why| pyo3::exceptions::PyValueError::new_err(format!("{key}: {why}")))?;
        }
    }
    Ok(ZenohConfig {
        mode,
        listen,
        connect,
        multicast_scouting: false,
        file: None,
        security: None,
        // Not yet measured from Python (docs/performance.md, *Bytes on the radio*).
        udp_reports: false,
    })
}

/// A class set from `["Vehicle", "Obstacle:surroundings"]`.
fn classes(
    which: &str,
    entries: Option<Vec<String>>,
    default: slate_ici::ClassSet,
) -> PyResult<slate_ici::ClassSet> {
    match entries {
        None => Ok(default),
        Some(e) => slate_node::class_set(&e)
            .map_err(|why| pyo3::exceptions::PyValueError::new_err(format!("{which}: {why}"))),
    }
}

/// The nodes open in this process, with their boards: one module has one node, and one
/// board one node (two would answer each other's catch-ups and send every report twice).
static OPEN_NODES: Mutex<Vec<std::sync::Weak<Node>>> = Mutex::new(Vec::new());

/// Refuses a node on a board or at an address an open node of this process already has.
fn check_not_open(py: Python<'_>, address: &Address, board: &Arc<Board>) -> PyResult<()> {
    let mut open = OPEN_NODES.lock();
    open.retain(|n| n.upgrade().is_some_and(|n| !n.is_closed()));
    for node in open.iter().filter_map(std::sync::Weak::upgrade) {
        let why = if Arc::ptr_eq(node.board(), board) {
            format!(
                "this board already has an open node, {}: close it first, or give the new node its own board",
                node.address()
            )
        } else if node.address() == address {
            format!(
                "a node {address} is already open in this process: close it first, or give each module its own address"
            )
        } else {
            continue;
        };
        return Err(errors::new(py, Kind::Node, why));
    }
    Ok(())
}

/// The entries of `key` (`plans_from=`, or one of `writes=`), or a ValueError naming
/// the one that is wrong.
fn plan_senders(key: &str, entries: &[String]) -> PyResult<Vec<slate_node::PlanSender>> {
    let parse = |e: &String| {
        e.parse().map_err(|why: slate_ici::PatternError| {
            pyo3::exceptions::PyValueError::new_err(format!(
                "{key}: {why}; or \"robot\" or \"operators\""
            ))
        })
    };
    entries.iter().map(parse).collect()
}

/// `writes=`: `{"Class.attr" or "Class": [entries as in plans_from]}`, as
/// `[authority.writes]` in a node's config.
fn write_rules(rules: BTreeMap<String, Vec<String>>) -> PyResult<Vec<slate_node::WritesFrom>> {
    rules
        .into_iter()
        .map(|(target, entries)| {
            let writers = plan_senders(&format!("writes[{}]", quote(&target)), &entries)?;
            Ok(slate_node::WritesFrom::new(&target, writers))
        })
        .collect()
}

#[pymethods]
impl PyNode {
    #[new]
    #[pyo3(signature = (address, board=None, *, connect=None, listen=None, mode="peer", interest=None, export=None, lossless=None, dashboard=None, record=None, state=None, plans_from=None, writes=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        address: &str,
        board: Option<Py<PyBoard>>,
        connect: Option<Vec<String>>,
        listen: Option<Vec<String>>,
        mode: &str,
        interest: Option<Vec<String>>,
        export: Option<Vec<String>>,
        lossless: Option<Vec<String>>,
        dashboard: Option<&str>,
        record: Option<PathBuf>,
        state: Option<PathBuf>,
        plans_from: Option<Vec<String>>,
        writes: Option<BTreeMap<String, Vec<String>>>,
    ) -> PyResult<Self> {
        let addr = to_address(py, address)?;
        let board = match board {
            Some(b) => b,
            None => Py::new(py, PyBoard::for_node(addr.clone()))?,
        };
        let zenoh = zenoh(
            py,
            mode,
            listen.unwrap_or_default(),
            connect.unwrap_or_default(),
        )?;
        let ici = slate_node::default_ici()
            .interest(classes("interest", interest, slate_ici::ClassSet::all())?)
            .export(classes("export", export, slate_ici::ClassSet::none())?)
            .lossless(classes("lossless", lossless, slate_ici::ClassSet::none())?);
        let dashboard: Option<SocketAddr> = dashboard
            .map(|d| {
                d.parse().map_err(|_| {
                    pyo3::exceptions::PyValueError::new_err(format!(
                        "dashboard {} is not an address like \"127.0.0.1:8080\"",
                        quote(d)
                    ))
                })
            })
            .transpose()?;
        let b = board.get();
        check_not_open(py, &addr, b.inner())?;
        let engine = b.engine(py).clone();
        let mut builder = Node::builder(addr)
            .zenoh(zenoh)
            .ici(ici)
            .board(b.inner().clone())
            .engine(engine);
        if let Some(d) = dashboard {
            builder = builder.dashboard(d);
        }
        if let Some(path) = record {
            builder = builder.record(RecordConfig::new(path));
        }
        if let Some(dir) = state {
            builder = builder.state(StateConfig::new(dir));
        }
        if let Some(entries) = plans_from {
            builder = builder.plans_from(plan_senders("plans_from", &entries)?);
        }
        if let Some(rules) = writes {
            builder = builder.writes_from(write_rules(rules)?);
        }
        let node = py
            .detach(|| builder.start())
            .map_err(|e| errors::new(py, Kind::Node, e.to_string()))?;
        let node = Arc::new(node);
        OPEN_NODES.lock().push(Arc::downgrade(&node));
        Ok(PyNode { node, board })
    }

    /// The module's address.
    #[getter]
    fn address(&self) -> String {
        self.node.address().to_string()
    }

    /// The node's board.
    #[getter]
    fn board(&self, py: Python<'_>) -> Py<PyBoard> {
        self.board.clone_ref(py)
    }

    /// The Zenoh endpoints it listens on.
    #[getter]
    fn listening(&self) -> Vec<String> {
        self.node.listening().to_vec()
    }

    /// The dashboard's URL, if it serves one.
    #[getter]
    fn dashboard_url(&self) -> Option<String> {
        self.node.dashboard_url()
    }

    /// What its state directory gave back when it started (`objects`, `packets`,
    /// `refused`), or None without `state=`.
    #[getter]
    fn restored(&self) -> Option<std::collections::BTreeMap<&'static str, usize>> {
        self.node.restored().map(|r| {
            [
                ("objects", r.objects),
                ("packets", r.packets),
                ("refused", r.refused),
            ]
            .into()
        })
    }

    /// Has it been closed?
    #[getter]
    fn closed(&self) -> bool {
        self.node.is_closed()
    }

    /// The modules it holds alive, sorted.
    fn peers(&self, py: Python<'_>) -> Vec<String> {
        let mut peers: Vec<String> = py
            .detach(|| self.node.peers())
            .iter()
            .map(ToString::to_string)
            .collect();
        peers.sort();
        peers
    }

    /// Sends a plan (source text of one `plan NAME { ... }`) to the module `to`, on a
    /// virtual circuit. The handle's `acks` yields its acknowledgements as they arrive.
    #[pyo3(signature = (source, *, to))]
    fn send_plan(&self, py: Python<'_>, source: &str, to: &str) -> PyResult<PlanHandle> {
        let to = to_address(py, to)?;
        if self.node.is_closed() {
            return Err(errors::new(py, Kind::Plan, "the node is closed"));
        }
        let handle = py
            .detach(|| self.node.send_plan(&to, source))
            .map_err(|e| errors::new(py, Kind::Plan, e.to_string()))?;
        Ok(PlanHandle {
            node: self.node.clone(),
            circuit: handle.circuit,
            name: handle.name.clone(),
            to: handle.to.to_string(),
            acks: handle.acks().clone(),
            done: Arc::new(AtomicBool::new(false)),
            lost_at: Mutex::new(None),
        })
    }

    /// The dashboard's view of the node as a dict (map items, classes, objects, plans,
    /// links, events; see docs/dashboard.md).
    fn snapshot(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let text = py.detach(|| self.node.snapshot().to_string());
        let json = py.import("json")?;
        Ok(json
            .call_method1("loads", (PyString::new(py, &text),))?
            .unbind())
    }

    /// The ICI's counters, as `slate stats --format json` prints a module's (docs/cli.md):
    /// `traffic` per link and message kind, `drops`, `catch_up` (`gaps` found in a
    /// source's stream: what the network lost or dropped), `merges`, `peers`.
    fn stats(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let text = py.detach(|| serde_json::to_string(&self.node.stats()).unwrap_or_default());
        let json = py.import("json")?;
        Ok(json
            .call_method1("loads", (PyString::new(py, &text),))?
            .unbind())
    }

    /// Leaves the network: what the board committed is sent first, then peers see the
    /// module go down. Idempotent; the board stays usable.
    fn close(&self, py: Python<'_>) {
        py.detach(|| self.node.close());
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    #[pyo3(signature = (exc_type=None, exc_value=None, traceback=None))]
    fn __exit__(
        &self,
        py: Python<'_>,
        exc_type: Option<&Bound<'_, PyAny>>,
        exc_value: Option<&Bound<'_, PyAny>>,
        traceback: Option<&Bound<'_, PyAny>>,
    ) -> bool {
        let _ = (exc_type, exc_value, traceback);
        self.close(py);
        false
    }

    fn __repr__(&self) -> String {
        let state = if self.node.is_closed() {
            ", closed"
        } else {
            ""
        };
        format!("Node({}{state})", quote(self.node.address().as_str()))
    }
}

/// A plan sent to another module: its circuit, and its acknowledgements.
#[pyclass(module = "slate", name = "PlanHandle", frozen)]
pub(crate) struct PlanHandle {
    node: Arc<Node>,
    /// The circuit's number.
    #[pyo3(get)]
    circuit: u64,
    /// The plan's name.
    #[pyo3(get)]
    name: String,
    /// The module running it.
    #[pyo3(get)]
    to: String,
    acks: Receiver<PlanStep>,
    /// The circuit closed (terminated, rejected, cancelled), or its destination was lost
    /// and not back within [`LOST_WAIT`].
    done: Arc<AtomicBool>,
    /// Since when the destination has been lost (a `destination_lost` ack and nothing
    /// after it).
    lost_at: Mutex<Option<Instant>>,
}

impl PlanHandle {
    fn next_ack(&self, py: Python<'_>, timeout: Option<Duration>) -> PyResult<Option<Ack>> {
        if self.done.load(Ordering::Acquire) {
            return Ok(None);
        }
        let node = self.node.clone();
        let alive = move || !node.is_closed();
        let lost_left = self.lost_left();
        let wait = match (timeout, lost_left) {
            (Some(t), Some(l)) => Some(t.min(l)),
            (t, l) => t.or(l),
        };
        let step = stream::next_from(py, &self.acks, wait, &alive)?;
        match &step {
            Some(s) => self.took(s),
            None if lost_left.is_some_and(|l| wait == Some(l)) => {
                self.done.store(true, Ordering::Release);
            }
            None => {}
        }
        Ok(step.as_ref().map(Ack::from))
    }

    /// How much longer a lost destination is waited for, if it is lost.
    fn lost_left(&self) -> Option<Duration> {
        self.lost_at
            .lock()
            .map(|at| LOST_WAIT.saturating_sub(at.elapsed()))
    }

    /// A step arrived: a loss starts the wait for the destination, any other step ends
    /// it, a closing one ends the handle.
    fn took(&self, step: &PlanStep) {
        *self.lost_at.lock() = (*step == PlanStep::DestinationLost).then(Instant::now);
        if step.closes_circuit() {
            self.done.store(true, Ordering::Release);
        }
    }
}

#[pymethods]
impl PlanHandle {
    /// The acknowledgements as they arrive: iterating waits for each (with the GIL
    /// released) and ends after the last one (terminated, rejected, cancelled) or when
    /// the node closes. A `destination_lost` ack is not the last: the circuit sends the
    /// plan again when the destination comes back and its acks resume; iteration ends
    /// if it is not back within 30 s.
    #[getter]
    fn acks(slf: Py<Self>) -> Acks {
        Acks { handle: slf }
    }

    /// The next acknowledgement, or `None` after `timeout` seconds (`None`: no limit),
    /// after the last one, or once the node is closed.
    #[pyo3(signature = (timeout=None))]
    fn get(&self, py: Python<'_>, timeout: Option<f64>) -> PyResult<Option<Ack>> {
        self.next_ack(py, stream::timeout(timeout)?)
    }

    /// Has the plan taken its last step?
    #[getter]
    fn done(&self) -> bool {
        self.done.load(Ordering::Acquire)
    }

    /// Asks the destination to cancel the plan (it acknowledges `cancelled`).
    fn cancel(&self, py: Python<'_>) -> PyResult<()> {
        py.detach(|| self.node.circuits().cancel(self.circuit))
            .map_err(|e| errors::new(py, Kind::Plan, e.to_string()))
    }

    fn __repr__(&self) -> String {
        format!(
            "PlanHandle(circuit={}, name={}, to={})",
            self.circuit,
            quote(&self.name),
            quote(&self.to)
        )
    }
}

/// Iterator over a plan's acknowledgements.
#[pyclass(module = "slate", name = "Acks", frozen)]
pub(crate) struct Acks {
    handle: Py<PlanHandle>,
}

#[pymethods]
impl Acks {
    fn __iter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    fn __next__(&self, py: Python<'_>) -> PyResult<Option<Ack>> {
        self.handle.get().next_ack(py, None)
    }
}

/// One step of a plan's progression, as its destination acknowledged it.
#[pyclass(module = "slate", name = "Ack", frozen, get_all)]
#[derive(Clone)]
pub(crate) struct Ack {
    /// `received`, `accepted`, `rejected`, `initiated`, `triggered`, `terminated`,
    /// `cancelled` or `destination_lost`.
    step: String,
    /// False for `rejected`, a failed `triggered` and `destination_lost`.
    ok: bool,
    /// What the action did (`fired 2`), why it failed, or why the plan was rejected.
    detail: String,
    /// Is it the last step of the circuit? Not for `destination_lost`: the destination
    /// may come back, and its acknowledgements resume.
    last: bool,
}

impl From<&PlanStep> for Ack {
    fn from(s: &PlanStep) -> Self {
        Ack {
            step: s.kind().to_owned(),
            ok: s.is_ok(),
            detail: s.detail().to_owned(),
            last: s.closes_circuit(),
        }
    }
}

#[pymethods]
impl Ack {
    fn __repr__(&self) -> String {
        let mut text = format!("Ack({}", quote(&self.step));
        if !self.ok {
            text.push_str(", ok=False");
        }
        if !self.detail.is_empty() {
            text.push_str(&format!(", detail={}", quote(&self.detail)));
        }
        text + ")"
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other.cast::<Ack>().is_ok_and(|o| {
            let o = o.get();
            (&o.step, o.ok, &o.detail) == (&self.step, self.ok, &self.detail)
        })
    }

    fn __hash__(&self) -> u64 {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        (&self.step, self.ok, &self.detail).hash(&mut h);
        h.finish()
    }
}
