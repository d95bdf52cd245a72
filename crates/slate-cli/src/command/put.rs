//! `slate put OBJ.ATTR VALUE`: write one attribute on a live team.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use serde_json::json;
use slate_model::{Update, WriteError};
use slate_node::Node;
use slate_node::inspect::{Classes, parse_value};

use crate::cli::{Format, PutArgs};
use crate::command::failed;
use crate::command::live::{join, known, packet_json, packet_text, print_json, split, unit};

/// Writes, waits until the packet has gone out, prints it.
pub fn run(args: &PutArgs, format: Format) -> anyhow::Result<ExitCode> {
    let (object, Some(attr)) = split(&args.target) else {
        anyhow::bail!("{:?}: expected OBJ.ATTR, like gsr.speed", args.target);
    };
    check_quality(args)?;
    let node = join(&args.live)?;
    let result = put(&node, object, attr, args, format);
    node.close();
    result?;
    Ok(ExitCode::SUCCESS)
}

/// Fails (exit 2) on an accuracy or confidence no write would take, before joining.
fn check_quality(args: &PutArgs) -> anyhow::Result<()> {
    let accuracy = args.accuracy.unwrap_or(0.0);
    let confidence = args.confidence.unwrap_or(1.0);
    Ok(slate_model::check_quality(accuracy, confidence)?)
}

fn put(
    node: &Node,
    object: &str,
    attr: &str,
    args: &PutArgs,
    format: Format,
) -> anyhow::Result<()> {
    let board = node.board();
    known(node, object)?;
    let classes = Classes::of(board);
    let info = board.info(object).context("the object went away")?;
    let class = if info.is_class {
        object.to_owned()
    } else {
        info.class.to_string()
    };
    let Some(decl) = classes.decl(&class, attr) else {
        let have = classes.attributes(&class).join(", ");
        return failed(format!(
            "{object} ({class}) has no attribute {attr:?} (it has: {have})"
        ));
    };
    let value = parse_value(&args.value, decl.ty).map_err(anyhow::Error::msg)?;
    let mut update = Update::new(value);
    if let Some(a) = args.accuracy {
        update = update.accuracy(a);
    }
    if let Some(c) = args.confidence {
        update = update.confidence(c);
    }
    let before = progress(node);
    // A malformed value is bad input (exit 2); a write the board refuses because no module
    // would take it (a non-owner's write to an `owned` attribute, a guarded one) is a
    // refusal (exit 1).
    let revision = match board.write(object, attr, update) {
        Ok(revision) => revision,
        Err(e @ WriteError::Invalid { .. }) => {
            return Err(anyhow::Error::new(e).context(format!("cannot write {object}.{attr}")));
        }
        Err(e) => return failed(format!("cannot write {object}.{attr}: {e}")),
    };
    let sent = wait_sent(node, before);
    let packet = board.read(object, attr)?;
    linger(node);
    let unit = unit(board, &classes, object, attr);
    if !sent {
        return failed(format!(
            "{object}.{attr} was written, but no module took it within 5 s (does any model {class}?)"
        ));
    }
    match format {
        Format::Json => {
            let mut j = packet_json(board, attr, unit, &packet);
            j["object"] = json!(object);
            j["revision"] = json!(revision);
            print_json(&j)
        }
        Format::Text => {
            println!("{object}.{attr} = {}", packet_text(board, unit, &packet));
            Ok(())
        }
    }
}

/// Stays on the network long enough for the protocol's own loss recovery: reports are
/// published best effort, and a receiver that missed one learns it from the writer's
/// next heartbeat (robot link 250 ms, team link 1 s) and asks the writer to catch it up
/// after its gap grace (300 ms). The writer must still be there to answer.
pub(crate) fn linger(node: &Node) {
    let me = node.address();
    let config = slate_ici::IciConfig::default();
    let longest = node
        .peers()
        .iter()
        .map(|p| config.link(slate_ici::LinkKind::between(me, p)).heartbeat)
        .max();
    if let Some(heartbeat) = longest {
        std::thread::sleep(heartbeat + config.gap_grace + Duration::from_millis(200));
    }
}

/// Packets the ICI sent, and catch-up requests it answered.
fn progress(node: &Node) -> (u64, u64) {
    let stats = node.ici().stats();
    (stats.reports.items_sent, stats.catch_up.answered)
}

/// Waits (at most 5 s) until the packet has gone out: the ICI sent it live, or a peer
/// that did not know this observer yet (its interest unknown, nothing was sent to it)
/// caught up with it since (the answer holds the packet). A report filter may also hold
/// a packet for its minimum interval.
fn wait_sent(node: &Node, before: (u64, u64)) -> bool {
    let deadline = Instant::now() + Duration::from_secs(5);
    while Instant::now() < deadline {
        let now = progress(node);
        if now.0 > before.0 || now.1 > before.1 {
            return true;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    false
}
