//! Shared fixtures: classes, addresses, packets, and the tolerance check of a roundtrip.

use std::time::Duration;

use slate_model::{Address, AttrDecl, ClassDef, MANUAL_EPOCH, Packet, Timestamp, Value, ValueType};
use slate_wire::{Assertion, ObjectEntry, Report, Schema};

pub use slate_testing::addr;

/// The sending module of most tests.
pub fn nav() -> Address {
    addr("team/r1/nav")
}

/// A timestamp `micros` after the manual clock's epoch, with a logical counter.
pub fn at(micros: u64, logical: u64) -> Timestamp {
    let t = Timestamp::from_duration(MANUAL_EPOCH + Duration::from_micros(micros));
    Timestamp::from_raw(t.raw() | logical)
}

pub fn packet(
    value: impl Into<Value>,
    accuracy: f64,
    confidence: f64,
    timestamp: Timestamp,
) -> Packet {
    Packet {
        value: value.into(),
        accuracy,
        confidence,
        timestamp,
        source: nav(),
    }
}

pub fn assertion(object: &ObjectEntry, attr: &str, packet: Packet) -> Assertion {
    Assertion {
        object: object.clone(),
        attr: attr.into(),
        packet,
    }
}

pub fn report(seq: u64, items: Vec<Assertion>) -> Report {
    Report { seq, items }
}

/// The classes of the size targets: a robot pose, and tracked objects whose four
/// attributes are reals in 0..1000 at resolution 0.01.
pub fn classes() -> Vec<ClassDef> {
    let coord = |name| {
        AttrDecl::new(name, ValueType::Real)
            .unit("m")
            .bounds(-10_000.0, 10_000.0)
            .resolution(0.01)
    };
    let level = |name| {
        AttrDecl::new(name, ValueType::Real)
            .bounds(0.0, 1000.0)
            .resolution(0.01)
    };
    vec![
        ClassDef::new("Robot")
            .attr(coord("x"))
            .attr(coord("y"))
            .attr(
                AttrDecl::new("heading", ValueType::Real)
                    .unit("rad")
                    .bounds(0.0, std::f64::consts::TAU)
                    .resolution(0.001),
            )
            .attr(
                AttrDecl::new("speed", ValueType::Real)
                    .unit("m/s")
                    .bounds(0.0, 20.0)
                    .resolution(0.01),
            ),
        ClassDef::new("Tracked")
            .attr(level("range"))
            .attr(level("level"))
            .attr(level("depth"))
            .attr(level("width")),
    ]
}

pub fn schema() -> Schema {
    Schema::new(&classes())
}

pub fn robot() -> ObjectEntry {
    ObjectEntry::new("r1", "Robot").owner(nav())
}

/// Asserts that `got` is `sent` after quantisation: names, sources and timestamps
/// exact; values within half a resolution (exact when not quantised); accuracy
/// within its log step; confidence within 1/510.
pub fn assert_close(schema: &Schema, sent: &Report, got: &Report) {
    assert_eq!(sent.seq, got.seq);
    assert_eq!(sent.items.len(), got.items.len());
    for (s, g) in sent.items.iter().zip(&got.items) {
        assert_eq!((&s.object, &s.attr), (&g.object, &g.attr));
        let decl = schema.attr(&s.object.class, &s.attr).unwrap();
        let (sp, gp) = (&s.packet, &g.packet);
        assert_eq!((sp.timestamp, &sp.source), (gp.timestamp, &gp.source));
        assert_value_close(decl, &sp.value, &gp.value);
        let scale = decl.resolution.unwrap_or(1.0);
        let acc_tolerance = (sp.accuracy * 0.0906).max(scale / 32.0);
        assert!(
            (sp.accuracy - gp.accuracy).abs() <= acc_tolerance,
            "accuracy {} -> {}",
            sp.accuracy,
            gp.accuracy
        );
        assert!((sp.confidence - gp.confidence).abs() <= 0.5 / 255.0 + 1e-12);
    }
}

fn assert_value_close(decl: &AttrDecl, sent: &Value, got: &Value) {
    let quantised = decl.bounds.is_some() && decl.resolution.is_some();
    match (sent, got) {
        (Value::Real(a), Value::Real(b)) if quantised => close(decl, *a, *b),
        (Value::Vector(a), Value::Vector(b)) if quantised => {
            assert_eq!(a.len(), b.len());
            a.iter()
                .zip(b.iter())
                .for_each(|(x, y)| close(decl, *x, *y));
        }
        _ => assert_eq!(sent, got),
    }
}

fn close(decl: &AttrDecl, a: f64, b: f64) {
    let half = decl.resolution.unwrap_or(0.0) / 2.0;
    assert!((a - b).abs() <= half * (1.0 + 1e-9), "{a} -> {b}");
}

/// A small deterministic generator (splitmix64).
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    pub fn real(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}
