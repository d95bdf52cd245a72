use std::sync::Arc;

use proptest::prelude::*;
use slate_model::{
    Address, AttrDecl, Board, ClassDef, Clock, Filter, MergePolicy, Merged, NewObject, Normaliser,
    Packet, Timestamp, Value, ValueType, WriteError,
};

fn board() -> Board {
    let b = Board::builder().clock(Clock::manual()).build();
    let def = ClassDef::new("Track")
        .attr(AttrDecl::new("latest", ValueType::Real))
        .attr(AttrDecl::new("confident", ValueType::Real).merge(MergePolicy::Confident))
        .attr(AttrDecl::new("owned", ValueType::Real).merge(MergePolicy::Owned));
    b.define(def).unwrap();
    let owner = Address::new("team/r1/nav").unwrap();
    b.create_with(NewObject::new("Track", "t").owner(owner))
        .unwrap();
    b
}

fn packet(value: f64, ts: u64, conf: f64, source: &str) -> Packet {
    Packet {
        value: Value::Real(value),
        accuracy: 0.0,
        confidence: conf,
        timestamp: Timestamp::from_raw(1 << 50 | ts),
        source: Address::new(source).unwrap(),
    }
}

/// Merges `packet(value, ts, conf, source)` into `t.attr` and says what happened:
/// `"applied"`, `"kept"`, or `"not owner"`.
fn merge(b: &Board, attr: &str, (value, ts, conf, source): (f64, u64, f64, &str)) -> &'static str {
    match b.merge("t", attr, packet(value, ts, conf, source)).unwrap() {
        Merged::Applied(_) => "applied",
        Merged::Kept => "kept",
        Merged::NotOwner => "not owner",
        other => panic!("{other:?}"),
    }
}

#[test]
fn latest_wins_by_timestamp_then_source() {
    let b = board();
    let outcomes = [
        (1.0, 10, 1.0, "team/r1/a"),
        (2.0, 9, 1.0, "team/r1/b"),
        (3.0, 10, 1.0, "team/r1/b"),
        (4.0, 10, 1.0, "team/r1/a"),
    ]
    .map(|p| merge(&b, "latest", p));
    assert_eq!(outcomes, ["applied", "kept", "applied", "kept"]);
    let p = b.read("t", "latest").unwrap();
    assert_eq!(
        (p.value.as_f64(), p.source.as_str()),
        (Some(3.0), "team/r1/b")
    );
}

#[test]
fn confident_wins_by_confidence_and_owned_only_from_the_owner() {
    let b = board();
    merge(&b, "confident", (1.0, 10, 0.9, "team/r1/a"));
    assert_eq!(merge(&b, "confident", (2.0, 20, 0.5, "team/r1/b")), "kept");
    assert_eq!(b.read("t", "confident").unwrap().value.as_f64(), Some(1.0));
    assert_eq!(
        merge(&b, "owned", (5.0, 10, 1.0, "team/r2/nav")),
        "not owner"
    );
    assert_eq!(merge(&b, "owned", (6.0, 10, 1.0, "team/r1/nav")), "applied");
    assert_eq!(b.read("t", "owned").unwrap().value.as_f64(), Some(6.0));
}

#[test]
fn merged_packets_are_validated() {
    let b = board();
    let mut p = packet(1.0, 10, 1.0, "team/r1/a");
    p.confidence = 2.0;
    assert!(b.merge("t", "latest", p).is_err());
    assert!(
        b.merge("ghost", "latest", packet(1.0, 1, 1.0, "team/r1/a"))
            .is_err()
    );
}

#[test]
fn merge_all_is_one_revision_and_judges_each_packet_on_its_own() {
    let b = board();
    let watch = b.watch(Filter::all()).unwrap();
    let before = b.stats().revision;
    let mut bad = packet(9.0, 30, 1.0, "team/r1/a");
    bad.confidence = 2.0;
    let out = b.merge_all([
        ("t", "latest", packet(1.0, 10, 1.0, "team/r1/a")),
        ("ghost", "latest", packet(1.0, 10, 1.0, "team/r1/a")),
        ("t", "latest", bad),
        // Judged against the first packet of this very call.
        ("t", "latest", packet(2.0, 9, 1.0, "team/r1/a")),
        ("t", "owned", packet(5.0, 10, 1.0, "team/r2/nav")),
        ("t", "confident", packet(3.0, 10, 0.5, "team/r1/b")),
    ]);
    let revision = before + 1;
    assert!(matches!(out[0], Ok(Merged::Applied(r)) if r == revision));
    assert!(matches!(out[1], Err(WriteError::UnknownObject(_))));
    assert!(matches!(out[2], Err(WriteError::Invalid { .. })));
    assert!(matches!(out[3], Ok(Merged::Kept)));
    assert!(matches!(out[4], Ok(Merged::NotOwner)));
    assert!(matches!(out[5], Ok(Merged::Applied(r)) if r == revision));
    assert_eq!(b.stats().revision, revision);
    assert_eq!(b.read("t", "latest").unwrap().value.as_f64(), Some(1.0));
    assert_eq!(b.read("t", "confident").unwrap().value.as_f64(), Some(3.0));
    let change = watch.try_recv().expect("one notification");
    assert_eq!((change.revision, change.items.len()), (revision, 2));
    assert!(watch.try_recv().is_none(), "one notification only");
    // Nothing applied: no revision at all.
    let out = b.merge_all([("t", "latest", packet(0.0, 1, 1.0, "team/r1/a"))]);
    assert!(matches!(out[0], Ok(Merged::Kept)));
    assert_eq!(b.stats().revision, revision);
}

#[test]
fn merge_all_keyed_takes_a_live_key_and_the_names_for_a_stale_one() {
    let b = board();
    let key = b.key("t", "latest").unwrap();
    let p = |v, ts| packet(v, ts, 1.0, "team/r1/a");
    // A live key is taken as it is (the names are not looked up again).
    let out = b.merge_all_keyed([("not looked up", "latest", Some(key), p(1.0, 10))]);
    assert!(matches!(out[0], Ok(Merged::Applied(_))), "{out:?}");
    assert_eq!(b.read("t", "latest").unwrap().value.as_f64(), Some(1.0));
    // Made again: the old key is stale, the names find the new object.
    b.delete("t").unwrap();
    b.create("Track", "t").unwrap();
    let out = b.merge_all_keyed([("t", "latest", Some(key), p(2.0, 20))]);
    assert!(matches!(out[0], Ok(Merged::Applied(_))), "{out:?}");
    assert_eq!(b.read("t", "latest").unwrap().value.as_f64(), Some(2.0));
    let out = b.merge_all_keyed([("ghost", "latest", Some(key), p(3.0, 30))]);
    assert!(
        matches!(out[0], Err(WriteError::UnknownObject(_))),
        "{out:?}"
    );
}

#[test]
fn a_watch_of_own_writes_skips_merged_packets() {
    let b = board();
    let own = b.watch(Filter::all().own_writes_only()).unwrap();
    let all = b.watch(Filter::all()).unwrap();
    b.merge("t", "latest", packet(1.0, 10, 1.0, "team/r1/a"))
        .unwrap();
    b.write("t", "latest", 2.0).unwrap();
    b.create("Track", "u").unwrap();
    let items = |w: &slate_model::Watch| {
        std::iter::from_fn(|| w.try_recv())
            .flat_map(|c| c.items)
            .count()
    };
    assert_eq!(items(&all), 3);
    assert_eq!(items(&own), 2, "the own write and the creation");
}

/// Rounds own reals to whole numbers.
struct Round;

impl Normaliser for Round {
    fn normalise(&self, _: &AttrDecl, packet: &mut Packet) {
        if let Value::Real(x) = &mut packet.value {
            *x = x.round();
        }
    }
}

#[test]
fn a_normaliser_rewrites_own_writes_only() {
    let b = board();
    b.set_normaliser(Some(Arc::new(Round)));
    b.write("t", "latest", 2.4).unwrap();
    assert_eq!(b.read("t", "latest").unwrap().value.as_f64(), Some(2.0));
    let mut batch = b.batch();
    batch.write("t", "confident", 7.6);
    batch.commit().unwrap();
    assert_eq!(b.read("t", "confident").unwrap().value.as_f64(), Some(8.0));
    // Received packets are stored as they came.
    let p = packet(1.5, 1 << 40, 1.0, "team/r1/nav");
    b.merge("t", "owned", p).unwrap();
    assert_eq!(b.read("t", "owned").unwrap().value.as_f64(), Some(1.5));
    b.set_normaliser(None);
    b.write("t", "latest", 2.4).unwrap();
    assert_eq!(b.read("t", "latest").unwrap().value.as_f64(), Some(2.4));
}

proptest! {
    /// Any order, with duplicates, gives the same final packets on every board.
    #[test]
    fn merging_converges_whatever_the_order(
        packets in prop::collection::vec((0u64..20, 0u8..3, 0u8..4, 0u8..3), 1..30),
        seed in any::<u64>(),
    ) {
        let sources = ["team/r1/nav", "team/r1/b", "team/r2/c"];
        let attrs = ["latest", "confident", "owned"];
        let all: Vec<(&str, Packet)> = packets
            .iter()
            .map(|&(ts, src, conf, attr)| {
                let p = packet(ts as f64, ts, f64::from(conf) / 3.0, sources[src as usize]);
                (attrs[attr as usize], p)
            })
            .collect();
        let (a, b) = (board(), board());
        for (attr, p) in &all {
            a.merge("t", attr, p.clone()).unwrap();
        }
        // The other board: reversed, rotated by the seed, each packet twice.
        let mut order: Vec<_> = all.iter().rev().chain(all.iter()).collect();
        let n = order.len();
        order.rotate_left((seed as usize) % n);
        for (attr, p) in &order {
            b.merge("t", attr, p.clone()).unwrap();
        }
        // A third: the same order in batches of three.
        let c = board();
        for chunk in order.chunks(3) {
            for r in c.merge_all(chunk.iter().map(|(attr, p)| ("t", *attr, p.clone()))) {
                r.unwrap();
            }
        }
        for attr in attrs {
            prop_assert_eq!(a.read("t", attr).unwrap(), b.read("t", attr).unwrap(), "{}", attr);
            prop_assert_eq!(a.read("t", attr).unwrap(), c.read("t", attr).unwrap(), "{}", attr);
        }
    }
}
