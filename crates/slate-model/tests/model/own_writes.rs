//! Own writes that receivers would judge differently: stale stamps, non-owners, stamps
//! from the future. Every board must end with the same packet.

use std::time::Duration;

use slate_model::{
    AttrDecl, Board, BoardEvent, ChainError, ClassDef, Clock, MANUAL_EPOCH, MergePolicy, Merged,
    NewObject, Packet, Timestamp, Update, Value, ValueType, WriteError,
};
use slate_testing::addr;

/// A board at `me`, with `t: Track` owned by `team/r1/nav`.
fn board_at(me: &str) -> Board {
    let b = Board::builder()
        .clock(Clock::manual())
        .address(addr(me))
        .build();
    let def = ClassDef::new("Track")
        .attr(AttrDecl::new("latest", ValueType::Real))
        .attr(AttrDecl::new("confident", ValueType::Real).merge(MergePolicy::Confident))
        .attr(AttrDecl::new("owned", ValueType::Real).merge(MergePolicy::Owned))
        .attr(AttrDecl::new("fused", ValueType::Real).merge(MergePolicy::Fused));
    b.define(def).unwrap();
    b.create_with(NewObject::new("Track", "t").owner(addr("team/r1/nav")))
        .unwrap();
    b
}

fn before(secs: u64) -> Timestamp {
    Timestamp::from_duration(MANUAL_EPOCH - Duration::from_secs(secs))
}

#[test]
fn an_own_write_stamped_before_the_held_packet_is_refused_and_stores_nothing() {
    let b = board_at("team/r1/nav");
    for attr in ["latest", "owned", "confident"] {
        b.write("t", attr, 1.0).unwrap();
        let held = b.read("t", attr).unwrap();
        let err = b
            .write("t", attr, Update::new(2.0).timestamp(before(100)))
            .unwrap_err();
        assert!(
            matches!(err, WriteError::Superseded { .. }),
            "{attr}: {err}"
        );
        let text = err.to_string();
        assert!(text.contains("write without a timestamp"), "{text}");
        assert_eq!(b.read("t", attr).unwrap(), held, "{attr}");
    }
}

#[test]
fn a_stale_own_write_in_a_batch_fails_the_whole_batch() {
    let b = board_at("team/r1/nav");
    b.write("t", "latest", 1.0).unwrap();
    let mut batch = b.batch();
    batch.write("t", "confident", 5.0).write(
        "t",
        "latest",
        Update::new(2.0).timestamp(before(100)),
    );
    assert!(batch.commit().is_err());
    assert_eq!(b.read("t", "latest").unwrap().value.as_f64(), Some(1.0));
    assert!(b.read("t", "confident").unwrap().value.is_none());
}

#[test]
fn an_own_write_stamped_after_the_held_packet_is_stored() {
    let b = board_at("team/r1/nav");
    b.write("t", "latest", Update::new(1.0).timestamp(before(100)))
        .unwrap();
    b.write("t", "latest", Update::new(2.0).timestamp(before(50)))
        .unwrap();
    assert_eq!(b.read("t", "latest").unwrap().value.as_f64(), Some(2.0));
}

/// What the writer keeps after any accepted own write is what a receiver merging the
/// same packets keeps: the writer's copy and the receiver's are one.
#[test]
fn writer_and_receiver_hold_the_same_latest_packet_after_an_old_stamped_write() {
    let writer = board_at("team/r1/nav");
    let receiver = board_at("team/r2/nav");
    let mut sent = Vec::new();
    for (value, stamp) in [(1.0, None), (2.0, Some(before(100)))] {
        let update = match stamp {
            Some(ts) => Update::new(value).timestamp(ts),
            None => Update::new(value),
        };
        if writer.write("t", "latest", update).is_ok() {
            sent.push(writer.read("t", "latest").unwrap());
        }
        writer.clock().advance(Duration::from_millis(10)).unwrap();
        receiver.clock().advance(Duration::from_millis(10)).unwrap();
    }
    for p in sent {
        receiver.merge("t", "latest", p).unwrap();
    }
    assert_eq!(
        writer.read("t", "latest").unwrap(),
        receiver.read("t", "latest").unwrap()
    );
}

#[test]
fn a_non_owner_write_to_an_owned_attribute_is_refused_and_stores_nothing() {
    let b = board_at("team/r2/nav");
    let err = b.write("t", "owned", 2.0).unwrap_err();
    assert!(matches!(err, WriteError::NotOwner { .. }), "{err}");
    let text = err.to_string();
    assert!(text.contains("team/r1/nav"), "{text}");
    assert!(b.read("t", "owned").unwrap().value.is_none());
    // In a batch too, and the batch applies nothing.
    let mut batch = b.batch();
    batch.write("t", "latest", 1.0).write("t", "owned", 2.0);
    assert!(batch.commit().is_err());
    assert!(b.read("t", "latest").unwrap().value.is_none());
    // Other attributes of the object, and the owner's own writes, are fine.
    b.write("t", "latest", 1.0).unwrap();
    board_at("team/r1/nav").write("t", "owned", 2.0).unwrap();
}

#[test]
fn a_write_naming_the_owner_as_source_is_the_owners_write() {
    // The rule receivers apply: the packet's source must be the object's owner.
    let b = board_at("team/r2/nav");
    b.write("t", "owned", Update::new(2.0).source(addr("team/r1/nav")))
        .unwrap();
    let err = b
        .write("t", "owned", Update::new(3.0).source(addr("team/r3/nav")))
        .unwrap_err();
    assert!(matches!(err, WriteError::NotOwner { .. }), "{err}");
}

fn future_packet(b: &Board, ahead: Duration) -> Packet {
    Packet {
        value: Value::Real(9.0),
        accuracy: 0.0,
        confidence: 1.0,
        timestamp: Timestamp::from_duration(b.clock().physical() + ahead),
        source: addr("team/r9/bad"),
    }
}

#[test]
fn a_received_packet_stamped_beyond_the_clock_tolerance_is_refused_and_reported() {
    let b = board_at("team/r2/nav");
    let events = b.events();
    b.write("t", "latest", 1.0).unwrap();
    let years = Duration::from_secs(3 * 365 * 86_400);
    let out = b.merge("t", "latest", future_packet(&b, years)).unwrap();
    assert!(matches!(out, Merged::FromTheFuture { .. }), "{out:?}");
    assert_eq!(b.read("t", "latest").unwrap().value.as_f64(), Some(1.0));
    // Later writes still change the value.
    b.write("t", "latest", 2.0).unwrap();
    assert_eq!(b.read("t", "latest").unwrap().value.as_f64(), Some(2.0));
    let got: Vec<BoardEvent> = events.try_iter().collect();
    assert!(
        got.iter()
            .any(|e| matches!(e, BoardEvent::FutureStamp { source, .. } if source.as_str() == "team/r9/bad")),
        "{got:?}"
    );
    assert_eq!(b.stats().future_stamps, 1);
    // Within the tolerance, a packet is merged as before.
    let near = future_packet(&b, Duration::from_millis(100));
    assert!(matches!(
        b.merge("t", "latest", near).unwrap(),
        Merged::Applied(_)
    ));
}

#[test]
fn an_own_write_stamped_beyond_the_clock_tolerance_is_refused() {
    let b = board_at("team/r1/nav");
    let ts = Timestamp::from_duration(b.clock().physical() + Duration::from_secs(3600));
    let err = b
        .write("t", "latest", Update::new(1.0).timestamp(ts))
        .unwrap_err();
    assert!(matches!(err, WriteError::FromTheFuture { .. }), "{err}");
    assert!(b.read("t", "latest").unwrap().value.is_none());
}

#[test]
fn a_call_token_from_another_board_is_refused() {
    let a = board_at("team/r1/nav");
    let b = board_at("team/r1/nav");
    let token = std::sync::Arc::new(parking_lot::Mutex::new(None));
    let keep = token.clone();
    a.on_write("t", "latest", move |call| {
        *keep.lock() = call.token();
        Ok(())
    })
    .unwrap();
    a.write("t", "latest", 1.0).unwrap();
    let token = token.lock().clone().expect("a token");
    assert!(matches!(
        b.write_as(&token, "t", "latest", 2.0),
        Err(WriteError::Chain(ChainError::ForeignToken))
    ));
    assert!(b.read_as(&token, "t", "latest").is_err());
    assert!(b.read("t", "latest").unwrap().value.is_none());
}

/// A packet for `t.attr` from `source`, stamped `ahead` of `b`'s clock.
fn packet_from(b: &Board, source: &str, ahead: Duration) -> Packet {
    Packet {
        source: addr(source),
        ..future_packet(b, ahead)
    }
}

/// Refusals the events in `got` account for: each event is one, plus those from the same
/// source it says were not reported one by one before it.
fn told(got: &[BoardEvent]) -> u64 {
    got.iter()
        .map(|e| match e {
            BoardEvent::NotOwner { suppressed, .. }
            | BoardEvent::FutureStamp { suppressed, .. } => 1 + suppressed,
            _ => 0,
        })
        .sum()
}

/// `n` packets from `source` merged into `b` one every 5 ms of its clock, each refused
/// as `refused` says; what the board's events said meanwhile.
fn flood(b: &Board, n: usize, (attr, ahead): (&str, Duration), source: &str) -> Vec<BoardEvent> {
    let events = b.events();
    for _ in 0..n {
        b.clock().advance(Duration::from_millis(5)).unwrap();
        let out = b.merge("t", attr, packet_from(b, source, ahead)).unwrap();
        assert!(!matches!(out, Merged::Applied(_)), "{out:?}");
    }
    events.try_iter().collect()
}

/// 1 000 refusals from one source over 5 s of the board's clock: at most one event a
/// second, and the events say how many refusals each stands for (only the last second's
/// are still to be told).
fn assert_told_once_a_second(got: &[BoardEvent]) {
    assert!(
        (2..=6).contains(&got.len()),
        "{} events: {:?}",
        got.len(),
        got.first()
    );
    let told = told(got);
    assert!(told <= 1000 && 1000 - told <= 200, "{told} told of 1000");
}

#[test]
fn a_thousand_not_owner_packets_make_a_bounded_number_of_events_and_each_is_counted() {
    let b = board_at("team/r2/nav");
    let got = flood(&b, 1000, ("owned", Duration::ZERO), "team/r9/evil");
    assert_eq!(b.stats().not_owner, 1000);
    assert_told_once_a_second(&got);
    // Another source is told of at once, whatever the first one does.
    let other = flood(&b, 1, ("owned", Duration::ZERO), "team/r8/cam");
    let said = other.iter().any(
        |e| matches!(e, BoardEvent::NotOwner { writer, suppressed: 0, .. } if writer.as_str() == "team/r8/cam"),
    );
    assert!(said, "{other:?}");
}

#[test]
fn a_thousand_future_stamped_packets_make_a_bounded_number_of_events_and_each_is_counted() {
    let b = board_at("team/r2/nav");
    let years = Duration::from_secs(3 * 365 * 86_400);
    let got = flood(&b, 1000, ("latest", years), "team/r9/evil");
    assert_eq!(b.stats().future_stamps, 1000);
    assert_told_once_a_second(&got);
}
