//! The dependency index: from a committed change (object, class, attribute handles) to the
//! plans whose conditions read it, without looking at any other plan.

use std::sync::Arc;

use rustc_hash::FxHashMap;
use slate_model::{AttrId, Board, ObjectId, TouchKind, Touched};

use crate::engine::Dep;

/// Plans by what they read. Keys are board handles, resolved once at installation (and
/// again when a named object is created).
#[derive(Default)]
pub(crate) struct DepIndex {
    /// `gsr.speed`: live named objects.
    by_object: FxHashMap<(ObjectId, AttrId), Vec<usize>>,
    /// Named objects' dependencies, to resolve when an object of that name appears.
    named: FxHashMap<Arc<str>, Vec<(AttrId, usize)>>,
    /// Live named objects: handle to name.
    ids: FxHashMap<ObjectId, Arc<str>>,
    /// Plans reading an attribute of any named object (a class-level write may change it).
    any_named: FxHashMap<AttrId, Vec<usize>>,
    /// `o.range` in a quantifier over a class.
    by_class: FxHashMap<(ObjectId, AttrId), Vec<usize>>,
    /// An attribute read through a reference.
    by_attr: FxHashMap<AttrId, Vec<usize>>,
    /// Instances of a class appearing or disappearing.
    members: FxHashMap<ObjectId, Vec<usize>>,
    /// Class handle to its lineage (itself first).
    lineages: FxHashMap<ObjectId, Arc<[ObjectId]>>,
}

fn push(list: &mut Vec<usize>, plan: usize) {
    if list.last() != Some(&plan) {
        list.push(plan);
    }
}

impl DepIndex {
    /// Adds one dependency of `plan`. Names the board does not know (yet) are skipped,
    /// except object names, which are resolved when the object is created.
    pub fn add(&mut self, plan: usize, dep: &Dep, board: &Board) {
        let class = |c: &str| board.info(c).filter(|i| i.is_class).map(|i| i.id);
        match dep {
            Dep::Object(o, a) => {
                let Some(attr) = board.attr_id(a) else { return };
                self.named.entry(o.clone()).or_default().push((attr, plan));
                push(self.any_named.entry(attr).or_default(), plan);
                if let Some(info) = board.info(o) {
                    self.ids.insert(info.id, o.clone());
                    push(self.by_object.entry((info.id, attr)).or_default(), plan);
                }
            }
            Dep::Class(c, a) => {
                if let (Some(c), Some(a)) = (class(c), board.attr_id(a)) {
                    push(self.by_class.entry((c, a)).or_default(), plan);
                }
            }
            Dep::Attr(a) => {
                if let Some(a) = board.attr_id(a) {
                    push(self.by_attr.entry(a).or_default(), plan);
                }
            }
            Dep::Members(c) => {
                if let Some(c) = class(c) {
                    push(self.members.entry(c).or_default(), plan);
                }
            }
        }
    }

    /// Calls `f` with every plan a change may concern (possibly more than once).
    pub fn touched(&mut self, t: &Touched, board: &Board, f: &mut dyn FnMut(usize)) {
        let lineage = self.lineage(t.class, board);
        match (t.kind, t.attr) {
            (TouchKind::Write, Some(attr)) => self.written(t, attr, &lineage, f),
            (TouchKind::Create, _) => {
                self.members_changed(&lineage, f);
                if let Some(name) = board
                    .name_of(t.object)
                    .filter(|n| self.named.contains_key(n))
                {
                    self.appeared(t.object, name, f);
                }
            }
            (TouchKind::Delete, _) => {
                self.members_changed(&lineage, f);
                if let Some(name) = self.ids.remove(&t.object) {
                    self.disappeared(t.object, &name, f);
                }
            }
            (TouchKind::Write, None) => {}
        }
    }

    fn written(&self, t: &Touched, attr: AttrId, lineage: &[ObjectId], f: &mut dyn FnMut(usize)) {
        let mut each = |list: Option<&Vec<usize>>| list.into_iter().flatten().for_each(|p| f(*p));
        each(self.by_object.get(&(t.object, attr)));
        if t.object == t.class {
            // A class-level write changes what instances without their own value read.
            each(self.any_named.get(&attr));
        }
        for class in lineage {
            each(self.by_class.get(&(*class, attr)));
        }
        each(self.by_attr.get(&attr));
    }

    fn members_changed(&self, lineage: &[ObjectId], f: &mut dyn FnMut(usize)) {
        for class in lineage {
            self.members
                .get(class)
                .into_iter()
                .flatten()
                .for_each(|p| f(*p));
        }
    }

    fn appeared(&mut self, id: ObjectId, name: Arc<str>, f: &mut dyn FnMut(usize)) {
        for (attr, plan) in self.named.get(&name).into_iter().flatten() {
            push(self.by_object.entry((id, *attr)).or_default(), *plan);
            f(*plan);
        }
        self.ids.insert(id, name);
    }

    fn disappeared(&mut self, id: ObjectId, name: &str, f: &mut dyn FnMut(usize)) {
        for (attr, plan) in self.named.get(name).into_iter().flatten() {
            self.by_object.remove(&(id, *attr));
            f(*plan);
        }
    }

    fn lineage(&mut self, class: ObjectId, board: &Board) -> Arc<[ObjectId]> {
        self.lineages
            .entry(class)
            .or_insert_with(|| board.lineage(class).into())
            .clone()
    }
}
