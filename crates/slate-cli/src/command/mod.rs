//! One file per verb; `live.rs` holds what the live verbs share (joining the team as an
//! observer, Ctrl-C, printing packets).

pub mod bench;
pub mod check;
pub mod demo;
pub mod get;
pub mod hz;
pub mod keys;
pub mod launch;
mod live;
pub mod ls;
pub mod node;
pub mod plan;
pub mod plan_test;
pub mod play;
pub mod put;
pub mod record;
pub mod stats;
pub mod tree;
pub mod watch;

/// An error that exits with code 1: the request was understood, but what it names does
/// not exist or was refused (an unknown object, a rejected plan). Other errors exit 2.
#[derive(Debug)]
pub struct Failed(pub String);

impl std::fmt::Display for Failed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Failed {}

/// Returns a [`Failed`] error.
pub fn failed<T>(message: impl Into<String>) -> anyhow::Result<T> {
    Err(Failed(message.into()).into())
}
