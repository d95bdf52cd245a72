//! `slate bench SUITE`: run a benchmark suite of the `slate-bench` crate and print its
//! figures.

use std::process::ExitCode;

use crate::cli::{BenchArgs, Format};

/// Runs the suite and prints the report as text or JSON.
pub fn run(args: &BenchArgs, format: Format) -> anyhow::Result<ExitCode> {
    let cfg = slate_bench::Config {
        samples: args.samples as usize,
        sample_ms: args.sample_ms,
    };
    if cfg!(debug_assertions) {
        eprintln!(
            "slate: warning: this is a debug build; run `cargo run --release -p slate-cli -- bench ...` for real figures"
        );
    }
    let report = slate_bench::run(args.suite, &cfg, &mut |step| {
        eprintln!("  measuring {step} ...")
    })?;
    match format {
        Format::Json => println!("{}", serde_json::to_string_pretty(&report.json())?),
        Format::Text => print!("{}", report.text()),
    }
    Ok(ExitCode::SUCCESS)
}
