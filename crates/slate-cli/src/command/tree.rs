//! `slate tree [FILE...]`: the class tree of a live team, or of .slate files.

use std::collections::BTreeMap;
use std::process::ExitCode;
use std::sync::Arc;

use anyhow::Context as _;
use serde_json::{Value as Json, json};
use slate_model::{Board, Clock, THING};
use slate_node::inspect::Classes;
use slate_plans::Engine;

use crate::cli::{Format, TreeArgs};
use crate::command::failed;
use crate::command::live::{join, print_export_note, print_json, seen_through_export_json};

/// Prints the tree.
pub fn run(args: &TreeArgs, format: Format) -> anyhow::Result<ExitCode> {
    if args.files.is_empty() {
        let node = join(&args.live)?;
        let conflicts = Conflicts::of(node.ici().class_conflicts());
        let seen = Some(seen_through_export_json(&node));
        let result = print(node.board(), &conflicts, format, seen);
        if format == Format::Text {
            print_export_note(&node);
        }
        node.close();
        result?;
    } else {
        let board = load(&args.files)?;
        print(&board, &Conflicts::default(), format, None)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// A scratch board with the files loaded in order (the first error fails, exit 1).
fn load(files: &[std::path::PathBuf]) -> anyhow::Result<Arc<Board>> {
    let board = Arc::new(Board::builder().clock(Clock::manual()).build());
    let engine = Engine::new(&board);
    for path in files {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {name}"))?;
        if let Err(e) = engine.load(&name, &text) {
            return failed(e.rendered);
        }
    }
    Ok(board)
}

/// The modules that define a class differently from the board shown, by class.
#[derive(Default)]
struct Conflicts(BTreeMap<String, Vec<String>>);

impl Conflicts {
    fn of(found: Vec<(String, slate_model::Address)>) -> Self {
        let mut by_class: BTreeMap<String, Vec<String>> = BTreeMap::new();
        for (class, peer) in found {
            by_class.entry(class).or_default().push(peer.to_string());
        }
        Conflicts(by_class)
    }

    fn peers(&self, class: &str) -> &[String] {
        self.0.get(class).map(Vec::as_slice).unwrap_or_default()
    }
}

/// Prints the tree; `seen_through_export` (live only) goes into the JSON.
fn print(
    board: &Board,
    conflicts: &Conflicts,
    format: Format,
    seen_through_export: Option<Json>,
) -> anyhow::Result<()> {
    let classes = Classes::of(board);
    let counts = counts(board);
    let mut children: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for d in classes.defs() {
        children.entry(d.parent.as_str()).or_default().push(&d.name);
    }
    match format {
        Format::Json => {
            let list: Vec<_> = classes
                .defs()
                .map(|d| {
                    let attrs: Vec<&str> = d.attrs.iter().map(|a| a.name.as_str()).collect();
                    json!({
                        "name": d.name, "parent": d.parent, "attrs": attrs,
                        "objects": counts.get(d.name.as_str()).copied().unwrap_or(0),
                        "conflicts": conflicts.peers(&d.name),
                    })
                })
                .collect();
            let mut j = json!({"classes": list});
            if let Some(seen) = seen_through_export {
                j["seen_through_export"] = seen;
            }
            print_json(&j)
        }
        Format::Text => {
            println!("{THING}");
            let tree = Tree {
                classes: &classes,
                children: &children,
                counts: &counts,
                conflicts,
            };
            tree.print_children(THING, "");
            Ok(())
        }
    }
}

/// Objects per class (direct instances).
fn counts(board: &Board) -> BTreeMap<String, usize> {
    let mut counts = BTreeMap::new();
    for id in board.instances(THING).unwrap_or_default() {
        if let Some(info) = board.name_of(id).and_then(|n| board.info(&n)) {
            *counts.entry(info.class.to_string()).or_default() += 1;
        }
    }
    counts
}

/// What the text tree is drawn from.
struct Tree<'a> {
    classes: &'a Classes,
    children: &'a BTreeMap<&'a str, Vec<&'a str>>,
    counts: &'a BTreeMap<String, usize>,
    conflicts: &'a Conflicts,
}

impl Tree<'_> {
    fn print_children(&self, parent: &str, indent: &str) {
        let kids = self
            .children
            .get(parent)
            .map(Vec::as_slice)
            .unwrap_or_default();
        for (i, name) in kids.iter().enumerate() {
            if *name == THING {
                continue;
            }
            let last = i + 1 == kids.len();
            let (branch, more) = if last {
                ("└── ", "    ")
            } else {
                ("├── ", "│   ")
            };
            println!("{indent}{branch}{}", self.line(name));
            self.print_children(name, &format!("{indent}{more}"));
        }
    }

    /// `Vehicle (position, speed): 2 objects`, and the modules that define it otherwise.
    fn line(&self, name: &str) -> String {
        let line = line(self.classes, self.counts, name);
        match self.conflicts.peers(name) {
            [] => line,
            peers => format!(
                "{line}  [conflict: defined differently by {}; their objects are not merged]",
                peers.join(", ")
            ),
        }
    }
}

/// `Vehicle (position, speed): 2 objects`.
fn line(classes: &Classes, counts: &BTreeMap<String, usize>, name: &str) -> String {
    let attrs: Vec<&str> = classes
        .defs()
        .find(|d| d.name == name)
        .map(|d| d.attrs.iter().map(|a| a.name.as_str()).collect())
        .unwrap_or_default();
    let attrs = if attrs.is_empty() {
        String::new()
    } else {
        format!(" ({})", attrs.join(", "))
    };
    match counts.get(name).copied().unwrap_or(0) {
        0 => format!("{name}{attrs}"),
        1 => format!("{name}{attrs}: 1 object"),
        n => format!("{name}{attrs}: {n} objects"),
    }
}
