//! [`Node`]: one module's board, plan engine, ICI, plan circuits and transport, with the
//! threads that run them on the system clock, an event log and an optional dashboard.

use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use parking_lot::Mutex;
use slate_dashboard::Dashboard;
use slate_ici::{
    Ici, IciConfig, LinkPolicy, PlanCircuits, PlanHandle, SendPlanError, Transport, link_kind,
};
use slate_model::{Address, Board, Clock};
use slate_plans::{Engine, LinkName, LoadError, Loaded};
use slate_zenoh::{ZenohConfig, ZenohTransport};
use zenoh::query::Queryable;

use crate::authority::{
    PlanSender, WritesFrom, default_plans_from, plan_authority, write_authority,
};
use crate::config::{NodeConfig, SourceFile, default_ici};
use crate::error::StartError;
use crate::foxglove::Foxglove;
use crate::monitor::{EventLog, Level, Monitor, NodeEvent};
use crate::record::{RecordConfig, RecordError, RecordStats, Recorder};
use crate::state::{Keeper, Restored, StateConfig, StateError, StateStats, Store};
use crate::team_keys::{self, Identity};
use crate::timers::Timers;
use crate::view::View;

/// What carries a node's messages.
#[derive(Clone)]
pub enum TransportChoice {
    /// A Zenoh session opened with this config.
    Zenoh(ZenohConfig),
    /// Any transport at the node's address: a simulator endpoint (`SimNet::join`), or one
    /// opened by the caller.
    Custom(Arc<dyn Transport>),
}

/// A `.slate` source to load at start.
#[derive(Clone, Debug)]
enum Source {
    File(SourceFile),
    Text { name: String, text: String },
}

/// Builds a [`Node`]: the address, a transport, and optionally a board, an engine, the
/// ICI's settings, sources to load and a dashboard.
///
/// ```
/// use slate_ici::SimNet;
/// use slate_model::Address;
/// use slate_node::Node;
///
/// let net = SimNet::new(7);
/// let address = Address::new("team/r1/nav")?;
/// let node = Node::builder(address.clone())
///     .transport(net.join(&address))
///     .clock(net.clock())
///     .source("world.slate", "class Vehicle { speed: real = 0.0; } object gsr : Vehicle;")
///     .start()?;
/// node.board().write("gsr", "speed", 2.5)?;
/// node.close();
/// # Ok::<(), slate_node::Error>(())
/// ```
pub struct NodeBuilder {
    address: Address,
    transport: TransportChoice,
    board: Option<Arc<Board>>,
    engine: Option<Engine>,
    clock: Option<Clock>,
    ici: IciConfig,
    sources: Vec<Source>,
    dashboard: Option<SocketAddr>,
    dashboard_token: Option<String>,
    foxglove: Option<SocketAddr>,
    record: Option<RecordConfig>,
    state: Option<StateConfig>,
    plans_from: Vec<PlanSender>,
    writes_from: Vec<WritesFrom>,
}

impl NodeBuilder {
    /// A node at `address`, on Zenoh with the default config and a node's ICI settings
    /// ([`default_ici`]), until told otherwise.
    pub fn new(address: Address) -> Self {
        NodeBuilder {
            address,
            transport: TransportChoice::Zenoh(ZenohConfig::default()),
            board: None,
            engine: None,
            clock: None,
            ici: default_ici(),
            sources: Vec::new(),
            dashboard: None,
            dashboard_token: None,
            foxglove: None,
            record: None,
            state: None,
            plans_from: default_plans_from(),
            writes_from: Vec::new(),
        }
    }

    /// Joins a Zenoh network.
    pub fn zenoh(mut self, config: ZenohConfig) -> Self {
        self.transport = TransportChoice::Zenoh(config);
        self
    }

    /// Uses this transport (its address must be the node's).
    pub fn transport(mut self, transport: Arc<dyn Transport>) -> Self {
        self.transport = TransportChoice::Custom(transport);
        self
    }

    /// Uses an existing board (at the node's address) instead of a new one.
    pub fn board(mut self, board: Arc<Board>) -> Self {
        self.board = Some(board);
        self
    }

    /// Uses the board's existing plan engine (whoever made it runs its deadline timers on
    /// the system clock: [`Engine::run_timers`]).
    pub fn engine(mut self, engine: Engine) -> Self {
        self.engine = Some(engine);
        self
    }

    /// The clock of a new board (default: the system clock; a simulator's for `SimNet`).
    pub fn clock(mut self, clock: Clock) -> Self {
        self.clock = Some(clock);
        self
    }

    /// The ICI's settings (interest, export policy, timing), in place of [`default_ici`].
    pub fn ici(mut self, config: IciConfig) -> Self {
        self.ici = config;
        self
    }

    /// Loads a `.slate` file at start (files and sources in the order given): a path, or
    /// a [`SourceFile`] with the placeholders to replace in its text.
    pub fn file(mut self, file: impl Into<SourceFile>) -> Self {
        self.sources.push(Source::File(file.into()));
        self
    }

    /// Loads `.slate` source text at start; `name` names it in diagnostics.
    pub fn source(mut self, name: &str, text: &str) -> Self {
        self.sources.push(Source::Text {
            name: name.to_owned(),
            text: text.to_owned(),
        });
        self
    }

    /// Serves the Foxglove WebSocket protocol on `addr` (port 0: any free port, see
    /// [`Node::foxglove_addr`]): docs/foxglove.md.
    pub fn foxglove(mut self, addr: SocketAddr) -> Self {
        self.foxglove = Some(addr);
        self
    }

    /// Serves the dashboard on `addr` (port 0: any free port, see [`Node::dashboard_url`]).
    pub fn dashboard(mut self, addr: SocketAddr) -> Self {
        self.dashboard = Some(addr);
        self
    }

    /// Requires `token` of the dashboard's clients (without it, a dashboard on an
    /// address other than loopback generates one; [`Node::dashboard_url`] carries it).
    pub fn dashboard_token(mut self, token: String) -> Self {
        self.dashboard_token = Some(token);
        self
    }

    /// Records the board from the start (`docs/recording.md`).
    pub fn record(mut self, config: RecordConfig) -> Self {
        self.record = Some(config);
        self
    }

    /// Keeps the board in a state directory across restarts: what it holds is restored
    /// after the sources load and before the node joins the network (`docs/design.md`,
    /// "A restart").
    pub fn state(mut self, config: StateConfig) -> Self {
        self.state = Some(config);
        self
    }

    /// Who may send the node plans (by default its robot's modules and the team's
    /// operators: [`default_plans_from`]).
    pub fn plans_from(mut self, senders: Vec<PlanSender>) -> Self {
        self.plans_from = senders;
        self
    }

    /// Who may write which classes and attributes on the node's board besides itself
    /// (`[authority.writes]`; by default no rule: any module, as the merge policies
    /// allow). Each rule's class and attribute must be on the board once its sources
    /// load, or the start fails.
    pub fn writes_from(mut self, rules: Vec<WritesFrom>) -> Self {
        self.writes_from = rules;
        self
    }

    /// Starts the node: loads the sources, restores its state, joins the network, starts the ICI, the plan
    /// circuits, the timers (on the system clock) and the dashboard.
    pub fn start(self) -> Result<Node, StartError> {
        let board = match self.board {
            Some(b) if b.address() != &self.address => {
                return Err(StartError::BoardAddress {
                    board: b.address().clone(),
                    node: self.address,
                });
            }
            Some(b) => b,
            None => Arc::new(
                Board::builder()
                    .address(self.address.clone())
                    .clock(self.clock.unwrap_or_default())
                    .build(),
            ),
        };
        let system_clock = !board.clock().is_manual();
        let engine = match self.engine {
            Some(e) => e,
            None => {
                let e = Engine::new(&board);
                if system_clock {
                    drop(e.run_timers());
                }
                e
            }
        };
        for source in &self.sources {
            load(&engine, source)?;
        }
        let kept = match &self.state {
            Some(config) => Some(restore_state(&board, config)?),
            None => None,
        };
        let mut ici_config = self.ici;
        for (name, policy) in engine.link_policies() {
            LinkPolicy::from(&policy).apply_to(link_kind(name), &mut ici_config);
        }
        let mut zenoh = None;
        let operators = secured_operators(&self.address, &self.transport);
        let authority = plan_authority(&self.address, &self.plans_from, operators.as_deref());
        let writes = write_authority(
            &self.address,
            &self.writes_from,
            operators.as_deref(),
            &board,
        )
        .map_err(StartError::Authority)?;
        board.set_write_authority(writes);
        let (transport, listen): (Arc<dyn Transport>, Vec<String>) = match self.transport {
            TransportChoice::Zenoh(config) => {
                let t = ZenohTransport::open(self.address.clone(), &config)?;
                // Once open: a start that fails is one error line (docs/cli.md).
                say_how_secured(&self.address, &config);
                zenoh = Some(t.clone());
                (t, config.listen.clone())
            }
            TransportChoice::Custom(t) => (t, Vec::new()),
        };
        let interest = ici_config.interest.clone();
        let ici = match Ici::new(board.clone(), transport.clone(), ici_config) {
            Ok(ici) => ici,
            Err(e) => {
                transport.close();
                return Err(e.into());
            }
        };
        let links: Vec<LinkName> = engine.link_policies().into_keys().collect();
        apply_link_policies(&ici, &engine, &links);
        let circuits = Arc::new(PlanCircuits::attach(&ici, &engine));
        circuits.set_authority(authority);
        let (keeper, restored) = match (kept, &self.state) {
            (Some(kept), Some(config)) => match keep_state(&board, config, kept, &circuits) {
                Ok((keeper, restored)) => (Some(keeper), Some(restored)),
                Err(e) => {
                    transport.close();
                    return Err(e.into());
                }
            },
            _ => (None, None),
        };
        let log = Arc::new(EventLog::default());
        let monitor = Monitor::start(&board, &engine, (&ici, interest, &circuits), log.clone());
        let timers = system_clock.then(|| Timers::start(ici.clone()));
        let mut view = View::new(board, engine, ici, transport, circuits, log, listen);
        view.state = keeper.as_ref().map(Keeper::shared_stats);
        let view = Arc::new(view);
        let node = Node {
            view,
            threads: Mutex::new(Threads {
                monitor: Some(monitor),
                timers,
                dashboard: None,
                recorder: None,
                keeper,
                stats: None,
                foxglove: None,
            }),
            restored,
            closed: AtomicBool::new(false),
        };
        if let Some(config) = self.record
            && let Err(e) = node.start_recording(config)
        {
            node.close();
            return Err(e.into());
        }
        node.started();
        if let Some(z) = zenoh {
            node.serve_stats(&z);
        }
        if let Some(addr) = self.foxglove {
            match Foxglove::start(addr, &node.view.board) {
                Ok(f) => node.threads.lock().foxglove = Some(f),
                Err(e) => {
                    node.close();
                    return Err(e.into());
                }
            }
        }
        if let Some(addr) = self.dashboard {
            let token = self.dashboard_token;
            let dashboard = slate_dashboard::serve_with_token(addr, node.view.clone(), token);
            match dashboard {
                Ok(d) => node.threads.lock().dashboard = Some(d),
                Err(e) => {
                    node.close();
                    return Err(e.into());
                }
            }
        }
        Ok(node)
    }
}

/// The names of a secured team's operators, from the keys its Zenoh session runs with
/// (`None`: an insecure team, or a transport of the caller's).
fn secured_operators(me: &Address, transport: &TransportChoice) -> Option<Vec<String>> {
    let TransportChoice::Zenoh(config) = transport else {
        return None;
    };
    let team = config.security.as_ref()?.team.as_ref()?;
    let names = team.operators.iter().filter(|(t, _)| t == me.team());
    Some(names.map(|(_, name)| name.clone()).collect())
}

/// Hands the engine's merged policies of `links` (the `link` blocks of every file it
/// loaded) to the ICI. The node is where both exist: slate-plans does not depend on the
/// ICI, and a file can be loaded after the circuits are attached (`Node::load`).
fn apply_link_policies(ici: &Ici, engine: &Engine, links: &[LinkName]) {
    let policies = engine.link_policies();
    for name in links {
        if let Some(policy) = policies.get(name) {
            ici.set_link_policy(link_kind(*name), LinkPolicy::from(policy));
        }
    }
}

/// Opens the state directory, restores what it holds onto `board` and starts keeping
/// the board there.
/// A state directory's store, opened and put back on the board (before the node joins
/// its team), with the plans received it held, to install once the circuits exist.
struct Kept {
    store: Store,
    restored: Restored,
    plans: Vec<slate_ici::HeldPlan>,
}

fn restore_state(board: &Board, config: &StateConfig) -> Result<Kept, StateError> {
    let store = Store::open(&config.dir, board.address(), config.durability)?;
    let mut saved = store.load()?;
    let plans = std::mem::take(&mut saved.plans);
    let restored = crate::state::restore(board, saved);
    Ok(Kept {
        store,
        restored,
        plans,
    })
}

/// Installs the plans received again and starts keeping the board (and those plans).
fn keep_state(
    board: &Arc<Board>,
    config: &StateConfig,
    kept: Kept,
    circuits: &Arc<PlanCircuits>,
) -> Result<(Keeper, Restored), StateError> {
    let Kept {
        store,
        mut restored,
        plans,
    } = kept;
    crate::state::reinstate(circuits, plans, &mut restored);
    tracing::info!(dir = %config.dir.display(), ?restored, "state restored");
    let keeper = Keeper::start(board.clone(), store, config, Some((**circuits).clone()))?;
    Ok((keeper, restored))
}

fn load(engine: &Engine, source: &Source) -> Result<Loaded, StartError> {
    match source {
        Source::File(SourceFile { path, substitute }) => {
            let text = std::fs::read_to_string(path).map_err(|error| StartError::ReadSource {
                path: path.clone(),
                error,
            })?;
            let text = substitute.apply(&text);
            Ok(engine.load(&path.display().to_string(), &text)?)
        }
        Source::Text { name, text } => Ok(engine.load(name, text)?),
    }
}

impl slate_dashboard::DashboardSource for View {
    fn snapshot(&self) -> serde_json::Value {
        View::snapshot(self)
    }
}

struct Threads {
    monitor: Option<Monitor>,
    timers: Option<Timers>,
    dashboard: Option<Dashboard>,
    recorder: Option<Recorder>,
    keeper: Option<Keeper>,
    /// The queryable answering `slate stats` (on Zenoh only).
    stats: Option<Queryable<()>>,
    foxglove: Option<Foxglove>,
}

/// One module of a robot: a [`Board`], its plan [`Engine`], its [`Ici`] over a
/// [`Transport`] (Zenoh, or the simulator), and its [`PlanCircuits`] (plans sent to and
/// received from other modules, with their acknowledgements).
///
/// On the system clock a timer thread runs the ICI's timers and the engine's deadlines,
/// and a monitor thread keeps the event log. On a manual clock (the simulator) the node
/// starts no thread: timers and the event log move with the clock, in the thread that
/// moves it, so a simulated run depends on nothing but its seed.
/// [`close`](Node::close) (or drop) flushes what is in flight and leaves the network;
/// peers see the module go down.
///
/// ```no_run
/// use slate_node::{Node, NodeConfig};
/// let node = Node::start(&NodeConfig::read("module.toml".as_ref())?)?;
/// println!("{} sees {:?}", node.address(), node.peers());
/// node.close();
/// # Ok::<(), slate_node::Error>(())
/// ```
pub struct Node {
    /// Its parts (board, engine, ICI, transport, circuits, event log), which the
    /// dashboard's view reads too.
    view: Arc<View>,
    threads: Mutex<Threads>,
    /// What the state directory gave back at start, if the node keeps one.
    restored: Option<Restored>,
    closed: AtomicBool,
}

impl Node {
    /// A builder for a node at `address`.
    pub fn builder(address: Address) -> NodeBuilder {
        NodeBuilder::new(address)
    }

    /// Starts a node from its config (Zenoh, the files, interest, export, dashboard).
    ///
    /// With `[security]`, the team's keys are checked first (readable, the certificate
    /// for this address and signed by the team's authority, the key its own): the node
    /// refuses to start otherwise, naming the file and what to do.
    pub fn start(config: &NodeConfig) -> Result<Node, StartError> {
        let mut zenoh = config.zenoh.clone();
        if let Some(dir) = &config.security {
            let me = Identity::Module(config.address.clone());
            zenoh.security = Some(team_keys::security(dir, &me)?);
        }
        let mut b = NodeBuilder::new(config.address.clone())
            .zenoh(zenoh)
            .ici(config.ici.clone());
        for f in &config.files {
            b = b.file(f.clone());
        }
        if let Some(d) = config.dashboard {
            b = b.dashboard(d);
        }
        if let Some(token) = &config.dashboard_token {
            b = b.dashboard_token(token.clone());
        }
        if let Some(f) = config.foxglove {
            b = b.foxglove(f);
        }
        if let Some(r) = &config.record {
            b = b.record(r.clone());
        }
        if let Some(s) = &config.state {
            b = b.state(s.clone());
        }
        b.plans_from(config.plans_from.clone())
            .writes_from(config.writes_from.clone())
            .start()
    }

    fn started(&self) {
        let me = self.address();
        if let Some(r) = self.restored {
            let text = format!(
                "{me} restored its board: {} objects, {} packets ({} refused)",
                r.objects, r.packets, r.refused
            );
            self.log(Level::Info, text);
        }
        if self.view.listen.is_empty() {
            self.log(Level::Info, format!("{me} started"));
        } else {
            let on = self.view.listen.join(", ");
            self.log(Level::Info, format!("{me} started, listening on {on}"));
        }
    }

    fn log(&self, level: Level, text: String) {
        self.view.log.push(&self.view.board, level, text);
    }

    /// The module's address.
    pub fn address(&self) -> &Address {
        self.view.board.address()
    }

    /// The board.
    pub fn board(&self) -> &Arc<Board> {
        &self.view.board
    }

    /// The plan engine.
    pub fn engine(&self) -> &Engine {
        &self.view.engine
    }

    /// The ICI.
    pub fn ici(&self) -> &Ici {
        &self.view.ici
    }

    /// Its counters, as `slate stats` shows them (`uptime_s` is zero: the node does not
    /// keep its start time; the stats query answers with it).
    pub fn stats(&self) -> crate::ModuleStats {
        crate::ModuleStats::of_view(&self.view, std::time::Duration::ZERO)
    }

    /// The plan circuits.
    pub fn circuits(&self) -> &PlanCircuits {
        &self.view.circuits
    }

    /// The transport.
    pub fn transport(&self) -> &Arc<dyn Transport> {
        &self.view.transport
    }

    /// Loads `.slate` source text into the board (classes, objects, rules, plans).
    /// A file's `link` blocks change the ICI's link policies at once.
    pub fn load(&self, name: &str, text: &str) -> Result<Loaded, LoadError> {
        let loaded = self.view.engine.load(name, text)?;
        apply_link_policies(&self.view.ici, &self.view.engine, &loaded.links);
        Ok(loaded)
    }

    /// Sends a plan (`plan NAME { ... }` source text) to another module on a virtual
    /// circuit; the handle's `acks()` yields its acknowledgements as they arrive.
    pub fn send_plan(&self, to: &Address, text: &str) -> Result<PlanHandle, SendPlanError> {
        self.view.circuits.send(to, text)
    }

    /// The modules this node holds alive.
    pub fn peers(&self) -> Vec<Address> {
        self.view.ici.alive_peers()
    }

    /// The Zenoh endpoints it listens on (empty on another transport).
    pub fn listening(&self) -> &[String] {
        &self.view.listen
    }

    /// Where its Foxglove server listens, if it serves one.
    pub fn foxglove_addr(&self) -> Option<SocketAddr> {
        self.threads.lock().foxglove.as_ref().map(Foxglove::addr)
    }

    /// The dashboard's URL, if it serves one.
    pub fn dashboard_url(&self) -> Option<String> {
        self.threads.lock().dashboard.as_ref().map(Dashboard::url)
    }

    /// The last events: peers up and down, plan progress, failed active functions.
    pub fn events(&self) -> Vec<NodeEvent> {
        self.view.log.events()
    }

    /// Every event logged from now on (peers up and down, plan progress, conflicts,
    /// failed functions), as it is logged; a follower that falls 1024 events behind
    /// misses the newer ones.
    pub fn follow_events(&self) -> crossbeam_channel::Receiver<NodeEvent> {
        self.view.log.follow()
    }

    /// The dashboard's view of this node, as JSON (`docs/dashboard.md`).
    pub fn snapshot(&self) -> serde_json::Value {
        self.view.snapshot()
    }

    /// The dashboard's view of this node, typed (what [`snapshot`](Node::snapshot)
    /// serialises): for a program that shows this node among others, as the demo shows
    /// its console's classes and objects.
    pub fn view(&self) -> slate_dashboard::Snapshot {
        self.view.view()
    }

    /// Starts recording the board to MCAP files (`docs/recording.md`), from what it holds
    /// now on; a recording already running is finished first.
    pub fn start_recording(&self, config: RecordConfig) -> Result<(), RecordError> {
        self.stop_recording()?;
        let recorder = Recorder::start(&self.view, config)?;
        self.threads.lock().recorder = Some(recorder);
        Ok(())
    }

    /// Finishes the recording (what is waiting is written, then the file's summary),
    /// with its final counters; `None` if it was not recording.
    pub fn stop_recording(&self) -> Result<Option<RecordStats>, RecordError> {
        let recorder = self.threads.lock().recorder.take();
        recorder.map(|mut r| r.stop()).transpose()
    }

    /// The recording's counters so far, if it records.
    pub fn recording(&self) -> Option<RecordStats> {
        self.threads.lock().recorder.as_ref().map(Recorder::stats)
    }

    /// What its state directory gave back at start (`None`: it keeps no state).
    pub fn restored(&self) -> Option<Restored> {
        self.restored
    }

    /// The state keeper's counters so far (after [`close`](Node::close): its final
    /// ones), if it keeps its board.
    pub fn state(&self) -> Option<StateStats> {
        self.view.state.as_ref().map(|s| s.lock().clone())
    }

    /// Answers stats queries on `zenoh` (`crate::stats`); a node that cannot still runs,
    /// and says so.
    fn serve_stats(&self, zenoh: &ZenohTransport) {
        match crate::stats::serve(zenoh.session(), &self.view) {
            Ok(q) => self.threads.lock().stats = Some(q),
            Err(e) => tracing::warn!("slate stats will not see this node: {e}"),
        }
    }

    /// Has it been closed?
    pub fn is_closed(&self) -> bool {
        self.closed.load(Ordering::Acquire)
    }

    /// Stops: the dashboard and the timers first, then what the board committed is sent
    /// (the ICI drains its changes), then the transport closes (Zenoh sends what it has
    /// queued before the session ends) and peers see the module go down. Idempotent.
    pub fn close(&self) {
        if self.closed.swap(true, Ordering::AcqRel) {
            return;
        }
        let mut threads = self.threads.lock();
        if let Some(d) = threads.dashboard.take() {
            d.stop();
        }
        drop(threads.stats.take());
        if let Some(mut f) = threads.foxglove.take() {
            f.stop();
        }
        if let Some(mut t) = threads.timers.take() {
            t.stop();
        }
        self.view.ici.tick();
        tracing::debug!(stats = ?self.view.ici.stats(), "ICI counters at close");
        self.view.transport.close();
        self.log(Level::Info, format!("{} stopped", self.address()));
        if let Some(mut m) = threads.monitor.take() {
            m.stop();
        }
        if let Some(mut r) = threads.recorder.take()
            && let Err(e) = r.stop()
        {
            tracing::error!("{e}");
        }
        if let Some(mut k) = threads.keeper.take()
            && let Err(e) = k.stop()
        {
            tracing::error!("{e}");
        }
    }
}

impl Drop for Node {
    fn drop(&mut self) {
        self.close();
    }
}

/// One log line at start: whether the node's links are authenticated and encrypted, and
/// how to make them so when they are not.
fn say_how_secured(me: &Address, config: &ZenohConfig) {
    match &config.security {
        Some(s) => match &s.team {
            Some(team) => tracing::info!(
                "{me}: secured: TLS with mutual authentication as {me}; access control for {} modules and {} operators",
                team.modules.len(),
                team.operators.len()
            ),
            None => tracing::info!(
                "{me}: secured: TLS with mutual authentication, through the node it connects to"
            ),
        },
        None => tracing::info!(
            "{me}: insecure: links are neither authenticated nor encrypted, and anyone on the network may speak as any module (add [security] keys = \"DIR\" to the config; docs/security.md)"
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_built_node_starts_from_the_same_ici_settings_as_a_configured_one() {
        let address = Address::new("t/r1/nav").unwrap();
        let built = NodeBuilder::new(address.clone());
        assert_eq!(built.ici, NodeConfig::new(address).ici);
    }
}
