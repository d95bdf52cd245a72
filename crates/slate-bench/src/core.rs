//! `slate bench core`: the world model's hot paths against a `HashMap<(u32, u32), Packet>`.
//!
//! Baselines: `hashmap_get_ns` is a lookup that returns the packet (a clone: a board read
//! hands an owned packet to the caller, as any thread-safe blackboard must);
//! `hashmap_get_ref_ns` is the bare lookup; `hashmap_insert_ns` replaces the packet at an
//! existing key. Both maps use the standard library's default hasher.

use std::collections::HashMap;
use std::hint::black_box;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use slate_model::{
    Address, AttrDecl, Board, ClassDef, Key, Packet, Timestamp, Update, Value, ValueType,
};

use crate::{Config, Figures, measure};

/// The attributes of `Vehicle`.
pub const ATTRS: [&str; 8] = [
    "x", "y", "heading", "speed", "mode", "battery", "armed", "target",
];

/// The suite's board: `Vehicle` <- `GroundVehicle` <- `Gsr` with ten written `Gsr`s
/// `v0`..`v9` (`mode` left unwritten, so a read of it resolves on `Vehicle`), a
/// class-level `Vehicle.battery`, and `instances` `Obstacle`s `o0`.. for queries.
pub fn world(instances: usize) -> Board {
    let b = Board::new();
    let vehicle = ATTRS.iter().fold(ClassDef::new("Vehicle"), |c, a| {
        let ty = match *a {
            "mode" => ValueType::Str,
            "armed" => ValueType::Bool,
            "target" => ValueType::Ref,
            _ => ValueType::Real,
        };
        c.attr(AttrDecl::new(a, ty))
    });
    b.define(vehicle).expect("define Vehicle");
    b.define(ClassDef::new("GroundVehicle").parent("Vehicle"))
        .expect("define");
    b.define(ClassDef::new("Gsr").parent("GroundVehicle"))
        .expect("define");
    b.define(ClassDef::new("Obstacle").attr(AttrDecl::new("range", ValueType::Real)))
        .expect("define");
    for name in ["v0", "v1", "v2", "v3", "v4", "v5", "v6", "v7", "v8", "v9"] {
        b.create("Gsr", name).expect("create");
        for a in ["x", "y", "heading", "speed", "battery"] {
            b.write(name, a, 1.0).expect("write");
        }
    }
    b.write("Vehicle", "battery", 0.9)
        .expect("class-level write");
    for i in 0..instances {
        b.create("Obstacle", &format!("o{i}")).expect("create");
    }
    b
}

/// The packet the `HashMap` baselines store and clone.
pub fn packet() -> Packet {
    Packet {
        value: Value::Real(1.0),
        accuracy: 0.1,
        confidence: 0.9,
        timestamp: Timestamp::from_raw(1 << 40),
        source: Address::new("team/r1/nav").expect("address"),
    }
}

/// Runs the suite; `progress` is told each step.
pub fn run(cfg: &Config, progress: &mut dyn FnMut(&str)) -> Figures {
    let mut r =
        Figures::new("slate bench core: world model (Board) vs HashMap<(u32, u32), Packet>");
    progress("baselines");
    baselines(cfg, &mut r);
    let b = world(10_000);
    let own = b.key("v0", "speed").expect("key");
    let inherited = b.key("v0", "mode").expect("key"); // unwritten: declared on Vehicle
    let class_level = b.key("v1", "battery");
    let _ = class_level;
    let clock = b.clock().clone();
    r.add("clock_now_ns", measure(cfg, || _ = black_box(clock.now())));
    progress("reads");
    reads(cfg, &mut r, &b, own, inherited);
    progress("writes");
    writes(cfg, &mut r, &b, own);
    progress("active functions");
    active_fn(cfg, &mut r, &b);
    progress("query of 10 000 instances");
    let ns = measure(cfg, || {
        drop(black_box(b.instances("Obstacle").expect("query")))
    });
    r.add("query_10k_ns", ns);
    r
}

fn baselines(cfg: &Config, r: &mut Figures) {
    let mut map: HashMap<(u32, u32), Packet> = HashMap::new();
    for o in 0..10u32 {
        for a in 0..8u32 {
            map.insert((o, a), packet());
        }
    }
    let key = black_box((3u32, 4u32));
    r.add(
        "hashmap_get_ref_ns",
        measure(cfg, || _ = black_box(map.get(&key))),
    );
    r.add(
        "hashmap_get_ns",
        measure(cfg, || drop(black_box(map.get(&key).cloned()))),
    );
    let p = packet();
    r.add(
        "hashmap_insert_ns",
        measure(cfg, || drop(black_box(map.insert(key, p.clone())))),
    );
}

fn reads(cfg: &Config, r: &mut Figures, b: &Board, own: Key, inherited: Key) {
    r.compare(
        "read_ns",
        measure(cfg, || drop(black_box(b.read_key(own)))),
        "hashmap_get_ns",
        Some(2.0),
    );
    let ns = measure(cfg, || drop(black_box(b.read_key(inherited))));
    r.compare("read_inherited_ns", ns, "hashmap_get_ns", None);
    let ns = measure(cfg, || drop(black_box(b.read("v0", "speed"))));
    r.compare("read_by_name_ns", ns, "hashmap_get_ns", None);
}

fn writes(cfg: &Config, r: &mut Figures, b: &Board, own: Key) {
    let mut values = crate::Cycle::new(0.0, 49.0);
    let mut next = || values.next_value();
    let ns = measure(cfg, || drop(black_box(b.write_key(own, next()))));
    r.compare("write_ns", ns, "hashmap_insert_ns", Some(5.0));
    let ns = measure(cfg, || {
        drop(black_box(b.write_key(
            own,
            Update::new(next()).accuracy(0.1).confidence(0.9),
        )))
    });
    r.compare("write_full_packet_ns", ns, "hashmap_insert_ns", None);
    let keys: Vec<Key> = (0..10)
        .map(|i| b.key(&format!("v{i}"), "x").expect("key"))
        .collect();
    let ns = measure(cfg, || {
        let mut batch = b.batch();
        let v = next();
        for k in &keys {
            batch.write_key(*k, v);
        }
        drop(black_box(batch.commit()));
    });
    r.compare("batch10_ns", ns, "hashmap_insert_ns", None);
}

fn active_fn(cfg: &Config, r: &mut Figures, b: &Board) {
    let count = Arc::new(AtomicU64::new(0));
    let c = count.clone();
    b.on_write("v9", "heading", move |_| {
        c.fetch_add(1, Ordering::Relaxed);
        Ok(())
    })
    .expect("attach");
    let key = b.key("v9", "heading").expect("key");
    let mut values = crate::Cycle::new(0.0, 7.0);
    let ns = measure(cfg, || {
        let v = values.next_value();
        drop(black_box(b.write_key(key, v)));
    });
    r.compare("write_active_fn_ns", ns, "hashmap_insert_ns", None);
    assert!(count.load(Ordering::Relaxed) > 0, "the active function ran");
}

/// The timings (nanoseconds per operation) the suite's JSON always holds; the ones
/// performance.md quotes are among them.
pub const TIMED_FIELDS: &[&str] = &[
    "read_ns",
    "read_inherited_ns",
    "write_ns",
    "batch10_ns",
    "write_active_fn_ns",
    "query_10k_ns",
    "hashmap_get_ns",
    "hashmap_insert_ns",
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_core_suite_reports_every_field() {
        let j = run(&crate::TINY, &mut |_| {}).json();
        crate::assert_fields(&j, TIMED_FIELDS, |x| x > 0.0);
    }
}
