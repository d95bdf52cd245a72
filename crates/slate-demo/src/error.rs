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
    #[error("{board}: cannot load {file}:\n{rendered}")]
    Load {
        /// The board.
        board: String,
        /// The file.
        file: String,
        /// The diagnostics.
        rendered: String,
    },
    /// An ICI did not start.
    #[error("cannot start the ICI: {0}")]
    Ici(#[from] slate_ici::IciStartError),
    /// The dashboard could not be served.
    #[error("dashboard: {0}")]
    Dashboard(#[from] slate_dashboard::ServeError),
}
