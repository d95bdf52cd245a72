//! A node's board kept across restarts (`state = "DIR"`, `docs/design.md`, "A restart"):
//! classes, objects and their packets in a redb database, restored on start before the
//! node joins its team.
//!
//! The keeper runs off the write path, as the recorder does: the board hands each
//! committed change to a gathering watch ([`Board::watch_gathered`](slate_model::Board::watch_gathered))
//! in the writer's thread; a `slate-state` thread takes what waits there, all at once,
//! and folds it into one pending set
//! (the latest packet of each attribute) and commits it to the database every
//! [`StateConfig::commit_every`] or every [`StateConfig::commit_changes`] changes. A
//! writer never waits for the store. When the keeper falls a whole queue behind, the
//! watch drops changes; the keeper then saves the whole board again from a snapshot, so
//! nothing is missing from the store after its next commit.
//!
//! What a kill -9 loses: the changes committed to the board since the store's last
//! commit (at most `commit_every` of them, plus what waited in the queue). Objects of
//! the built-in `Module` and `Plan` classes are not kept: liveliness is the ICI's to
//! find out again, and plans come back from the node's files. Plans other modules sent
//! and the node accepted are kept (their text, sender, circuit and origin) while they
//! run, with where each was (its state, `fired` count and trigger's edge); after a
//! restart they are installed again on their circuits and take up there, so a trigger
//! that held does not fire them once more (a plan that ended or was cancelled before
//! the restart does not come back).

mod keeper;
mod pending;
mod restore;
mod store;
#[cfg(test)]
mod tests;

use std::path::PathBuf;
use std::time::Duration;

pub(crate) use keeper::Keeper;
pub use restore::Restored;
pub(crate) use restore::{reinstate, restore};
pub use store::{FILE, Saved, SavedPacket, Store};

/// How much a commit waits for the disk ([`redb::Durability`]).
#[non_exhaustive]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Durability {
    /// Each commit returns once the disk holds it (`fsync`): a kill -9 or a power loss
    /// loses at most the changes since the last commit.
    #[default]
    Immediate,
    /// Each commit is handed to the operating system without waiting for the disk: a
    /// kill -9 loses the same as [`Immediate`](Durability::Immediate), a power loss may
    /// lose more (what the system had not yet written).
    Eventual,
}

impl Durability {
    /// Its name in a config file.
    pub fn name(self) -> &'static str {
        match self {
            Durability::Immediate => "immediate",
            Durability::Eventual => "eventual",
        }
    }

    /// The durability of a config file's `durability = "..."`.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "immediate" => Some(Durability::Immediate),
            "eventual" => Some(Durability::Eventual),
            _ => None,
        }
    }
}

/// Where and how a node keeps its board.
#[derive(Clone, Debug, PartialEq)]
pub struct StateConfig {
    /// The directory of the store (created if missing); the database is [`FILE`] in it.
    pub dir: PathBuf,
    /// Commit the changes waiting at least this often: the most a kill -9 can lose.
    pub commit_every: Duration,
    /// Commit as soon as this many changes wait, whatever the time.
    pub commit_changes: usize,
    /// Change items (packets written, objects created or deleted) that may wait for the
    /// keeper before writers drop the changes that would go past it (the keeper then
    /// saves the whole board again).
    pub queue: usize,
    /// How much each commit waits for the disk.
    pub durability: Durability,
}

impl StateConfig {
    /// Keeps the board in `dir` with the defaults: a commit every 100 ms or every 4096
    /// changes, each waiting for the disk, a queue of 65 536 change items.
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        StateConfig {
            dir: dir.into(),
            commit_every: Duration::from_millis(100),
            commit_changes: 4096,
            queue: 1 << 16,
            durability: Durability::Immediate,
        }
    }
}

/// Why a node's state cannot be opened, read or kept. Each names the directory, and
/// what to do.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum StateError {
    /// The directory cannot be created or the database opened (permissions, a file
    /// where the directory should be, another node using it).
    #[error(
        "cannot open the state directory {}: {why} (check that it is a writable directory no other node uses, or start with --reset-state to move its store aside and begin with an empty board)",
        dir.display()
    )]
    Open {
        /// The directory.
        dir: PathBuf,
        /// Why.
        why: String,
    },
    /// The database is damaged or is not a slate store.
    #[error(
        "the state in {} is unreadable: {why} (move {} aside, or start with --reset-state to move it aside and begin with an empty board)",
        dir.display(), dir.join(FILE).display()
    )]
    Corrupt {
        /// The directory.
        dir: PathBuf,
        /// What is wrong.
        why: String,
    },
    /// The store holds another module's board.
    #[error(
        "the state in {} is the board of {stored}, not of {node} (give each module its own state directory)",
        dir.display()
    )]
    OtherModule {
        /// The directory.
        dir: PathBuf,
        /// The module whose board it holds.
        stored: String,
        /// The module starting.
        node: String,
    },
    /// A commit failed (a full disk, a removed drive): the store stops; the node goes on.
    #[error("cannot write the state in {}: {why}", dir.display())]
    Write {
        /// The directory.
        dir: PathBuf,
        /// Why.
        why: String,
    },
    /// The board refused the keeper's watch.
    #[error("cannot watch the board: {0}")]
    Watch(#[from] slate_model::LookupError),
    /// The keeper thread could not be started.
    #[error("cannot start the state keeper thread: {0}")]
    Thread(std::io::Error),
}

/// What the keeper has done so far.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct StateStats {
    /// The store holds every change the board committed up to this revision.
    pub revision: u64,
    /// Commits made.
    pub commits: u64,
    /// Packets written to the store (after folding: one per attribute per commit).
    pub packets: u64,
    /// Times the keeper fell a whole queue behind and saved the whole board again.
    pub resyncs: u64,
    /// Why the keeper stopped before it was told to, if it did.
    pub failed: Option<String>,
}

/// Moves a state directory's store aside (`slate node --reset-state`): the node then
/// starts with an empty board. Returns where it went (`None`: there was no store).
pub fn reset(dir: &std::path::Path) -> std::io::Result<Option<PathBuf>> {
    let file = dir.join(FILE);
    if !file.exists() {
        return Ok(None);
    }
    let stamp = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let aside = dir.join(format!("{FILE}.{stamp}.old"));
    std::fs::rename(&file, &aside)?;
    Ok(Some(aside))
}
