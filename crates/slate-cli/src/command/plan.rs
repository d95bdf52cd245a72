//! `slate plan send|ls|cancel`: plans on a live team.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use crossbeam_channel::{Receiver, select};
use serde_json::json;
use slate_ici::{LOST_WAIT, PlanHandle};
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
    one_plan(&path, &text)?;
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
    let result = send_and_follow(&node, &to, &text, timeout, signals, format);
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
    let mut follow = Follow::new(timeout, Instant::now());
    loop {
        let left = follow.deadline().map_or(Duration::from_secs(3600), |d| {
            d.saturating_duration_since(Instant::now())
        });
        select! {
            recv(handle.acks()) -> step => {
                let Ok(step) = step else { return failed("the circuit closed") };
                match follow.heard(&step, Instant::now()) {
                    Heard::Ack => print_step(&handle, &step, format)?,
                    Heard::Lost => note_lost(&handle, follow.deadline()),
                    Heard::Ended(end) => {
                        print_step(&handle, &step, format)?;
                        return outcome(&handle, end);
                    }
                }
            }
            recv(signals) -> _ => {
                if !follow.cancelling {
                    follow.cancelling = true;
                    node.circuits().cancel(handle.circuit)?;
                }
            }
            default(left) => {
                if let Some(end) = follow.expired(Instant::now()) {
                    if end == End::Lost {
                        print_step(&handle, &PlanStep::DestinationLost, format)?;
                    }
                    return outcome(&handle, end);
                }
            }
        }
    }
}

/// How following a circuit ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum End {
    /// The plan terminated.
    Terminated,
    /// It was cancelled: by this command (`true`) or by someone else.
    Cancelled(bool),
    /// The destination rejected it.
    Rejected,
    /// The destination was lost and had not come back when the wait ended.
    Lost,
    /// `--timeout` passed with the plan still running.
    StillRunning,
}

/// What an acknowledgement means to the follower.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Heard {
    /// A step to print; more will follow.
    Ack,
    /// The destination went down: say so on stderr and keep waiting for it.
    Lost,
    /// The last step: print it and end.
    Ended(End),
}

/// The waiting logic of `plan send`, apart from the channels and the clock it is fed
/// from: which step ends it, and when.
#[derive(Debug)]
struct Follow {
    /// When `--timeout` ends the wait (none: the plan's last step does).
    deadline: Option<Instant>,
    /// When the destination went down and has not been heard since.
    lost_at: Option<Instant>,
    /// This command asked for the plan to be cancelled (Ctrl-C).
    cancelling: bool,
}

impl Follow {
    fn new(timeout: Option<Duration>, now: Instant) -> Follow {
        Follow {
            deadline: timeout.map(|t| now + t),
            lost_at: None,
            cancelling: false,
        }
    }

    /// When the wait ends if nothing more is heard: at `--timeout`, or, without one,
    /// [`LOST_WAIT`] after the destination went down.
    fn deadline(&self) -> Option<Instant> {
        self.deadline
            .or_else(|| self.lost_at.map(|at| at + LOST_WAIT))
    }

    /// A lost destination is waited for (its circuit sends the plan again when it comes
    /// back, and the steps it took meanwhile follow); any other step means it is back.
    fn heard(&mut self, step: &PlanStep, now: Instant) -> Heard {
        if *step == PlanStep::DestinationLost {
            self.lost_at = Some(now);
            return Heard::Lost;
        }
        self.lost_at = None;
        match step {
            PlanStep::Terminated => Heard::Ended(End::Terminated),
            PlanStep::Cancelled => Heard::Ended(End::Cancelled(self.cancelling)),
            PlanStep::Rejected { .. } => Heard::Ended(End::Rejected),
            _ => Heard::Ack,
        }
    }

    /// How the wait ends at `now`, if it does.
    fn expired(&self, now: Instant) -> Option<End> {
        let over = self.deadline().is_some_and(|d| now >= d);
        let end = match self.lost_at {
            Some(_) => End::Lost,
            None => End::StillRunning,
        };
        over.then_some(end)
    }
}

/// The destination went down: the circuit stays open and sends the plan again when it
/// comes back, so the command waits for it.
fn note_lost(handle: &PlanHandle, until: Option<Instant>) {
    let wait = until.map_or("for it".to_owned(), |d| {
        format!(
            "up to {:.0} s",
            d.saturating_duration_since(Instant::now()).as_secs_f64()
        )
    });
    eprintln!(
        "slate: {} lost (circuit {}): waiting {wait} for it to come back",
        handle.to, handle.circuit
    );
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

/// Exit 0 when the plan terminated or this command cancelled it, or when `--timeout`
/// passed with the plan running; 1 otherwise.
fn outcome(handle: &PlanHandle, end: End) -> anyhow::Result<ExitCode> {
    let (name, to, circuit) = (&handle.name, &handle.to, handle.circuit);
    match end {
        End::Terminated | End::Cancelled(true) => Ok(ExitCode::SUCCESS),
        End::Cancelled(false) => failed(format!("plan {name} was cancelled on {to}")),
        End::Rejected => failed(format!("plan {name} was rejected by {to}")),
        End::Lost => failed(format!(
            "plan {name}: destination {to} lost, and not back when the wait ended"
        )),
        End::StillRunning => {
            eprintln!(
                "slate: plan {name} still running on {to} (circuit {circuit}) after the timeout"
            );
            Ok(ExitCode::SUCCESS)
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Feeds `steps` to a follower with a 30 s timeout, one second apart: what it
    /// prints, and how it ends (`None`: it still waits).
    fn follow(steps: &[PlanStep]) -> (Vec<&'static str>, Option<End>, Follow) {
        let t0 = Instant::now();
        let mut f = Follow::new(Some(Duration::from_secs(30)), t0);
        let mut printed = Vec::new();
        for (i, step) in steps.iter().enumerate() {
            match f.heard(step, t0 + Duration::from_secs(i as u64)) {
                Heard::Ack => printed.push(step.kind()),
                Heard::Lost => {}
                Heard::Ended(end) => {
                    printed.push(step.kind());
                    return (printed, Some(end), f);
                }
            }
        }
        (printed, None, f)
    }

    fn triggered() -> PlanStep {
        PlanStep::Triggered {
            ok: true,
            detail: "fired 1".into(),
        }
    }

    #[test]
    fn a_lost_destination_whose_acks_resume_ends_with_the_plan_not_the_loss() {
        let steps = [
            PlanStep::Received,
            PlanStep::DestinationLost,
            PlanStep::Accepted,
            PlanStep::Initiated,
            triggered(),
            PlanStep::Terminated,
        ];
        let (printed, end, _) = follow(&steps);
        assert_eq!(
            printed,
            [
                "received",
                "accepted",
                "initiated",
                "triggered",
                "terminated"
            ]
        );
        assert_eq!(end, Some(End::Terminated));
    }

    #[test]
    fn a_destination_still_lost_when_the_timeout_ends_is_reported_lost() {
        let (printed, end, f) = follow(&[PlanStep::Received, PlanStep::DestinationLost]);
        assert_eq!((printed, end), (vec!["received"], None), "it keeps waiting");
        let start = f.deadline().unwrap() - Duration::from_secs(30);
        assert_eq!(f.expired(start + Duration::from_secs(29)), None);
        assert_eq!(f.expired(start + Duration::from_secs(30)), Some(End::Lost));
    }

    #[test]
    fn a_destination_back_before_the_timeout_is_no_longer_lost() {
        let (_, end, f) = follow(&[PlanStep::DestinationLost, PlanStep::Initiated]);
        assert_eq!(end, None);
        let at_timeout = f.deadline().unwrap();
        assert_eq!(f.expired(at_timeout), Some(End::StillRunning));
    }

    #[test]
    fn without_a_timeout_a_lost_destination_is_waited_for_a_while() {
        let t0 = Instant::now();
        let mut f = Follow::new(None, t0);
        assert_eq!(f.heard(&PlanStep::Received, t0), Heard::Ack);
        assert_eq!(f.deadline(), None, "a running plan is followed to its end");
        assert_eq!(f.heard(&PlanStep::DestinationLost, t0), Heard::Lost);
        assert_eq!(f.expired(t0 + LOST_WAIT), Some(End::Lost));
        assert_eq!(f.heard(&PlanStep::Accepted, t0 + LOST_WAIT / 2), Heard::Ack);
        assert_eq!(f.deadline(), None, "back: no limit again");
    }

    #[test]
    fn final_steps_end_the_wait_as_before() {
        let rejected = PlanStep::Rejected {
            reason: "no".into(),
        };
        assert_eq!(follow(&[rejected]).1, Some(End::Rejected));
        assert_eq!(
            follow(&[PlanStep::Cancelled]).1,
            Some(End::Cancelled(false))
        );
    }
}
