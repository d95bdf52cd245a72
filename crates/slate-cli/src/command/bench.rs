//! `slate bench SUITE`: run a benchmark suite of the `slate-bench` crate and print its
//! figures.

use std::process::ExitCode;

use crate::cli::{BenchArgs, Format};

/// Runs the suite and prints the report as text or JSON.
pub fn run(args: &BenchArgs, format: Format) -> anyhow::Result<ExitCode> {
    if args.secure && args.suite != slate_bench::Suite::Net {
        anyhow::bail!("--secure measures the net suite only: run `slate bench net --secure`");
    }
    let cfg = slate_bench::Config {
        samples: args.samples as usize,
        sample_ms: args.sample_ms,
    };
    if cfg!(debug_assertions) {
        eprintln!(
            "slate: warning: this is a debug build; run `cargo run --release -p slate-cli -- bench ...` for real figures"
        );
    }
    let mut progress = |step: &str| eprintln!("  measuring {step} ...");
    let report = if args.secure {
        slate_bench::net_secure::run(&cfg, &mut progress)?
    } else {
        slate_bench::run(args.suite, &cfg, &mut progress)?
    };
    match format {
        Format::Json => println!("{}", serde_json::to_string_pretty(&report.json())?),
        Format::Text => print!("{}", report.text()),
    }
    Ok(ExitCode::SUCCESS)
}
