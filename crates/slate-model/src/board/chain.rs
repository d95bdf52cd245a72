//! The chain of active functions an access runs inside, to cut cycles and deep chains.
//!
//! An access made through a function's `Call` (or its token) carries the chain. An access
//! made any other way from inside a running function (a closure or a Python callable that
//! captured the board and calls `board.read`) belongs to the same chain too: each thread
//! keeps the chains of the functions running in it, so recursion through the board is cut
//! like recursion through the `Call`, and never overflows the stack.

use std::borrow::Cow;
use std::cell::RefCell;
use std::sync::Arc;

use super::MAX_NESTED_FUNCTIONS;
use crate::{ChainError, Key, Trigger};

/// One access whose active functions are running: key, trigger, object and attribute.
type Step = (Key, Trigger, Arc<str>, Arc<str>);

/// The accesses (key and trigger) whose active functions are running, outermost first.
/// Shared: a chain is cloned for every function it runs (the thread's record of running
/// chains, tokens), and only extended by [`Chain::with`]; the empty chain of every access
/// outside a function allocates nothing.
#[derive(Clone, Debug, Default)]
pub(crate) struct Chain {
    steps: Option<Arc<[Step]>>,
}

impl Chain {
    /// May an access to `key` with `trigger` run inside this chain? Not if it closes a
    /// cycle, goes deeper than `limit`, or this thread already runs
    /// [`MAX_NESTED_FUNCTIONS`] functions (of any boards) inside one another. An access
    /// outside any active function always may.
    pub fn admit(
        &self,
        key: Key,
        trigger: Trigger,
        limit: usize,
        names: impl FnOnce() -> (Arc<str>, Arc<str>),
    ) -> Result<(), ChainError> {
        let nested = nested_in_this_thread();
        if self.steps().is_empty() && nested < MAX_NESTED_FUNCTIONS {
            return Ok(());
        }
        let (object, attr) = names();
        if nested >= MAX_NESTED_FUNCTIONS {
            return Err(ChainError::DepthLimit {
                limit: MAX_NESTED_FUNCTIONS,
                object: object.to_string(),
                attr: attr.to_string(),
            });
        }
        if let Some(start) = self
            .steps()
            .iter()
            .position(|(k, t, ..)| *k == key && *t == trigger)
        {
            let mut path: Vec<String> = self.steps()[start..]
                .iter()
                .map(|(_, _, o, a)| format!("{o}.{a}"))
                .collect();
            path.push(format!("{object}.{attr}"));
            return Err(ChainError::Cycle { path });
        }
        if self.steps().len() > limit {
            return Err(ChainError::DepthLimit {
                limit,
                object: object.to_string(),
                attr: attr.to_string(),
            });
        }
        Ok(())
    }

    /// This chain with one more step.
    pub fn with(&self, key: Key, trigger: Trigger, object: &Arc<str>, attr: &Arc<str>) -> Chain {
        let mut steps = Vec::with_capacity(self.steps().len() + 1);
        steps.extend(self.steps().iter().cloned());
        steps.push((key, trigger, object.clone(), attr.clone()));
        Chain {
            steps: Some(steps.into()),
        }
    }

    /// The steps, outermost first.
    fn steps(&self) -> &[Step] {
        self.steps.as_deref().unwrap_or_default()
    }
}

thread_local! {
    /// The chains of the active functions running in this thread, innermost last, each
    /// with the identity of its board (see [`Running`]).
    static RUNNING: RefCell<Vec<(u64, Chain)>> = const { RefCell::new(Vec::new()) };
}

impl Chain {
    /// The chain an access to `board` from this thread belongs to: this one if it is not
    /// empty (the access came through a `Call`), else the chain of the innermost active
    /// function of `board` running in this thread, else none.
    pub fn or_running(&self, board: u64) -> Cow<'_, Chain> {
        if !self.steps().is_empty() {
            return Cow::Borrowed(self);
        }
        RUNNING.with_borrow(|running| {
            running
                .iter()
                .rev()
                .find(|(b, _)| *b == board)
                .map_or(Cow::Borrowed(self), |(_, chain)| Cow::Owned(chain.clone()))
        })
    }
}

/// How many active functions (of any board) this thread is running inside one another.
fn nested_in_this_thread() -> usize {
    RUNNING.with_borrow(|running| {
        running
            .iter()
            .filter(|(_, chain)| !chain.steps().is_empty())
            .count()
    })
}

/// While it lives, accesses to one board from this thread that carry no chain belong to
/// `chain`: entered around each active function (its chain) and around change hooks (no
/// chain: a hook's accesses start chains of their own).
pub(crate) struct Running(());

impl Running {
    /// Enters `chain` for `board` in this thread.
    pub fn enter(board: u64, chain: &Chain) -> Running {
        RUNNING.with_borrow_mut(|running| running.push((board, chain.clone())));
        Running(())
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        RUNNING.with_borrow_mut(|running| running.pop());
    }
}
