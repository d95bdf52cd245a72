//! Putting a stored board back: classes defined (parents first), objects created where
//! the board lacks them, packets merged with their original stamps and sources.
//!
//! Plans other modules had sent are installed again once the node's plan circuits
//! exist ([`reinstate`]), after the board is back.
//!
//! The packets go through [`Board::merge_all`], so the board's merge rules hold: a
//! stored packet replaces an initial value from the node's files (stamped zero), and
//! loses to nothing the board wrote since it started. The merge also brings the board's
//! clock past every stored stamp, so the ICI's new incarnation begins after them.

use slate_ici::{HeldPlan, PlanCircuits};
use slate_model::{Board, ClassDef, THING};

use super::store::{Saved, SavedPacket};
use crate::record::{declared_type, value_of};

/// What a restore put back, and what the board refused.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Restored {
    /// Classes the store held.
    pub classes: usize,
    /// Objects created from the store (those the node's files had created are not).
    pub objects: usize,
    /// Packets the board took.
    pub packets: usize,
    /// Plans other modules had sent, installed again where they were (see
    /// [`PlanCircuits::reinstate`]).
    pub plans: usize,
    /// Entries the board refused: a class the files now define differently, a packet
    /// of an attribute no longer declared, stamped beyond the clock's tolerance, or
    /// older than what the board holds; a plan received that no longer loads or whose
    /// sender may no longer send plans here.
    pub refused: usize,
}

/// Applies what a store held to `board`.
pub(crate) fn restore(board: &Board, saved: Saved) -> Restored {
    let mut r = Restored {
        classes: saved.classes.len(),
        ..Restored::default()
    };
    r.refused += define_all(board, saved.classes);
    for spec in saved.objects {
        if board.info(&spec.name).is_some() {
            continue;
        }
        match board.create_with(spec) {
            Ok(_) => r.objects += 1,
            Err(_) => r.refused += 1,
        }
    }
    let (packets, untyped) = typed(board, saved.packets);
    r.refused += untyped;
    for outcome in board.merge_all(packets) {
        match outcome {
            Ok(slate_model::Merged::Applied(_)) => r.packets += 1,
            _ => r.refused += 1,
        }
    }
    r
}

/// Installs again the plans other modules had sent (once the node's circuits exist);
/// each refused is logged with its reason and counted in `r.refused`.
pub(crate) fn reinstate(circuits: &PlanCircuits, plans: Vec<HeldPlan>, r: &mut Restored) {
    for plan in plans {
        let (name, from) = (plan.name.clone(), plan.from.clone());
        match circuits.reinstate(plan) {
            Ok(()) => r.plans += 1,
            Err(why) => {
                tracing::warn!(plan = %name, %from, %why, "a plan kept in the state is not installed again");
                r.refused += 1;
            }
        }
    }
}

/// Defines each class once its parent is defined; the number refused.
fn define_all(board: &Board, mut defs: Vec<ClassDef>) -> usize {
    let mut refused = 0;
    loop {
        let before = defs.len();
        defs.retain(|def| {
            let ready = def.parent == THING || board.class_def(&def.parent).is_some();
            if ready && board.define(def.clone()).is_err() {
                refused += 1;
            }
            !ready
        });
        if defs.is_empty() || defs.len() == before {
            return refused + defs.len();
        }
    }
}

/// The packets with their values typed by the board's declarations; the number left
/// out (no such object or attribute, or a value of another type).
fn typed(
    board: &Board,
    packets: Vec<SavedPacket>,
) -> (Vec<(String, String, slate_model::Packet)>, usize) {
    let mut out = Vec::with_capacity(packets.len());
    let mut untyped = 0;
    for p in packets {
        let value = declared_type(board, &p.object, &p.attr).and_then(|ty| value_of(&p.value, ty));
        match value {
            Some(value) => out.push((p.object, p.attr, slate_model::Packet { value, ..p.packet })),
            None => untyped += 1,
        }
    }
    (out, untyped)
}
