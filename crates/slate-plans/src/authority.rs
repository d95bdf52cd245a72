//! The authority a received plan runs with: that of the module that sent it (its
//! origin). A plan this board loaded itself writes as this module does; a received one
//! may write only what this board would take from its origin: not an `owned` attribute
//! of an object its origin does not own, nor what the board's `[authority] writes` do
//! not let its origin write, nor delete an object holding such values or of a class its
//! origin may not create, though the module running it may (docs/security.md,
//! *Authority over plans*). Judged when an action's effects are applied, so a target
//! chosen at run time (`any o: ...`) is judged too: a refused write fails the whole
//! action, which then writes nothing.

use std::collections::HashMap;
use std::sync::Arc;

use parking_lot::Mutex;
use slate_model::{Address, Board, WriteError};

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

/// Why `plan`, running as `origin`, may not apply `effects` on `board`: the first
/// write the board would not take from `origin` ([`Board::write_refusal`]: an `owned`
/// attribute of an object `origin` does not own, or what the board's `[authority]
/// writes` do not let `origin` write), object of a class it may not create, or object
/// it may not delete ([`Board::delete_refusal`]).
pub(crate) fn refusal(
    board: &Board,
    plan: &str,
    origin: &Address,
    effects: &[Effect],
) -> Option<String> {
    effects.iter().find_map(|e| {
        let refused = match e {
            Effect::Write(object, attr, _, _) => board.write_refusal(object, attr, origin),
            Effect::Create(spec) => board.admit_write(&spec.class, &spec.name, None, origin, false),
            Effect::Delete(object) => board.delete_refusal(object, origin),
            _ => Ok(()),
        };
        let why = match refused.err()? {
            WriteError::NotOwner {
                object,
                attr,
                owner,
                writer,
            } => format!(
                "{writer} may not write {object}.{attr}, an owned attribute owned by {owner}"
            ),
            other => other.to_string(),
        };
        let deleting = match e {
            Effect::Delete(object) => format!("deleting {object}, "),
            _ => String::new(),
        };
        Some(format!(
            "plan {plan} runs with the authority of {origin}: {deleting}{why}"
        ))
    })
}
