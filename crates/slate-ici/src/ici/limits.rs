//! Bounds per source and in total (docs/security.md, *Limits*): how many objects another
//! module may own on this board (`max_objects_per_source`), how many all others may
//! (`max_objects`), and how many modules this ICI keeps track of (`max_modules`). Past
//! one, what arrives is refused, counted (`rejects.over_limit`) and reported as a board
//! event (which the board tells at most once a second per source), so that a hostile or
//! broken module, or a crowd of made-up addresses, cannot grow this node's memory
//! without bound.
//!
//! Objects are counted by the board where it creates and deletes them
//! (`Board::owned_count`), so every path that deletes (a sweep, a lifecycle frame, the
//! team protocol, a restart) frees room without knowing of the bounds.

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
