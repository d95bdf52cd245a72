//! The `slate` binary.

mod bench;
mod cli;
mod command;
mod logging;

use std::process::ExitCode;

use clap::Parser;

use crate::cli::{Cli, Command, PlanCommand};
use crate::command::Failed;

fn main() -> ExitCode {
    let cli = Cli::parse();
    let node = matches!(cli.command, Command::Node(_));
    let default = if node {
        logging::NODE
    } else {
        logging::OBSERVER
    };
    if let Err(e) = logging::init(cli.log.as_deref(), default) {
        eprintln!("slate: error: {e}");
        return ExitCode::from(2);
    }
    let format = cli.format;
    let result = match cli.command {
        Command::Bench(args) => command::bench::run(&args, format),
        Command::Check(args) => command::check::run(&args, format),
        Command::Demo(args) => command::demo::run(&args, format),
        Command::Node(args) => command::node::run(&args, format),
        Command::Tree(args) => command::tree::run(&args, format),
        Command::Ls(args) => command::ls::run(&args, format),
        Command::Get(args) => command::get::run(&args, format),
        Command::Put(args) => command::put::run(&args, format),
        Command::Watch(args) => command::watch::run(&args, format),
        Command::Plan(PlanCommand::Send(args)) => command::plan::send(&args, format),
        Command::Plan(PlanCommand::Ls(args)) => command::plan::ls(&args, format),
        Command::Plan(PlanCommand::Cancel(args)) => command::plan::cancel(&args, format),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("{}", report(&e));
            let code = if e.downcast_ref::<Failed>().is_some() {
                1
            } else {
                2
            };
            ExitCode::from(code)
        }
    }
}

/// What to print for an error: `slate: error: MESSAGE`, except for a `.slate` file's
/// diagnostics, which say `FILE:LINE:COL: error:` themselves (one "error" per line).
fn report(e: &anyhow::Error) -> String {
    let load = e
        .chain()
        .find_map(|c| c.downcast_ref::<slate_plans::LoadError>());
    match load {
        Some(l) => format!("slate: {}", l.rendered),
        None => format!("slate: error: {}", message(e)),
    }
}

/// The error and its causes joined by `: `, leaving out a cause whose text the message
/// already holds (many errors display their source too). Diagnostics keep their lines
/// (the source line and the caret).
fn message(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let part = cause.to_string();
        if text.contains(&part) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&part);
    }
    text
}
