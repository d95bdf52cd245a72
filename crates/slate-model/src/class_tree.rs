//! The class tree as a value: class definitions by name with each class's lineage, the
//! one place outside the board that walks parent links.

use std::sync::Arc;

use rustc_hash::FxHashMap;

use crate::{AttrDecl, ClassDef, THING};

/// A class and its ancestors, class first, [`THING`] last (shared: a tree computes each
/// chain once and hands out clones of it).
pub type Lineage = Arc<[Arc<str>]>;

/// A set of class definitions with the chain of every class computed once.
///
/// The rules every user of the class tree follows (the board, the wire schema, the ICI,
/// the checker, the inspection tools):
///
/// - **Lineage** ([`ClassTree::lineage`]): the class, its parent, the parent's parent and
///   so on, then [`THING`]. `Thing` is always in the tree and its lineage is `[Thing]`.
/// - **Cycles and unknown parents**: the chain stops before a parent it already holds (a
///   cycle) or one the tree does not hold, and `Thing` still ends it. A board refuses
///   both, so a tree built from a board never meets them; a tree built from arbitrary
///   definitions stays finite.
/// - **Depth**: not cut. A chain holds each class at most once, so it is never longer
///   than the tree is large, and a tree built from a board agrees with the board at any
///   depth.
/// - **Declarations** ([`ClassTree::declarations`]): root first, each class's in the
///   order it declares them; where a class redeclares an inherited attribute the
///   ancestor's declaration holds (a board refuses the redeclaration).
///
/// ```
/// use slate_model::{AttrDecl, ClassDef, ClassTree, ValueType};
///
/// let tree = ClassTree::new(&[
///     ClassDef::new("Vehicle").attr(AttrDecl::new("speed", ValueType::Real)),
///     ClassDef::new("Gsr").parent("Vehicle").attr(AttrDecl::new("mode", ValueType::Str)),
/// ]);
/// let chain: Vec<&str> = tree.lineage("Gsr").unwrap().iter().map(|c| &**c).collect();
/// assert_eq!(chain, ["Gsr", "Vehicle", "Thing"]);
/// let attrs: Vec<&str> = tree.declarations("Gsr").map(|(_, a)| a.name.as_str()).collect();
/// assert_eq!(attrs, ["speed", "mode"]);
/// assert_eq!(tree.decl("Gsr", "speed").map(|d| d.ty), Some(ValueType::Real));
/// ```
#[derive(Clone, Debug)]
pub struct ClassTree {
    classes: FxHashMap<Arc<str>, Entry>,
}

/// One class: its definition and its chain.
#[derive(Clone, Debug)]
struct Entry {
    def: ClassDef,
    lineage: Lineage,
}

impl Default for ClassTree {
    /// A tree holding only `Thing`.
    fn default() -> Self {
        let mut classes = FxHashMap::default();
        classes.insert(THING.into(), root_entry());
        ClassTree { classes }
    }
}

impl ClassTree {
    /// A tree of these definitions (and `Thing`). Where two definitions share a name the
    /// later one holds; a definition named `Thing` is ignored (the root is fixed).
    pub fn new(defs: &[ClassDef]) -> Self {
        let mut tree = ClassTree::default();
        for def in defs.iter().filter(|d| d.name != THING) {
            tree.put(def.clone());
        }
        tree.relink();
        tree
    }

    /// Adds a definition, or replaces the one of the same name; every chain it changes
    /// is recomputed. A definition named `Thing` is ignored.
    pub fn insert(&mut self, def: ClassDef) {
        if def.name == THING {
            return;
        }
        let extends_leaf = self.is_new_leaf(&def);
        let name = def.name.clone();
        self.put(def);
        if extends_leaf {
            self.link(&name);
        } else {
            self.relink();
        }
    }

    /// Does the tree hold this class? (`Thing` always.)
    pub fn contains(&self, class: &str) -> bool {
        self.classes.contains_key(class)
    }

    /// The definition of a class (`Thing`'s has an empty parent).
    pub fn def(&self, class: &str) -> Option<&ClassDef> {
        self.classes.get(class).map(|e| &e.def)
    }

    /// Every definition except `Thing`'s, by name.
    pub fn defs(&self) -> impl Iterator<Item = &ClassDef> {
        let mut defs: Vec<&ClassDef> = self
            .classes
            .values()
            .map(|e| &e.def)
            .filter(|d| d.name != THING)
            .collect();
        defs.sort_unstable_by(|a, b| a.name.cmp(&b.name));
        defs.into_iter()
    }

    /// Number of classes, `Thing` included.
    pub fn len(&self) -> usize {
        self.classes.len()
    }

    /// Is the tree empty? (Never: `Thing` is always there.)
    pub fn is_empty(&self) -> bool {
        self.classes.is_empty()
    }

    /// The class and its ancestors, class first, `Thing` last; `None` for a class the
    /// tree does not hold.
    pub fn lineage(&self, class: &str) -> Option<&Lineage> {
        self.classes.get(class).map(|e| &e.lineage)
    }

    /// Is `class` the class `ancestor` or one of its descendants?
    pub fn is_a(&self, class: &str, ancestor: &str) -> bool {
        self.lineage(class)
            .is_some_and(|l| l.iter().any(|c| &**c == ancestor))
    }

    /// Every attribute declaration an instance of `class` has, with the class declaring
    /// it: root first, each class's in its order, an inherited declaration winning over a
    /// redeclaration. Empty for a class the tree does not hold.
    pub fn declarations<'a>(
        &'a self,
        class: &str,
    ) -> impl Iterator<Item = (&'a ClassDef, &'a AttrDecl)> + 'a {
        let chain: Vec<&ClassDef> = self
            .lineage(class)
            .into_iter()
            .flat_map(|l| l.iter().rev())
            .filter_map(|c| self.def(c))
            .collect();
        let mut seen: Vec<&str> = Vec::new();
        chain
            .into_iter()
            .flat_map(|d| d.attrs.iter().map(move |a| (d, a)))
            .filter(move |(_, a)| {
                let first = !seen.contains(&a.name.as_str());
                seen.push(&a.name);
                first
            })
    }

    /// The declaration of `attr` an instance of `class` (or the class itself) has.
    pub fn decl(&self, class: &str, attr: &str) -> Option<&AttrDecl> {
        self.lineage(class)?
            .iter()
            .rev()
            .filter_map(|c| self.def(c))
            .find_map(|d| d.attrs.iter().find(|a| a.name == attr))
    }

    /// Stores a definition without computing its chain.
    fn put(&mut self, def: ClassDef) {
        let entry = Entry {
            lineage: Arc::from([]),
            def,
        };
        self.classes.insert(entry.def.name.as_str().into(), entry);
    }

    /// Is `def` a class the tree lacks, below a parent whose chain is final, and named as
    /// a parent by nobody? Then only its own chain needs computing.
    fn is_new_leaf(&self, def: &ClassDef) -> bool {
        !self.classes.contains_key(def.name.as_str())
            && self.classes.contains_key(def.parent.as_str())
            && self.classes.values().all(|e| e.def.parent != def.name)
    }

    /// Recomputes every chain.
    fn relink(&mut self) {
        let names: Vec<Arc<str>> = self.classes.keys().cloned().collect();
        for name in names {
            self.link(&name);
        }
    }

    /// Computes the chain of one class from the parent links (the rules in the type's doc).
    fn link(&mut self, class: &str) {
        let lineage = self.walk(class);
        if let Some(e) = self.classes.get_mut(class) {
            e.lineage = lineage;
        }
    }

    /// Follows parent links from `class`, stopping at `Thing`, a cycle or an unknown
    /// parent; `Thing` ends the chain.
    fn walk(&self, class: &str) -> Lineage {
        let mut chain: Vec<Arc<str>> = Vec::new();
        let mut at = self.classes.get_key_value(class);
        while let Some((name, entry)) = at.filter(|(n, _)| &***n != THING) {
            if chain.contains(name) {
                break;
            }
            chain.push(name.clone());
            at = self.classes.get_key_value(entry.def.parent.as_str());
        }
        chain.push(THING.into());
        chain.into()
    }
}

/// `Thing`: no parent, no declarations, its own chain.
fn root_entry() -> Entry {
    Entry {
        def: ClassDef {
            name: THING.to_owned(),
            parent: String::new(),
            attrs: Vec::new(),
        },
        lineage: Arc::from([Arc::from(THING)]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ValueType;

    fn names(tree: &ClassTree, class: &str) -> Vec<String> {
        tree.lineage(class)
            .map(|l| l.iter().map(|c| c.to_string()).collect())
            .unwrap_or_default()
    }

    fn vehicles() -> ClassTree {
        ClassTree::new(&[
            ClassDef::new("Gsr")
                .parent("Vehicle")
                .attr(AttrDecl::new("mode", ValueType::Str)),
            ClassDef::new("Vehicle").attr(AttrDecl::new("speed", ValueType::Real)),
        ])
    }

    #[test]
    fn lineage_runs_from_the_class_to_thing_whatever_the_definition_order() {
        let tree = vehicles();
        assert_eq!(names(&tree, "Gsr"), ["Gsr", "Vehicle", "Thing"]);
        assert_eq!(names(&tree, THING), ["Thing"]);
        assert!(tree.lineage("Nope").is_none());
        assert_eq!(tree.len(), 3);
    }

    #[test]
    fn cycles_and_unknown_parents_cut_the_chain_and_thing_ends_it() {
        let tree = ClassTree::new(&[
            ClassDef::new("A").parent("B"),
            ClassDef::new("B").parent("A"),
            ClassDef::new("C").parent("Missing"),
        ]);
        assert_eq!(names(&tree, "A"), ["A", "B", "Thing"]);
        assert_eq!(names(&tree, "B"), ["B", "A", "Thing"]);
        assert_eq!(names(&tree, "C"), ["C", "Thing"]);
    }

    #[test]
    fn deep_chains_are_not_cut() {
        let defs: Vec<ClassDef> = (1..300)
            .map(|i| ClassDef::new(&format!("C{i}")).parent(&format!("C{}", i - 1)))
            .chain([ClassDef::new("C0")])
            .collect();
        let tree = ClassTree::new(&defs);
        assert_eq!(tree.lineage("C299").map(|l| l.len()), Some(301));
    }

    #[test]
    fn declarations_come_root_first_and_an_inherited_one_wins() {
        let tree = ClassTree::new(&[
            ClassDef::new("Vehicle").attr(AttrDecl::new("speed", ValueType::Real)),
            ClassDef::new("Gsr")
                .parent("Vehicle")
                .attr(AttrDecl::new("mode", ValueType::Str))
                .attr(AttrDecl::new("speed", ValueType::Int)),
        ]);
        let got: Vec<(&str, &str)> = tree
            .declarations("Gsr")
            .map(|(c, a)| (c.name.as_str(), a.name.as_str()))
            .collect();
        assert_eq!(got, [("Vehicle", "speed"), ("Gsr", "mode")]);
        assert_eq!(
            tree.decl("Gsr", "speed").map(|d| d.ty),
            Some(ValueType::Real)
        );
        assert!(tree.decl("Vehicle", "mode").is_none());
    }

    #[test]
    fn inserting_a_missing_parent_relinks_its_children() {
        let mut tree = ClassTree::new(&[ClassDef::new("Gsr").parent("Vehicle")]);
        assert_eq!(names(&tree, "Gsr"), ["Gsr", "Thing"]);
        tree.insert(ClassDef::new("Vehicle"));
        assert_eq!(names(&tree, "Gsr"), ["Gsr", "Vehicle", "Thing"]);
        tree.insert(ClassDef::new("Rover").parent("Gsr"));
        assert_eq!(names(&tree, "Rover"), ["Rover", "Gsr", "Vehicle", "Thing"]);
    }

    #[test]
    fn thing_is_fixed_and_classes_list_by_name() {
        let tree = ClassTree::new(&[
            ClassDef::new(THING).parent("Rock"),
            ClassDef::new("Rock"),
            ClassDef::new("Gsr"),
        ]);
        assert_eq!(names(&tree, THING), ["Thing"]);
        let listed: Vec<&str> = tree.defs().map(|d| d.name.as_str()).collect();
        assert_eq!(listed, ["Gsr", "Rock"]);
        assert!(tree.is_a("Rock", THING) && !tree.is_a("Rock", "Gsr"));
    }
}
