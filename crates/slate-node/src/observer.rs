//! Short-lived observers: how the CLI's live verbs join a team over Zenoh, catch up with
//! every module's current state, and leave.
//!
//! An observer is a node like any other, at `TEAM/ROBOT/cli-PID`, and a Zenoh client of
//! the node it connects to: it models everything,
//! owns no object and writes only what it is told to (`slate put`), so it leaves no
//! object on anyone's board. The other modules keep a `Module` object for it, which goes
//! `alive = false` once it has left, like any module that stopped, and is deleted once it
//! has been dead for the ICI's `forget_dead` (10 min by default).

use std::collections::BTreeSet;
use std::sync::Arc;
use std::time::{Duration, Instant};

use slate_ici::{ClassSet, IciConfig, Transport};
use slate_model::Address;
use slate_zenoh::{Mode, OpenError, Security, ZenohConfig, ZenohTransport, keys};
use zenoh::Wait;

use crate::error::{ObserveError, StartError};
use crate::node::Node;
use crate::team_keys::{self, Identity};

/// The module segment of observers' addresses starts with this: the prefix a secured
/// team's access control lets an operator speak under (one constant for both).
pub const OBSERVER_PREFIX: &str = slate_zenoh::OPERATOR_PREFIX;

/// How an observer joins.
#[derive(Clone, Debug)]
pub struct ObserverOptions {
    /// Zenoh endpoints to connect to (a node's listen endpoint).
    pub connect: Vec<String>,
    /// The observer's address; by default `TEAM/ROBOT/cli-PID` on the robot of the first
    /// module found (by address). An observer on another robot than a module sees only
    /// what that module exports.
    pub address: Option<Address>,
    /// How long to wait for modules to answer and for their catch-up answers.
    pub wait: Duration,
    /// An operator's keys, to join a secured team (`None`: an insecure team).
    pub operator: Option<OperatorKeys>,
}

/// An operator's keys: the team's keys folder and the operator's identity in it
/// (`slate keys issue DIR TEAM/NAME`).
#[derive(Clone, Debug)]
pub struct OperatorKeys {
    /// The keys folder.
    pub dir: std::path::PathBuf,
    /// The operator, `team/name`.
    pub identity: Identity,
}

impl Default for ObserverOptions {
    fn default() -> Self {
        ObserverOptions {
            connect: vec!["tcp/127.0.0.1:7447".to_owned()],
            address: None,
            wait: Duration::from_secs(5),
            operator: None,
        }
    }
}

/// The Zenoh config of an observer: a Zenoh *client* of the nodes it connects to (the
/// first that answers). Every message to and from it goes through that node, which routes
/// for its clients: the observer's subscriptions and liveliness token reach the other
/// modules along the same path, in order, so a module that sees it come up can reach it
/// at once (a peer would be reached over links of its own, opened a little later, and
/// the first messages to it could be lost).
fn zenoh_config(connect: &[String], security: Option<Security>) -> ZenohConfig {
    ZenohConfig {
        mode: Mode::Client,
        listen: Vec::new(),
        connect: connect.to_vec(),
        multicast_scouting: false,
        file: None,
        security,
        // A client of one node for a short while: not a team member's reports.
        udp_reports: false,
    }
}

/// The operator's checked keys (as a node checks its own), if it has any.
pub(crate) fn operator_security(
    operator: Option<&OperatorKeys>,
) -> Result<Option<Security>, ObserveError> {
    let Some(keys) = operator else {
        return Ok(None);
    };
    let mut security = team_keys::security(&keys.dir, &keys.identity).map_err(StartError::Keys)?;
    // A client hears the team through the node it connects to, which relays every
    // module's messages: that node's access control judges them (`Security::team`).
    security.team = None;
    Ok(Some(security))
}

/// Joins the team reachable through `options.connect` as an observer, and returns once
/// it has caught up with every module it found (or `options.wait` has passed).
pub fn observe(options: &ObserverOptions) -> Result<Node, ObserveError> {
    let deadline = Instant::now() + options.wait;
    let security = operator_security(options.operator.as_ref())?;
    let identity = options.operator.as_ref().map(|k| &k.identity);
    let (address, modules) = match &options.address {
        Some(a) => (a.clone(), BTreeSet::new()),
        None => {
            let keys = security.clone().zip(identity);
            let modules = discover_with(&options.connect, options.wait, keys)?;
            (observer_address(&modules, identity)?, modules)
        }
    };
    if let Some(identity) = identity.filter(|i| !i.may_speak_as(&address)) {
        return Err(ObserveError::NotOperator {
            address,
            identity: identity.clone(),
        });
    }
    let ici = IciConfig::default()
        .interest(ClassSet::all())
        .export(ClassSet::all())
        .observer(true);
    let node = Node::builder(address)
        .zenoh(zenoh_config(&options.connect, security))
        .ici(ici)
        .start()
        .map_err(|e| match e {
            StartError::Open(open) => unreachable_unless_malformed(open, &options.connect),
            other => ObserveError::Start(other),
        })?;
    // Other observers too, so that a `put` reaches a live `watch` (an observer killed
    // without closing keeps its token until Zenoh's lease ends: joining then waits the
    // whole `wait`).
    wait_for_peers(&node, &modules, deadline);
    if node.transport().peers().is_empty() {
        node.close();
        return Err(ObserveError::NoModules {
            endpoints: options.connect.join(", "),
            seconds: options.wait.as_secs_f64(),
        });
    }
    let expected = expected_peers(&node, &modules);
    wait_caught_up(&node, &expected, deadline);
    Ok(node)
}

/// `TEAM/ROBOT/cli-PID` on the robot of the first module (not an observer) found; for an
/// operator `TEAM/ROBOT/cli-NAME-PID`.
fn observer_address(
    modules: &BTreeSet<Address>,
    operator: Option<&Identity>,
) -> Result<Address, ObserveError> {
    let teams: BTreeSet<&str> = modules.iter().map(Address::team).collect();
    if teams.len() > 1 {
        let teams: Vec<&str> = teams.into_iter().collect();
        return Err(ObserveError::SeveralTeams {
            teams: teams.join(", "),
        });
    }
    let first = modules
        .iter()
        .find(|a| !is_observer(a))
        .or_else(|| modules.iter().next());
    let Some(first) = first else {
        return Err(ObserveError::NoModules {
            endpoints: String::new(),
            seconds: 0.0,
        });
    };
    let prefix = match operator {
        Some(identity) => identity.observer_prefix(),
        None => OBSERVER_PREFIX.to_owned(),
    };
    let text = format!(
        "{}/{}/{prefix}{}",
        first.team(),
        first.robot(),
        std::process::id()
    );
    Ok(Address::new(&text).unwrap_or_else(|_| first.clone()))
}

/// Is this an observer's address?
pub fn is_observer(address: &Address) -> bool {
    address.module().starts_with(OBSERVER_PREFIX)
}

/// Why a client's session did not open: a client that reaches no node fails to open at
/// once, which says nothing is there; a malformed endpoint says so itself.
fn unreachable_unless_malformed(e: OpenError, connect: &[String]) -> ObserveError {
    match e {
        OpenError::Endpoint(_) | OpenError::Insecure { .. } => ObserveError::Open(e),
        _ => ObserveError::Unreachable {
            endpoints: connect.join(", "),
        },
    }
}

/// The slate modules alive on the Zenoh network reachable through `connect`, of every
/// team, found by their liveliness tokens within `wait`.
pub fn discover(connect: &[String], wait: Duration) -> Result<BTreeSet<Address>, ObserveError> {
    discover_with(connect, wait, None)
}

/// [`discover`], over a secured session when `keys` are given.
fn discover_with(
    connect: &[String],
    wait: Duration,
    keys: Option<(Security, &Identity)>,
) -> Result<BTreeSet<Address>, ObserveError> {
    let probe = open_probe(connect, keys)?;
    let found = alive_within(&probe, wait);
    probe.close();
    if found.is_empty() {
        return Err(ObserveError::NoModules {
            endpoints: connect.join(", "),
            seconds: wait.as_secs_f64(),
        });
    }
    Ok(found)
}

/// The modules `probe` finds alive (itself left out): once a liveliness query finds
/// any, asked again until two in a row agree (within `wait`, every 50 ms); empty if
/// none found any.
pub(crate) fn alive_within(probe: &ZenohTransport, wait: Duration) -> BTreeSet<Address> {
    let deadline = Instant::now() + wait;
    settled(deadline, || {
        let left = deadline.saturating_duration_since(Instant::now());
        let mut found = query_alive(probe, left.min(Duration::from_millis(500)));
        found.remove(probe.address());
        found
    })
}

/// Asks `query` every 50 ms until two answers in a row agree and are not empty, or
/// `deadline` (then the last answer). A client that has just joined receives the team's
/// liveliness tokens one by one: the first answer may hold only some modules.
fn settled(deadline: Instant, mut query: impl FnMut() -> BTreeSet<Address>) -> BTreeSet<Address> {
    let mut last = query();
    while Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(50));
        let found = query();
        if !found.is_empty() && found == last {
            return found;
        }
        last = found;
    }
    last
}

/// The probe's address: `slate-probe/cli/pPID` (a team of its own, so that no module
/// takes it for a mate), or for an operator one its certificate may speak as,
/// `TEAM/probe/cli-NAME-pPID` (a secured team's access control would refuse the
/// probe's liveliness token otherwise).
fn probe_address(operator: Option<&Identity>) -> Address {
    let pid = std::process::id();
    let text = match operator {
        Some(identity) => format!(
            "{}/probe/{}p{pid}",
            identity.team(),
            identity.observer_prefix()
        ),
        None => format!("slate-probe/cli/p{pid}"),
    };
    Address::new(&text).unwrap_or_else(|_| Address::unknown())
}

/// A bare Zenoh client of the nodes at `connect` (secured when `keys` are given), for
/// queries (liveliness, counters). A client that reaches no node fails to open, which
/// says nothing is there; a malformed endpoint says so itself.
pub(crate) fn open_probe(
    connect: &[String],
    keys: Option<(Security, &Identity)>,
) -> Result<Arc<ZenohTransport>, ObserveError> {
    let (security, operator) = keys.unzip();
    let config = zenoh_config(connect, security);
    ZenohTransport::open(probe_address(operator), &config)
        .map_err(|e| unreachable_unless_malformed(e, connect))
}

/// One liveliness query for every slate module of every team.
fn query_alive(probe: &ZenohTransport, timeout: Duration) -> BTreeSet<Address> {
    let every_team = keys::alive_in("*");
    let Ok(replies) = probe
        .session()
        .liveliness()
        .get(every_team)
        .timeout(timeout)
        .wait()
    else {
        return BTreeSet::new();
    };
    let mut found = BTreeSet::new();
    while let Ok(reply) = replies.recv() {
        if let Ok(sample) = reply.result()
            && let Some(a) = keys::source(sample.key_expr().as_str())
        {
            found.insert(a);
        }
    }
    found
}

/// Waits until the transport sees every expected module (or at least one if none is
/// expected), or the deadline.
fn wait_for_peers(node: &Node, expected: &BTreeSet<Address>, deadline: Instant) {
    while Instant::now() < deadline {
        let peers: BTreeSet<Address> = node.transport().peers().into_iter().collect();
        let done = if expected.is_empty() {
            !peers.is_empty()
        } else {
            expected
                .iter()
                .all(|a| peers.contains(a) || a == node.address())
        };
        if done {
            return;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Waits until the observer and every module it expects have met both ways, or the
/// deadline: the observer holds every such module's current state (a catch-up with each
/// has completed and none is outstanding: an answer that needed class definitions is
/// asked for again), and every peer has asked the observer for its own (a peer sends
/// its hello, with its interest, just before: until then the observer's writes would not
/// be sent to it). Both must hold at two polls in a row: the ICI applies an answer's
/// objects just after it marks the catch-up complete.
///
/// `expected` is what discovery found and the transport has reported up so far: a
/// module that goes down meanwhile is waited for, because Zenoh may withdraw every
/// token a client holds and declare them again as it joins (seen on secured teams);
/// an observer that took "no peer up" for "caught up with every peer" left at once and
/// answered from an empty board.
fn wait_caught_up(node: &Node, expected: &BTreeSet<Address>, deadline: Instant) {
    let mut polls_met = 0;
    while Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
        let peers = node.transport().peers();
        let view = JoinView {
            expected,
            peers: &peers,
            answered: node.ici().stats().catch_up.answered,
        };
        let met = view.met(|p| node.ici().is_caught_up_with(p));
        polls_met = if met { polls_met + 1 } else { 0 };
        if polls_met >= 2 {
            return;
        }
    }
}

/// The modules a joining observer waits for: those discovery found and those its
/// transport reports up, itself left out.
fn expected_peers(node: &Node, discovered: &BTreeSet<Address>) -> BTreeSet<Address> {
    let mut expected = discovered.clone();
    expected.extend(node.transport().peers());
    expected.remove(node.address());
    expected
}

/// What a joining observer sees at one poll: the modules it waits for, the peers its
/// transport reports up, and how many catch-ups it has answered.
struct JoinView<'a> {
    expected: &'a BTreeSet<Address>,
    peers: &'a [Address],
    answered: u64,
}

impl JoinView<'_> {
    /// Have the observer and its peers met both ways (`caught_up` says whether the
    /// observer holds a peer's current state)? Never with no peer up: every module
    /// expected must be up and caught up with.
    fn met(&self, caught_up: impl Fn(&Address) -> bool) -> bool {
        let up = |a: &Address| self.peers.contains(a);
        !self.peers.is_empty()
            && self.expected.iter().all(|a| up(a) && caught_up(a))
            && self.answered >= self.peers.len() as u64
            && self.peers.iter().all(caught_up)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn addr(text: &str) -> Address {
        Address::new(text).unwrap()
    }

    #[test]
    fn an_observer_whose_peers_all_went_down_is_not_caught_up_with_them() {
        // Zenoh may withdraw every token a client holds and declare them again as it
        // joins (seen on secured teams): for that moment the transport reports no peer.
        let expected: BTreeSet<Address> = [addr("t/r1/nav"), addr("t/r1/cam")].into();
        let view = JoinView {
            expected: &expected,
            peers: &[],
            answered: 2,
        };
        assert!(
            !view.met(|_| true),
            "caught up with {expected:?} while none is up"
        );
    }

    #[test]
    fn discovery_waits_for_the_tokens_still_arriving_before_it_answers() {
        // A client that has just joined receives the team's liveliness tokens one by
        // one: the first query may find loco only, and an observer placed on loco's
        // robot (the first found) is not where the operator's team starts.
        let team: BTreeSet<Address> =
            [addr("t/r1/cam"), addr("t/r1/nav"), addr("t/r2/loco")].into();
        let mut answers = vec![team.clone(), team.clone(), [addr("t/r2/loco")].into()];
        let deadline = Instant::now() + Duration::from_secs(5);
        let found = settled(deadline, || answers.pop().unwrap_or_else(|| team.clone()));
        assert_eq!(found, team);
    }

    #[test]
    fn an_observer_is_not_caught_up_while_an_expected_module_is_down() {
        let expected: BTreeSet<Address> = [addr("t/r1/nav"), addr("t/r1/cam")].into();
        let up = [addr("t/r1/cam")];
        let view = JoinView {
            expected: &expected,
            peers: &up,
            answered: 2,
        };
        assert!(!view.met(|_| true), "nav is down");
        let both = [addr("t/r1/cam"), addr("t/r1/nav")];
        let view = JoinView {
            peers: &both,
            ..view
        };
        assert!(view.met(|_| true), "both up and caught up with");
        assert!(
            !view.met(|a| a.module() == "cam"),
            "nav's state is not held"
        );
    }
}
