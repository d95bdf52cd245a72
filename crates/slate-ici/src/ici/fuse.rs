//! `fused` attributes: the latest estimate of every source, and their combination.
//!
//! The ICI keeps, per object attribute, the latest packet of each source (by timestamp).
//! The board holds the fusion of all of them, written with the unknown source, and a
//! module reports only its own estimate, never the fusion: nothing is counted twice.
//! The set of latest estimates does not depend on arrival order or duplicates, and the
//! fusion is computed from it in source order, so every board writes the same packet.

use std::collections::BTreeMap;
use std::sync::Arc;

use slate_model::{Address, Packet, Value};

use super::filter::Key;

/// The estimates of every fused attribute this module heard of.
#[derive(Default)]
pub(crate) struct Fusion {
    cells: BTreeMap<Key, BTreeMap<Address, Packet>>,
}

impl Fusion {
    /// Takes a source's estimate; true if it is newer than what that source said before.
    pub fn update(&mut self, key: Key, packet: Packet) -> bool {
        let cell = self.cells.entry(key).or_default();
        match cell.get(&packet.source) {
            Some(old) if old.timestamp >= packet.timestamp => false,
            _ => {
                cell.insert(packet.source.clone(), packet);
                true
            }
        }
    }

    /// The fusion of the estimates of `key`, values clamped to `bounds`.
    pub fn result(&self, key: &Key, bounds: Option<(f64, f64)>) -> Option<Packet> {
        fuse(self.cells.get(key)?, bounds)
    }

    /// Every estimate held (for catch-up answers), by object.
    pub fn estimates(&self, object: &str) -> Vec<(Arc<str>, Packet)> {
        self.cells
            .iter()
            .filter(|((o, _), _)| &**o == object)
            .flat_map(|((_, a), cell)| cell.values().map(|p| (a.clone(), p.clone())))
            .collect()
    }

    /// Forgets an object (deleted).
    pub fn forget(&mut self, object: &str) {
        self.cells.retain(|(o, _), _| &**o != object);
    }
}

/// Inverse-variance fusion (accuracy is a standard deviation) of reals and vectors;
/// estimates with accuracy 0 are exact and outweigh the rest. Confidence is the
/// highest, the timestamp the latest, the source unknown. Other types, or mixed
/// shapes, take the latest estimate by `(timestamp, source)`.
pub(crate) fn fuse(cell: &BTreeMap<Address, Packet>, bounds: Option<(f64, f64)>) -> Option<Packet> {
    let latest = cell
        .values()
        .max_by(|a, b| (a.timestamp, &a.source).cmp(&(b.timestamp, &b.source)))?;
    let mut out = latest.clone();
    out.source = Address::unknown();
    out.confidence = cell.values().map(|p| p.confidence).fold(0.0, f64::max);
    if let Some((value, accuracy)) = combine(cell.values(), bounds) {
        out.value = value;
        out.accuracy = accuracy;
    }
    Some(out)
}

/// The reals a numeric value is made of; `None` for other types.
fn reals(v: &Value) -> Option<&[f64]> {
    match v {
        Value::Real(x) => Some(std::slice::from_ref(x)),
        Value::Vector(x) => Some(x),
        _ => None,
    }
}

/// The weighted mean and its standard deviation, if every value is a real, or every
/// value a vector of one length.
fn combine<'a>(
    packets: impl Iterator<Item = &'a Packet> + Clone,
    bounds: Option<(f64, f64)>,
) -> Option<(Value, f64)> {
    let first = packets.clone().next()?;
    let is_real = matches!(first.value, Value::Real(_));
    let shape = reals(&first.value)?.len();
    let same = |p: &Packet| {
        matches!(p.value, Value::Real(_)) == is_real
            && reals(&p.value).map(<[f64]>::len) == Some(shape)
    };
    if !packets.clone().all(same) {
        return None;
    }
    let exact = packets.clone().any(|p| p.accuracy == 0.0);
    let weight = |p: &Packet| {
        if exact {
            1.0
        } else {
            1.0 / (p.accuracy * p.accuracy)
        }
    };
    let mut sum = vec![0.0; shape];
    let mut total = 0.0;
    for p in packets.filter(|p| !exact || p.accuracy == 0.0) {
        let w = weight(p);
        total += w;
        for (s, x) in sum.iter_mut().zip(reals(&p.value).unwrap_or_default()) {
            *s += w * x;
        }
    }
    let (lo, hi) = bounds.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
    let mean: Vec<f64> = sum.iter().map(|s| (s / total).clamp(lo, hi)).collect();
    let accuracy = if exact { 0.0 } else { (1.0 / total).sqrt() };
    let value = if is_real {
        Value::Real(mean[0])
    } else {
        Value::from(mean)
    };
    Some((value, accuracy))
}

#[cfg(test)]
mod tests {
    use super::*;
    use slate_model::Timestamp;

    fn est(source: &str, v: f64, acc: f64, ts: u64) -> Packet {
        Packet {
            value: Value::Real(v),
            accuracy: acc,
            confidence: 0.5 + ts as f64 / 100.0,
            timestamp: Timestamp::from_raw(ts),
            source: Address::new(source).unwrap(),
        }
    }

    fn key() -> Key {
        ("target".into(), "x".into())
    }

    #[test]
    fn two_estimates_fuse_by_inverse_variance() {
        let mut f = Fusion::default();
        f.update(key(), est("t/r1/a", 10.0, 1.0, 1));
        f.update(key(), est("t/r2/a", 20.0, 2.0, 2));
        let p = f.result(&key(), None).unwrap();
        // weights 1 and 1/4: (10 + 20/4) / 1.25 = 12
        assert!((p.value.as_f64().unwrap() - 12.0).abs() < 1e-12);
        assert!((p.accuracy - (1.0f64 / 1.25).sqrt()).abs() < 1e-12);
        assert_eq!(p.timestamp, Timestamp::from_raw(2));
        assert!(p.source.is_unknown());
        assert_eq!(p.confidence, 0.52);
    }

    #[test]
    fn order_and_duplicates_do_not_matter() {
        let all = [
            est("t/r1/a", 1.0, 0.5, 1),
            est("t/r2/a", 3.0, 0.7, 2),
            est("t/r1/a", 2.0, 0.4, 3),
            est("t/r3/b", 5.0, 1.5, 4),
        ];
        let mut forward = Fusion::default();
        all.iter().for_each(|p| {
            forward.update(key(), p.clone());
        });
        let mut backward = Fusion::default();
        all.iter().rev().chain(all.iter()).for_each(|p| {
            backward.update(key(), p.clone());
        });
        assert_eq!(forward.result(&key(), None), backward.result(&key(), None));
    }

    #[test]
    fn an_older_estimate_of_a_source_is_ignored() {
        let mut f = Fusion::default();
        assert!(f.update(key(), est("t/r1/a", 1.0, 0.5, 5)));
        assert!(!f.update(key(), est("t/r1/a", 9.0, 0.5, 4)));
        assert_eq!(f.result(&key(), None).unwrap().value.as_f64(), Some(1.0));
    }

    #[test]
    fn exact_estimates_outweigh_the_others() {
        let mut f = Fusion::default();
        f.update(key(), est("t/r1/a", 1.0, 0.0, 1));
        f.update(key(), est("t/r2/a", 3.0, 0.0, 2));
        f.update(key(), est("t/r3/a", 100.0, 1.0, 3));
        let p = f.result(&key(), None).unwrap();
        assert_eq!((p.value.as_f64(), p.accuracy), (Some(2.0), 0.0));
    }

    #[test]
    fn vectors_fuse_per_element_and_other_types_take_the_latest() {
        let mut cell = BTreeMap::new();
        let mut a = est("t/r1/a", 0.0, 1.0, 1);
        a.value = Value::from([0.0, 10.0]);
        let mut b = est("t/r2/a", 0.0, 1.0, 2);
        b.value = Value::from([2.0, 20.0]);
        cell.insert(a.source.clone(), a.clone());
        cell.insert(b.source.clone(), b.clone());
        assert_eq!(fuse(&cell, None).unwrap().value, Value::from([1.0, 15.0]));
        a.value = Value::Bool(false);
        b.value = Value::Bool(true);
        cell.insert(a.source.clone(), a);
        cell.insert(b.source.clone(), b);
        assert_eq!(fuse(&cell, None).unwrap().value, Value::Bool(true));
    }
}
