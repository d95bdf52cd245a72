//! The authority a received plan runs with: that of the module that sent it (its
//! origin). A plan this board loaded itself writes as this module does; a received one
//! may not write an `owned` attribute of an object its origin does not own, though the
//! module running it may (docs/security.md, *Authority over plans*). Judged when an
//! action's effects are applied, so a target chosen at run time (`any o: ...`) is judged
//! too: a refused write fails the whole action, which then writes nothing.

use std::collections::HashMap;
use std::sync::Arc;

use parking_lot::Mutex;
use slate_model::{Address, Board, MergePolicy};

use crate::action::Effect;

/// The origins of received plans, by plan name (only plans that run as another module
/// have one). One entry per plan on this board: plan names are unique on a board.
#[derive(Default)]
pub(crate) struct Origins(Mutex<HashMap<Arc<str>, Address>>);

impl Origins {
    /// The plan `plan`, when loaded, runs as `origin`.
    pub fn set(&self, plan: &str, origin: Address) {
        self.0.lock().insert(plan.into(), origin);
    }

    /// The plan runs as this module again (it was not loaded, or is gone).
    pub fn clear(&self, plan: &str) {
        self.0.lock().remove(plan);
    }

    /// The module `plan` runs as, if not this one.
    pub fn of(&self, plan: &str) -> Option<Address> {
        self.0.lock().get(plan).cloned()
    }
}

/// Why `plan`, running as `origin`, may not apply `effects` on `board`: the first write
/// of an `owned` attribute of an object `origin` does not own.
pub(crate) fn refusal(
    board: &Board,
    plan: &str,
    origin: &Address,
    effects: &[Effect],
) -> Option<String> {
    effects.iter().find_map(|e| match e {
        Effect::Write(object, attr, _, _) => owned_by_another(board, object, attr, origin).map(|owner| {
            format!(
                "plan {plan} runs with the authority of {origin}: {origin} may not write {object}.{attr}, an owned attribute owned by {owner}"
            )
        }),
        _ => None,
    })
}

/// The owner of `object`, if `attr` is `owned` there and `writer` is not its owner.
fn owned_by_another(board: &Board, object: &str, attr: &str, writer: &Address) -> Option<Address> {
    let info = board.info(object).filter(|i| !i.is_class)?;
    let decl = board.attr_decl(&info.class, attr)?;
    (decl.merge == MergePolicy::Owned && info.owner != *writer).then_some(info.owner)
}
