//! `slate watch PATTERN`: a live team's changes, one line each.

use std::process::ExitCode;
use std::time::Duration;

use serde_json::json;
use slate_ici::MODULE_CLASS;
use slate_model::{Board, Change, ChangeItem, Filter};
use slate_node::Node;
use slate_node::inspect::Classes;

use crate::cli::{Format, WatchArgs};
use crate::command::live::{
    export_note, interrupted, join, known, packet_json, packet_text, print_line, split, team_of,
    unit,
};

/// Prints changes until Ctrl-C or `--count` lines.
pub fn run(args: &WatchArgs, format: Format) -> anyhow::Result<ExitCode> {
    let signals = interrupted()?;
    let node = join(&args.live)?;
    let result = watch(&node, &args.pattern, args.count, format, signals);
    node.close();
    result?;
    Ok(ExitCode::SUCCESS)
}

fn watch(
    node: &Node,
    pattern: &str,
    count: Option<u64>,
    format: Format,
    signals: &crossbeam_channel::Receiver<()>,
) -> anyhow::Result<()> {
    let board = node.board();
    let (filter, modules) = filter(node, pattern)?;
    let watch = board.watch(filter)?;
    let note = export_note(node).map_or(String::new(), |n| format!("; {n}"));
    eprintln!(
        "watching {pattern} on {} ({} modules up); Ctrl-C to stop{note}",
        team_of(board),
        node.peers().len()
    );
    let mut printed = 0;
    while count.is_none_or(|n| printed < n) {
        if signals.try_recv().is_ok() {
            break;
        }
        let Some(change) = watch.recv_timeout(Duration::from_millis(100)) else {
            continue;
        };
        for line in lines(board, &change, modules, format) {
            if count.is_some_and(|n| printed >= n) {
                break;
            }
            match format {
                Format::Json => print_line(&line)?,
                Format::Text => println!("{}", line["text"].as_str().unwrap_or_default()),
            }
            printed += 1;
        }
    }
    Ok(())
}

/// The watch filter of a pattern, and whether Module objects are wanted.
fn filter(node: &Node, pattern: &str) -> anyhow::Result<(Filter, bool)> {
    let board = node.board();
    let (target, attr) = split(pattern);
    let base = match target {
        "*" => Filter::all(),
        t => {
            known(node, t)?;
            if board.class_def(t).is_some() {
                Filter::class(t)
            } else {
                Filter::object(t)
            }
        }
    };
    let modules = target != "*" && Classes::of(board).lineage(target).contains(&MODULE_CLASS)
        || board
            .info(target)
            .is_some_and(|i| &*i.class == MODULE_CLASS);
    Ok((attr.map_or(base.clone(), |a| base.attr(a)), modules))
}

/// One JSON line per item (with a `text` rendering for the text format).
fn lines(board: &Board, change: &Change, modules: bool, format: Format) -> Vec<serde_json::Value> {
    let classes = Classes::of(board);
    let is_module = |object: &str| {
        board
            .info(object)
            .is_some_and(|i| classes.lineage(&i.class).contains(&MODULE_CLASS))
    };
    let mut out = Vec::new();
    for item in &change.items {
        let mut j = match item {
            ChangeItem::Write {
                object,
                attr,
                packet,
            } => {
                if !modules && is_module(object) {
                    continue;
                }
                let unit = unit(board, &classes, object, attr);
                let mut j = packet_json(board, attr, unit, packet);
                j["kind"] = json!("write");
                j["object"] = json!(&**object);
                if format == Format::Text {
                    j["text"] = json!(format!(
                        "{object}.{attr} = {}",
                        packet_text(board, unit, packet)
                    ));
                }
                j
            }
            ChangeItem::Create { object, class } | ChangeItem::Delete { object, class } => {
                if !modules && &**class == MODULE_CLASS {
                    continue;
                }
                let kind = if matches!(item, ChangeItem::Create { .. }) {
                    "create"
                } else {
                    "delete"
                };
                let verb = if kind == "create" {
                    "created"
                } else {
                    "deleted"
                };
                json!({"kind": kind, "object": &**object, "class": &**class,
                       "text": format!("{verb} {object} ({class})")})
            }
        };
        j["revision"] = json!(change.revision);
        if format == Format::Json
            && let Some(m) = j.as_object_mut()
        {
            m.remove("text");
        }
        out.push(j);
    }
    out
}
