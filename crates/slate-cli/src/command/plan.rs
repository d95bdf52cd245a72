//! `slate plan send|ls|cancel`: plans on a live team.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use crossbeam_channel::{Receiver, select};
use serde_json::json;
use slate_ici::PlanHandle;
use slate_model::{Address, Board, ObjectInfo, Query, Value};
use slate_node::Node;
use slate_plans::{Item, PLAN_CLASS};
use slate_wire::PlanStep;

use crate::cli::{Format, PlanCancelArgs, PlanLsArgs, PlanSendArgs};
use crate::command::failed;
use crate::command::live::{
    export_note, interrupted, join, optional_address, print_json, print_line,
    seen_through_export_json, team_of,
};

/// How long a cancellation waits for its confirmation.
const CONFIRM: Duration = Duration::from_secs(5);

/// Sends the plan and prints its acknowledgements until it is over.
pub fn send(args: &PlanSendArgs, format: Format) -> anyhow::Result<ExitCode> {
    let path = args.file.display().to_string();
    let text =
        std::fs::read_to_string(&args.file).with_context(|| format!("cannot read {path}"))?;
    let name = one_plan(&path, &text)?;
    let to = Address::new(&args.to).context("--to")?;
    let timeout = args
        .timeout
        .map(|t| {
            Duration::try_from_secs_f64(t)
                .with_context(|| format!("--timeout {t}: expected seconds"))
        })
        .transpose()?;
    let signals = interrupted()?;
    let node = join(&args.live)?;
    let result = send_and_follow(&node, &to, &name, &text, timeout, signals, format);
    node.close();
    result
}

/// The name of the one plan a file holds; anything else fails with the diagnostics.
fn one_plan(path: &str, text: &str) -> anyhow::Result<String> {
    let file = match slate_plans::parse(text) {
        Ok(f) => f,
        Err(d) => return failed(d.render(path, text)),
    };
    match file.items.as_slice() {
        [Item::Plan(p)] => Ok(p.name.name.clone()),
        _ => failed(format!(
            "{path}: expected exactly one `plan NAME {{ ... }}` and nothing else ({} items)",
            file.items.len()
        )),
    }
}

fn send_and_follow(
    node: &Node,
    to: &Address,
    name: &str,
    text: &str,
    timeout: Option<Duration>,
    signals: &Receiver<()>,
    format: Format,
) -> anyhow::Result<ExitCode> {
    if !node.peers().contains(to) {
        let mut peers: Vec<String> = node.peers().iter().map(ToString::to_string).collect();
        peers.sort();
        return failed(format!(
            "no module {to} on {} (modules up: {})",
            team_of(node.board()),
            peers.join(", ")
        ));
    }
    let handle = node.send_plan(to, text)?;
    let deadline = timeout.map(|t| Instant::now() + t);
    let mut cancelling = false;
    loop {
        let left = deadline.map_or(Duration::from_secs(3600), |d| {
            d.saturating_duration_since(Instant::now())
        });
        select! {
            recv(handle.acks()) -> step => {
                let Ok(step) = step else { return failed("the circuit closed") };
                print_step(&handle, &step, format)?;
                if step.is_final() {
                    return outcome(&handle, &step, cancelling);
                }
            }
            recv(signals) -> _ => {
                if !cancelling {
                    cancelling = true;
                    node.circuits().cancel(handle.circuit)?;
                }
            }
            default(left) => {
                if deadline.is_some_and(|d| Instant::now() >= d) {
                    eprintln!("slate: plan {name} still running on {to} (circuit {}) after the timeout", handle.circuit);
                    return Ok(ExitCode::SUCCESS);
                }
            }
        }
    }
}

fn print_step(handle: &PlanHandle, step: &PlanStep, format: Format) -> anyhow::Result<()> {
    match format {
        Format::Json => {
            let (kind, detail) = step_parts(step);
            print_line(&json!({
                "plan": handle.name, "circuit": handle.circuit, "to": handle.to.as_str(),
                "step": kind, "detail": detail,
            }))
        }
        Format::Text => {
            println!("{} -> {}: {}", handle.name, handle.to, step);
            Ok(())
        }
    }
}

/// `("triggered", "fired 1")`, `("rejected", reason)`, `("accepted", "")`; a failed
/// action's kind is `failed` in this output (a JSON consumer tells it apart by kind alone).
fn step_parts(step: &PlanStep) -> (&'static str, String) {
    let kind = match step {
        PlanStep::Triggered { ok: false, .. } => "failed",
        other => other.kind(),
    };
    (kind, step.detail().to_owned())
}

/// Exit 0 when the plan terminated or this command cancelled it; 1 otherwise.
fn outcome(handle: &PlanHandle, step: &PlanStep, cancelling: bool) -> anyhow::Result<ExitCode> {
    let (name, to) = (&handle.name, &handle.to);
    match step {
        PlanStep::Terminated => Ok(ExitCode::SUCCESS),
        PlanStep::Cancelled if cancelling => Ok(ExitCode::SUCCESS),
        PlanStep::Cancelled => failed(format!("plan {name} was cancelled on {to}")),
        PlanStep::Rejected { .. } => failed(format!("plan {name} was rejected by {to}")),
        _ => failed(format!("plan {name}: {to} was lost")),
    }
}

/// Lists the plans on the team's boards.
pub fn ls(args: &PlanLsArgs, format: Format) -> anyhow::Result<ExitCode> {
    let node = join(&args.live)?;
    let plans = plans(node.board());
    let seen = seen_through_export_json(&node);
    let note = export_note(&node);
    node.close();
    match format {
        Format::Json => {
            let list: Vec<_> = plans.iter().map(|p| json!(p)).collect();
            print_json(&json!({"plans": list, "seen_through_export": seen}))?;
        }
        Format::Text => {
            for p in &plans {
                let error = if p.last_error.is_empty() {
                    String::new()
                } else {
                    format!("  error: {}", p.last_error)
                };
                let origin = if p.origin.is_empty() {
                    "local".to_owned()
                } else {
                    format!("from {}", p.origin)
                };
                println!(
                    "{:<20} {:<11} fired {:<4} on {}  {origin}{error}",
                    p.name, p.state, p.fired, p.on
                );
            }
            if plans.is_empty() {
                eprintln!("no plans");
            }
            if let Some(note) = note {
                eprintln!("note: {note}");
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// A plan as its plan object shows it.
#[derive(serde::Serialize)]
struct PlanRow {
    name: String,
    on: String,
    state: String,
    fired: i64,
    origin: String,
    last_error: String,
}

fn plans(board: &Board) -> Vec<PlanRow> {
    let ids = board.query(&Query::class(PLAN_CLASS)).unwrap_or_default();
    let mut rows: Vec<PlanRow> = ids
        .into_iter()
        .filter_map(|id| board.name_of(id).and_then(|n| board.info(&n)))
        .map(|info| row(board, &info))
        .collect();
    rows.sort_by(|a, b| (&a.on, &a.name).cmp(&(&b.on, &b.name)));
    rows
}

fn row(board: &Board, info: &ObjectInfo) -> PlanRow {
    let text = |attr: &str| {
        board
            .read(&info.name, attr)
            .map(|p| p.value.plain_text())
            .unwrap_or_default()
    };
    let fired = match board.read(&info.name, "fired").map(|p| p.value) {
        Ok(Value::Int(n)) => n,
        _ => 0,
    };
    PlanRow {
        name: info.name.to_string(),
        on: info.owner.to_string(),
        state: text("state"),
        fired,
        origin: text("origin"),
        last_error: text("last_error"),
    }
}

/// Cancels a plan by writing `cancelled` to its state; the node running it cancels it
/// and confirms by writing the state itself.
pub fn cancel(args: &PlanCancelArgs, format: Format) -> anyhow::Result<ExitCode> {
    let on = optional_address(args.on.as_deref(), "--on")?;
    let node = join(&args.live)?;
    let result = cancel_on(&node, &args.name, on.as_ref(), format);
    node.close();
    result?;
    Ok(ExitCode::SUCCESS)
}

fn cancel_on(node: &Node, name: &str, on: Option<&Address>, format: Format) -> anyhow::Result<()> {
    let board = node.board();
    let info = board
        .info(name)
        .filter(|i| &*i.class == PLAN_CLASS)
        .map_or_else(
            || {
                let hint = export_note(node).map_or(String::new(), |n| format!("; {n}"));
                failed(format!(
                    "no plan named {name:?} on the boards of {} (see `slate plan ls`){hint}",
                    team_of(board)
                ))
            },
            Ok,
        )?;
    let owner = info.owner.clone();
    if let Some(on) = on.filter(|a| **a != owner) {
        return failed(format!("plan {name} runs on {owner}, not {on}"));
    }
    let state = row(board, &info).state;
    if state == "terminated" || state == "cancelled" {
        return failed(format!("plan {name} on {owner} is already {state}"));
    }
    board.write(name, "state", "cancelled")?;
    if !confirmed(board, name, &owner) {
        return failed(format!(
            "plan {name} on {owner} did not confirm the cancellation within {} s (does its interest include Plan?)",
            CONFIRM.as_secs()
        ));
    }
    match format {
        Format::Json => {
            print_json(&json!({"plan": name, "on": owner.as_str(), "state": "cancelled"}))
        }
        Format::Text => {
            println!("plan {name} cancelled on {owner}");
            Ok(())
        }
    }
}

/// Waits until the plan's node itself has written its state `cancelled`.
fn confirmed(board: &Board, name: &str, owner: &Address) -> bool {
    let deadline = Instant::now() + CONFIRM;
    while Instant::now() < deadline {
        if let Ok(p) = board.read(name, "state")
            && p.source == *owner
            && matches!(&p.value, Value::Str(s) if &**s == "cancelled")
        {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    false
}
