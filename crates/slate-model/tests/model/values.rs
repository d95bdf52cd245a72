use std::time::Duration;

use slate_model::{Address, Clock, Update, Value, ValueError, ValueType, WriteError};

use crate::support::{board, with_vehicle};

fn invalid(e: WriteError) -> ValueError {
    match e {
        WriteError::Invalid { source, .. } => source,
        other => panic!("expected Invalid, got {other:?}"),
    }
}

#[test]
fn a_write_of_the_wrong_type_is_an_error_and_changes_nothing() {
    let b = with_vehicle();
    b.write("v", "speed", 1.5).unwrap();
    let before = b.revision();
    let e = invalid(b.write("v", "speed", 2).unwrap_err());
    assert_eq!(
        e,
        ValueError::WrongType {
            expected: ValueType::Real,
            found: Value::Int(2)
        }
    );
    assert!(matches!(
        invalid(b.write("v", "mode", 3.0).unwrap_err()),
        ValueError::WrongType { .. }
    ));
    assert!(matches!(
        invalid(b.write("v", "position", [1.0, 2.0, 3.0]).unwrap_err()),
        ValueError::WrongType { .. }
    ));
    assert!(matches!(
        invalid(b.write("v", "target", "quarry").unwrap_err()),
        ValueError::WrongType { .. }
    ));
    assert_eq!(b.read("v", "speed").unwrap().value.as_f64(), Some(1.5));
    assert_eq!(b.revision(), before);
}

#[test]
fn out_of_range_packets_are_errors_not_clamps() {
    let b = with_vehicle();
    assert!(matches!(
        invalid(b.write("v", "speed", 51.0).unwrap_err()),
        ValueError::OutOfBounds { .. }
    ));
    assert!(matches!(
        invalid(b.write("v", "wheels", 17).unwrap_err()),
        ValueError::OutOfBounds { .. }
    ));
    assert!(matches!(
        invalid(b.write("v", "speed", f64::NAN).unwrap_err()),
        ValueError::NotFinite(_)
    ));
    let e = invalid(
        b.write("v", "speed", Update::new(1.0).accuracy(-1.0))
            .unwrap_err(),
    );
    assert_eq!(e, ValueError::Accuracy(-1.0));
    let e = invalid(
        b.write("v", "speed", Update::new(1.0).confidence(1.01))
            .unwrap_err(),
    );
    assert_eq!(e, ValueError::Confidence(1.01));
    assert!(matches!(
        invalid(
            b.write("v", "speed", Update::new(1.0).accuracy(f64::INFINITY))
                .unwrap_err()
        ),
        ValueError::Accuracy(_)
    ));
    // Nothing was stored: the declared default is still what reads back.
    assert_eq!(b.read("v", "speed").unwrap().value.as_f64(), Some(0.0));
}

#[test]
fn unknown_names_are_errors_that_say_what() {
    let b = board();
    b.create("Obstacle", "rock").unwrap();
    let e = b.write("rock", "speed", 1.0).unwrap_err();
    assert_eq!(
        e.to_string(),
        "rock has no attribute speed (its class does not declare it)"
    );
    assert_eq!(
        b.write("pebble", "range", 1.0).unwrap_err().to_string(),
        "no object named pebble"
    );
    let e = b
        .write("rock", "range", Update::new(1.0).confidence(2.0))
        .unwrap_err();
    assert_eq!(
        e.to_string(),
        "rock.range: confidence 2 must be between 0 and 1"
    );
}

#[test]
fn writes_are_stamped_and_sourced_and_fill_defaults() {
    let b = with_vehicle();
    let t0 = b.clock().now();
    b.clock().advance(Duration::from_secs(1)).unwrap();
    b.write("v", "speed", 2.0).unwrap();
    let p = b.read("v", "speed").unwrap();
    assert!(p.timestamp > t0);
    assert_eq!(b.clock().age(p.timestamp), Duration::ZERO);
    assert_eq!(p.source, *b.address());
    // Unset accuracy and confidence come from the declared default packet.
    assert_eq!((p.accuracy, p.confidence), (0.5, 0.5));
    // Without a declared default they are 0 and 1.
    b.write("v", "wheels", 4).unwrap();
    let p = b.read("v", "wheels").unwrap();
    assert_eq!((p.accuracy, p.confidence), (0.0, 1.0));
    b.clock().advance(Duration::from_secs(3)).unwrap();
    assert_eq!(b.clock().age(p.timestamp), Duration::from_secs(3));
}

#[test]
fn a_given_timestamp_and_source_are_kept_and_merged_into_the_clock() {
    let b = with_vehicle();
    let remote_clock = Clock::manual();
    remote_clock.advance(Duration::from_millis(200)).unwrap();
    let ts = remote_clock.now();
    let src = Address::new("team/r9/nav").unwrap();
    b.write(
        "v",
        "speed",
        Update::new(3.0).timestamp(ts).source(src.clone()),
    )
    .unwrap();
    let p = b.read("v", "speed").unwrap();
    assert_eq!((p.timestamp, p.source), (ts, src));
    // The board's clock now stamps after the remote timestamp although its time is behind.
    assert!(b.clock().now() > ts);
}

#[test]
fn keys_read_and_write_like_names() {
    let b = board();
    b.create("Gsr", "g").unwrap();
    let k = b.key("g", "speed").unwrap();
    b.write_key(k, 7.0).unwrap();
    assert_eq!(b.read("g", "speed").unwrap().value.as_f64(), Some(7.0));
    assert_eq!(b.read_key(k).unwrap().value.as_f64(), Some(7.0));
    assert!(b.key("g", "nothing").is_err());
}
