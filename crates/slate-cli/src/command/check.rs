//! `slate check FILE...`: validate .slate files.

use std::process::ExitCode;
use std::sync::Arc;

use anyhow::Context as _;
use serde_json::json;
use slate_model::{Board, Clock};
use slate_plans::Engine;

use crate::cli::{CheckArgs, Format};

/// Loads every file into one scratch board, as one module (in any order), and reports
/// what is wrong.
pub fn run(args: &CheckArgs, format: Format) -> anyhow::Result<ExitCode> {
    let board = Arc::new(Board::builder().clock(Clock::manual()).build());
    let engine = Engine::new(&board);
    let mut files = Vec::new();
    for path in &args.files {
        let name = path.display().to_string();
        let source =
            std::fs::read_to_string(path).with_context(|| format!("cannot read {name}"))?;
        files.push((name, source));
    }
    // The files form one module: each may name what another defines, in any order.
    let results: Vec<_> = files
        .iter()
        .map(|(name, _)| name.clone())
        .zip(engine.load_all(&files))
        .collect();
    let ok = results.iter().all(|(_, r)| r.is_ok());
    match format {
        Format::Text => print_text(&results),
        Format::Json => print_json(&results)?,
    }
    Ok(if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

type Results = [(String, Result<slate_plans::Loaded, slate_plans::LoadError>)];

/// `1 object`, `2 objects`.
fn count(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

fn print_text(results: &Results) {
    for (name, r) in results {
        match r {
            Ok(l) => println!(
                "{name}: ok ({}, {}, {}, {})",
                count(l.classes.len(), "class", "classes"),
                count(l.objects.len(), "object", "objects"),
                count(l.rules, "rule", "rules"),
                count(l.plans.len(), "plan", "plans")
            ),
            Err(e) => eprintln!("{}", e.rendered),
        }
    }
}

fn print_json(results: &Results) -> anyhow::Result<()> {
    let files: Vec<_> = results
        .iter()
        .map(|(name, r)| match r {
            Ok(l) => json!({"file": name, "ok": true, "classes": l.classes, "objects": l.objects, "plans": l.plans, "diagnostics": []}),
            Err(e) => {
                let diags: Vec<_> = e
                    .diagnostics
                    .iter()
                    .map(|d| json!({"line": d.span.line, "column": d.span.col, "severity": if d.is_error() { "error" } else { "warning" }, "message": d.message}))
                    .collect();
                json!({"file": name, "ok": false, "diagnostics": diags})
            }
        })
        .collect();
    let ok = results.iter().all(|(_, r)| r.is_ok());
    println!(
        "{}",
        serde_json::to_string_pretty(&json!({"ok": ok, "files": files}))?
    );
    Ok(())
}
