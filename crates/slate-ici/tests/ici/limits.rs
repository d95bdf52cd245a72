//! Bounds per source and in total (docs/security.md, *Limits*): one module, or a crowd
//! of made-up addresses, cannot grow another board without bound, and everyone else's
//! objects are untouched.

use std::sync::Arc;

use slate_ici::IciConfig;
use slate_model::{BoardEvent, Query};

use crate::support::{Team, addr, open};

/// Objects on `member`'s board owned by `owner`.
fn owned_by(team: &Team, member: &str, owner: &str) -> usize {
    let query = Query::class("Thing").owner(addr(owner));
    team.board(member).query(&query).unwrap_or_default().len()
}

/// A receiver that holds at most `per_source` objects of any other module, and
/// `total` in all.
fn bounded(per_source: usize, total: usize) -> IciConfig {
    IciConfig {
        max_objects_per_source: per_source,
        max_objects: total,
        ..open()
    }
}

#[test]
fn a_source_creating_objects_past_its_bound_is_refused_counted_and_evented() {
    let mut team = Team::new(171);
    team.add("t/r1/evil", open());
    team.add("t/r1/nav", open());
    team.add("t/r1/loco", bounded(10, 1000));
    let events = team.board("t/r1/loco").events();
    team.run(1.0);
    for i in 0..5 {
        let nav = team.board("t/r1/nav");
        nav.create("Rock", &format!("rock{i}")).unwrap();
        nav.write(&format!("rock{i}"), "x", 1.0).unwrap();
    }
    for i in 0..30 {
        let evil = team.board("t/r1/evil");
        evil.create("Raw", &format!("junk{i}")).unwrap();
        evil.write(&format!("junk{i}"), "sample", 1.0).unwrap();
    }
    team.run(3.0);
    assert_eq!(owned_by(&team, "t/r1/loco", "t/r1/evil"), 10);
    assert_eq!(
        owned_by(&team, "t/r1/loco", "t/r1/nav"),
        5,
        "nav's untouched"
    );
    assert_eq!(
        owned_by(&team, "t/r1/nav", "t/r1/evil"),
        30,
        "unbounded elsewhere"
    );
    let loco = team.member("t/r1/loco");
    assert!(
        loco.ici.stats().rejects.over_limit >= 20,
        "{:?}",
        loco.ici.stats().rejects
    );
    let got: Vec<BoardEvent> = events.try_iter().collect();
    let said = got.iter().any(|e| {
        matches!(e, BoardEvent::ObjectLimit { owner, limit: 10, .. } if owner.as_str() == "t/r1/evil")
    });
    assert!(said, "{got:?}");
}

#[test]
fn the_total_bound_holds_against_several_sources() {
    let mut team = Team::new(172);
    for m in ["a", "b", "c"] {
        team.add(&format!("t/r1/{m}"), open());
    }
    team.add("t/r1/loco", bounded(100, 20));
    team.run(1.0);
    for m in ["a", "b", "c"] {
        let board = team.board(&format!("t/r1/{m}"));
        for i in 0..15 {
            board.create("Raw", &format!("{m}{i}")).unwrap();
        }
    }
    team.run(3.0);
    let held: usize = ["a", "b", "c"]
        .iter()
        .map(|m| owned_by(&team, "t/r1/loco", &format!("t/r1/{m}")))
        .sum();
    assert_eq!(held, 20);
    assert!(team.member("t/r1/loco").ici.stats().rejects.over_limit >= 25);
}

#[test]
fn sprayed_source_addresses_stop_at_the_modules_bound() {
    let mut team = Team::new(173);
    let config = IciConfig {
        max_modules: 8,
        ..open()
    };
    team.add("t/r1/loco", config);
    let sprayed: Vec<_> = (0..40)
        .map(|i| team.net.join(&addr(&format!("t/r{}/m{i}", i % 4))))
        .collect();
    team.run(2.0);
    let modules = team
        .board("t/r1/loco")
        .query(&Query::class("Module"))
        .unwrap_or_default()
        .len();
    assert!(modules <= 8, "{modules} Module objects");
    let loco = team.member("t/r1/loco");
    assert!(
        loco.ici.stats().rejects.over_limit >= 32,
        "{:?}",
        loco.ici.stats().rejects
    );
    drop(sprayed);
}

#[test]
fn a_source_naming_past_its_names_bound_is_refused_counted_and_evented() {
    let mut team = Team::new(174);
    team.add("t/r1/evil", open());
    team.add("t/r1/nav", open());
    let config = IciConfig {
        max_names_per_source: 40,
        ..open()
    };
    team.add("t/r1/loco", config);
    let events = team.board("t/r1/loco").events();
    team.run(1.0);
    for i in 0..3 {
        let nav = team.board("t/r1/nav");
        nav.create("Rock", &format!("rock{i}")).unwrap();
        nav.write(&format!("rock{i}"), "x", 1.0).unwrap();
    }
    for i in 0..100 {
        let evil = team.board("t/r1/evil");
        evil.create("Raw", &format!("name{i}")).unwrap();
        evil.write(&format!("name{i}"), "sample", 1.0).unwrap();
        team.run(0.02);
    }
    team.run(3.0);
    // Objects come in lifecycle frames, which name them without the dictionary (and
    // are bounded by max_objects_per_source); their values come in reports, whose
    // names are held for the source: those past the bound are refused.
    let loco = team.board("t/r1/loco");
    let written = |name: &str| {
        loco.read(name, "sample")
            .is_ok_and(|p| p.value.as_f64() == Some(1.0))
    };
    let held = (0..100).filter(|i| written(&format!("name{i}"))).count();
    assert!(held < 40, "{held} of evil's values held");
    let nav = (0..3).filter(|i| {
        loco.read(&format!("rock{i}"), "x")
            .is_ok_and(|p| p.value.as_f64() == Some(1.0))
    });
    assert_eq!(nav.count(), 3, "nav's untouched");
    let loco = team.member("t/r1/loco");
    assert!(
        loco.ici.stats().rejects.over_limit >= 1,
        "{:?}",
        loco.ici.stats().rejects
    );
    let got: Vec<BoardEvent> = events.try_iter().collect();
    let said = got.iter().any(|e| {
        matches!(e, BoardEvent::NameLimit { source, limit: 40, .. } if source.as_str() == "t/r1/evil")
    });
    assert!(said, "{got:?}");
}

/// Takes what it is sent and drops it.
struct Deaf;

impl slate_ici::Handler for Deaf {
    fn message(&self, _: &slate_model::Address, _: &[u8]) {}
    fn peer(&self, _: &slate_model::Address, _: bool) {}
}

#[test]
fn a_requester_asking_for_catch_up_in_a_loop_gets_a_bounded_number_of_bytes() {
    use slate_ici::{LinkKind, MsgKind, Transport};
    use slate_wire::{CatchUpRequest, Encoder, Message, Schema};
    // loco's current state is some 200 objects; it answers one requester at most
    // 4 KiB a second.
    let config = IciConfig {
        max_answer_bytes_per_requester: 4096,
        ..open()
    };
    let team = Team::of(175, [("t/r1/loco", config)]);
    let loco = team.board("t/r1/loco");
    for i in 0..200 {
        loco.create("Rock", &format!("rock{i}")).unwrap();
        loco.write(&format!("rock{i}"), "x", f64::from(i)).unwrap();
    }
    let flood = team.net.join(&addr("t/r1/flood"));
    flood.set_handler(Arc::new(Deaf));
    team.run(1.0);
    let request = Message::CatchUpRequest(CatchUpRequest {
        have_seq: 0,
        needs_names: true,
        needs_classes: true,
    });
    let bytes = Encoder::new(addr("t/r1/flood"))
        .encode(&request, &Schema::new(&[]))
        .unwrap();
    let received = || flood.stats().link(LinkKind::Robot).recv_bytes;
    let ask = || {
        flood
            .send(&addr("t/r1/loco"), MsgKind::CatchUpRequest, &bytes)
            .unwrap();
    };
    let before = received();
    ask();
    team.run(0.1);
    let one_state = received() - before;
    assert!(one_state > 4096, "one state: {one_state} bytes");
    // 500 requests over 5 s: the heartbeat interval alone would allow 20 answers.
    for _ in 0..500 {
        ask();
        team.run(0.01);
    }
    let sent = received() - before;
    let stats = team.member("t/r1/loco").ici.stats().catch_up;
    assert!(
        sent <= one_state + 6 * 4096 + one_state,
        "{sent} bytes in 5 s for a state of {one_state} ({stats:?})"
    );
    assert!(stats.answered <= 1 + 1 + 5 * 4096 / one_state, "{stats:?}");
    assert!(stats.over_budget >= 1, "{stats:?}");
}
