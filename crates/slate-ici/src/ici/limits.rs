//! Bounds per source and in total (docs/security.md, *Limits*): how many objects another
//! module may own on this board (`max_objects_per_source`), how many all others may
//! (`max_objects`), how many modules this ICI keeps track of (`max_modules`), and how
//! many names one module may make it hold (`max_names_per_source`, which the decoder
//! checks). Past
//! one, what arrives is refused, counted (`rejects.over_limit`) and reported as a board
//! event (which the board tells at most once a second per source), so that a hostile or
//! broken module, or a crowd of made-up addresses, cannot grow this node's memory
//! without bound.
//!
//! Objects are counted by the board where it creates and deletes them
//! (`Board::owned_count`), so every path that deletes (a sweep, a lifecycle frame, the
//! team protocol, a restart) frees room without knowing of the bounds.

use std::time::Duration;

use parking_lot::Mutex;
use slate_model::{Address, Board, NewObject};

use super::state::State;

impl State {
    /// Refuses `address` if this ICI does not know it yet and already keeps track of
    /// `max_modules` modules: counted, and an event (at most one a second).
    pub(crate) fn refuses_new_module(&mut self, address: &Address) -> bool {
        if self.peers.len() < self.config.max_modules || self.peers.contains_key(address) {
            return false;
        }
        self.stats.rejects.over_limit += 1;
        self.board
            .report_module_limit(address, self.config.max_modules);
        true
    }

    /// A message from `from` was refused: its names would take what this ICI holds of
    /// `from`'s past `max_names_per_source`. Counted, and an event (at most one a
    /// second per source).
    pub(crate) fn refuse_names(&mut self, from: &Address) {
        self.stats.rejects.over_limit += 1;
        self.board
            .report_name_limit(from, self.config.max_names_per_source);
    }
}

/// Refuses to create `spec` if its owner, another module, owns `max_objects_per_source`
/// objects on `board` already, or other modules own `max_objects` together: counted,
/// and an event (at most one a second per owner). This board's own objects are never
/// refused.
pub(crate) fn refuses_object(board: &Board, state: &Mutex<State>, spec: &NewObject) -> bool {
    let Some(owner) = spec.owner.as_ref().filter(|o| *o != board.address()) else {
        return false;
    };
    let owned = board.owned_count(owner);
    let (all, own) = board.object_counts();
    let mut st = state.lock();
    let (per_source, total) = (st.config.max_objects_per_source, st.config.max_objects);
    let bound = if owned >= per_source {
        (per_source, false)
    } else if all.saturating_sub(own) >= total {
        (total, true)
    } else {
        return false;
    };
    st.stats.rejects.over_limit += 1;
    drop(st);
    board.report_object_limit(owner, &spec.name, bound.0, bound.1);
    true
}

/// The catch-up answer bytes sent one requester and not yet paid off, paid off at
/// `max_answer_bytes_per_requester` a second: while any is owed, its requests wait. An
/// answer goes whole (a part of a current state would sweep what it left out), so the
/// debt may exceed a second's worth; over time the requester gets at most that rate, plus
/// one answer.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct AnswerBytes {
    /// Bytes owed as of `at`.
    owed: u64,
    /// When `owed` was last brought up to date (ICI time).
    at: Duration,
}

impl AnswerBytes {
    /// Is anything still owed at `now`, paying off `rate` bytes a second?
    pub fn owes(&self, now: Duration, rate: u64) -> bool {
        self.owed_at(now, rate) > 0
    }

    /// Adds `bytes` sent at `now` to what is owed.
    pub fn charge(&mut self, bytes: usize, now: Duration, rate: u64) {
        self.owed = self.owed_at(now, rate).saturating_add(bytes as u64);
        self.at = now;
    }

    /// What is owed at `now`, after paying off since `at`.
    fn owed_at(&self, now: Duration, rate: u64) -> u64 {
        let paid = now.saturating_sub(self.at).as_secs_f64() * rate as f64;
        self.owed.saturating_sub(paid as u64)
    }
}
