//! Issue 17, finding 1, over real Zenoh sessions on 127.0.0.1: a `Plan` message of 12 kB
//! from a made-up address, whose trigger is 6 000 additions, is rejected with the limit on
//! its circuit; the node stays up, counts it, and loads a later plan.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;
use slate_ici::{Ici, IciConfig, Transport};
use slate_model::{Address, Board};
use slate_node::Node;
use slate_testing::free_port;
use slate_wire::{Message, Plan, PlanStep};
use slate_zenoh::{ZenohConfig, ZenohTransport};

const CELL: &str = "class Part { temp: real = 0.0; done: bool = false; } object part : Part;";

/// A bare module on its own Zenoh session: no plan engine, only an ICI to send raw plan
/// messages with, and the plan messages it gets back.
struct Sender {
    ici: Arc<Ici>,
    transport: Arc<ZenohTransport>,
    acks: Receiver<(Address, Message)>,
    stop: Arc<AtomicBool>,
    ticker: Option<JoinHandle<()>>,
}

impl Sender {
    fn open(address: &str, node_port: u16) -> Sender {
        let address = Address::new(address).unwrap();
        let config = ZenohConfig {
            connect: vec![format!("tcp/127.0.0.1:{node_port}")],
            ..ZenohConfig::default()
        };
        let transport = ZenohTransport::open(address.clone(), &config).expect("opens");
        let board = Arc::new(Board::builder().address(address).build());
        let ici = Arc::new(Ici::new(board, transport.clone(), IciConfig::default()).unwrap());
        let (tx, acks) = crossbeam_channel::unbounded();
        ici.set_plan_handler(Arc::new(tx));
        let stop = Arc::new(AtomicBool::new(false));
        let ticker = crate::support::ticker(&ici, &stop);
        Sender {
            ici,
            transport,
            acks,
            stop,
            ticker: Some(ticker),
        }
    }

    /// Sends `text` as plan `name` on `circuit` to `to`; the steps acknowledged within 10 s,
    /// up to the first final one.
    fn send(&self, to: &Address, circuit: u64, name: &str, text: String) -> Vec<PlanStep> {
        let plan = Plan {
            circuit,
            name: name.into(),
            source_text: text,
            to: to.clone(),
            origin: self.ici.address().clone(),
        };
        self.ici.send_raw(to, &Message::Plan(plan)).unwrap();
        let end = Instant::now() + Duration::from_secs(10);
        let mut steps = Vec::new();
        while Instant::now() < end && !steps.last().is_some_and(closes_or_accepts) {
            if let Ok((_, Message::PlanAck(ack))) =
                self.acks.recv_timeout(Duration::from_millis(50))
                && ack.circuit == circuit
            {
                steps.push(ack.step);
            }
        }
        steps
    }

    fn close(mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.ticker.take() {
            let _ = t.join();
        }
        self.transport.close();
    }
}

/// Whether no step follows `step` until the plan runs: a final one, or `Accepted`.
fn closes_or_accepts(step: &PlanStep) -> bool {
    step.is_final() || *step == PlanStep::Accepted
}

#[test]
fn a_plan_nested_too_deep_sent_over_zenoh_is_rejected_and_the_node_runs_on() {
    let port = free_port();
    let node = Node::builder(Address::new("t/r2/cell").unwrap())
        .zenoh(ZenohConfig {
            listen: vec![format!("tcp/127.0.0.1:{port}")],
            ..ZenohConfig::default()
        })
        .source("cell.slate", CELL)
        // Any module may send it plans: this is about a text that is too deep, whoever
        // sends it (a member of the team may).
        .plans_from(vec!["*/*/*".parse().expect("a pattern")])
        .start()
        .expect("the node starts");
    let sender = Sender::open("t/r9/nobody", port);
    let cell = node.address().clone();
    let end = Instant::now() + Duration::from_secs(10);
    while Instant::now() < end && !sender.ici.alive_peers().contains(&cell) {
        thread::sleep(Duration::from_millis(20));
    }

    let chain = format!("part.temp{}", "+1".repeat(6_000));
    let deep =
        format!("plan deep {{\n  trigger: {chain} > 0;\n  action {{ set part.done = true; }}\n}}");
    let steps = sender.send(&cell, 1, "deep", deep);
    let good = "plan fine { trigger: part.temp > 1.0; action { set part.done = true; } }";
    let later = sender.send(&cell, 2, "fine", good.to_owned());
    let stats = node.circuits().stats();
    let summary = node.snapshot()["summary"].clone();
    let closed = node.is_closed();
    sender.close();
    node.close();

    let [PlanStep::Received, PlanStep::Rejected { reason }] = steps.as_slice() else {
        panic!("not received then rejected: {steps:?}")
    };
    assert!(reason.contains("t/r9/nobody/deep.slate:2:"), "{reason}");
    assert!(reason.contains("at most 64 levels"), "{reason}");
    assert!(!closed, "the node runs on");
    assert_eq!(later, [PlanStep::Received, PlanStep::Accepted]);
    assert_eq!(
        (stats.received, stats.accepted, stats.rejected),
        (2, 1, 1),
        "{stats:?}"
    );
    assert_eq!(
        summary["plans rejected"], 1,
        "the dashboard shows it: {summary}"
    );
}
