//! The JSON contract of `docs/dashboard.md` as types: every producer (a node's view, the
//! demo's) fills a [`Snapshot`] and hands the page its JSON ([`Snapshot::to_json`]), so a
//! field is named, typed and omitted the same way by all of them.
//!
//! Optional fields that are `None` are left out, which the page reads as absent; the one
//! exception is `age`, written as `null` when the value claims no time (a declared default,
//! an initial value from a file), because the contract gives that `null` its own meaning.

use std::collections::BTreeMap;

use serde::Serialize;
use serde_json::Value;

/// A map item, or an attribute, whose age is over this many seconds is drawn stale.
pub const STALE_AFTER_S: f64 = 5.0;

/// Is a value of this age (seconds; `None`: it claims no time) stale? A value that claims
/// no time is never stale.
pub fn is_stale(age: Option<f64>) -> bool {
    age.is_some_and(|a| a > STALE_AFTER_S)
}

/// The whole view, as the page receives it.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Snapshot {
    /// Top bar and window title.
    pub title: String,
    /// Seconds on the world's clock.
    pub time: f64,
    /// How the run is going.
    pub status: Status,
    /// Free-form key → value (numbers, strings), shown as a grid.
    pub summary: BTreeMap<String, Value>,
    /// The map's extent and items.
    pub map: MapView,
    /// The class tree, one row per class.
    pub classes: Vec<ClassRow>,
    /// Every object with its packets.
    pub objects: Vec<ObjectRow>,
    /// Plans with their states and acknowledgements.
    pub plans: Vec<PlanRow>,
    /// Links against their budgets.
    pub links: Vec<LinkRow>,
    /// The event log.
    pub events: Vec<EventRow>,
}

impl Snapshot {
    /// The snapshot as the page's JSON.
    pub fn to_json(&self) -> Value {
        // Serializing these types cannot fail: every map key is a string.
        serde_json::to_value(self).unwrap_or(Value::Null)
    }
}

/// How the run is going: the page colours `running` green, `finished` blue, `failed` red.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
#[non_exhaustive]
pub enum Status {
    /// Under way.
    #[default]
    Running,
    /// Over, as planned.
    Finished,
    /// Over, having failed.
    Failed,
}

/// The map: its extent and what is drawn on it.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct MapView {
    /// `[xmin, ymin, xmax, ymax]`; `None`: fitted around the items.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bounds: Option<[f64; 4]>,
    /// The items.
    pub items: Vec<MapItem>,
}

/// One thing drawn on the map.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct MapItem {
    /// Links the item to the object of that name; the label when there is no `label`.
    pub id: String,
    /// How it is drawn.
    pub kind: ItemKind,
    /// Text beside it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub label: Option<String>,
    /// Position, map units.
    pub x: f64,
    /// Position, map units.
    pub y: f64,
    /// Radians, counter-clockwise from +x.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heading: Option<f64>,
    /// Radius of the accuracy circle, map units.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accuracy: Option<f64>,
    /// In `[0, 1]`, drawn as opacity.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub confidence: Option<f64>,
    /// Seconds since the position was written; `null`: it claims no time.
    pub age: Option<f64>,
    /// Drawn faded and dashed.
    pub stale: bool,
    /// `Some(false)`: drawn crossed out.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub alive: Option<bool>,
    /// The module that owns (or wrote) it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub owner: Option<String>,
    /// Who found this target (a target turns green once set).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub found_by: Option<String>,
    /// The board this view is from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub board: Option<String>,
    /// An obstacle's size, map units.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
}

/// How a map item is drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
#[non_exhaustive]
pub enum ItemKind {
    /// A triangle along its heading, with a trail.
    Robot,
    /// A grey disc of its radius.
    Obstacle,
    /// An amber diamond, green once found.
    Target,
    /// A double ring.
    Goal,
    /// A small square.
    #[default]
    Other,
}

/// One class of the tree.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ClassRow {
    /// Class name.
    pub name: String,
    /// Its parent's name (an unknown parent makes it a root).
    pub parent: String,
    /// The attributes it declares itself.
    pub attrs: Vec<String>,
}

/// One object and its packets.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ObjectRow {
    /// The board holding it (with `name`, identifies the row).
    pub board: String,
    /// Object name.
    pub name: String,
    /// Its class.
    pub class: String,
    /// Its context (`self`, `surroundings`, `system`, ...).
    pub context: String,
    /// The module that owns it.
    pub owner: String,
    /// One row per attribute packet.
    pub attrs: Vec<AttrRow>,
}

/// One attribute packet: value, accuracy, confidence, age, source.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct AttrRow {
    /// Attribute name.
    pub name: String,
    /// The value as people read it (strings without quotes).
    pub value: String,
    /// Potential deviation, in the attribute's unit.
    pub accuracy: f64,
    /// In `[0, 1]`.
    pub confidence: f64,
    /// Seconds since it was written; `null`: it claims no time.
    pub age: Option<f64>,
    /// The module that wrote it.
    pub source: String,
}

/// One plan: where it runs, where it came from, its state and acknowledgements.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PlanRow {
    /// The board running it.
    pub board: String,
    /// Plan name.
    pub name: String,
    /// Its state (`active`, `triggered`, `terminated`, `failed`, `rejected`, `lost`, ...).
    pub state: String,
    /// Times its action ran, where known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fired: Option<u64>,
    /// Its action's last error (empty: none), where known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub last_error: Option<String>,
    /// The board that sent it (empty: loaded locally).
    pub origin: String,
    /// Its acknowledgements in order, each as its step's text.
    pub acks: Vec<String>,
}

/// One link's traffic against its budget.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct LinkRow {
    /// Shown as the row's name.
    pub name: String,
    /// The link kind (`team`, `robot`, ...).
    pub kind: String,
    /// Current rate.
    pub bytes_per_s: f64,
    /// The budget the rate is drawn against; `None`: no budget.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub budget_bps: Option<f64>,
    /// Bytes carried so far.
    pub total_bytes: u64,
}

/// One entry of the event log.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EventRow {
    /// Seconds on the world's clock.
    pub t: f64,
    /// How much it matters.
    pub level: Level,
    /// What happened, in a sentence.
    pub text: String,
}

/// How much an event matters; the page colours it. Exhaustive: producers match on it
/// (a node logs each level through `tracing` at the same level).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Level {
    /// Normal operation.
    Info,
    /// Something went wrong, and the run carries on.
    Warn,
    /// Something failed.
    Error,
}

impl Level {
    /// `info`, `warn` or `error`.
    pub fn name(self) -> &'static str {
        match self {
            Level::Info => "info",
            Level::Warn => "warn",
            Level::Error => "error",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn an_empty_snapshot_has_every_section() {
        let j = Snapshot::default().to_json();
        for section in [
            "title", "time", "status", "summary", "map", "classes", "objects",
        ] {
            assert!(j.get(section).is_some(), "{section} missing from {j}");
        }
        assert_eq!(j["status"], "running");
        assert_eq!(j["map"], json!({"items": []}));
    }

    #[test]
    fn a_map_item_leaves_out_what_it_lacks_but_keeps_a_null_age() {
        let item = MapItem {
            id: "r1".into(),
            kind: ItemKind::Robot,
            x: 1.0,
            y: 2.0,
            ..MapItem::default()
        };
        let j = serde_json::to_value(&item).unwrap();
        assert_eq!(
            j,
            json!({"id": "r1", "kind": "robot", "x": 1.0, "y": 2.0, "age": null, "stale": false})
        );
    }

    #[test]
    fn levels_and_kinds_read_as_the_contract_names_them() {
        let event = EventRow {
            t: 1.5,
            level: Level::Warn,
            text: "r3 lost".into(),
        };
        let j = serde_json::to_value(&event).unwrap();
        assert_eq!(j["level"], Level::Warn.name());
        assert_eq!(
            serde_json::to_value(ItemKind::Obstacle).unwrap(),
            "obstacle"
        );
    }

    #[test]
    fn only_a_value_with_an_age_over_the_limit_is_stale() {
        assert!(!is_stale(None));
        assert!(!is_stale(Some(STALE_AFTER_S)));
        assert!(is_stale(Some(STALE_AFTER_S + 0.1)));
    }
}
