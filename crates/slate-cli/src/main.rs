//! The `slate` binary.

mod cli;
mod command;
mod logging;

use std::process::ExitCode;

use clap::Parser;
use clap::error::ErrorKind;

use crate::cli::{Cli, Command, KeysCommand, PlanCommand};
use crate::command::Failed;

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return usage_error(&e),
    };
    let node = matches!(cli.command, Command::Node(_));
    let default = if node {
        logging::NODE
    } else {
        logging::OBSERVER
    };
    let logs = match logging::init(cli.log.as_deref(), default, cli.log_format) {
        Ok(logs) => logs,
        Err(e) => {
            eprintln!("slate: error: {e}");
            return ExitCode::from(2);
        }
    };
    let format = cli.format;
    let result = match cli.command {
        Command::Bench(args) => command::bench::run(&args, format),
        Command::Check(args) => command::check::run(&args, format),
        Command::Demo(args) => command::demo::run(&args, format),
        Command::DemoModule(args) => command::demo::module(&args),
        Command::Keys(KeysCommand::Init(args)) => command::keys::init(&args, format),
        Command::Keys(KeysCommand::Issue(args)) => command::keys::issue(&args, format),
        Command::Launch(args) => {
            let logs = command::launch::ModuleLogs {
                filter: cli.log.clone(),
                format: cli.log_format,
            };
            command::launch::run(&args, format, logs)
        }
        Command::Node(args) => command::node::run(&args, format, &logs),
        Command::Tree(args) => command::tree::run(&args, format),
        Command::Ls(args) => command::ls::run(&args, format),
        Command::Get(args) => command::get::run(&args, format),
        Command::Put(args) => command::put::run(&args, format),
        Command::Watch(args) => command::watch::run(&args, format),
        Command::Record(args) => command::record::run(&args, format),
        Command::Play(args) => command::play::run(&args, format),
        Command::Stats(args) => command::stats::run(&args, format),
        Command::Bw(args) => command::stats::bw(&args, format),
        Command::Hz(args) => command::hz::run(&args, format),
        Command::Plan(PlanCommand::Send(args)) => command::plan::send(&args, format),
        Command::Plan(PlanCommand::Ls(args)) => command::plan::ls(&args, format),
        Command::Plan(PlanCommand::Cancel(args)) => command::plan::cancel(&args, format),
        Command::Plan(PlanCommand::Test(args)) => command::plan_test::run(&args, format),
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

/// A usage error as one line, `slate: error: ...`, exit 2 (docs/cli.md); help and the
/// version print as clap renders them.
fn usage_error(e: &clap::Error) -> ExitCode {
    let shown = matches!(
        e.kind(),
        ErrorKind::DisplayHelp
            | ErrorKind::DisplayVersion
            | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
    );
    if shown {
        let _ = e.print();
        return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
    }
    eprintln!("slate: error: {}", usage_line(&e.render().to_string()));
    ExitCode::from(2)
}

/// clap's rendering in one line: the error and its tips, and where to read more. clap
/// separates the error, its tips and the usage by blank lines; an error's details may
/// continue on indented lines.
fn usage_line(rendered: &str) -> String {
    let mut error = String::new();
    let mut see = String::new();
    for block in rendered.split("\n\n") {
        let text = block.split_whitespace().collect::<Vec<_>>().join(" ");
        if let Some(usage) = text.strip_prefix("Usage: ") {
            see = format!(" (see `{} --help`)", command_path(usage));
        } else if let Some(first) = text.strip_prefix("error: ") {
            error = first.to_owned();
        } else if text.starts_with("tip:") {
            error = format!("{error}; {text}");
        }
    }
    format!("{error}{see}")
}

/// `slate put` of the usage `slate put [OPTIONS] <OBJ.ATTR> <VALUE>`.
fn command_path(usage: &str) -> String {
    usage
        .split(' ')
        .take_while(|w| !w.starts_with(['[', '<', '-']))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_usage_error_is_one_line_with_its_details_tips_and_where_to_read_more() {
        let rendered = "error: the following required arguments were not provided:\n  <OBJ[.ATTR]>\n\nUsage: slate get <OBJ[.ATTR]>\n\nFor more information, try '--help'.\n";
        assert_eq!(
            usage_line(rendered),
            "the following required arguments were not provided: <OBJ[.ATTR]> (see `slate get --help`)"
        );
        let rendered = "error: unexpected argument '--x' found\n\n  tip: to pass '--x' as a value, use '-- --x'\n\nUsage: slate put [OPTIONS] <OBJ.ATTR> <VALUE>\n\nFor more information, try '--help'.\n";
        assert_eq!(
            usage_line(rendered),
            "unexpected argument '--x' found; tip: to pass '--x' as a value, use '-- --x' (see `slate put --help`)"
        );
    }
}
