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
    Ici(#[from] slate_ici::IciStartError),
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
    /// The recording (`record` in the config) did not start.
    #[error("cannot record: {0}")]
    Record(#[from] crate::record::RecordError),
    /// The state directory (`state` in the config) cannot be opened or read.
    #[error("{0}")]
    State(#[from] crate::state::StateError),
    /// The team's keys (`[security]` in the config) cannot be used.
    #[error("cannot use the team's keys: {0}")]
    Keys(#[from] crate::team_keys::KeysError),
    /// A rule of `[authority.writes]` names what the board does not have.
    #[error("{0}")]
    Authority(String),
    /// The Foxglove server (`foxglove` in the config) did not start.
    #[error(transparent)]
    Foxglove(#[from] crate::foxglove::FoxgloveError),
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
        "no slate module reachable through {endpoints} within {seconds:.1} s (is a module listening there? `slate node` and `slate launch` print each module's endpoint; the live verbs take one with --connect)"
    )]
    NoModules {
        /// The endpoints tried.
        endpoints: String,
        /// How long it waited, in seconds.
        seconds: f64,
    },
    /// Nothing at the endpoints took the connection: the session did not open at all,
    /// at once, without waiting.
    #[error(
        "no slate module reachable through {endpoints}: nothing there took the connection (is a module listening there? `slate node` and `slate launch` print each module's endpoint; the live verbs take one with --connect)"
    )]
    Unreachable {
        /// The endpoints tried.
        endpoints: String,
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
    /// The observer's address is not one the operator's certificate may speak as.
    #[error(
        "{identity} may join only as {}/ROBOT/{}NAME, not as {address}",
        identity.team(),
        identity.observer_prefix()
    )]
    NotOperator {
        /// The address asked for.
        address: slate_model::Address,
        /// The operator.
        identity: crate::team_keys::Identity,
    },
    /// A module filter is not `TEAM[/ROBOT[/MODULE]]` (segments of letters, digits, `_`,
    /// `-`, or `*`).
    #[error(
        "{filter:?} is not a module address: expected TEAM, TEAM/ROBOT or TEAM/ROBOT/MODULE, like team/r1/nav"
    )]
    BadFilter {
        /// The filter given.
        filter: String,
    },
}

/// Any error a program running nodes meets: a config, a start, an observer, the ICI, a
/// board operation or a `.slate` load, folded into one so that a function doing several
/// of them returns one type. Each variant holds the precise error unchanged and displays
/// as it does.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A config file cannot be used.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A node did not start.
    #[error(transparent)]
    Start(#[from] StartError),
    /// An observer did not join.
    #[error(transparent)]
    Observe(#[from] ObserveError),
    /// A board operation failed (every board error, through [`slate_model::Error`]).
    #[error(transparent)]
    Model(#[from] slate_model::Error),
    /// A `.slate` source did not load.
    #[error(transparent)]
    Load(#[from] slate_plans::LoadError),
    /// The ICI, a plan circuit, the transport or the codec refused (through
    /// [`slate_ici::Error`]).
    #[error(transparent)]
    Ici(#[from] slate_ici::Error),
}

/// `From` for each error `$variant` folds, through its own umbrella, so `?` folds it
/// directly.
macro_rules! fold_errors {
    ($variant:ident: $($error:ty),* $(,)?) => {
        $(
            impl From<$error> for Error {
                fn from(error: $error) -> Self {
                    Error::$variant(error.into())
                }
            }
        )*
    };
}

fold_errors!(Model:
    slate_model::AddressError,
    slate_model::BatchError,
    slate_model::ChainError,
    slate_model::ClockDriftError,
    slate_model::ClockError,
    slate_model::CreateError,
    slate_model::DefineError,
    slate_model::DeleteError,
    slate_model::FnError,
    slate_model::LookupError,
    slate_model::ReadError,
    slate_model::ValueError,
    slate_model::WriteError,
);

fold_errors!(Ici:
    slate_ici::IciStartError,
    slate_ici::SendRawError,
    slate_ici::SendPlanError,
    slate_ici::SendError,
    slate_wire::EncodeError,
    slate_wire::DecodeError,
);

#[cfg(test)]
mod tests {
    use super::*;
    use slate_model::Address;

    #[test]
    fn a_board_error_folds_into_model_and_displays_unchanged() {
        let parse = || -> Result<Address, Error> { Ok(Address::new("not an address")?) };
        let folded = parse().unwrap_err();
        let Error::Model(slate_model::Error::Address(inner)) = &folded else {
            panic!("an address error folds into Model(Address): {folded:?}");
        };
        assert_eq!(folded.to_string(), inner.to_string());
    }

    #[test]
    fn a_transport_error_folds_into_ici() {
        let send = || -> Result<(), Error> { Err(slate_ici::SendError::Closed)? };
        assert!(matches!(send(), Err(Error::Ici(slate_ici::Error::Send(_)))));
    }
}
