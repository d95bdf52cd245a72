//! The changes waiting for the next commit, folded: the latest packet of each attribute,
//! the last word on each object, and the classes when they changed.

use std::collections::{BTreeSet, HashMap, HashSet};
use std::sync::Arc;

use slate_model::{
    Address, Board, ChangeItem, ClassDef, Context, MODULE_CLASS, PLAN_CLASS, Packet,
};

/// An object as the store keeps it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ObjectRecord {
    pub class: Arc<str>,
    pub context: Context,
    pub owner: Address,
}

/// What the next commit writes.
#[derive(Debug, Default)]
pub(crate) struct Pending {
    /// Replace everything the store holds (a full save from a snapshot).
    pub wipe: bool,
    /// Every class definition, when they changed since the last commit.
    pub classes: Option<Vec<ClassDef>>,
    /// Objects created (or found by a full save).
    pub objects: HashMap<Arc<str>, ObjectRecord>,
    /// Objects deleted: their record and packets go before the commit writes the rest.
    pub deleted: BTreeSet<Arc<str>>,
    /// The latest packet of each `(object, attribute)`.
    pub packets: HashMap<(Arc<str>, Arc<str>), Packet>,
    /// The plans received that the node runs, when they changed since the last commit
    /// (they replace those the store holds).
    pub plans: Option<Vec<slate_ici::HeldPlan>>,
    /// Changes folded in (a full save counts as one).
    pub changes: usize,
    /// The board's revision up to which every change is folded in.
    pub revision: u64,
}

/// Is an object of `class` left out of the store? Liveliness (`Module`) is the ICI's to
/// find out again; `Plan` objects belong to plans, which come back from the files or,
/// for plans received, from the store's plans table (with where each was).
pub(crate) fn transient(class: &str) -> bool {
    class == MODULE_CLASS || class == PLAN_CLASS
}

impl Pending {
    /// Is there nothing to commit?
    pub fn is_empty(&self) -> bool {
        self.changes == 0 && self.classes.is_none() && self.plans.is_none()
    }

    /// The whole board from one snapshot, to replace what the store holds; the
    /// snapshot's revision. The objects left out are added to `skipped`.
    pub fn full(board: &Board, skipped: &mut HashSet<Arc<str>>) -> (Pending, u64) {
        let mut p = Pending {
            wipe: true,
            classes: Some(board.class_defs()),
            changes: 1,
            ..Pending::default()
        };
        let snap = board.snapshot();
        for id in snap.objects() {
            let Some(info) = snap.info(id) else { continue };
            if !info.is_class && transient(&info.class) {
                skipped.insert(info.name);
                continue;
            }
            for (attr, packet, _) in snap.own_values(id) {
                p.packets.insert((info.name.clone(), attr), packet);
            }
            if !info.is_class {
                p.objects
                    .insert(info.name, record(info.class, info.context, info.owner));
            }
        }
        p.revision = snap.revision();
        let revision = p.revision;
        (p, revision)
    }

    /// Folds in one item of the change committed at `revision` (items come in revision
    /// order); objects are looked up on `board` for their context and owner (one deleted
    /// since is dropped: its deletion follows).
    pub fn fold(
        &mut self,
        board: &Board,
        revision: u64,
        item: ChangeItem,
        skipped: &mut HashSet<Arc<str>>,
    ) {
        if revision > self.revision {
            self.changes += 1;
            self.revision = revision;
        }
        match item {
            ChangeItem::Write {
                object,
                attr,
                packet,
            } if !skipped.contains(&object) => {
                self.packets.insert((object, attr), packet);
            }
            ChangeItem::Write { .. } => {}
            ChangeItem::Create { object, class } => {
                self.created(board, object, class, skipped);
            }
            ChangeItem::Delete { object, .. } => self.removed(object, skipped),
        }
    }

    fn created(
        &mut self,
        board: &Board,
        object: Arc<str>,
        class: Arc<str>,
        skipped: &mut HashSet<Arc<str>>,
    ) {
        if transient(&class) {
            skipped.insert(object);
            return;
        }
        if let Some(info) = board.info(&object).filter(|i| i.class == class) {
            let r = record(info.class, info.context, info.owner);
            self.objects.insert(object, r);
        }
    }

    fn removed(&mut self, object: Arc<str>, skipped: &mut HashSet<Arc<str>>) {
        if skipped.remove(&object) {
            return;
        }
        self.objects.remove(&object);
        self.packets.retain(|(o, _), _| *o != object);
        self.deleted.insert(object);
    }
}

fn record(class: Arc<str>, context: Context, owner: Address) -> ObjectRecord {
    ObjectRecord {
        class,
        context,
        owner,
    }
}
