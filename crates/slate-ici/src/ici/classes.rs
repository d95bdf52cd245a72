//! Class sets (what a board models, what may leave a robot) and the catalog of class
//! definitions the ICI encodes and matches with.

use std::sync::Arc;

use slate_model::{AttrDecl, Board, ClassTree, Context, THING};
use slate_wire::Schema;

/// Bit of a context in a context mask.
pub(crate) fn context_bit(c: Context) -> u8 {
    match c {
        Context::Self_ => 1,
        Context::Surroundings => 2,
        Context::System => 4,
    }
}

/// Every context.
pub(crate) const ALL_CONTEXTS: u8 = 7;

/// A set of classes, each in some contexts: what a board models (its *interest*), or
/// what may leave a robot on the team link (its *export policy*).
///
/// A class stands for itself and all its subclasses. Matching uses the context an
/// object has on the board in question.
///
/// ```
/// use slate_ici::ClassSet;
/// use slate_model::Context;
/// let interest = ClassSet::none()
///     .class("Vehicle")
///     .class_in("Obstacle", &[Context::Surroundings]);
/// assert!(!interest.is_empty());
/// assert!(ClassSet::all().is_all());
/// ```
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ClassSet {
    rules: Vec<(Arc<str>, u8)>,
}

impl ClassSet {
    /// No class at all.
    pub fn none() -> Self {
        ClassSet::default()
    }

    /// Every class (`Thing` and below) in every context.
    pub fn all() -> Self {
        ClassSet::none().class(THING)
    }

    /// Adds a class (and its subclasses) in every context.
    pub fn class(self, name: &str) -> Self {
        self.with(name, ALL_CONTEXTS)
    }

    /// Adds a class (and its subclasses) in the given contexts only.
    pub fn class_in(self, name: &str, contexts: &[Context]) -> Self {
        let mask = contexts.iter().fold(0, |m, c| m | context_bit(*c));
        self.with(name, mask)
    }

    pub(crate) fn with(mut self, name: &str, mask: u8) -> Self {
        if mask != 0 {
            self.rules.push((name.into(), mask & ALL_CONTEXTS));
        }
        self
    }

    /// Is the set empty?
    pub fn is_empty(&self) -> bool {
        self.rules.is_empty()
    }

    /// Does it hold every class in every context?
    pub fn is_all(&self) -> bool {
        self.rules
            .iter()
            .any(|(c, m)| &**c == THING && *m == ALL_CONTEXTS)
    }

    /// Does it hold everything `other` holds, rule by rule (a rule of `other` for a
    /// subclass of one of its classes counts as not held: the answer errs on "no")?
    pub(crate) fn covers(&self, other: &ClassSet) -> bool {
        self.is_all()
            || other.rules.iter().all(|(class, mask)| {
                let held = self.rules.iter().filter(|(c, _)| c == class);
                held.fold(0, |m, (_, h)| m | h) & mask == *mask
            })
    }

    /// The rules: class name and context mask (1 SELF, 2 SURROUNDINGS, 4 SYSTEM).
    pub(crate) fn rules(&self) -> &[(Arc<str>, u8)] {
        &self.rules
    }

    /// Does it hold an object whose class chain is `lineage` (class first), in `context`?
    pub fn contains(&self, lineage: &[Arc<str>], context: Context) -> bool {
        let bit = context_bit(context);
        self.rules
            .iter()
            .any(|(c, m)| m & bit != 0 && lineage.iter().any(|l| l == c))
    }

    /// Does a class-level value of the class with chain `lineage` matter to it: is the
    /// class in the set, or an ancestor of a class in it (whose instances inherit it)?
    pub(crate) fn relates_to_class(&self, lineage: &[Arc<str>], catalog: &Catalog) -> bool {
        let class = lineage.first();
        self.rules.iter().any(|(c, _)| {
            lineage.contains(c)
                || class.is_some_and(|k| catalog.lineage(c).is_some_and(|l| l.contains(k)))
        })
    }
}

// A class and its ancestors, class first, `Thing` last (computed once by the tree).
pub(crate) use slate_model::Lineage;

/// The class definitions of a board, as the ICI needs them: the wire schema and the
/// class tree. Rebuilt from the board when a class is missing.
pub(crate) struct Catalog {
    pub schema: Schema,
    /// Every class's chain (`Thing`'s too), by the tree's rules.
    tree: ClassTree,
}

impl Catalog {
    pub fn new(board: &Board) -> Self {
        Catalog::from_tree(board.class_tree())
    }

    #[cfg(test)]
    pub fn from_defs(defs: &[slate_model::ClassDef]) -> Self {
        Catalog::from_tree(ClassTree::new(defs))
    }

    fn from_tree(tree: ClassTree) -> Self {
        Catalog {
            schema: Schema::from_tree(&tree),
            tree,
        }
    }

    /// Does the catalog hold this class?
    pub fn knows(&self, class: &str) -> bool {
        self.tree.contains(class)
    }

    /// The class and its ancestors, up to `Thing`.
    pub fn lineage(&self, class: &str) -> Option<Lineage> {
        self.tree.lineage(class).cloned()
    }

    /// The declaration of `class.attr` (declared there or by an ancestor).
    pub fn decl(&self, class: &str, attr: &str) -> Option<&AttrDecl> {
        self.schema.attr(class, attr)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use slate_model::ClassDef;

    fn catalog() -> Catalog {
        Catalog::from_defs(&[
            ClassDef::new("Vehicle"),
            ClassDef::new("Gsr").parent("Vehicle"),
            ClassDef::new("Rock"),
        ])
    }

    fn chain(c: &Catalog, class: &str) -> Lineage {
        c.lineage(class).unwrap()
    }

    #[test]
    fn lineage_runs_up_to_thing() {
        let c = catalog();
        let gsr = chain(&c, "Gsr");
        let names: Vec<&str> = gsr.iter().map(|s| &**s).collect();
        assert_eq!(names, ["Gsr", "Vehicle", "Thing"]);
        assert_eq!(chain(&c, THING).len(), 1);
        assert!(c.lineage("Nope").is_none());
    }

    #[test]
    fn a_class_set_holds_subclasses_in_its_contexts() {
        let c = catalog();
        let set = ClassSet::none().class_in("Vehicle", &[Context::System]);
        assert!(set.contains(&chain(&c, "Gsr"), Context::System));
        assert!(!set.contains(&chain(&c, "Gsr"), Context::Self_));
        assert!(!set.contains(&chain(&c, "Rock"), Context::System));
        assert!(ClassSet::all().contains(&chain(&c, "Rock"), Context::Self_));
        assert!(!ClassSet::none().contains(&chain(&c, "Rock"), Context::Self_));
    }

    #[test]
    fn class_level_values_matter_to_subclass_sets_and_ancestor_sets() {
        let c = catalog();
        let gsr_only = ClassSet::none().class("Gsr");
        assert!(gsr_only.relates_to_class(&chain(&c, "Vehicle"), &c));
        assert!(gsr_only.relates_to_class(&chain(&c, "Gsr"), &c));
        assert!(!gsr_only.relates_to_class(&chain(&c, "Rock"), &c));
        assert!(
            ClassSet::none()
                .class("Vehicle")
                .relates_to_class(&chain(&c, "Gsr"), &c)
        );
    }

    #[test]
    fn a_class_set_matches_through_a_chain_deeper_than_256() {
        let defs: Vec<ClassDef> = (1..300)
            .map(|i| ClassDef::new(&format!("C{i}")).parent(&format!("C{}", i - 1)))
            .chain([ClassDef::new("C0")])
            .collect();
        let c = Catalog::from_defs(&defs);
        assert_eq!(c.lineage("C299").map(|l| l.len()), Some(301));
        let set = ClassSet::none().class("C0");
        assert!(set.contains(&chain(&c, "C299"), Context::Self_));
    }
}
