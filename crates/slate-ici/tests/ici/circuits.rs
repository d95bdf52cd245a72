//! Plan circuits: a plan sent to another module and every step of its progression,
//! under loss, duplication and reordering, across a partition, decomposed into
//! sub-plans; and the explicit reports of plans' `report` actions.

use std::sync::Arc;
use std::time::Duration;

use parking_lot::Mutex;
use slate_ici::{
    AddressPattern, ClassSet, Handler, Ici, IciConfig, LinkConfig, LinkKind, LinkStats,
    MAX_PLAN_TEXT_BYTES, MsgKind, PlanAuthority, PlanCircuits, PlanHandle, Rng, SendError,
    SendPlanError, SimConfig, SimNet, Transport,
};
use slate_model::{Address, Board, WriteAuthority};
use slate_plans::{Engine, PlanState};
use slate_wire::{Decoder, Message, Plan, PlanAck, PlanStep, Schema};

use crate::support::{addr, secs};

/// A part on a welding cell: the destination's world.
const CELL: &str = "
class Part { temp: real = 0.0; level: real in 0 .. 500 = 0.0; done: bool = false; ready: bool = false; }
class Torch { armed: bool = false; on: bool = false; }
class Seam { found: bool = false; tracking: bool = false; }
object part : Part;
object torch : Torch;
object seam : Seam;
";

/// Triggers once hot (sets the level), fails once too hot (the level's bounds), ends
/// when the part is done.
const WELD: &str = "plan weld {
    trigger: part.temp > 100.0;
    termination: part.done == true;
    action { set part.level = part.temp; }
}";

/// One module: board, plan engine, ICI and circuits.
struct Module {
    board: Arc<Board>,
    engine: Engine,
    ici: Ici,
    circuits: PlanCircuits,
}

fn module(net: &SimNet, address: &str, world: &str) -> Module {
    let transport = net.join(&addr(address));
    module_on(net, transport, world, config())
}

fn module_on(
    net: &SimNet,
    transport: Arc<dyn Transport>,
    world: &str,
    config: IciConfig,
) -> Module {
    let board = Arc::new(
        Board::builder()
            .clock(net.clock())
            .address(transport.address().clone())
            .build(),
    );
    let engine = Engine::new(&board);
    engine.load("world.slate", world).unwrap();
    let ici = Ici::new(board.clone(), transport, config).unwrap();
    let circuits = PlanCircuits::attach(&ici, &engine);
    // These tests are about circuits: any module may send plans (the authority tests
    // below set their own).
    circuits.set_authority(PlanAuthority::anyone());
    Module {
        board,
        engine,
        ici,
        circuits,
    }
}

/// A planner (t/r1/planner, no classes) and the welding cell (t/r2/cell) on a new
/// network of `seed`, half a second after they start.
fn planner_and_cell(seed: u64) -> (SimNet, Module, Module) {
    let net = SimNet::new(seed);
    let origin = module(&net, "t/r1/planner", "");
    let cell = module(&net, "t/r2/cell", CELL);
    net.run_for(secs(0.5));
    (net, origin, cell)
}

/// Everything exported; the team link's liveliness slow enough that 30% loss never
/// makes a module look dead.
fn config() -> IciConfig {
    IciConfig::default()
        .export(ClassSet::all())
        .liveliness(LinkKind::Team, secs(0.5), secs(30.0))
}

/// Runs until the handle has `n` steps (collected into `got`), at most `max` seconds.
/// Sends `plan` from `origin` to `to` and runs until its first three steps came back
/// (received, accepted, initiated); the handle and those steps.
fn send_until_initiated(
    net: &SimNet,
    origin: &Module,
    to: &str,
    plan: &str,
) -> (PlanHandle, Vec<PlanStep>) {
    let h = origin.circuits.send(&addr(to), plan).unwrap();
    let mut got = Vec::new();
    wait_steps(net, &h, &mut got, 3, 5.0);
    (h, got)
}

/// The first `n` steps of `h` (or those within 10 s of real time) while plans are
/// loaded on the circuits' own thread: virtual time runs in small slices, with real time
/// between them for that thread to work in.
fn wait_steps_loaded(net: &SimNet, h: &PlanHandle, n: usize) -> Vec<PlanStep> {
    let mut got = Vec::new();
    let deadline = std::time::Instant::now() + Duration::from_secs(10);
    while got.len() < n && std::time::Instant::now() < deadline {
        net.run_for(secs(0.01));
        std::thread::sleep(Duration::from_millis(5));
        got.extend(h.acks().try_iter());
    }
    got
}

fn wait_steps(net: &SimNet, h: &PlanHandle, got: &mut Vec<PlanStep>, n: usize, max: f64) {
    net.run_until(
        || {
            got.extend(h.acks().try_iter());
            got.len() >= n
        },
        secs(max),
    );
    assert!(got.len() >= n, "only {got:?} after {max} s");
}

fn triggered(ok: bool) -> impl Fn(&PlanStep) -> bool {
    move |s| matches!(s, PlanStep::Triggered { ok: o, .. } if *o == ok)
}

/// A transport that duplicates and reorders the acks it sends (reliable sends never do
/// either on the simulator): a held ack goes after the next ack, or with the 16th
/// publish (heartbeats) if no ack follows.
struct Chaos {
    inner: Arc<dyn Transport>,
    rng: Mutex<Rng>,
    held: Mutex<Vec<(Address, Vec<u8>)>>,
    publishes: std::sync::atomic::AtomicU64,
}

impl Chaos {
    fn flush(&self) {
        let held = std::mem::take(&mut *self.held.lock());
        for (to, bytes) in held {
            let _ = self.inner.send(&to, MsgKind::PlanAck, &bytes);
        }
    }
}

impl Transport for Chaos {
    fn address(&self) -> &Address {
        self.inner.address()
    }

    fn set_handler(&self, handler: Arc<dyn Handler>) {
        self.inner.set_handler(handler);
    }

    fn publish(&self, link: LinkKind, kind: MsgKind, payload: &[u8]) -> Result<(), SendError> {
        let n = self
            .publishes
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        if n % 16 == 15 {
            self.flush();
        }
        self.inner.publish(link, kind, payload)
    }

    fn send(&self, to: &Address, kind: MsgKind, payload: &[u8]) -> Result<(), SendError> {
        if kind != MsgKind::PlanAck {
            return self.inner.send(to, kind, payload);
        }
        let roll = self.rng.lock().below(10);
        if roll < 3 {
            self.held.lock().push((to.clone(), payload.to_vec()));
            return Ok(());
        }
        self.inner.send(to, kind, payload)?;
        if roll < 6 {
            self.inner.send(to, kind, payload)?;
        }
        self.flush();
        Ok(())
    }

    fn listen(&self, link: LinkKind, on: bool) -> bool {
        self.inner.listen(link, on)
    }

    fn peers(&self) -> Vec<Address> {
        self.inner.peers()
    }

    fn stats(&self) -> LinkStats {
        self.inner.stats()
    }

    fn close(&self) {
        self.inner.close();
    }
}

/// The weld plan over a link with 30% loss, duplication and jitter, acks duplicated
/// and reordered: returns the steps the origin heard and those the destination kept.
fn weld_under_faults(seed: u64) -> (Vec<PlanStep>, Vec<PlanStep>) {
    let lossy = LinkConfig::clean()
        .delay(secs(0.02))
        .jitter(secs(0.03))
        .loss(0.3)
        .duplicate(0.3);
    let net = SimNet::with_config(
        seed,
        SimConfig {
            team: lossy,
            ..SimConfig::default()
        },
    );
    let origin = module(&net, "t/r1/planner", "");
    let chaos = Arc::new(Chaos {
        inner: net.join(&addr("t/r2/cell")),
        rng: Mutex::new(Rng::new(seed)),
        held: Mutex::new(Vec::new()),
        publishes: Default::default(),
    });
    let cell = module_on(&net, chaos, CELL, config());
    net.run_for(secs(1.0));

    let h = origin.circuits.send(&addr("t/r2/cell"), WELD).unwrap();
    assert_eq!((h.name.as_str(), h.to.as_str()), ("weld", "t/r2/cell"));
    let mut got = Vec::new();
    wait_steps(&net, &h, &mut got, 3, 20.0);
    for temp in [150.0, 50.0, 160.0, 50.0, 600.0, 50.0, 170.0, 50.0, 700.0] {
        cell.board.write("part", "temp", temp).unwrap();
        net.run_for(secs(0.2));
    }
    cell.board.write("part", "done", true).unwrap();
    wait_steps(&net, &h, &mut got, 9, 30.0);
    net.run_for(secs(10.0));
    got.extend(h.acks().try_iter());
    assert_eq!(origin.circuits.sent()[0].steps, got);
    assert_eq!(
        cell.board.read("part", "level").unwrap().value.as_f64(),
        Some(170.0)
    );
    let acks = net.stats().kind(LinkKind::Team, MsgKind::PlanAck);
    assert!(
        acks.retransmits > 0,
        "acks were lost and retransmitted: {acks:?}"
    );
    assert!(
        acks.delivered_msgs > 9,
        "duplicates reached the origin: {acks:?}"
    );
    let received = cell.circuits.received();
    assert_eq!(received[0].peer, addr("t/r1/planner"));
    (got, received[0].steps.clone())
}

#[test]
fn every_step_arrives_once_in_order_under_loss_duplication_and_reordering() {
    let ok = |n: u64| PlanStep::Triggered {
        ok: true,
        detail: format!("fired {n}"),
    };
    for seed in 60..65 {
        let (got, kept) = weld_under_faults(seed);
        assert_eq!(
            got.len(),
            9,
            "seed {seed}: nothing twice, nothing after the end: {got:?}"
        );
        assert_eq!(
            got[..3],
            [PlanStep::Received, PlanStep::Accepted, PlanStep::Initiated]
        );
        assert_eq!(
            [&got[3], &got[4], &got[6]],
            // `fired` counts the actions that committed: the failure at 5 does not count.
            [&ok(1), &ok(2), &ok(3)],
            "seed {seed}"
        );
        for failed in [&got[5], &got[7]] {
            let PlanStep::Triggered { ok: false, detail } = failed else {
                panic!("seed {seed}: {got:?}")
            };
            assert!(detail.contains("level"), "the failure says why: {detail}");
        }
        assert_eq!(got[8], PlanStep::Terminated);
        assert_eq!(
            kept, got,
            "seed {seed}: the destination kept the same steps"
        );
    }
}

/// What a [`Lossy`] transport does with a plan message it is asked to send.
enum Fate {
    /// Sends it.
    Send,
    /// Loses it (a datagram the radio dropped: no transport retransmits it).
    Lose,
    /// Sends it twice (the radio duplicated it).
    Twice,
}

/// The fate of each plan message a [`Lossy`] transport sends, in order.
type Judge = Box<dyn FnMut(&Message) -> Fate + Send>;

/// A transport over a link that does not retransmit (a UDP team link): a judge decides
/// what becomes of each plan message sent; everything else goes through.
struct Lossy {
    inner: Arc<dyn Transport>,
    judge: Mutex<Judge>,
}

impl Lossy {
    fn fate(&self, kind: MsgKind, payload: &[u8]) -> Fate {
        if !matches!(kind, MsgKind::Plan | MsgKind::PlanAck | MsgKind::PlanCancel) {
            return Fate::Send;
        }
        let msg = Decoder::new()
            .decode(self.inner.address(), payload, &Schema::default())
            .unwrap();
        (self.judge.lock())(&msg)
    }
}

impl Transport for Lossy {
    fn address(&self) -> &Address {
        self.inner.address()
    }

    fn set_handler(&self, handler: Arc<dyn Handler>) {
        self.inner.set_handler(handler);
    }

    fn publish(&self, link: LinkKind, kind: MsgKind, payload: &[u8]) -> Result<(), SendError> {
        self.inner.publish(link, kind, payload)
    }

    fn send(&self, to: &Address, kind: MsgKind, payload: &[u8]) -> Result<(), SendError> {
        match self.fate(kind, payload) {
            Fate::Lose => Ok(()),
            Fate::Send => self.inner.send(to, kind, payload),
            Fate::Twice => {
                self.inner.send(to, kind, payload)?;
                self.inner.send(to, kind, payload)
            }
        }
    }

    fn listen(&self, link: LinkKind, on: bool) -> bool {
        self.inner.listen(link, on)
    }

    fn peers(&self) -> Vec<Address> {
        self.inner.peers()
    }

    fn stats(&self) -> LinkStats {
        self.inner.stats()
    }

    fn close(&self) {
        self.inner.close();
    }

    fn retransmits(&self) -> bool {
        false
    }
}

/// A module whose plan messages meet `judge`.
fn lossy_module(net: &SimNet, address: &str, world: &str, judge: Judge) -> Module {
    let lossy = Lossy {
        inner: net.join(&addr(address)),
        judge: Mutex::new(judge),
    };
    module_on(net, Arc::new(lossy), world, config())
}

/// A judge that loses the first message `is` holds for, and sends every other.
fn lose_first(is: impl Fn(&Message) -> bool + Send + 'static) -> Judge {
    let mut lost = false;
    Box::new(move |msg| match is(msg) && !lost {
        true => {
            lost = true;
            Fate::Lose
        }
        false => Fate::Send,
    })
}

/// The origin's steps of `h` once it has `n` of them (at most `max` seconds).
fn steps_of(net: &SimNet, h: &PlanHandle, n: usize, max: f64) -> Vec<PlanStep> {
    let mut got = Vec::new();
    wait_steps(net, h, &mut got, n, max);
    got
}

#[test]
fn a_plan_whose_first_copy_is_lost_is_still_initiated_once_and_acknowledged() {
    let net = SimNet::new(71);
    let is_plan = |m: &Message| matches!(m, Message::Plan(_));
    let origin = lossy_module(&net, "t/r1/planner", "", lose_first(is_plan));
    let cell = module(&net, "t/r2/cell", CELL);
    net.run_for(secs(0.5));
    let h = origin.circuits.send(&addr("t/r2/cell"), WELD).unwrap();
    let got = steps_of(&net, &h, 3, 10.0);
    assert_eq!(
        got,
        [PlanStep::Received, PlanStep::Accepted, PlanStep::Initiated]
    );
    assert_eq!(cell.circuits.stats().received, 1);
    assert!(origin.circuits.stats().resent >= 1, "the plan went again");
}

#[test]
fn a_duplicate_copy_of_a_plan_never_initiates_it_twice() {
    let net = SimNet::new(72);
    let twice: Judge = Box::new(|m| match m {
        Message::Plan(_) => Fate::Twice,
        _ => Fate::Send,
    });
    let origin = lossy_module(&net, "t/r1/planner", "", twice);
    let cell = module(&net, "t/r2/cell", CELL);
    net.run_for(secs(0.5));
    let h = origin.circuits.send(&addr("t/r2/cell"), WELD).unwrap();
    let mut got = steps_of(&net, &h, 3, 10.0);
    cell.board.write("part", "temp", 150.0).unwrap();
    net.run_for(secs(3.0));
    got.extend(h.acks().try_iter());
    let initiated =
        |steps: &[PlanStep]| steps.iter().filter(|s| **s == PlanStep::Initiated).count();
    assert_eq!(initiated(&got), 1, "{got:?}");
    assert_eq!(initiated(&cell.circuits.received()[0].steps), 1);
    assert_eq!(cell.engine.status("weld").map(|s| s.fired), Some(1));
    let stats = cell.circuits.stats();
    assert_eq!(stats.received, 1, "{stats:?}");
    assert!(
        stats.answered_again >= 1,
        "the copy was answered: {stats:?}"
    );
}

#[test]
fn a_lost_last_step_of_a_plan_still_reaches_its_origin() {
    let net = SimNet::new(73);
    let origin = module(&net, "t/r1/planner", "");
    let is_end = |m: &Message| matches!(m, Message::PlanAck(a) if a.step == PlanStep::Terminated);
    let cell = lossy_module(&net, "t/r2/cell", CELL, lose_first(is_end));
    net.run_for(secs(0.5));
    let h = origin.circuits.send(&addr("t/r2/cell"), WELD).unwrap();
    steps_of(&net, &h, 3, 10.0);
    cell.board.write("part", "done", true).unwrap();
    let got = steps_of(&net, &h, 1, 10.0);
    assert_eq!(got, [PlanStep::Terminated]);
    assert!(
        cell.circuits.stats().repeated >= 1,
        "{:?}",
        cell.circuits.stats()
    );
}

#[test]
fn a_lost_step_is_asked_for_until_it_comes_even_when_the_asks_are_lost_three_times() {
    let net = SimNet::new(74);
    let mut copies = 0;
    let lose_three_asks: Judge = Box::new(move |m| match m {
        Message::Plan(_) => {
            copies += 1;
            match copies {
                2..=4 => Fate::Lose,
                _ => Fate::Send,
            }
        }
        _ => Fate::Send,
    });
    let origin = lossy_module(&net, "t/r1/planner", "", lose_three_asks);
    let is_received =
        |m: &Message| matches!(m, Message::PlanAck(a) if a.step == PlanStep::Received);
    let cell = lossy_module(&net, "t/r2/cell", CELL, lose_first(is_received));
    net.run_for(secs(0.5));
    let h = origin.circuits.send(&addr("t/r2/cell"), WELD).unwrap();
    let got = steps_of(&net, &h, 3, 20.0);
    assert_eq!(
        got,
        [PlanStep::Received, PlanStep::Accepted, PlanStep::Initiated]
    );
    assert_eq!(cell.circuits.stats().received, 1);
}

#[test]
fn a_rejected_plan_says_why_with_line_and_column() {
    let (net, origin, cell) = planner_and_cell(61);
    let to = addr("t/r2/cell");

    // Names are checked by the destination, against its board.
    let h = origin
        .circuits
        .send(
            &to,
            "plan bad {\n    trigger: part.tmp > 1.0;\n    action { }\n}",
        )
        .unwrap();
    let mut got = Vec::new();
    wait_steps(&net, &h, &mut got, 2, 5.0);
    let PlanStep::Rejected { reason } = &got[1] else {
        panic!("{got:?}")
    };
    assert_eq!(got[0], PlanStep::Received);
    assert!(
        reason.contains("t/r1/planner/bad.slate:2:19: error: class Part has no attribute tmp"),
        "{reason}"
    );

    // A syntax error never leaves the origin...
    let err = origin
        .circuits
        .send(
            &to,
            "plan oops {\n  trigger: part.temp > ;\n  action { }\n}",
        )
        .unwrap_err();
    let SendPlanError::NotOnePlan { rendered } = &err else {
        panic!("{err}")
    };
    assert!(rendered.contains("plan.slate:2:"), "{rendered}");
    assert!(matches!(
        origin.circuits.send(&to, "class C { x: real; }"),
        Err(SendPlanError::NotOnePlan { .. })
    ));

    // ... but a destination checks what any origin sends it.
    let (tx, rx) = crossbeam_channel::unbounded();
    let raw = module(&net, "t/r3/raw", "");
    raw.ici.set_plan_handler(Arc::new(tx));
    net.run_for(secs(0.5));
    let plan = Plan {
        circuit: 1,
        name: "oops".into(),
        source_text: "plan oops {\n  trigger: part.temp > ;\n  action { }\n}".into(),
        to: to.clone(),
        origin: addr("t/r3/raw"),
    };
    raw.ici.send_raw(&to, &Message::Plan(plan)).unwrap();
    net.run_for(secs(0.5));
    let acks: Vec<PlanAck> = rx
        .try_iter()
        .filter_map(|(_, m)| match m {
            Message::PlanAck(a) => Some(a),
            _ => None,
        })
        .collect();
    assert_eq!(acks.len(), 2, "{acks:?}");
    assert_eq!((acks[0].seq, &acks[0].step), (1, &PlanStep::Received));
    let PlanStep::Rejected { reason } = &acks[1].step else {
        panic!("{acks:?}")
    };
    assert!(reason.contains("t/r3/raw/oops.slate:2:"), "{reason}");
    assert!(
        reason.contains('^'),
        "a caret under the source line: {reason}"
    );
    assert!(cell.engine.status("oops").is_none());
}

#[test]
fn a_plan_whose_name_is_taken_is_rejected_not_renamed() {
    let (net, origin, cell) = planner_and_cell(62);
    let to = addr("t/r2/cell");
    let first = origin.circuits.send(&to, WELD).unwrap();
    let second = origin.circuits.send(&to, WELD).unwrap();
    assert_ne!(first.circuit, second.circuit);
    let mut got = Vec::new();
    wait_steps(&net, &second, &mut got, 2, 5.0);
    let PlanStep::Rejected { reason } = &got[1] else {
        panic!("{got:?}")
    };
    assert!(
        reason.contains("a plan named weld already exists on t/r2/cell (active)"),
        "{reason}"
    );
    assert_eq!(first.acks().try_iter().count(), 3, "the first runs on");
    assert_eq!(cell.engine.plans().len(), 1);
}

#[test]
fn the_origin_cancels_a_plan_it_sent() {
    let (net, origin, cell) = planner_and_cell(63);
    let (h, mut got) = send_until_initiated(&net, &origin, "t/r2/cell", WELD);
    origin.circuits.cancel(h.circuit).unwrap();
    wait_steps(&net, &h, &mut got, 4, 5.0);
    assert_eq!(got[3], PlanStep::Cancelled);
    assert_eq!(
        cell.engine.status("weld").unwrap().state,
        PlanState::Cancelled
    );
    cell.board.write("part", "temp", 150.0).unwrap();
    net.run_for(secs(1.0));
    assert_eq!(
        h.acks().try_iter().count(),
        0,
        "a cancelled plan never acts"
    );
    assert!(matches!(
        origin.circuits.cancel(h.circuit),
        Err(SendPlanError::Closed(_))
    ));
    assert!(matches!(
        origin.circuits.cancel(99),
        Err(SendPlanError::UnknownCircuit(99))
    ));
    let plan_origin = cell.board.read("weld", "origin").unwrap().value;
    assert_eq!(plan_origin.to_string(), "\"t/r1/planner\"");
}

#[test]
fn a_partitioned_destination_is_lost_and_its_acks_resume_after_the_heal() {
    let (net, origin, cell) = planner_and_cell(64);
    let (h, mut got) = send_until_initiated(&net, &origin, "t/r2/cell", WELD);

    net.partition(&[addr("t/r1/planner")], &[addr("t/r2/cell")]);
    // Lost once the ICI believes it dead: at the transport's down if it was already
    // silent a heartbeat period, else past the team link's timeout (30 s here).
    wait_steps(&net, &h, &mut got, 4, 35.0);
    assert_eq!(got[3], PlanStep::DestinationLost);
    cell.board.write("part", "temp", 150.0).unwrap(); // its ack is cut
    net.run_for(secs(5.0));
    assert_eq!(got.len(), 4);
    got.extend(h.acks().try_iter());
    assert_eq!(got.len(), 4, "nothing crosses the partition: {got:?}");

    net.heal();
    wait_steps(&net, &h, &mut got, 5, 10.0);
    assert!(triggered(true)(&got[4]), "{got:?}");
    cell.board.write("part", "done", true).unwrap();
    wait_steps(&net, &h, &mut got, 6, 10.0);
    assert_eq!(got[5], PlanStep::Terminated);
    net.run_for(secs(3.0));
    assert_eq!(h.acks().try_iter().count(), 0, "no step twice");
    assert_eq!(
        cell.circuits.received()[0].steps.len(),
        5,
        "the destination's steps: no DestinationLost there"
    );
}

#[test]
fn a_plan_decomposes_into_sub_plans_on_their_own_circuits() {
    // The paper's welding cell: the planner sends the welding plan to the execution
    // controller, which decomposes it into sub-plans for the torch and the seam sensor.
    let net = SimNet::new(65);
    let planner = module(&net, "t/base/planner", "");
    let exec = module(&net, "t/cell/exec", CELL);
    let torch = module(&net, "t/cell/torch", CELL);
    let sensor = module(&net, "t/cell/seam", CELL);
    net.run_for(secs(0.5));
    let weld = r#"plan weld_part {
        trigger: part.ready == true;
        action {
            send plan weld_seam { trigger: torch.armed == true; action { set torch.on = true; } } to "t/cell/torch";
            send plan track_seam { trigger: seam.found == true; action { set seam.tracking = true; } } to "t/cell/seam";
        }
    }"#;
    let (h, mut got) = send_until_initiated(&net, &planner, "t/cell/exec", weld);
    exec.board.write("part", "ready", true).unwrap();
    wait_steps(&net, &h, &mut got, 4, 5.0);
    assert!(triggered(true)(&got[3]), "{got:?}");
    net.run_for(secs(0.5));
    torch.board.write("torch", "armed", true).unwrap();
    sensor.board.write("seam", "found", true).unwrap();
    net.run_for(secs(1.0));

    let subs = exec.circuits.sent();
    assert_eq!(subs.len(), 2, "{subs:?}");
    let fired = PlanStep::Triggered {
        ok: true,
        detail: "fired 1".into(),
    };
    for (sub, to) in subs.iter().zip(["t/cell/torch", "t/cell/seam"]) {
        assert_eq!(sub.peer, addr(to));
        assert_eq!(
            sub.steps,
            [
                PlanStep::Received,
                PlanStep::Accepted,
                PlanStep::Initiated,
                fired.clone()
            ],
            "{}",
            sub.name
        );
    }
    assert_eq!(exec.circuits.received()[0].name, "weld_part");
    assert_eq!(
        torch.board.read("torch", "on").unwrap().value.to_string(),
        "true"
    );
    assert_eq!(
        sensor
            .board
            .read("seam", "tracking")
            .unwrap()
            .value
            .to_string(),
        "true"
    );
    assert_eq!(torch.circuits.received()[0].peer, addr("t/cell/exec"));
    assert!(planner.circuits.received().is_empty());
}

#[test]
fn plans_report_to_one_module_or_to_all_even_what_others_wrote() {
    // The relay sees the sensor (same robot); b and c are cut off from the sensor but
    // not from the relay, whose plans report the sensor's rock to them.
    let net = SimNet::new(66);
    let world = "class Rock { x: real = 0.0; }";
    let relay = module(&net, "t/r1/relay", world);
    let sensor = module(&net, "t/r1/sensor", world);
    let b = module(&net, "t/r2/b", world);
    let c = module(&net, "t/r3/c", world);
    net.partition(&[addr("t/r1/sensor")], &[addr("t/r2/b"), addr("t/r3/c")]);
    net.run_for(secs(0.5));
    sensor.board.create("Rock", "rock").unwrap();
    sensor.board.write("rock", "x", 5.0).unwrap();
    net.run_for(secs(0.5));
    assert!(relay.board.info("rock").is_some());
    relay
        .engine
        .load(
            "relay.slate",
            r#"plan tell_b { trigger: rock.x > 10.0; action { report rock.x to "t/r2/b"; } }
               plan tell_all { trigger: rock.x > 20.0; action { report rock; } }"#,
        )
        .unwrap();

    sensor.board.write("rock", "x", 15.0).unwrap();
    net.run_for(secs(0.5));
    let x = b.board.read("rock", "x").unwrap();
    assert_eq!(x.value.as_f64(), Some(15.0));
    assert_eq!(
        x.source,
        addr("t/r1/sensor"),
        "the writer's packet, relayed"
    );
    assert!(c.board.info("rock").is_none(), "reported to b only");

    sensor.board.write("rock", "x", 25.0).unwrap();
    net.run_for(secs(0.5));
    for m in [&b, &c] {
        assert_eq!(
            m.board.read("rock", "x").unwrap().value.as_f64(),
            Some(25.0)
        );
    }
    assert_eq!(relay.ici.stats().reports.explicit, 1 + 2);
    net.heal();
    net.run_for(secs(5.0));
    for m in [&relay, &b, &c] {
        assert_eq!(
            m.board.read("rock", "x").unwrap().value.as_f64(),
            Some(25.0)
        );
    }
}

#[test]
fn an_explicit_report_skips_the_report_filter() {
    let net = SimNet::new(67);
    let world = "class Gauge { level: real = 0.0 report deadband 100.0; } object g : Gauge;";
    let quiet = config().quiet(Duration::from_secs(3600));
    let a = module_on(&net, net.join(&addr("t/r1/a")), world, quiet);
    let b = module(
        &net,
        "t/r2/b",
        "class Gauge { level: real = 0.0 report deadband 100.0; }",
    );
    net.run_for(secs(0.5));
    a.board.write("g", "level", 1.0).unwrap();
    net.run_for(secs(0.5));
    a.board.write("g", "level", 2.0).unwrap();
    net.run_for(secs(0.5));
    assert_eq!(
        b.board.read("g", "level").unwrap().value.as_f64(),
        Some(1.0),
        "held"
    );
    let packet = a.board.read("g", "level").unwrap();
    let sent = a
        .ici
        .report(None, vec![("g".into(), "level".into(), packet)]);
    assert_eq!(sent, 1);
    net.run_for(secs(0.5));
    assert_eq!(
        b.board.read("g", "level").unwrap().value.as_f64(),
        Some(2.0)
    );
    let inherited = a.board.read("Gauge", "level").unwrap();
    assert_eq!(
        a.ici.report(
            Some(&addr("t/r2/b")),
            vec![("g".into(), "nope".into(), inherited)]
        ),
        0,
        "only what an object holds itself"
    );
}

#[test]
fn on_the_system_clock_timer_driven_steps_reach_the_origin() {
    // The engine's timer thread initiates the plan and fires it; nothing of the ICI is
    // in its call stack, and no board write follows the `Triggered` event: the
    // circuits' own thread takes it.
    let net = SimNet::new(68);
    let start = |address: &str, world: &str| {
        let transport = net.join(&addr(address));
        let board = Arc::new(
            Board::builder()
                .address(transport.address().clone())
                .build(),
        );
        let engine = Engine::new(&board);
        engine.load("world.slate", world).unwrap();
        let timers = engine.run_timers();
        let ici = Ici::new(board, transport, config()).unwrap();
        let circuits = PlanCircuits::attach(&ici, &engine);
        circuits.set_authority(PlanAuthority::anyone());
        (engine, circuits, timers)
    };
    let (_e1, origin, _t1) = start("t/r1/planner", "");
    let world = "class Counter { n: int = 0; } object c : Counter;";
    let (cell_engine, _cell, _t2) = start("t/r2/cell", world);
    // A write with a time (an initial value from a file has none: its age is `none`).
    cell_engine.board().unwrap().write("c", "n", 1_i64).unwrap();
    net.run_for(secs(0.5));
    let plan = "plan later { initiation: age(c.n) > 0.2s; action { report c; } }";
    let h = origin.send(&addr("t/r2/cell"), plan).unwrap();
    let got = wait_steps_loaded(&net, &h, 4);
    assert_eq!(
        got[..3],
        [PlanStep::Received, PlanStep::Accepted, PlanStep::Initiated]
    );
    assert!(got.get(3).is_some_and(triggered(true)), "{got:?}");
    assert_eq!(cell_engine.status("later").unwrap().fired, 1);
}

/// A module that sends raw plan messages and collects the acks it gets back.
fn raw_sender(
    net: &SimNet,
    address: &str,
) -> (Module, crossbeam_channel::Receiver<(Address, Message)>) {
    let (tx, rx) = crossbeam_channel::unbounded();
    let raw = module(net, address, "");
    raw.ici.set_plan_handler(Arc::new(tx));
    net.run_for(secs(0.5));
    (raw, rx)
}

/// Sends `text` as plan `name` on circuit 1 from `raw` to t/r2/cell; the acks that came back.
fn send_raw_plan(
    net: &SimNet,
    (raw, acks): &(Module, crossbeam_channel::Receiver<(Address, Message)>),
    name: &str,
    text: String,
) -> Vec<PlanStep> {
    let plan = Plan {
        circuit: 1,
        name: name.into(),
        source_text: text,
        to: addr("t/r2/cell"),
        origin: raw.ici.address().clone(),
    };
    raw.ici
        .send_raw(&addr("t/r2/cell"), &Message::Plan(plan))
        .unwrap();
    net.run_for(secs(0.5));
    acks.try_iter()
        .filter_map(|(_, m)| match m {
            Message::PlanAck(a) => Some(a.step),
            _ => None,
        })
        .collect()
}

/// The reason of the `Rejected` step that must follow `Received`.
fn rejected(steps: &[PlanStep]) -> &str {
    match steps {
        [PlanStep::Received, PlanStep::Rejected { reason }] => reason,
        other => panic!("not received then rejected: {other:?}"),
    }
}

/// The welding cell still runs a good plan after refusing a bad one.
fn still_welds(net: &SimNet, origin: &Module, cell: &Module) {
    let (_h, got) = send_until_initiated(net, origin, "t/r2/cell", WELD);
    assert_eq!(
        got,
        [PlanStep::Received, PlanStep::Accepted, PlanStep::Initiated]
    );
    cell.board.write("part", "temp", 150.0).unwrap();
    net.run_for(secs(0.5));
    assert_eq!(cell.engine.status("weld").map(|s| s.fired), Some(1));
}

#[test]
fn a_plan_nested_too_deep_from_a_made_up_address_is_rejected_not_a_crash() {
    let (net, origin, cell) = planner_and_cell(63);
    let raw = raw_sender(&net, "t/r9/nobody");
    // 12 kB: a trigger of 6 000 additions, as in issue 17.
    let chain = format!("part.temp{}", "+1".repeat(6_000));
    let text =
        format!("plan deep {{\n  trigger: {chain} > 0;\n  action {{ set part.done = true; }}\n}}");
    assert!(text.len() > 12_000);
    let steps = send_raw_plan(&net, &raw, "deep", text);
    let reason = rejected(&steps);
    assert!(reason.contains("t/r9/nobody/deep.slate:2:"), "{reason}");
    assert!(reason.contains("at most 64 levels"), "{reason}");
    assert!(cell.engine.status("deep").is_none());
    assert_eq!(cell.board.read("part", "done").unwrap().value, false.into());
    still_welds(&net, &origin, &cell);
}

#[test]
fn a_plan_text_over_the_limit_is_rejected_before_parsing() {
    let (net, origin, cell) = planner_and_cell(64);
    let raw = raw_sender(&net, "t/r9/nobody");
    let padding = "// padding\n".repeat(MAX_PLAN_TEXT_BYTES / 11);
    let text = format!("plan big {{ action {{ set part.done = true; }} }}\n{padding}");
    assert!(text.len() > MAX_PLAN_TEXT_BYTES && text.len() < slate_wire::MAX_TEXT_BYTES);
    let steps = send_raw_plan(&net, &raw, "big", text.clone());
    let reason = rejected(&steps);
    assert!(
        reason.contains(&format!("at most {MAX_PLAN_TEXT_BYTES} bytes")),
        "{reason}"
    );
    assert!(cell.engine.status("big").is_none());
    let err = origin.circuits.send(&addr("t/r2/cell"), &text).unwrap_err();
    assert!(matches!(err, SendPlanError::TooLarge { .. }), "{err}");
    still_welds(&net, &origin, &cell);
}

#[test]
fn the_reason_for_rejecting_a_long_line_fits_in_an_ack() {
    let (net, _origin, cell) = planner_and_cell(65);
    let raw = raw_sender(&net, "t/r9/nobody");
    // One line just under the limit, its error at its end: the reason must not quote it all.
    let filler = " ".repeat(MAX_PLAN_TEXT_BYTES - 100);
    let text = format!("plan long {{ action {{ }}{filler} trigger: part.temp > ; }}");
    assert!(text.len() <= MAX_PLAN_TEXT_BYTES);
    let steps = send_raw_plan(&net, &raw, "long", text);
    let reason = rejected(&steps);
    assert!(reason.contains("t/r9/nobody/long.slate:1:"), "{reason}");
    assert!(reason.contains("expected an expression"), "{reason}");
    assert!(reason.len() < 1_000, "{} bytes", reason.len());
    assert!(cell.engine.status("long").is_none());
}

#[test]
fn plans_received_accepted_and_rejected_are_counted() {
    let (net, origin, cell) = planner_and_cell(66);
    let raw = raw_sender(&net, "t/r9/nobody");
    let deep = format!(
        "plan deep {{ trigger: part.temp{} > 0; action {{ }} }}",
        "+1".repeat(100)
    );
    rejected(&send_raw_plan(&net, &raw, "deep", deep));
    still_welds(&net, &origin, &cell);
    let stats = cell.circuits.stats();
    assert_eq!(
        (stats.received, stats.accepted, stats.rejected),
        (2, 1, 1),
        "{stats:?}"
    );
}

/// Records the name of the thread that first wrote an object named `name` on a board.
struct FirstWriter {
    name: &'static str,
    thread: Mutex<Option<String>>,
}

impl slate_model::ChangeHook for FirstWriter {
    fn changed(&self, board: &Board, _: u64, _: &[slate_model::Touched]) {
        let mut thread = self.thread.lock();
        if thread.is_none() && board.info(self.name).is_some() {
            *thread = Some(std::thread::current().name().unwrap_or("?").to_owned());
        }
    }
}

#[test]
fn on_the_system_clock_a_plan_received_is_loaded_off_the_thread_that_delivers_it() {
    // The thread that delivers messages (the transport's receive thread; here the test's,
    // which moves the simulator) must not be the one that parses, checks and loads plans.
    let net = SimNet::new(69);
    let start = |address: &str| {
        let transport = net.join(&addr(address));
        let board = Arc::new(
            Board::builder()
                .address(transport.address().clone())
                .build(),
        );
        let engine = Engine::new(&board);
        engine.load("world.slate", CELL).unwrap();
        let ici = Ici::new(board.clone(), transport, config()).unwrap();
        let circuits = PlanCircuits::attach(&ici, &engine);
        circuits.set_authority(PlanAuthority::anyone());
        (board, circuits)
    };
    let (_b1, origin) = start("t/r1/planner");
    let (cell_board, cell) = start("t/r2/cell");
    let writer = Arc::new(FirstWriter {
        name: "weld",
        thread: Mutex::new(None),
    });
    cell_board.add_hook(writer.clone());
    net.run_for(secs(0.5));
    let h = origin.send(&addr("t/r2/cell"), WELD).unwrap();
    let got = wait_steps_loaded(&net, &h, 3);
    assert_eq!(
        got,
        [PlanStep::Received, PlanStep::Accepted, PlanStep::Initiated]
    );
    let loader = writer.thread.lock().clone();
    assert_eq!(loader.as_deref(), Some("slate-plan-circuits"));
    assert_eq!(cell.stats().accepted, 1);
}

/// `module`, judging plans by `authority` (`None`: the ICI's default, its own robot).
fn module_with_authority(
    net: &SimNet,
    address: &str,
    world: &str,
    authority: Option<PlanAuthority>,
) -> Module {
    let m = module(net, address, world);
    let authority = authority.unwrap_or_else(|| PlanAuthority::own_robot(&addr(address)));
    m.circuits.set_authority(authority);
    m
}

fn pattern(text: &str) -> AddressPattern {
    AddressPattern::new(text).unwrap()
}

#[test]
fn a_plan_from_a_module_without_authority_is_rejected_with_a_reason_and_counted() {
    // Issue 17, finding 2: a plan from a module that is none of the cell's robot's is
    // refused before it is parsed; the cell's own robot's modules may send it plans.
    let net = SimNet::new(71);
    let stranger = module(&net, "t/r9/evil", "");
    let cell = module_with_authority(&net, "t/r2/cell", CELL, None);
    let mate = module(&net, "t/r2/exec", "");
    let refusals = cell.circuits.refusals();
    net.run_for(secs(0.5));
    let pwn = "plan pwn { action { set part.done = true; } }";
    let h = stranger.circuits.send(&addr("t/r2/cell"), pwn).unwrap();
    let mut got = Vec::new();
    wait_steps(&net, &h, &mut got, 2, 5.0);
    let reason = rejected(&got);
    assert!(
        reason.contains("t/r9/evil may not send plans to t/r2/cell"),
        "{reason}"
    );
    assert!(reason.contains("only from t/r2/*"), "{reason}");
    assert!(cell.engine.status("pwn").is_none());
    assert_eq!(cell.board.read("part", "done").unwrap().value, false.into());
    let refused: Vec<_> = refusals.try_iter().collect();
    assert_eq!(refused.len(), 1, "{refused:?}");
    assert_eq!(
        (refused[0].from.as_str(), refused[0].name.as_str()),
        ("t/r9/evil", "pwn")
    );
    let stats = cell.circuits.stats();
    assert_eq!(
        (stats.received, stats.rejected, stats.unauthorised),
        (1, 1, 1),
        "{stats:?}"
    );

    let (_h, got) = send_until_initiated(&net, &mate, "t/r2/cell", WELD);
    assert_eq!(
        got,
        [PlanStep::Received, PlanStep::Accepted, PlanStep::Initiated]
    );
}

#[test]
fn a_module_named_in_the_authority_may_send_plans() {
    let (net, origin, cell) = planner_and_cell(72);
    let authority = PlanAuthority::own_robot(&addr("t/r2/cell")).allow(pattern("t/*/planner"));
    cell.circuits.set_authority(authority);
    still_welds(&net, &origin, &cell);
    assert_eq!(cell.circuits.stats().unauthorised, 0);
}

#[test]
fn a_plan_cannot_send_itself_on_beyond_what_its_origin_may_send() {
    // The planner may command the cell's execution controller, not its torch: a plan it
    // sends the controller may not send the torch a sub-plan either (the sub-plan names
    // the planner as its origin), though the controller itself may.
    let net = SimNet::new(73);
    let planner = module(&net, "t/base/planner", "");
    let exec_authority =
        PlanAuthority::own_robot(&addr("t/cell/exec")).allow(pattern("t/base/planner"));
    let exec = module_with_authority(&net, "t/cell/exec", CELL, Some(exec_authority));
    let torch = module_with_authority(&net, "t/cell/torch", CELL, None);
    net.run_for(secs(0.5));
    let relay = r#"plan relay {
        trigger: part.ready == true;
        action {
            send plan burn { action { set torch.on = true; } } to "t/cell/torch";
        }
    }"#;
    let (_h, got) = send_until_initiated(&net, &planner, "t/cell/exec", relay);
    assert_eq!(
        got,
        [PlanStep::Received, PlanStep::Accepted, PlanStep::Initiated]
    );
    exec.board.write("part", "ready", true).unwrap();
    net.run_for(secs(1.0));
    let subs = exec.circuits.sent();
    let [sub] = subs.as_slice() else {
        panic!("{subs:?}")
    };
    let reason = rejected(&sub.steps);
    assert!(
        reason.contains(
            "t/cell/exec sent on a plan of t/base/planner, which may not send plans to t/cell/torch"
        ),
        "{reason}"
    );
    assert!(torch.engine.status("burn").is_none());
    assert_eq!(torch.board.read("torch", "on").unwrap().value, false.into());
    assert_eq!(torch.circuits.stats().unauthorised, 1);

    let own = "plan own { action { set torch.on = true; } }";
    let (_h, got) = send_until_initiated(&net, &exec, "t/cell/torch", own);
    assert_eq!(got[..2], [PlanStep::Received, PlanStep::Accepted]);
}

#[test]
fn a_received_plan_cannot_write_an_owned_attribute_its_origin_does_not_own() {
    // Issue 17, item 3: a received plan runs with the authority of the module that sent
    // it. The planner may send the cell plans, but the cell owns the vault: a plan that
    // writes the vault's `owned` code fails with the reason and leaves it as it was; one
    // that writes a plain attribute runs.
    let vault = "class Vault { code: real merge owned = 0.0; level: real = 0.0; }
        object vault : Vault;";
    let net = SimNet::new(74);
    let planner = module(&net, "t/r1/planner", "");
    let cell = module(&net, "t/r2/cell", vault);
    net.run_for(secs(0.5));
    let steal = "plan steal { action { set vault.code = 66.0; } }";
    let (_h, got) = send_until_initiated(&net, &planner, "t/r2/cell", steal);
    assert_eq!(got[..2], [PlanStep::Received, PlanStep::Accepted]);
    net.run_for(secs(0.5));
    assert_eq!(cell.board.read("vault", "code").unwrap().value, 0.0.into());
    let error = cell.engine.status("steal").and_then(|s| s.last_error);
    let error = error.unwrap_or_default();
    assert!(
        error.contains("t/r1/planner may not write vault.code")
            && error.contains("owned by t/r2/cell"),
        "{error}"
    );

    let fill = "plan fill { action { set vault.level = 3.0; } }";
    send_until_initiated(&net, &planner, "t/r2/cell", fill);
    net.run_for(secs(0.5));
    assert_eq!(cell.board.read("vault", "level").unwrap().value, 3.0.into());
    let own = "plan own { action { set vault.code = 7.0; } }";
    cell.engine.load("own.slate", own).unwrap();
    net.run_for(secs(0.5));
    assert_eq!(cell.board.read("vault", "code").unwrap().value, 7.0.into());
}

#[test]
fn a_received_plan_cannot_delete_what_its_origin_may_not_write() {
    // Issue 17, item 3: deleting an object takes away every value it holds, so a received
    // plan deletes only what its origin could write. The cell owns the vault (an `owned`
    // code) and its rules keep crates to its own robot: the planner's plans deleting
    // either fail with the reason and leave the object; deleting a plain object runs, and
    // so do the cell's own plans.
    let things = "class Vault { code: real merge owned = 0.0; }
        class Crate { weight: real = 0.0; }
        class Note { text: string = \"\"; }
        object vault : Vault; object box : Crate; object memo : Note; object spare : Crate;";
    let net = SimNet::new(76);
    let planner = module(&net, "t/r1/planner", "");
    let cell = module(&net, "t/r2/cell", things);
    let robot = vec![AddressPattern::robot_of(&addr("t/r2/cell"))];
    cell.board
        .set_write_authority(WriteAuthority::default().rule("Crate", None, robot));
    net.run_for(secs(0.5));
    let error = |plan: &str| {
        let status = cell.engine.status(plan).and_then(|s| s.last_error);
        status.unwrap_or_default()
    };
    for (plan, object, reason) in [
        (
            "crack",
            "vault",
            "t/r1/planner may not write vault.code, an owned attribute owned by t/r2/cell",
        ),
        ("dump", "box", "Crate may be written by t/r2/*"),
    ] {
        let text = format!("plan {plan} {{ action {{ delete {object}; }} }}");
        let (_h, got) = send_until_initiated(&net, &planner, "t/r2/cell", &text);
        assert_eq!(got[..2], [PlanStep::Received, PlanStep::Accepted]);
        net.run_for(secs(0.5));
        assert!(cell.board.info(object).is_some(), "{object} was deleted");
        let error = error(plan);
        assert!(
            error.contains("runs with the authority of t/r1/planner")
                && error.contains(&format!("deleting {object}"))
                && error.contains(reason),
            "{error}"
        );
    }

    let tidy = "plan tidy { action { delete memo; } }";
    send_until_initiated(&net, &planner, "t/r2/cell", tidy);
    net.run_for(secs(0.5));
    assert!(cell.board.info("memo").is_none(), "{}", error("tidy"));
    let own = "plan own { action { delete vault; delete spare; } }";
    cell.engine.load("own.slate", own).unwrap();
    net.run_for(secs(0.5));
    assert!(cell.board.info("vault").is_none() && cell.board.info("spare").is_none());
}

#[test]
fn a_received_plan_cannot_write_what_the_boards_rules_do_not_let_its_origin_write() {
    // Issue 17, item 3: the cell's board lets only its own robot write the vault's level
    // (`[authority.writes]`). The planner may send the cell plans, so its plan is
    // accepted, but it runs with the planner's authority: writing the level fails with
    // the rule, creating a vault too; the cell's own plan writes it.
    let vault = "class Vault { level: real = 0.0; } object vault : Vault;";
    let net = SimNet::new(75);
    let planner = module(&net, "t/r1/planner", "");
    let cell = module(&net, "t/r2/cell", vault);
    let robot = vec![AddressPattern::robot_of(&addr("t/r2/cell"))];
    cell.board
        .set_write_authority(WriteAuthority::default().rule("Vault", None, robot));
    net.run_for(secs(0.5));
    let fill = "plan fill { action { set vault.level = 3.0; } }";
    let (_h, got) = send_until_initiated(&net, &planner, "t/r2/cell", fill);
    assert_eq!(got[..2], [PlanStep::Received, PlanStep::Accepted]);
    net.run_for(secs(0.5));
    assert_eq!(cell.board.read("vault", "level").unwrap().value, 0.0.into());
    let error = cell.engine.status("fill").and_then(|s| s.last_error);
    let error = error.unwrap_or_default();
    assert!(
        error.contains("runs with the authority of t/r1/planner")
            && error.contains("t/r1/planner may not write vault.level")
            && error.contains("Vault may be written by t/r2/*"),
        "{error}"
    );
    let make = "plan make { action { create Vault spare; } }";
    send_until_initiated(&net, &planner, "t/r2/cell", make);
    net.run_for(secs(0.5));
    assert!(cell.board.info("spare").is_none());

    let own = "plan own { action { set vault.level = 7.0; } }";
    cell.engine.load("own.slate", own).unwrap();
    net.run_for(secs(0.5));
    assert_eq!(cell.board.read("vault", "level").unwrap().value, 7.0.into());
}

/// A plan that names its origin's object, sent as its destination appears (or comes
/// back after a restart, when the origin sends its open circuits' plans again), reaches
/// the destination before the origin's state does: the destination learns `part` only
/// by catching up with the origin. Loaded at once, it was rejected ("unknown name part")
/// though nothing was wrong with it; it waits for that catch-up instead.
#[test]
fn a_plan_sent_as_its_destination_appears_waits_there_for_the_origins_state() {
    let classes =
        "class Part { temp: real = 0.0; level: real in 0 .. 500 = 0.0; done: bool = false; }";
    let net = SimNet::new(81);
    let origin = module(
        &net,
        "t/r1/planner",
        &format!("{classes} object part : Part;"),
    );
    net.run_for(secs(0.5));
    let cell = module(&net, "t/r2/cell", classes);
    net.run_for(secs(0.01));
    let h = origin.circuits.send(&addr("t/r2/cell"), WELD).unwrap();
    let got = steps_of(&net, &h, 3, 10.0);
    assert_eq!(
        got,
        [PlanStep::Received, PlanStep::Accepted, PlanStep::Initiated]
    );
    assert!(cell.board.info("part").is_some());
    origin.board.write("part", "temp", 150.0).unwrap();
    let fired = steps_of(&net, &h, 1, 5.0);
    assert!(triggered(true)(&fired[0]), "{fired:?}");
}
