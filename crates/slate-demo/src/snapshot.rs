//! The dashboard's view of a run (the JSON contract of docs/dashboard.md): the map as
//! the console's board knows it (robots and targets with their accuracy, confidence and
//! age; obstacles from the terrain map), the console's class tree and objects, every plan
//! sent on a circuit with its acknowledgements, the links against their budget, events.

use serde_json::{Value, json};
use slate_ici::LinkKind;
use slate_model::{Board, Packet, Value as V};
use slate_wire::PlanStep;

use crate::observe::{flag, instances, point, reference, text};
use crate::run::Demo;

/// Older than this (seconds), a position is drawn stale.
const STALE: f64 = 5.0;

/// The whole snapshot.
pub fn snapshot(demo: &Demo, status: &str) -> Value {
    let c = &demo.config;
    json!({
        "title": format!("slate demo — seed {}, {} robots, {} network", c.seed, c.robots, c.network.name()),
        "time": (demo.time() * 10.0).round() / 10.0,
        "status": status,
        "summary": summary(demo),
        "map": map(demo),
        "classes": classes(&demo.team.console().board),
        "objects": objects(&demo.team.console().board),
        "plans": plans(demo),
        "links": links(demo),
        "events": events(demo),
    })
}

fn summary(demo: &Demo) -> Value {
    let console = &demo.team.console().board;
    let found = instances(console, "Target")
        .iter()
        .filter(|t| !text(console, t, "found_by").is_empty())
        .count();
    let alive = demo.team.dead.iter().filter(|d| !**d).count();
    let team_bps = demo.traffic.team_bps();
    let fault = demo.observer.fault.as_ref();
    json!({
        "mission": text(console, "mission", "phase"),
        "targets found": format!("{found}/{}", demo.world.targets.len()),
        "robots alive": format!("{alive}/{}", demo.team.robots.len()),
        "duplicate investigations": demo.observer.duplicates().len(),
        "team link now": format!("{:.0} bit/s", team_bps),
        "team link peak": format!("{:.0} of {} bit/s", demo.traffic.peak_radio_bps.0, demo.config.team_link.budget_bps),
        "recovery": fault.and_then(|f| f.recovered.map(|r| format!("{:.1} s", r - f.at))).unwrap_or_else(|| "—".into()),
        "seed": demo.config.seed,
    })
}

fn age(board: &Board, p: &Packet) -> f64 {
    (board.clock().physical().as_secs_f64() - p.timestamp.as_secs_f64()).max(0.0)
}

fn map(demo: &Demo) -> Value {
    let console = &demo.team.console().board;
    let mut items: Vec<Value> = demo
        .world
        .obstacles
        .iter()
        .map(|o| json!({"id": o.id, "kind": "obstacle", "x": o.center[0], "y": o.center[1], "radius": o.radius}))
        .collect();
    for w in instances(console, "Waypoint") {
        if let Some((p, _)) = point(console, &w, "position") {
            let visited = flag(console, &w, "visited");
            let label = if visited { "✓" } else { "·" };
            items.push(json!({"id": w, "kind": "other", "label": label, "x": p[0], "y": p[1],
                "owner": reference(console, &w, "assignee"), "confidence": if visited { 0.2 } else { 0.8 }}));
        }
    }
    for t in instances(console, "Target") {
        items.extend(target_item(console, &t));
    }
    for (i, r) in demo.team.robots.iter().enumerate() {
        items.extend(robot_items(console, r, demo.team.dead[i]));
    }
    let b = demo.world.bounds;
    json!({"bounds": [b[0], b[1], b[2], b[3]], "items": items})
}

fn target_item(console: &Board, t: &str) -> Option<Value> {
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
    let mut item = json!({"id": t, "kind": "target", "label": label, "x": x, "y": y,
        "accuracy": p.accuracy, "confidence": identity.confidence, "age": age, "stale": age > STALE && found.is_empty(),
        "board": console.address().to_string(), "owner": p.source.to_string()});
    if !found.is_empty() {
        item["found_by"] = json!(found);
    }
    Some(item)
}

fn robot_items(console: &Board, r: &str, dead: bool) -> Vec<Value> {
    let Ok(p) = console.read(r, "position") else {
        return Vec::new();
    };
    let Some([x, y]) = p.value.as_vector() else {
        return Vec::new();
    };
    let heading = console
        .read(r, "heading")
        .ok()
        .and_then(|h| h.value.as_f64());
    let alive = !matches!(
        console.read(r, "alive").map(|a| a.value),
        Ok(V::Bool(false))
    );
    let age = age(console, &p);
    let phase = text(console, r, "phase");
    let mut items = vec![
        json!({"id": r, "kind": "robot", "label": format!("{r} {phase}"), "x": x, "y": y,
        "heading": heading, "accuracy": p.accuracy, "confidence": p.confidence, "age": age,
        "stale": age > STALE && !dead, "alive": alive, "board": console.address().to_string(),
        "owner": p.source.to_string()}),
    ];
    if let Some((g, _)) = point(console, r, "goal").filter(|_| alive) {
        items.push(json!({"id": format!("{r}_goal"), "kind": "goal", "label": format!("{r} goal"), "x": g[0], "y": g[1]}));
    }
    items
}

fn classes(board: &Board) -> Value {
    let defs = board.class_defs();
    Value::Array(
        defs.iter()
            .map(|d| {
                let attrs: Vec<&str> = d.attrs.iter().map(|a| a.name.as_str()).collect();
                json!({"name": d.name, "parent": d.parent, "attrs": attrs})
            })
            .collect(),
    )
}

fn objects(board: &Board) -> Value {
    let snap = board.snapshot();
    let now = board.clock().physical().as_secs_f64();
    let mut out = Vec::new();
    for id in snap.objects() {
        let Some(info) = snap.info(id) else { continue };
        if info.is_class {
            continue;
        }
        let attrs: Vec<Value> = snap
            .own_values(id)
            .into_iter()
            .map(|(name, p, _)| {
                json!({"name": &*name, "value": p.value.to_string(),
                "accuracy": p.accuracy, "confidence": p.confidence,
                "age": (now - p.timestamp.as_secs_f64()).max(0.0), "source": p.source.to_string()})
            })
            .collect();
        out.push(
            json!({"board": board.address().to_string(), "name": &*info.name, "class": &*info.class,
            "context": info.context.name(), "owner": info.owner.to_string(), "attrs": attrs}),
        );
    }
    Value::Array(out)
}

fn plans(demo: &Demo) -> Value {
    let mut out = Vec::new();
    for m in &demo.team.modules {
        for c in m.circuits.sent() {
            let status = demo
                .team
                .modules
                .iter()
                .find(|d| d.address == c.peer)
                .and_then(|d| d.engine.status(&c.name));
            let state = status.as_ref().map_or_else(
                || {
                    c.steps
                        .last()
                        .map_or("sent", PlanStep::plan_state)
                        .to_owned()
                },
                |s| s.state.name().to_owned(),
            );
            let state = if c.steps.contains(&PlanStep::DestinationLost) {
                "lost".to_owned()
            } else {
                state
            };
            out.push(
                json!({"board": c.peer.to_string(), "name": c.name, "origin": m.address.to_string(),
                "state": state, "fired": status.as_ref().map_or(0, |s| s.fired),
                "last_error": status.and_then(|s| s.last_error).unwrap_or_default(),
                "acks": c.steps.iter().map(ToString::to_string).collect::<Vec<_>>()}),
            );
        }
    }
    Value::Array(out)
}

fn links(demo: &Demo) -> Value {
    let budget = demo.config.team_link.budget_bps as f64 / 8.0;
    let mut out = Vec::new();
    let mut totals: Vec<_> = demo.traffic.total.iter().collect();
    totals.sort_by_key(|((robot, link), _)| {
        (std::cmp::Reverse(*link == LinkKind::Team), robot.clone())
    });
    for ((robot, link), total) in totals {
        let rate = demo
            .traffic
            .rate
            .get(&(robot.clone(), *link))
            .copied()
            .unwrap_or(0.0);
        let (name, budget) = match link {
            LinkKind::Team => (format!("{robot} radio (team link)"), json!(budget)),
            LinkKind::Robot => (format!("{robot} LAN"), Value::Null),
        };
        if *link == LinkKind::Robot && *total == 0 {
            continue;
        }
        out.push(json!({"name": name, "kind": link.name(), "bytes_per_s": rate, "budget_bps": budget, "total_bytes": total}));
    }
    Value::Array(out)
}

fn events(demo: &Demo) -> Value {
    let events = &demo.observer.events;
    let from = events.len().saturating_sub(300);
    Value::Array(
        events[from..]
            .iter()
            .map(|e| json!({"t": (e.t * 10.0).round() / 10.0, "level": e.level.name(), "text": e.text}))
            .collect(),
    )
}
