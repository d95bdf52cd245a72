//! Why a config did not read, a node did not start, or an observer did not join.

use std::path::PathBuf;

/// A config file that cannot be used. Every variant names the file; the key and what was
/// expected where it applies. Each displays as one line.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file cannot be read.
    #[error("{file}: cannot read: {error}")]
    Read {
        /// The file.
        file: String,
        /// Why.
        error: std::io::Error,
    },
    /// The file is not valid TOML.
    #[error("{file}:{line}:{column}: not valid TOML: {message}")]
    Syntax {
        /// The file.
        file: String,
        /// Line (from 1).
        line: usize,
        /// Column (from 1).
        column: usize,
        /// The parser's message.
        message: String,
    },
    /// A key the config does not have.
    #[error("{file}: unknown key `{key}` (known keys: {known})")]
    Unknown {
        /// The file.
        file: String,
        /// The full key (`zenoh.lisen`).
        key: String,
        /// The keys of that table.
        known: String,
    },
    /// A required key is missing.
    #[error("{file}: missing key `{key}`: expected {expected}")]
    Missing {
        /// The file.
        file: String,
        /// The full key.
        key: String,
        /// What it should hold.
        expected: String,
    },
    /// A key holds a value of the wrong type or form.
    #[error("{file}: key `{key}`: expected {expected}, found {found}")]
    Invalid {
        /// The file.
        file: String,
        /// The full key.
        key: String,
        /// What it should hold.
        expected: String,
        /// What it holds.
        found: String,
    },
}

/// Why a node did not start. Nothing is left running.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum StartError {
    /// The builder was given a board of another address.
    #[error("the board is {board} but the node is {node}")]
    BoardAddress {
        /// The board's address.
        board: slate_model::Address,
        /// The node's address.
        node: slate_model::Address,
    },
    /// The Zenoh session did not open.
    #[error("cannot join the network: {0}")]
    Open(#[from] slate_zenoh::OpenError),
    /// The ICI did not start.
    #[error("cannot start the ICI: {0}")]
    Ici(#[from] slate_ici::StartError),
    /// A `.slate` file cannot be read.
    #[error("cannot read {}: {error}", path.display())]
    ReadSource {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// A `.slate` source did not load (the diagnostics, rendered with the source line).
    #[error("{0}")]
    Load(#[from] slate_plans::LoadError),
    /// The dashboard did not start.
    #[error("cannot serve the dashboard: {0}")]
    Dashboard(#[from] slate_dashboard::ServeError),
}

/// Why an observer could not join a live team.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum ObserveError {
    /// The Zenoh session did not open.
    #[error("cannot join the network: {0}")]
    Open(#[from] slate_zenoh::OpenError),
    /// No slate module answered in time.
    #[error(
        "no slate module reachable through {endpoints} within {seconds:.1} s (is a node running? see `slate node --help`)"
    )]
    NoModules {
        /// The endpoints tried.
        endpoints: String,
        /// How long it waited, in seconds.
        seconds: f64,
    },
    /// Modules of several teams answered and none was chosen.
    #[error("modules of several teams answered ({teams}); choose one with --as TEAM/ROBOT/NAME")]
    SeveralTeams {
        /// The teams seen.
        teams: String,
    },
    /// The observer's node did not start.
    #[error("{0}")]
    Start(#[from] StartError),
}
