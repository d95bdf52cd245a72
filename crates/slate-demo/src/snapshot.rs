//! The dashboard's view of a run (the JSON contract of docs/dashboard.md): the map as
//! the console's board knows it (robots and targets with their accuracy, confidence and
//! age; obstacles from the terrain map), the console's class tree and objects (its node's
//! own view of them), every plan
//! sent on a circuit with its acknowledgements, the links against their budget, events.

use std::collections::BTreeMap;

use serde_json::{Value, json};
use slate_dashboard::{
    EventRow, ItemKind, LinkRow, MapItem, MapView, PlanRow, Snapshot, Status, is_stale,
};
use slate_ici::LinkKind;
use slate_model::{Board, Packet, Value as V};
use slate_wire::PlanStep;

use crate::observe::{flag, instances, point, reference, text};
use crate::run::Demo;

/// The whole snapshot.
pub fn snapshot(demo: &Demo, status: Status) -> Snapshot {
    let c = &demo.config;
    let console = demo.team.console().node.view();
    Snapshot {
        title: format!(
            "slate demo — seed {}, {} robots, {} network",
            c.seed,
            c.robots,
            c.network.name()
        ),
        time: (demo.time() * 10.0).round() / 10.0,
        status,
        summary: summary(demo),
        map: map(demo),
        classes: console.classes,
        objects: console.objects,
        plans: plans(demo),
        links: links(demo),
        events: events(demo),
    }
}

fn summary(demo: &Demo) -> BTreeMap<String, Value> {
    let console = demo.team.console().node.board();
    let found = instances(console, "Target")
        .iter()
        .filter(|t| !text(console, t, "found_by").is_empty())
        .count();
    let alive = demo.team.dead.iter().filter(|d| !**d).count();
    let team_bps = demo.traffic.team_bps();
    let fault = demo.observer.fault.as_ref();
    let recovery = fault.and_then(|f| f.recovered.map(|r| format!("{:.1} s", r - f.at)));
    [
        ("mission", json!(text(console, "mission", "phase"))),
        (
            "targets found",
            json!(format!("{found}/{}", demo.world.targets.len())),
        ),
        (
            "robots alive",
            json!(format!("{alive}/{}", demo.team.robots.len())),
        ),
        (
            "duplicate investigations",
            json!(demo.observer.duplicates().len()),
        ),
        ("team link now", json!(format!("{:.0} bit/s", team_bps))),
        (
            "team link peak",
            json!(format!(
                "{:.0} of {} bit/s",
                demo.traffic.peak_radio_bps.0, demo.config.team_link.budget_bps
            )),
        ),
        ("recovery", json!(recovery.unwrap_or_else(|| "—".into()))),
        ("seed", json!(demo.config.seed)),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_owned(), v))
    .collect()
}

/// Seconds since the packet was written on the console's clock; `None` when it claims
/// no time.
fn age(board: &Board, p: &Packet) -> Option<f64> {
    p.age(board.clock()).map(|a| a.as_secs_f64())
}

fn map(demo: &Demo) -> MapView {
    let console = demo.team.console().node.board();
    let mut items: Vec<MapItem> = demo
        .world
        .obstacles
        .iter()
        .map(|o| MapItem {
            id: o.id.to_string(),
            kind: ItemKind::Obstacle,
            x: o.center[0],
            y: o.center[1],
            radius: Some(o.radius),
            ..MapItem::default()
        })
        .collect();
    items.extend(
        instances(console, "Waypoint")
            .iter()
            .filter_map(|w| waypoint_item(console, w)),
    );
    for t in instances(console, "Target") {
        items.extend(target_item(console, &t));
    }
    for (i, r) in demo.team.robots.iter().enumerate() {
        items.extend(robot_items(console, r, demo.team.dead[i]));
    }
    let b = demo.world.bounds;
    MapView {
        bounds: Some([b[0], b[1], b[2], b[3]]),
        items,
    }
}

/// A waypoint, ticked once visited (and then drawn faint).
fn waypoint_item(console: &Board, w: &str) -> Option<MapItem> {
    let (p, _) = point(console, w, "position")?;
    let visited = flag(console, w, "visited");
    Some(MapItem {
        id: w.to_owned(),
        kind: ItemKind::Other,
        label: Some(if visited { "✓" } else { "·" }.to_owned()),
        x: p[0],
        y: p[1],
        owner: Some(reference(console, w, "assignee")),
        confidence: Some(if visited { 0.2 } else { 0.8 }),
        ..MapItem::default()
    })
}

fn target_item(console: &Board, t: &str) -> Option<MapItem> {
    let p = console.read(t, "location").ok()?;
    let [x, y] = p.value.as_vector()? else {
        return None;
    };
    let identity = console.read(t, "identity").ok()?;
    let found = text(console, t, "found_by");
    let claimant = reference(console, t, "claimant");
    let label = match (found.is_empty(), claimant.is_empty()) {
        (false, _) => format!("{t} ✓ {found}"),
        (true, false) => format!("{t} → {claimant}"),
        _ => t.to_owned(),
    };
    let age = age(console, &p);
    Some(MapItem {
        id: t.to_owned(),
        kind: ItemKind::Target,
        label: Some(label),
        x: *x,
        y: *y,
        accuracy: Some(p.accuracy),
        confidence: Some(identity.confidence),
        age,
        stale: is_stale(age) && found.is_empty(),
        board: Some(console.address().to_string()),
        owner: Some(p.source.to_string()),
        found_by: (!found.is_empty()).then_some(found),
        ..MapItem::default()
    })
}

fn robot_items(console: &Board, r: &str, dead: bool) -> Vec<MapItem> {
    let Ok(p) = console.read(r, "position") else {
        return Vec::new();
    };
    let Some([x, y]) = p.value.as_vector() else {
        return Vec::new();
    };
    let alive = !matches!(
        console.read(r, "alive").map(|a| a.value),
        Ok(V::Bool(false))
    );
    let age = age(console, &p);
    let mut items = vec![MapItem {
        id: r.to_owned(),
        kind: ItemKind::Robot,
        label: Some(format!("{r} {}", text(console, r, "phase"))),
        x: *x,
        y: *y,
        heading: console
            .read(r, "heading")
            .ok()
            .and_then(|h| h.value.as_f64()),
        accuracy: Some(p.accuracy),
        confidence: Some(p.confidence),
        age,
        stale: is_stale(age) && !dead,
        alive: Some(alive),
        board: Some(console.address().to_string()),
        owner: Some(p.source.to_string()),
        ..MapItem::default()
    }];
    if let Some((g, _)) = point(console, r, "goal").filter(|_| alive) {
        items.push(MapItem {
            id: format!("{r}_goal"),
            kind: ItemKind::Goal,
            label: Some(format!("{r} goal")),
            x: g[0],
            y: g[1],
            ..MapItem::default()
        });
    }
    items
}

/// Every plan sent on a circuit, with the state its destination's engine holds (the
/// latest step's when the engine has none; `lost` once the destination is).
fn plans(demo: &Demo) -> Vec<PlanRow> {
    let mut out = Vec::new();
    for m in &demo.team.modules {
        for c in m.node.circuits().sent() {
            let status = demo
                .team
                .modules
                .iter()
                .find(|d| *d.address() == c.peer)
                .and_then(|d| d.node.engine().status(&c.name));
            let state = if c.steps.contains(&PlanStep::DestinationLost) {
                "lost".to_owned()
            } else {
                status.as_ref().map_or_else(
                    || {
                        c.steps
                            .last()
                            .map_or("sent", PlanStep::plan_state)
                            .to_owned()
                    },
                    |s| s.state.name().to_owned(),
                )
            };
            out.push(PlanRow {
                board: c.peer.to_string(),
                origin: m.address().to_string(),
                state,
                fired: Some(status.as_ref().map_or(0, |s| s.fired)),
                last_error: Some(status.and_then(|s| s.last_error).unwrap_or_default()),
                acks: c.steps.iter().map(ToString::to_string).collect(),
                name: c.name,
            });
        }
    }
    out
}

fn links(demo: &Demo) -> Vec<LinkRow> {
    let budget = demo.config.team_link.budget_bps as f64 / 8.0;
    let mut totals: Vec<_> = demo.traffic.total.iter().collect();
    totals.sort_by_key(|((robot, link), _)| {
        (std::cmp::Reverse(*link == LinkKind::Team), robot.clone())
    });
    let mut out = Vec::new();
    for ((robot, link), total) in totals {
        if *link == LinkKind::Robot && *total == 0 {
            continue;
        }
        let rate = demo.traffic.rate.get(&(robot.clone(), *link)).copied();
        let (name, budget_bps) = match link {
            LinkKind::Team => (format!("{robot} radio (team link)"), Some(budget)),
            LinkKind::Robot => (format!("{robot} LAN"), None),
        };
        out.push(LinkRow {
            name,
            kind: link.name().to_owned(),
            bytes_per_s: rate.unwrap_or(0.0),
            budget_bps,
            total_bytes: *total,
        });
    }
    out
}

/// The last 300 events (the page shows no more).
fn events(demo: &Demo) -> Vec<EventRow> {
    let events = &demo.observer.events;
    let from = events.len().saturating_sub(300);
    events[from..]
        .iter()
        .map(|e| EventRow {
            t: (e.t * 10.0).round() / 10.0,
            level: e.level,
            text: e.text.clone(),
        })
        .collect()
}
