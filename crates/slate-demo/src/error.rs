//! Why a demo could not run.

/// Why a demo could not run.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum DemoError {
    /// The settings are wrong.
    #[error("{0}")]
    Config(String),
    /// The network could not be set up.
    #[error("network: {0}")]
    Network(String),
    /// A `.slate` file did not load on a board (a bug in the demo's files).
    #[error("{board}: a demo file did not load:\n{rendered}")]
    Load {
        /// The board.
        board: String,
        /// The diagnostics, naming the file.
        rendered: String,
    },
    /// A module's node did not start.
    #[error("cannot start a module: {0}")]
    Start(#[from] slate_node::StartError),
    /// The recording could not start (`--record`).
    #[error("recording: {0}")]
    Record(String),
    /// The dashboard could not be served.
    #[error("dashboard: {0}")]
    Dashboard(#[from] slate_dashboard::ServeError),
}
