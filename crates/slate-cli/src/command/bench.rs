//! `slate bench SUITE`: run a benchmark suite and print its figures.

use std::process::ExitCode;

use crate::bench::{self, Report};
use crate::cli::{BenchArgs, Format, Suite};

/// Runs the suite and prints the report as text or JSON.
pub fn run(args: &BenchArgs, format: Format) -> anyhow::Result<ExitCode> {
    let cfg = bench::Config {
        samples: args.samples as usize,
        sample_ms: args.sample_ms,
    };
    if cfg!(debug_assertions) {
        eprintln!(
            "slate: warning: this is a debug build; run `cargo run --release -p slate-cli -- bench ...` for real figures"
        );
    }
    let report = match args.suite {
        Suite::Core => bench::core::run(&cfg, &mut |step| eprintln!("  measuring {step} ...")),
        Suite::Plans => bench::plans::run(&cfg, &mut |step| eprintln!("  measuring {step} ...")),
        Suite::Wire => bench::wire::run(&cfg, &mut |step| eprintln!("  measuring {step} ..."))?,
        Suite::Net => bench::net::run(&cfg, &mut |step| eprintln!("  measuring {step} ..."))?,
        Suite::Cli => bench::cli::run(&cfg, &mut |step| eprintln!("  measuring {step} ..."))?,
    };
    match format {
        Format::Json => println!("{}", serde_json::to_string_pretty(&report.json())?),
        Format::Text => print!("{}", report.text()),
    }
    Ok(ExitCode::SUCCESS)
}

impl Report {
    fn text(&self) -> String {
        let mut out = format!(
            "{}\n\n{:<36} {:>15}  {}\n",
            self.title, "figure", "value", "vs baseline"
        );
        for m in &self.rows {
            let ratio = m
                .baseline
                .map_or(String::new(), |(name, ratio)| format!("{ratio:.2}x {name}"));
            out.push_str(&format!(
                "{:<36} {}  {ratio}{}\n",
                m.name,
                m.figure(),
                m.verdicts()
            ));
        }
        if !self.facts.is_empty() {
            out.push('\n');
        }
        for (name, value) in &self.facts {
            out.push_str(&format!("{name:<36} {value}\n"));
        }
        out
    }
}
