//! `slate node --config FILE`: run one module until SIGINT or SIGTERM. While it starts,
//! Zenoh's warnings are left out: a failed start is one error line (docs/cli.md).

use std::process::ExitCode;

use serde_json::json;
use slate_node::{Node, NodeConfig};

use crate::cli::{Format, NodeArgs};
use crate::command::live::{interrupted, print_line};
use crate::logging::Logs;

/// Starts the node, says where it listens, waits for a signal (with `--format json`,
/// printing each event of its log meanwhile), stops cleanly.
pub fn run(args: &NodeArgs, format: Format, logs: &Logs) -> anyhow::Result<ExitCode> {
    let mut config = NodeConfig::read(&args.config)?;
    if let Some(addr) = args.foxglove {
        config.foxglove = Some(addr);
    }
    if args.reset_state {
        reset_state(&config)?;
    }
    let signals = interrupted()?;
    let node = logs.quiet_zenoh(|| Node::start(&config))?;
    let dashboard = node.dashboard_url();
    let foxglove = node.foxglove_addr().map(|a| format!("ws://{a}"));
    match format {
        Format::Json => print_line(&json!({
            "event": "ready", "address": node.address().as_str(),
            "listening": node.listening(), "connect": config.zenoh.connect,
            "dashboard": dashboard, "foxglove": foxglove, "pid": std::process::id(),
            "record": config.record.as_ref().map(|r| r.path.display().to_string()),
            "state": config.state.as_ref().map(|s| s.dir.display().to_string()),
            "restored": node.restored().map(|r| json!({
                "objects": r.objects, "packets": r.packets, "refused": r.refused,
            })),
        }))?,
        Format::Text => {
            let listening = match node.listening() {
                [] => "nowhere (connects only)".to_owned(),
                l => l.join(", "),
            };
            let dashboard = dashboard.map_or(String::new(), |u| format!("; dashboard at {u}"));
            let foxglove = foxglove.map_or(String::new(), |u| format!("; Foxglove at {u}"));
            println!(
                "slate node {}: listening on {listening}{dashboard}{foxglove}",
                node.address()
            );
        }
    }
    stream_events(&node, format, signals)?;
    let peers = node.peers().len();
    let revision = node.board().revision();
    node.close();
    match format {
        Format::Json => print_line(&json!({
            "event": "stopped", "address": node.address().as_str(),
            "peers": peers, "revision": revision,
        }))?,
        Format::Text => println!("slate node {}: stopped", node.address()),
    }
    Ok(ExitCode::SUCCESS)
}

/// `--reset-state`: moves the store of the config's state directory aside.
fn reset_state(config: &NodeConfig) -> anyhow::Result<()> {
    let Some(state) = &config.state else {
        anyhow::bail!(
            "--reset-state: the config has no `state = \"DIR\"`, so there is no state to reset"
        );
    };
    let dir = &state.dir;
    match slate_node::state::reset(dir) {
        Ok(Some(aside)) => eprintln!("moved the state store aside to {}", aside.display()),
        Ok(None) => eprintln!("no state store in {} to reset", dir.display()),
        Err(e) => anyhow::bail!(
            "cannot move the state store in {} aside: {e}",
            dir.display()
        ),
    }
    Ok(())
}

/// Waits for SIGINT or SIGTERM; with `--format json`, prints each event the node logs
/// meanwhile as one line: `{"event": "news", "time", "level", "text"}` (peers up and down,
/// plan progress, conflicts; the same sentences its log on stderr has).
fn stream_events(
    node: &Node,
    format: Format,
    signals: &crossbeam_channel::Receiver<()>,
) -> anyhow::Result<()> {
    if format == Format::Text {
        let _ = signals.recv();
        return Ok(());
    }
    let events = node.follow_events();
    loop {
        crossbeam_channel::select! {
            recv(signals) -> _ => return Ok(()),
            recv(events) -> e => match e {
                Ok(e) => print_line(&json!({
                    "event": "news", "time": e.time, "level": e.level, "text": e.text,
                }))?,
                Err(_) => {
                    let _ = signals.recv();
                    return Ok(());
                }
            },
        }
    }
}
