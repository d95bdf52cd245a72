//! Do the boards agree? The team's view — the console and every surviving robot's
//! execution controller — must hold the same objects of the team classes with the same
//! values. What a dead module wrote last may have reached only some boards (nobody can
//! repeat it for it: docs/ici.md, "Limits"), so its packets, and objects it owned, are
//! left out of the comparison.
//!
//! Two measures: [`disagreement`] (do they agree now?) and [`Propagation`] (how long did
//! each change take to reach every board?).

use std::collections::{BTreeMap, BTreeSet};

use slate_model::{Address, Board, Value};

use crate::module::{Module, Role};
use crate::team::Team;

/// The classes every board of the team view models.
pub const TEAM_CLASSES: [&str; 4] = ["Robot", "Target", "Waypoint", "Mission"];

/// (object, attribute) → (value, source), on one board.
type View = BTreeMap<(String, String), (Value, Address)>;

/// The boards of the team view and what each holds.
fn views(team: &Team) -> (Vec<(String, View)>, BTreeSet<Address>) {
    let dead: BTreeSet<Address> = team
        .modules
        .iter()
        .filter(|m| !team.alive_modules().any(|a| a.address() == m.address()))
        .map(Module::stands_for)
        .collect();
    let mut boards = vec![team.console()];
    for i in (0..team.robots.len()).filter(|i| !team.dead[*i]) {
        boards.push(team.module(i, Role::Exec));
    }
    let views = boards
        .iter()
        .map(|m| (m.address().to_string(), view(m.node.board())))
        .collect();
    (views, dead)
}

/// Stored values of the team classes; an object shows as `(name, "")` with its owner.
fn view(board: &Board) -> View {
    let snap = board.snapshot();
    let mut out = View::new();
    for class in TEAM_CLASSES {
        for id in snap.instances(class).unwrap_or_default() {
            let Some(info) = snap.info(id) else { continue };
            out.insert(
                (info.name.to_string(), String::new()),
                (Value::Bool(true), info.owner),
            );
            for (attr, p, _) in snap.own_values(id) {
                out.insert(
                    (info.name.to_string(), attr.to_string()),
                    (p.value, p.source),
                );
            }
        }
    }
    out
}

/// The keys on which the views differ. Skipped: a key a dead module wrote (or, for an
/// object, owns) on any board, and every key of an object some board lacks while another
/// holds it from a dead owner (the dead module's last word reached only some boards).
fn differing(
    views: &[(String, View)],
    dead: &BTreeSet<Address>,
) -> BTreeMap<(String, String), String> {
    let keys: BTreeSet<&(String, String)> = views.iter().flat_map(|(_, v)| v.keys()).collect();
    let from_dead = |key: &(String, String)| {
        views
            .iter()
            .any(|(_, v)| v.get(key).is_some_and(|(_, s)| dead.contains(s)))
    };
    let orphans: BTreeSet<&String> = keys
        .iter()
        .filter(|k| {
            k.1.is_empty() && from_dead(k) && views.iter().any(|(_, v)| !v.contains_key(*k))
        })
        .map(|k| &k.0)
        .collect();
    let mut out = BTreeMap::new();
    for key in keys {
        if orphans.contains(&key.0) || from_dead(key) {
            continue;
        }
        let held: Vec<Option<&Value>> = views
            .iter()
            .map(|(_, v)| v.get(key).map(|h| &h.0))
            .collect();
        if let Some(k) = held.iter().position(|h| *h != held[0]) {
            let show = |h: Option<&Value>| h.map_or("nothing".to_owned(), ToString::to_string);
            let what = if key.1.is_empty() {
                key.0.clone()
            } else {
                format!("{}.{}", key.0, key.1)
            };
            let text = format!(
                "{what}: {} holds {}, {} holds {}",
                views[0].0,
                show(held[0]),
                views[k].0,
                show(held[k])
            );
            out.insert(key.clone(), text);
        }
    }
    out
}

/// The first disagreement between the team-view boards, or `None` if they agree.
pub fn disagreement(team: &Team) -> Option<String> {
    let (views, dead) = views(team);
    differing(&views, &dead).into_values().next()
}

/// How long each change took to reach every board of the team view: a key opens when
/// the boards start to differ on it and closes when they agree again.
#[derive(Clone, Debug, Default)]
pub struct Propagation {
    open: BTreeMap<(String, String), f64>,
    /// Seconds each closed difference lasted.
    pub delays: Vec<f64>,
}

impl Propagation {
    /// Compares the boards at world time `t`.
    pub fn observe(&mut self, team: &Team, t: f64) {
        let (views, dead) = views(team);
        let now = differing(&views, &dead);
        let closed: Vec<(String, String)> = self
            .open
            .keys()
            .filter(|k| !now.contains_key(*k))
            .cloned()
            .collect();
        for key in closed {
            if let Some(since) = self.open.remove(&key) {
                self.delays.push(t - since);
            }
        }
        for key in now.into_keys() {
            self.open.entry(key).or_insert(t);
        }
    }

    /// The `q` quantile (0..=1) of the delays.
    pub fn quantile(&self, q: f64) -> Option<f64> {
        let mut d = self.delays.clone();
        d.sort_by(f64::total_cmp);
        let i = ((d.len() as f64 - 1.0) * q.clamp(0.0, 1.0)).round() as usize;
        d.get(i).copied()
    }
}
