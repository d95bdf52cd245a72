//! `slate record -o FILE.mcap [PATTERN...]`: a live team's world model recorded to MCAP
//! by an observer (docs/recording.md), until Ctrl-C or `--for`.

use std::path::Path;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Context;
use serde_json::json;
use slate_node::{Node, RecordConfig, RecordStats};

use crate::cli::{Format, RecordArgs};
use crate::command::live::{interrupted, join, known, print_line, team_of};

/// How often progress goes to stderr.
const PROGRESS: Duration = Duration::from_secs(2);

/// Joins, records until a signal or `--for`, finishes the file, prints what it holds.
pub fn run(args: &RecordArgs, format: Format) -> anyhow::Result<ExitCode> {
    let config = config(args)?;
    let limit = seconds(args.duration, "--for")?;
    let signals = interrupted()?;
    let node = join(&args.live)?;
    let result = record(&node, config, limit, signals);
    node.close();
    let stats = result?;
    report(&args.output, &stats, format)?;
    Ok(ExitCode::SUCCESS)
}

/// The recorder's settings from the arguments.
fn config(args: &RecordArgs) -> anyhow::Result<RecordConfig> {
    let mut config = RecordConfig::new(&args.output);
    config.max_bytes = (args.max_size_mb > 0).then(|| args.max_size_mb.saturating_mul(1 << 20));
    config.max_duration = seconds(args.max_age, "--max-age")?;
    config.only.clone_from(&args.patterns);
    Ok(config)
}

/// A positive number of seconds, if given.
fn seconds(value: Option<f64>, option: &str) -> anyhow::Result<Option<Duration>> {
    value
        .map(|s| {
            Duration::try_from_secs_f64(s)
                .ok()
                .filter(|d| !d.is_zero())
                .with_context(|| format!("{option} {s}: expected a positive number of seconds"))
        })
        .transpose()
}

fn record(
    node: &Node,
    config: RecordConfig,
    limit: Option<Duration>,
    signals: &crossbeam_channel::Receiver<()>,
) -> anyhow::Result<RecordStats> {
    for pattern in &config.only {
        known(node, pattern)?;
    }
    let what = match config.only.as_slice() {
        [] => "everything".to_owned(),
        only => only.join(", "),
    };
    let file = config.path.display().to_string();
    node.start_recording(config)?;
    let stop = limit.map_or("Ctrl-C to stop".to_owned(), |d| {
        format!("stops after {}s", d.as_secs_f64())
    });
    eprintln!(
        "recording {what} on {} ({} modules up) to {file}; {stop}",
        team_of(node.board()),
        node.peers().len()
    );
    wait(node, limit, signals);
    let stats = node.stop_recording()?.unwrap_or_default();
    match &stats.failed {
        Some(why) => anyhow::bail!("the recording stopped: {why}"),
        None => Ok(stats),
    }
}

/// Waits for a signal or the limit, with progress on stderr.
fn wait(node: &Node, limit: Option<Duration>, signals: &crossbeam_channel::Receiver<()>) {
    let began = Instant::now();
    loop {
        let left = limit.map_or(PROGRESS, |l| l.saturating_sub(began.elapsed()));
        if signals.recv_timeout(left.min(PROGRESS)).is_ok()
            || limit.is_some_and(|l| began.elapsed() >= l)
        {
            return;
        }
        if let Some(stats) = node.recording() {
            if let Some(why) = &stats.failed {
                eprintln!("recording stopped: {why}");
                return;
            }
            eprintln!("{}", progress(&stats));
        }
    }
}

/// `recorded N messages, B bytes (D changes dropped)`.
fn progress(stats: &RecordStats) -> String {
    let dropped = match stats.dropped {
        0 => String::new(),
        d => format!(" ({d} changes dropped: the recorder fell behind)"),
    };
    format!(
        "recorded {} messages, {} bytes in {} file(s){dropped}",
        stats.messages, stats.bytes, stats.files
    )
}

fn report(path: &Path, stats: &RecordStats, format: Format) -> anyhow::Result<()> {
    let files: Vec<String> = (0..stats.files)
        .map(|i| {
            slate_node::record::rotated_path(path, i)
                .display()
                .to_string()
        })
        .collect();
    match format {
        Format::Json => print_line(&json!({
            "event": "recorded", "files": files, "messages": stats.messages,
            "bytes": stats.bytes, "dropped": stats.dropped,
        })),
        Format::Text => {
            println!("{}: {}", files.join(", "), progress(stats));
            Ok(())
        }
    }
}
