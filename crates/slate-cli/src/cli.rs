//! Command-line definitions (clap). `main.rs` dispatches; each verb lives in `command/`.

use clap::{Parser, Subcommand, ValueEnum};

/// slate: a distributed blackboard world model for robot modules and teams of robots.
#[derive(Debug, Parser)]
#[command(name = "slate", version, about, long_about = None)]
pub struct Cli {
    /// Output format: readable text, or one JSON object for scripts.
    #[arg(long, global = true, value_enum, default_value_t = Format::Text)]
    pub format: Format,

    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Output format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// Human-readable text.
    Text,
    /// One JSON object.
    Json,
}

/// The verbs.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Measure slate's hot paths against a baseline measured in the same run.
    ///
    /// Prints the median time per operation and its ratio to the baseline. Build with
    /// `--release`; debug builds are 10-50x slower and say so.
    ///
    /// Example: slate bench core --format json
    Bench(BenchArgs),

    /// Check .slate files: syntax, names, types. Prints every error with its line and
    /// column; exits 0 when every file is valid and 1 otherwise.
    ///
    /// Files are loaded in order into one scratch board, so a file may use the classes of
    /// the files before it.
    ///
    /// Example: slate check examples/gsr.slate
    Check(CheckArgs),
}

/// Arguments of `slate check`.
#[derive(Debug, clap::Args)]
pub struct CheckArgs {
    /// The .slate files.
    #[arg(required = true)]
    pub files: Vec<std::path::PathBuf>,
}

/// Arguments of `slate bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Which benchmark suite to run.
    #[arg(value_enum)]
    pub suite: Suite,

    /// Samples per measurement; the median is reported.
    #[arg(long, default_value_t = 21, value_parser = clap::value_parser!(u32).range(3..=1001))]
    pub samples: u32,

    /// Target duration of one sample, in milliseconds.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..=1000))]
    pub sample_ms: u64,
}

/// Benchmark suites.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Suite {
    /// The world model: reads, writes, batches, active functions, queries.
    Core,
    /// The plan engine: compiling plans, writes with plans installed, write to action.
    Plans,
}
