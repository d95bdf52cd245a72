//! The `slate` binary.

mod bench;
mod cli;
mod command;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let cli = cli::Cli::parse();
    let result = match cli.command {
        cli::Command::Bench(args) => command::bench::run(&args, cli.format),
        cli::Command::Check(args) => command::check::run(&args, cli.format),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("slate: error: {e:#}");
            ExitCode::from(2)
        }
    }
}
