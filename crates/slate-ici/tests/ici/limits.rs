//! Bounds per source and in total (docs/security.md, *Limits*): one module, or a crowd
//! of made-up addresses, cannot grow another board without bound, and everyone else's
//! objects are untouched.

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
