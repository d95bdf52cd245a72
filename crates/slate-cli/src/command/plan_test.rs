//! `slate plan test PLAN.slate --against FILE.mcap`: what plans would have done on a
//! recorded board, beside what the plans of the same names did in the recorded run
//! (`slate_node::record::test_plans`, docs/recording.md). Nothing is sent.

use std::process::ExitCode;

use anyhow::Context as _;
use serde_json::json;
use slate_node::record::{AgainstError, Firing, PlanTest, Recording, test_plans};

use crate::cli::{Format, PlanTestArgs};
use crate::command::failed;
use crate::command::live::print_json;

/// Replays, prints the firings; exits 1 when the plans do not load on the recorded board.
pub fn run(args: &PlanTestArgs, format: Format) -> anyhow::Result<ExitCode> {
    let label = args.file.display().to_string();
    let text =
        std::fs::read_to_string(&args.file).with_context(|| format!("cannot read {label}"))?;
    let with = args
        .with
        .iter()
        .map(|p| {
            let label = p.display().to_string();
            let text =
                std::fs::read_to_string(p).with_context(|| format!("cannot read {label}"))?;
            Ok((label, text))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let recording = Recording::read(&args.against)?;
    let test = match test_plans(&recording, &with, &label, &text) {
        Ok(test) => test,
        Err(e @ AgainstError::Load(_)) => {
            return failed(format!("{e}\n(against {})", args.against.display()));
        }
        Err(e) => return Err(e.into()),
    };
    match format {
        Format::Json => print_json(&to_json(&test, &recording))?,
        Format::Text => print!("{}", to_text(&test, &recording, &args.against)),
    }
    Ok(ExitCode::SUCCESS)
}

fn to_json(test: &PlanTest, recording: &Recording) -> serde_json::Value {
    let list = |f: &[Firing]| f.iter().map(Firing::to_json).collect::<Vec<_>>();
    json!({
        "plans": test.plans, "address": recording.address,
        "installed_at": test.installed_at.map(|d| d.as_secs_f64()),
        "messages": test.messages, "refused": test.refused,
        "predicted": list(&test.predicted), "recorded": list(&test.recorded),
    })
}

fn to_text(test: &PlanTest, recording: &Recording, path: &std::path::Path) -> String {
    let mut s = format!(
        "{} against {} ({}, {} messages replayed, {} refused)\n",
        test.plans.join(", "),
        path.display(),
        recording.address.as_deref().unwrap_or("unknown board"),
        test.messages,
        test.refused
    );
    s.push_str("would have:\n");
    lines(&mut s, &test.predicted);
    s.push_str("in the recorded run:\n");
    lines(&mut s, &test.recorded);
    s
}

fn lines(s: &mut String, firings: &[Firing]) {
    if firings.is_empty() {
        s.push_str("  nothing\n");
    }
    for f in firings {
        s.push_str(&line(f));
    }
}

/// `  12.300 s  plan triggered (fired 1): wrote obj.attr = value; would send ...`
fn line(f: &Firing) -> String {
    let e = &f.event;
    let mut text = format!(
        "  {:9.3} s  {} {}",
        f.at.as_secs_f64(),
        e["plan"].as_str().unwrap_or("?"),
        f.name()
    );
    if let Some(fired) = e["fired"].as_u64() {
        text.push_str(&format!(" (fired {fired})"));
    }
    if let Some(error) = e["error"].as_str() {
        text.push_str(&format!(": error: {error}"));
    }
    let wrote: Vec<String> = f
        .wrote
        .iter()
        .map(|w| {
            format!(
                "{}.{} = {}",
                w["object"].as_str().unwrap_or("?"),
                w["attr"].as_str().unwrap_or("?"),
                w["value"]
            )
        })
        .collect();
    if !wrote.is_empty() {
        text.push_str(&format!(": wrote {}", wrote.join(", ")));
    }
    if !f.sent.is_empty() {
        text.push_str(&format!("; would send {}", f.sent.join(", ")));
    }
    text.push('\n');
    text
}
