//! The node's view for the dashboard (the JSON contract of `docs/dashboard.md`): map items
//! from objects with a `position` vec<2>, classes, objects with their packets, plans with
//! their circuits' acknowledgements, link statistics and the event log.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Instant;

use parking_lot::Mutex;
use serde_json::{Value as Json, json};
use slate_dashboard::{
    AttrRow, ClassRow, EventRow, ItemKind, LinkRow, MapItem, MapView, ObjectRow, PlanRow, Snapshot,
    Status, is_stale,
};
use slate_ici::{Ici, LinkKind, PlanCircuits, Transport};
use slate_model::{Board, Packet, Value};
use slate_plans::Engine;
use slate_wire::PlanStep;

use crate::inspect::{Classes, packets};
use crate::monitor::EventLog;

/// Everything the view reads, shared with the node.
pub(crate) struct View {
    pub board: Arc<Board>,
    pub engine: Engine,
    pub ici: Ici,
    pub transport: Arc<dyn Transport>,
    pub circuits: Arc<PlanCircuits>,
    pub log: Arc<EventLog>,
    pub listen: Vec<String>,
    /// The state keeper's counters, if the node keeps its board.
    pub state: Option<Arc<Mutex<crate::state::StateStats>>>,
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
            state: None,
            rates: Mutex::new(Rates::default()),
        }
    }

    /// The whole snapshot, as the page's JSON.
    pub fn snapshot(&self) -> Json {
        self.view().to_json()
    }

    /// The whole snapshot.
    pub fn view(&self) -> Snapshot {
        let classes = Classes::of(&self.board);
        Snapshot {
            title: format!("slate node {}", self.board.address()),
            time: self.board.clock().physical().as_secs_f64(),
            status: Status::Running,
            summary: self.summary(),
            map: MapView {
                bounds: None,
                items: self.map_items(&classes),
            },
            classes: class_rows(&classes),
            objects: self.objects(&classes),
            plans: self.plans(),
            links: self.links(),
            events: self.events(),
        }
    }

    fn summary(&self) -> BTreeMap<String, Json> {
        let stats = self.board.stats();
        let plans = self.circuits.stats();
        [
            ("address", json!(self.board.address().as_str())),
            ("listening", json!(self.listen.join(", "))),
            ("peers alive", json!(self.ici.alive_peers().len())),
            ("objects", json!(stats.objects)),
            ("classes", json!(stats.classes)),
            ("revision", json!(stats.revision)),
            ("plans received", json!(plans.received)),
            ("plans rejected", json!(plans.rejected)),
            ("plans refused: no authority", json!(plans.unauthorised)),
        ]
        .into_iter()
        .chain(self.state_summary())
        .map(|(k, v)| (k.to_owned(), v))
        .collect()
    }

    /// `state revision`: every change up to it is in the state directory (when the node
    /// keeps one); `state commits`.
    fn state_summary(&self) -> Vec<(&'static str, Json)> {
        let Some(stats) = &self.state else {
            return Vec::new();
        };
        let stats = stats.lock();
        vec![
            ("state revision", json!(stats.revision)),
            ("state commits", json!(stats.commits)),
        ]
    }

    fn objects(&self, classes: &Classes) -> Vec<ObjectRow> {
        let me = self.board.address().to_string();
        self.names()
            .into_iter()
            .filter_map(|name| {
                let info = self.board.info(&name)?;
                let attrs = packets(&self.board, classes, &name)?
                    .into_iter()
                    .map(|(attr, p)| self.attr_row(attr, &p))
                    .collect();
                Some(ObjectRow {
                    board: me.clone(),
                    name,
                    class: info.class.to_string(),
                    context: info.context.name().to_owned(),
                    owner: info.owner.to_string(),
                    attrs,
                })
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

    fn attr_row(&self, name: String, p: &Packet) -> AttrRow {
        AttrRow {
            name,
            value: p.value.plain_text(),
            accuracy: p.accuracy,
            confidence: p.confidence,
            age: self.age(p),
            source: p.source.to_string(),
        }
    }

    /// Seconds since the packet was written; `None` (null) for a packet that claims no
    /// time (a declared default, an initial value from a file), which must not read as
    /// fresh.
    fn age(&self, p: &Packet) -> Option<f64> {
        p.age(self.board.clock()).map(|a| a.as_secs_f64())
    }

    fn map_items(&self, classes: &Classes) -> Vec<MapItem> {
        self.names()
            .into_iter()
            .filter_map(|name| self.map_item(classes, name))
            .collect()
    }

    /// An object with a `position` vec<2>, drawn by its class chain's kind.
    fn map_item(&self, classes: &Classes, name: String) -> Option<MapItem> {
        let pos = self.board.read(&name, "position").ok()?;
        let [x, y] = <[f64; 2]>::try_from(pos.value.as_vector()?).ok()?;
        let info = self.board.info(&name)?;
        let real = |attr| self.board.read(&name, attr).ok()?.value.as_f64();
        let alive = match self.board.read(&name, "alive").map(|p| p.value) {
            Ok(Value::Bool(alive)) => Some(alive),
            _ => None,
        };
        let age = self.age(&pos);
        Some(MapItem {
            kind: kind(&classes.lineage(&info.class)),
            x,
            y,
            heading: real("heading"),
            accuracy: Some(pos.accuracy),
            confidence: Some(pos.confidence),
            age,
            stale: is_stale(age),
            alive,
            owner: Some(info.owner.to_string()),
            board: Some(self.board.address().to_string()),
            radius: real("radius"),
            id: name,
            ..MapItem::default()
        })
    }

    fn plans(&self) -> Vec<PlanRow> {
        let me = self.board.address().to_string();
        let received = self.circuits.received();
        let mut out: Vec<PlanRow> = self
            .engine
            .plans()
            .into_iter()
            .map(|p| {
                let circuit = received.iter().find(|c| c.name == p.name);
                PlanRow {
                    board: me.clone(),
                    state: p.state.name().to_owned(),
                    fired: Some(p.fired),
                    last_error: Some(p.last_error.unwrap_or_default()),
                    origin: circuit.map_or_else(String::new, |c| c.peer.to_string()),
                    acks: circuit.map(|c| ack_texts(&c.steps)).unwrap_or_default(),
                    name: p.name,
                }
            })
            .collect();
        for c in self.circuits.sent() {
            out.push(PlanRow {
                board: c.peer.to_string(),
                state: c
                    .steps
                    .last()
                    .map_or("sent", PlanStep::plan_state)
                    .to_owned(),
                origin: me.clone(),
                acks: ack_texts(&c.steps),
                name: c.name,
                ..PlanRow::default()
            });
        }
        out
    }

    fn links(&self) -> Vec<LinkRow> {
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
            .map(|l| LinkRow {
                name: format!("{l} link"),
                kind: l.name().to_owned(),
                bytes_per_s: rates.per_s.get(l).copied().unwrap_or(0.0),
                budget_bps: None,
                total_bytes: totals.get(l).copied().unwrap_or(0),
            })
            .collect()
    }

    fn events(&self) -> Vec<EventRow> {
        self.log
            .events()
            .into_iter()
            .map(|e| EventRow {
                t: e.time,
                level: e.level,
                text: e.text,
            })
            .collect()
    }
}

fn class_rows(classes: &Classes) -> Vec<ClassRow> {
    classes
        .defs()
        .map(|d| ClassRow {
            name: d.name.clone(),
            parent: d.parent.clone(),
            attrs: d.attrs.iter().map(|a| a.name.clone()).collect(),
        })
        .collect()
}

/// Each acknowledgement as its step's text.
fn ack_texts(steps: &[PlanStep]) -> Vec<String> {
    steps.iter().map(ToString::to_string).collect()
}

/// The map's kind of an object, from its class chain's names.
fn kind(lineage: &[&str]) -> ItemKind {
    for class in lineage {
        let c = class.to_ascii_lowercase();
        for (word, kind) in [
            ("vehicle", ItemKind::Robot),
            ("robot", ItemKind::Robot),
            ("obstacle", ItemKind::Obstacle),
            ("target", ItemKind::Target),
            ("goal", ItemKind::Goal),
        ] {
            if c.contains(word) {
                return kind;
            }
        }
    }
    ItemKind::Other
}
