//! Merge policies across boards: owned, confident, fused.

use slate_ici::{LinkConfig, SimConfig};
use slate_model::{Update, Value};

use crate::support::{Team, divergence, open, secs};

fn trio(seed: u64, config: SimConfig) -> Team {
    let mut team = Team::with(seed, config);
    for a in ["t/r1/nav", "t/r2/nav", "t/r3/nav"] {
        team.add(a, open());
    }
    team.run(0.5);
    team
}

#[test]
fn owned_attributes_take_writes_from_the_owner_only() {
    let team = trio(11, SimConfig::default());
    let owner = team.board("t/r1/nav");
    owner.create("Vehicle", "gsr").unwrap();
    owner.write("gsr", "heading", 1.0).unwrap();
    team.run(0.5);
    // A non-owner's write is refused where it is made: nothing to refuse elsewhere.
    assert!(team.board("t/r2/nav").write("gsr", "heading", 2.0).is_err());
    team.run(0.5);
    for at in ["t/r1/nav", "t/r2/nav", "t/r3/nav"] {
        let node = team.member(at);
        assert_eq!(
            node.board.read("gsr", "heading").unwrap().value.as_f64(),
            Some(1.0),
            "{at}"
        );
        assert_eq!(node.ici.stats().merges.not_owner, 0, "{at}");
    }
    owner.write("gsr", "heading", 3.0).unwrap();
    team.run(0.5);
    for at in ["t/r2/nav", "t/r3/nav"] {
        assert_eq!(
            team.board(at)
                .read("gsr", "heading")
                .unwrap()
                .value
                .as_f64(),
            Some(3.0)
        );
    }
}

#[test]
fn the_most_confident_packet_wins_on_every_board() {
    let team = trio(12, SimConfig::default());
    team.board("t/r1/nav").create("Rock", "boulder").unwrap();
    team.run(0.5);
    let write = |at: &str, v: f64, c: f64| {
        let u = Update::new(v).confidence(c);
        team.board(at).write("boulder", "seen", u).unwrap();
        team.run(0.2);
    };
    write("t/r1/nav", 1.0, 0.9);
    write("t/r2/nav", 2.0, 0.9);
    write("t/r3/nav", 3.0, 0.4);
    team.run(1.0);
    assert_eq!(divergence(&team.members), None);
    let p = team.board("t/r3/nav").read("boulder", "seen").unwrap();
    assert_eq!(
        p.value.as_f64(),
        Some(2.0),
        "equal confidence: the later one"
    );
}

/// Every robot estimates the target's range; every board holds the same fusion, which
/// counts each robot once, whatever the order, delay and duplication of reports.
#[test]
fn fused_estimates_converge_to_the_same_fusion_everywhere() {
    let mut results = Vec::new();
    for seed in 0..5 {
        let link = LinkConfig::clean()
            .delay(secs(0.02))
            .jitter(secs(0.2))
            .duplicate(0.3)
            .loss(0.2);
        let team = trio(
            100 + seed,
            SimConfig {
                team: link,
                ..SimConfig::default()
            },
        );
        team.board("t/r1/nav").create("Target", "t1").unwrap();
        team.run(3.0);
        for round in 0..3 {
            for (i, at) in ["t/r1/nav", "t/r2/nav", "t/r3/nav"].iter().enumerate() {
                let estimate = 100.0 + i as f64 * 10.0;
                let accuracy = 1.0 + i as f64;
                let u = Update::new(estimate).accuracy(accuracy);
                team.board(at).write("t1", "range", u).unwrap();
                team.run(0.01 * (round + 1) as f64);
            }
        }
        team.assert_converges(30);
        let p = team.board("t/r2/nav").read("t1", "range").unwrap();
        assert!(p.source.is_unknown(), "the fusion has no single source");
        // Three independent estimates, each counted once.
        let w: f64 = [1.0f64, 2.0, 3.0].iter().map(|a| 1.0 / (a * a)).sum();
        assert!((p.accuracy - (1.0 / w).sqrt()).abs() < 0.1, "{p:?}");
        let v = p.value.as_f64().unwrap();
        assert!(
            (v - (100.0 + 110.0 / 4.0 + 120.0 / 9.0) / w).abs() < 0.5,
            "{v}"
        );
        results.push(p);
    }
    assert!(
        results.windows(2).all(|w| w[0].value == w[1].value),
        "{results:?}"
    );
}

#[test]
fn a_module_reports_its_own_estimate_never_the_fusion() {
    let team = trio(13, SimConfig::default());
    team.board("t/r1/nav").create("Target", "t1").unwrap();
    team.run(0.5);
    team.board("t/r1/nav")
        .write("t1", "range", Update::new(10.0).accuracy(1.0))
        .unwrap();
    team.board("t/r2/nav")
        .write("t1", "range", Update::new(20.0).accuracy(1.0))
        .unwrap();
    team.run(1.0);
    let before = team.member("t/r3/nav").ici.stats().merges.fused;
    // r1 writing its estimate again: still counted once.
    team.board("t/r1/nav")
        .write("t1", "range", Update::new(10.0).accuracy(1.0))
        .unwrap();
    team.run(1.0);
    let p = team.board("t/r3/nav").read("t1", "range").unwrap();
    assert_eq!(p.value, Value::Real(15.0));
    assert!((p.accuracy - 0.5f64.sqrt()).abs() < 0.05, "{p:?}");
    assert!(team.member("t/r3/nav").ici.stats().merges.fused <= before + 1);
}
