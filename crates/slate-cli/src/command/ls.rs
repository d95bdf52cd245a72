//! `slate ls CLASS`: the objects of a class on a live team.

use std::process::ExitCode;

use serde_json::json;
use slate_model::{ObjectInfo, Query};

use crate::cli::{Format, LsArgs};
use crate::command::failed;
use crate::command::live::{
    join, print_export_note, print_json, seen_through_export_json, team_of,
};
use slate_node::Node;

/// Lists the objects.
pub fn run(args: &LsArgs, format: Format) -> anyhow::Result<ExitCode> {
    let node = join(&args.live)?;
    let result = list(&node, &args.class, format);
    node.close();
    result?;
    Ok(ExitCode::SUCCESS)
}

/// Lists the objects; says (stderr, or `seen_through_export` in JSON) which modules it
/// sees only through their export.
fn list(node: &Node, class: &str, format: Format) -> anyhow::Result<()> {
    let board = node.board();
    if board.class_def(class).is_none() {
        return failed(format!(
            "no class named {class:?} on the boards of {} (see `slate tree`)",
            team_of(board)
        ));
    }
    let ids = board.query(&Query::class(class))?;
    let mut infos: Vec<ObjectInfo> = ids
        .into_iter()
        .filter_map(|id| board.name_of(id).and_then(|n| board.info(&n)))
        .collect();
    infos.sort_by(|a, b| a.name.cmp(&b.name));
    match format {
        Format::Json => {
            let objects: Vec<_> = infos
                .iter()
                .map(|i| {
                    json!({"name": &*i.name, "class": &*i.class, "context": i.context.name(), "owner": i.owner.to_string()})
                })
                .collect();
            print_json(&json!({
                "class": class, "objects": objects,
                "seen_through_export": seen_through_export_json(node),
            }))
        }
        Format::Text => {
            let width = |f: &dyn Fn(&ObjectInfo) -> usize| infos.iter().map(f).max().unwrap_or(0);
            let (wn, wc) = (width(&|i| i.name.len()), width(&|i| i.class.len()));
            for i in &infos {
                println!(
                    "{:<wn$}  {:<wc$}  {:<12}  {}",
                    i.name,
                    i.class,
                    i.context.name(),
                    i.owner
                );
            }
            if infos.is_empty() {
                eprintln!("no {class} objects");
            }
            print_export_note(node);
            Ok(())
        }
    }
}
