//! `slate node --config FILE`: run one module until SIGINT or SIGTERM. While it starts,
//! Zenoh's warnings are left out: a failed start is one error line (docs/cli.md).

use std::process::ExitCode;

use serde_json::json;
use slate_node::{Node, NodeConfig};

use crate::cli::{Format, NodeArgs};
use crate::command::live::{interrupted, print_line};
use crate::logging::Logs;

/// Starts the node, says where it listens, waits for a signal, stops cleanly.
pub fn run(args: &NodeArgs, format: Format, logs: &Logs) -> anyhow::Result<ExitCode> {
    let config = NodeConfig::read(&args.config)?;
    if args.reset_state {
        reset_state(&config)?;
    }
    let signals = interrupted()?;
    let node = logs.quiet_zenoh(|| Node::start(&config))?;
    let dashboard = node.dashboard_url();
    match format {
        Format::Json => print_line(&json!({
            "event": "ready", "address": node.address().as_str(),
            "listening": node.listening(), "connect": config.zenoh.connect,
            "dashboard": dashboard, "pid": std::process::id(),
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
            println!(
                "slate node {}: listening on {listening}{dashboard}",
                node.address()
            );
        }
    }
    let _ = signals.recv();
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
