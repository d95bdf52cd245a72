//! `slate get OBJ[.ATTR]`: packets on a live team.

use std::process::ExitCode;

use serde_json::json;
use slate_model::{Board, Packet};
use slate_node::Node;
use slate_node::inspect::{Classes, packets};

use crate::cli::{Format, GetArgs};
use crate::command::failed;
use crate::command::live::{join, known, packet_json, packet_text, print_json, split, unit};

/// Prints the packets.
pub fn run(args: &GetArgs, format: Format) -> anyhow::Result<ExitCode> {
    let (object, attr) = split(&args.target);
    let node = join(&args.live)?;
    let result = get(&node, object, attr, format);
    node.close();
    result?;
    Ok(ExitCode::SUCCESS)
}

fn get(node: &Node, object: &str, attr: Option<&str>, format: Format) -> anyhow::Result<()> {
    known(node, object)?;
    let board = node.board();
    let classes = Classes::of(board);
    let list: Vec<(String, Packet)> = match attr {
        Some(a) => vec![(a.to_owned(), read(board, &classes, object, a)?)],
        None => packets(board, &classes, object).unwrap_or_default(),
    };
    let info = board.info(object);
    match format {
        Format::Json => {
            let attrs: Vec<_> = list
                .iter()
                .map(|(a, p)| packet_json(board, a, unit(board, &classes, object, a), p))
                .collect();
            print_json(&json!({
                "object": object,
                "class": info.as_ref().map(|i| i.class.to_string()),
                "context": info.as_ref().map(|i| i.context.name()),
                "owner": info.as_ref().map(|i| i.owner.to_string()),
                "attrs": attrs,
            }))
        }
        Format::Text => {
            if attr.is_none()
                && let Some(i) = &info
            {
                println!("{object}: {} ({}), owner {}", i.class, i.context, i.owner);
            }
            for (a, p) in &list {
                let text = packet_text(board, unit(board, &classes, object, a), p);
                match attr {
                    Some(_) => println!("{object}.{a} = {text}"),
                    None => println!("  {a} = {text}"),
                }
            }
            Ok(())
        }
    }
}

/// One attribute's packet; an attribute the object does not have fails (exit 1).
fn read(board: &Board, classes: &Classes, object: &str, attr: &str) -> anyhow::Result<Packet> {
    let class = board
        .info(object)
        .map(|i| {
            if i.is_class {
                object.to_owned()
            } else {
                i.class.to_string()
            }
        })
        .unwrap_or_default();
    if classes.decl(&class, attr).is_none() {
        let have = classes.attributes(&class).join(", ");
        return failed(format!(
            "{object} ({class}) has no attribute {attr:?} (it has: {have})"
        ));
    }
    Ok(board.read(object, attr)?)
}
