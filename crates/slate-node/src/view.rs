//! The node's view for the dashboard (the JSON contract of `docs/dashboard.md`): map items
//! from objects with a `position` vec<2>, classes, objects with their packets, plans with
//! their circuits' acknowledgements, link statistics and the event log.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Instant;

use parking_lot::Mutex;
use serde_json::{Value as Json, json};
use slate_ici::{Ici, LinkKind, PlanCircuits, Transport};
use slate_model::{Board, Packet, Value};
use slate_plans::Engine;
use slate_wire::PlanStep;

use crate::inspect::{Classes, packets};
use crate::monitor::EventLog;

/// A map item older than this is drawn stale.
pub const STALE_AFTER_S: f64 = 5.0;

/// Everything the view reads, shared with the node.
pub(crate) struct View {
    pub board: Arc<Board>,
    pub engine: Engine,
    pub ici: Ici,
    pub transport: Arc<dyn Transport>,
    pub circuits: Arc<PlanCircuits>,
    pub log: Arc<EventLog>,
    pub listen: Vec<String>,
    rates: Mutex<Rates>,
}

/// Bytes per second per link, measured between snapshots at least half a second apart.
#[derive(Default)]
struct Rates {
    at: Option<Instant>,
    totals: BTreeMap<LinkKind, u64>,
    per_s: BTreeMap<LinkKind, f64>,
}

impl View {
    pub fn new(
        board: Arc<Board>,
        engine: Engine,
        ici: Ici,
        transport: Arc<dyn Transport>,
        circuits: Arc<PlanCircuits>,
        log: Arc<EventLog>,
        listen: Vec<String>,
    ) -> Self {
        View {
            board,
            engine,
            ici,
            transport,
            circuits,
            log,
            listen,
            rates: Mutex::new(Rates::default()),
        }
    }

    /// The whole snapshot.
    pub fn snapshot(&self) -> Json {
        let classes = Classes::of(&self.board);
        let objects = self.objects(&classes);
        let stats = self.board.stats();
        json!({
            "title": format!("slate node {}", self.board.address()),
            "time": self.board.clock().physical().as_secs_f64(),
            "status": "running",
            "summary": {
                "address": self.board.address().as_str(),
                "listening": self.listen.join(", "),
                "peers alive": self.ici.alive_peers().len(),
                "objects": stats.objects,
                "classes": stats.classes,
                "revision": stats.revision,
            },
            "map": {"items": self.map_items(&classes)},
            "classes": classes_json(&classes),
            "objects": objects,
            "plans": self.plans(),
            "links": self.links(),
            "events": self.events(),
        })
    }

    fn objects(&self, classes: &Classes) -> Vec<Json> {
        let me = self.board.address().as_str();
        self.names()
            .into_iter()
            .filter_map(|name| {
                let info = self.board.info(&name)?;
                let attrs: Vec<Json> = packets(&self.board, classes, &name)?
                    .into_iter()
                    .map(|(attr, p)| self.packet_json(&attr, &p))
                    .collect();
                Some(json!({
                    "board": me, "name": name, "class": &*info.class,
                    "context": info.context.name(), "owner": info.owner.to_string(),
                    "attrs": attrs,
                }))
            })
            .collect()
    }

    /// Every object's name (not the classes).
    fn names(&self) -> Vec<String> {
        let ids = self.board.instances(slate_model::THING).unwrap_or_default();
        ids.into_iter()
            .filter_map(|id| self.board.name_of(id))
            .map(|n| n.to_string())
            .collect()
    }

    fn packet_json(&self, attr: &str, p: &Packet) -> Json {
        json!({
            "name": attr, "value": value_text(&p.value), "accuracy": p.accuracy,
            "confidence": p.confidence, "age": self.age(p), "source": p.source.to_string(),
        })
    }

    /// Seconds since the packet was written; `None` (null) for a packet that claims no
    /// time (a declared default, an initial value from a file), which must not read as
    /// fresh.
    fn age(&self, p: &Packet) -> Option<f64> {
        p.has_time()
            .then(|| self.board.clock().age(p.timestamp).as_secs_f64())
    }

    fn map_items(&self, classes: &Classes) -> Vec<Json> {
        let me = self.board.address().as_str();
        let mut items = Vec::new();
        for name in self.names() {
            let Ok(pos) = self.board.read(&name, "position") else {
                continue;
            };
            let Some([x, y]) = pos
                .value
                .as_vector()
                .and_then(|v| <[f64; 2]>::try_from(v).ok())
            else {
                continue;
            };
            let Some(info) = self.board.info(&name) else {
                continue;
            };
            let age = self.age(&pos);
            let mut item = json!({
                "id": name, "kind": kind(&classes.lineage(&info.class)), "x": x, "y": y,
                "accuracy": pos.accuracy, "confidence": pos.confidence, "age": age,
                "stale": age.is_some_and(|a| a > STALE_AFTER_S), "owner": info.owner.to_string(), "board": me,
            });
            for (attr, field) in [("heading", "heading"), ("radius", "radius")] {
                if let Some(v) = self
                    .board
                    .read(&name, attr)
                    .ok()
                    .and_then(|p| p.value.as_f64())
                {
                    item[field] = json!(v);
                }
            }
            if let Ok(Value::Bool(alive)) = self.board.read(&name, "alive").map(|p| p.value) {
                item["alive"] = json!(alive);
            }
            items.push(item);
        }
        items
    }

    fn plans(&self) -> Vec<Json> {
        let me = self.board.address().to_string();
        let received = self.circuits.received();
        let mut out: Vec<Json> = self
            .engine
            .plans()
            .into_iter()
            .map(|p| {
                let circuit = received.iter().find(|c| c.name == p.name);
                let origin = circuit.map_or_else(String::new, |c| c.peer.to_string());
                let acks: Vec<String> = circuit
                    .map(|c| c.steps.iter().map(ToString::to_string).collect())
                    .unwrap_or_default();
                json!({
                    "board": me, "name": p.name, "state": p.state.name(), "fired": p.fired,
                    "last_error": p.last_error.unwrap_or_default(), "origin": origin, "acks": acks,
                })
            })
            .collect();
        for c in self.circuits.sent() {
            let acks: Vec<String> = c.steps.iter().map(ToString::to_string).collect();
            let state = c.steps.last().map_or("sent", PlanStep::plan_state);
            out.push(json!({
                "board": c.peer.to_string(), "name": c.name, "state": state,
                "origin": me, "acks": acks,
            }));
        }
        out
    }

    fn links(&self) -> Vec<Json> {
        let stats = self.transport.stats();
        let mut rates = self.rates.lock();
        let now = Instant::now();
        let totals: BTreeMap<LinkKind, u64> = LinkKind::ALL
            .iter()
            .map(|l| {
                let t = stats.link(*l);
                (*l, t.sent_bytes + t.recv_bytes)
            })
            .collect();
        let elapsed = rates.at.map(|t| now.duration_since(t).as_secs_f64());
        if elapsed.is_none_or(|e| e >= 0.5) {
            if let Some(e) = elapsed {
                for (l, total) in &totals {
                    let before = rates.totals.get(l).copied().unwrap_or(0);
                    rates
                        .per_s
                        .insert(*l, total.saturating_sub(before) as f64 / e);
                }
            }
            rates.at = Some(now);
            rates.totals = totals.clone();
        }
        LinkKind::ALL
            .iter()
            .map(|l| {
                json!({
                    "name": format!("{l} link"), "kind": l.name(),
                    "bytes_per_s": rates.per_s.get(l).copied().unwrap_or(0.0),
                    "total_bytes": totals.get(l).copied().unwrap_or(0),
                })
            })
            .collect()
    }

    fn events(&self) -> Vec<Json> {
        self.log
            .events()
            .into_iter()
            .map(|e| json!({"t": e.time, "level": e.level.name(), "text": e.text}))
            .collect()
    }
}

fn classes_json(classes: &Classes) -> Vec<Json> {
    classes
        .defs()
        .map(|d| {
            let attrs: Vec<&str> = d.attrs.iter().map(|a| a.name.as_str()).collect();
            json!({"name": d.name, "parent": d.parent, "attrs": attrs})
        })
        .collect()
}

/// The map's kind of an object, from its class chain's names.
fn kind(lineage: &[&str]) -> &'static str {
    for class in lineage {
        let c = class.to_ascii_lowercase();
        for (word, kind) in [
            ("vehicle", "robot"),
            ("robot", "robot"),
            ("obstacle", "obstacle"),
            ("target", "target"),
            ("goal", "goal"),
        ] {
            if c.contains(word) {
                return kind;
            }
        }
    }
    "other"
}

/// A value as text: strings without their quotes, the rest as the language writes them.
pub fn value_text(v: &Value) -> String {
    match v {
        Value::Str(s) => s.to_string(),
        other => other.to_string(),
    }
}
