//! `slate play FILE.mcap`: a recording replayed into a board on a manual clock, at the
//! recorded pace or faster, with the dashboard if asked (docs/recording.md).

use std::process::ExitCode;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context;
use serde_json::json;
use slate_ici::SimNet;
use slate_model::{Address, Board, Clock};
use slate_node::Node;
use slate_node::record::{Recording, Step, Timed, board_state};

use crate::cli::{Format, LiveArgs, PlayArgs};
use crate::command::live::{interrupted, join_as, operator_keys, print_line};

/// The board's address when the file does not say whose it was.
const UNKNOWN: &str = "replay/play/board";

/// The robot segment of a replay's address on a live team (`--onto`): it marks the
/// replay as the source of what it writes.
const REPLAY_ROBOT: &str = "replay";

/// What a replay did.
#[derive(Default)]
struct Played {
    messages: u64,
    refused: u64,
    until: Duration,
}

/// Reads, replays, prints the board it ends with; with a dashboard, waits for Ctrl-C.
pub fn run(args: &PlayArgs, format: Format) -> anyhow::Result<ExitCode> {
    let speed = speed(&args.speed)?;
    let until = until(args.until)?;
    let recording = Recording::read(&args.file)?;
    let signals = interrupted()?;
    let address = recording
        .address
        .as_deref()
        .and_then(|a| Address::new(a).ok())
        .unwrap_or_else(|| Address::new(UNKNOWN).expect("a valid address"));
    if let Some(team) = &args.onto {
        return onto(args, team, &address, &recording, (speed, until), format);
    }
    let (node, clock) = replay_node(&address, &recording, args.dashboard)?;
    if let Some(url) = node.dashboard_url() {
        eprintln!("replaying {} on {url}", args.file.display());
    }
    let pace = Pace {
        speed,
        until,
        signals,
    };
    let played = play(&recording, &pace, |time, step| {
        let _ = clock.set(time.max(clock.physical()));
        Recording::apply(node.board(), step)
    });
    report(&node, &recording, &played, format)?;
    if node.dashboard_url().is_some() && signals.try_recv().is_err() {
        eprintln!("replayed; the dashboard stays up until Ctrl-C");
        let _ = signals.recv();
    }
    node.close();
    Ok(ExitCode::SUCCESS)
}

/// `max` (`None`: no waiting) or a positive factor.
fn speed(text: &str) -> anyhow::Result<Option<f64>> {
    if text == "max" {
        return Ok(None);
    }
    text.parse::<f64>()
        .ok()
        .filter(|s| s.is_finite() && *s > 0.0)
        .map(Some)
        .with_context(|| format!("--speed {text}: expected a positive number, or max"))
}

fn until(value: Option<f64>) -> anyhow::Result<Option<Duration>> {
    value
        .map(|s| {
            Duration::try_from_secs_f64(s)
                .ok()
                .with_context(|| format!("--until {s}: expected a number of seconds >= 0"))
        })
        .transpose()
}

/// A node holding a new board on a manual clock set to the recording's start, on a
/// network of its own (nothing leaves it).
fn replay_node(
    address: &Address,
    recording: &Recording,
    dashboard: Option<std::net::SocketAddr>,
) -> anyhow::Result<(Node, Clock)> {
    let clock = Clock::manual();
    if let Some((start, _)) = recording.span() {
        let _ = clock.set(start.max(clock.physical()));
    }
    let board = Arc::new(
        Board::builder()
            .address(address.clone())
            .clock(clock.clone())
            .build(),
    );
    let net = SimNet::new(0);
    let mut builder = Node::builder(address.clone())
        .board(board)
        .transport(net.join(address));
    if let Some(addr) = dashboard {
        builder = builder.dashboard(addr);
    }
    Ok((builder.start()?, clock))
}

/// How a replay goes: its speed (`None`: as fast as it goes), where it stops, and the
/// signals that stop it early.
struct Pace {
    speed: Option<f64>,
    until: Option<Duration>,
    signals: &'static crossbeam_channel::Receiver<()>,
}

/// Hands each message to `apply` (with its recorded time) at its time, scaled by the
/// speed, until the end, `until`, or a signal; `apply` says whether it was taken.
fn play(
    recording: &Recording,
    pace: &Pace,
    mut apply: impl FnMut(Duration, &Step) -> bool,
) -> Played {
    let mut played = Played::default();
    let Some((start, _)) = recording.span() else {
        return played;
    };
    let began = Instant::now();
    for Timed { time, step } in &recording.steps {
        let offset = time.saturating_sub(start);
        let stop = pace.until.is_some_and(|u| offset > u)
            || waited_for_signal(began, offset, pace.speed, pace.signals);
        if stop {
            break;
        }
        played.messages += 1;
        played.until = offset;
        if !apply(*time, step) {
            played.refused += 1;
        }
    }
    played
}

/// `--onto TEAM`: joins the team through `--connect` as [`replay_address`] and writes
/// the recording there as that module's own writes, at the recorded pace or faster.
fn onto(
    args: &PlayArgs,
    team: &str,
    recorded: &Address,
    recording: &Recording,
    (speed, until): (Option<f64>, Option<Duration>),
    format: Format,
) -> anyhow::Result<ExitCode> {
    let address = replay_address(args, team, recorded)?;
    let live = LiveArgs {
        connection: args.connection.clone(),
        address: Some(address.to_string()),
    };
    let node = join_as(&live, &format!("--onto {team}"))?;
    let pace = Pace {
        speed,
        until,
        signals: interrupted()?,
    };
    let played = play(recording, &pace, |_, step| {
        Recording::apply_as_writer(node.board(), step)
    });
    crate::command::put::linger(&node);
    report(&node, recording, &played, format)?;
    node.close();
    Ok(ExitCode::SUCCESS)
}

/// The replay's address on `team`: `TEAM/replay/MODULE` (MODULE: the recorded board's),
/// or with an operator's keys `TEAM/replay/cli-NAME-MODULE`, an address the operator's
/// certificate may speak as on a secured team (docs/security.md, "Replays").
fn replay_address(args: &PlayArgs, team: &str, recorded: &Address) -> anyhow::Result<Address> {
    let operator = operator_keys(&args.connection)?;
    let prefix = operator.map_or_else(String::new, |k| k.identity.observer_prefix());
    let text = format!("{team}/{REPLAY_ROBOT}/{prefix}{}", recorded.module());
    Address::new(&text).with_context(|| format!("--onto {team}: {text} is not a module address"))
}

/// Waits until `offset` (scaled) after `began`; true if a signal came first.
fn waited_for_signal(
    began: Instant,
    offset: Duration,
    speed: Option<f64>,
    signals: &crossbeam_channel::Receiver<()>,
) -> bool {
    let Some(speed) = speed else {
        return signals.try_recv().is_ok();
    };
    let due = began + offset.div_f64(speed);
    let left = due.saturating_duration_since(Instant::now());
    signals.recv_timeout(left).is_ok()
}

fn report(
    node: &Node,
    recording: &Recording,
    played: &Played,
    format: Format,
) -> anyhow::Result<()> {
    let board = board_state(node.board());
    let objects = board.as_object().map_or(0, serde_json::Map::len);
    let cut = if recording.complete {
        ""
    } else {
        " (cut off: played to its last chunk)"
    };
    match format {
        Format::Json => print_line(&json!({
            "event": "played", "address": node.address().as_str(),
            "messages": played.messages, "refused": played.refused,
            "until": played.until.as_secs_f64(), "complete": recording.complete,
            "objects": board,
        })),
        Format::Text => {
            println!(
                "played {} messages of {} ({} refused) up to {:.1} s{cut}: {objects} objects",
                played.messages,
                node.address(),
                played.refused,
                played.until.as_secs_f64()
            );
            Ok(())
        }
    }
}
