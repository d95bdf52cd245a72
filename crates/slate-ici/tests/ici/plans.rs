//! The plan engine's extension point: raw plan messages out, a handler in.

use std::sync::Arc;

use slate_ici::{LinkKind, MsgKind, PlanHandler, SendRawError};
use slate_model::Address;
use slate_wire::{CatchUpRequest, Message, Plan, PlanAck, PlanStep};

use crate::support::{Team, addr, open};

#[derive(Default)]
struct Recorder(parking_lot::Mutex<Vec<String>>);

impl PlanHandler for Recorder {
    fn message(&self, from: &Address, msg: Message) {
        self.0.lock().push(format!("{from}: {msg:?}"));
    }

    fn peer(&self, peer: &Address, alive: bool) {
        self.0.lock().push(format!("{peer} alive={alive}"));
    }
}

#[test]
fn plans_and_acks_travel_raw_and_reach_the_plan_handler() {
    let team = Team::of(40, [("t/r1/planner", open()), ("t/r2/nav", open())]);
    team.run(0.5);
    let (tx, rx) = crossbeam_channel::unbounded();
    team.member("t/r2/nav").ici.set_plan_handler(Arc::new(tx));
    let recorder = Arc::new(Recorder::default());
    team.member("t/r1/planner")
        .ici
        .set_plan_handler(recorder.clone());
    let plan = Message::Plan(Plan {
        circuit: 7,
        name: "patrol".into(),
        source_text: "plan patrol { }".into(),
        to: addr("t/r2/nav"),
        origin: addr("t/r1/planner"),
    });
    team.member("t/r1/planner")
        .ici
        .send_raw(&addr("t/r2/nav"), &plan)
        .unwrap();
    team.run(0.5);
    assert_eq!(rx.try_recv().unwrap(), (addr("t/r1/planner"), plan));
    let ack = Message::PlanAck(PlanAck {
        circuit: 7,
        seq: 1,
        step: PlanStep::Accepted,
    });
    team.member("t/r2/nav")
        .ici
        .send_raw(&addr("t/r1/planner"), &ack)
        .unwrap();
    team.run(0.5);
    assert!(recorder.0.lock().iter().any(|m| m.contains("Accepted")));
    let stats = team.member("t/r1/planner").ici.stats();
    assert_eq!(stats.get(LinkKind::Team, MsgKind::Plan).sent_msgs, 1);
}

#[test]
fn the_plan_handler_hears_a_destination_die() {
    let team = Team::of(41, [("t/r1/planner", open()), ("t/r2/nav", open())]);
    team.run(0.5);
    let recorder = Arc::new(Recorder::default());
    team.member("t/r1/planner")
        .ici
        .set_plan_handler(recorder.clone());
    team.net.kill(&addr("t/r2/nav"));
    team.run(6.0);
    assert!(
        recorder
            .0
            .lock()
            .contains(&"t/r2/nav alive=false".to_owned())
    );
}

#[test]
fn only_plan_messages_go_raw() {
    let team = Team::of(42, [("t/r1/planner", open())]);
    let req = Message::CatchUpRequest(CatchUpRequest::default());
    let err = team
        .member("t/r1/planner")
        .ici
        .send_raw(&addr("t/r2/nav"), &req)
        .unwrap_err();
    assert!(matches!(
        err,
        SendRawError::NotAPlanMessage(MsgKind::CatchUpRequest)
    ));
}
