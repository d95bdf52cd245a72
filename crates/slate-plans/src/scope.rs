//! What the checker knows about the world a file is loaded into: the classes (with their
//! flattened attributes) and the objects, from the board and from the file itself.

use std::collections::{HashMap, HashSet};

use slate_model::{AttrDecl, Board, ClassDef, ClassTree, THING, ValueType};

/// One attribute as the checker sees it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct AttrInfo {
    /// The class that declares it.
    pub class: String,
    /// Is it computed on read?
    pub derived: bool,
    /// The declaration, to check constant values against before anything is applied.
    pub decl: AttrDecl,
}

#[derive(Clone, Debug, Default)]
pub(crate) struct ClassInfo {
    /// Declared here or inherited.
    pub attrs: HashMap<String, AttrInfo>,
}

/// Classes and objects by name.
#[derive(Clone, Debug, Default)]
pub(crate) struct Scope {
    /// Every class's flattened attributes, computed from `tree`.
    pub classes: HashMap<String, ClassInfo>,
    /// Object name to class name.
    pub objects: HashMap<String, String>,
    /// The classes, by the board's rules for chains and inherited declarations.
    tree: ClassTree,
    /// Derived attributes, by declaring class and attribute name.
    derived: HashSet<(String, String)>,
}

impl Scope {
    /// The classes and objects a board holds now.
    pub fn from_board(board: &Board) -> Self {
        let mut scope = Scope {
            tree: board.class_tree(),
            ..Scope::default()
        };
        scope.refresh(THING);
        let snap = board.snapshot();
        for id in snap.objects() {
            if let Some(info) = snap.info(id).filter(|i| !i.is_class) {
                scope
                    .objects
                    .insert(info.name.to_string(), info.class.to_string());
            }
        }
        scope
    }

    /// Adds a class (its parent must be known); `derived` names its derived attributes.
    pub fn add_class(&mut self, def: &ClassDef, derived: &[String]) {
        for attr in derived {
            self.derived.insert((def.name.clone(), attr.clone()));
        }
        self.tree.insert(def.clone());
        self.refresh(&def.name);
    }

    /// Marks each `(class, attr)` as derived (computed on read), for the class and its
    /// subclasses, recomputing the flattened attributes once for all of them.
    pub fn mark_derived<'a>(&mut self, marks: impl IntoIterator<Item = (&'a str, &'a str)>) {
        let before = self.derived.len();
        for (class, attr) in marks {
            self.derived.insert((class.to_owned(), attr.to_owned()));
        }
        if self.derived.len() > before {
            self.refresh(THING);
        }
    }

    /// Recomputes the flattened attributes of `class` and of every class below it.
    fn refresh(&mut self, class: &str) {
        let below: Vec<String> = std::iter::once(THING)
            .chain(self.tree.defs().map(|d| d.name.as_str()))
            .filter(|c| self.tree.is_a(c, class))
            .map(str::to_owned)
            .collect();
        for name in below {
            let info = self.flattened(&name);
            self.classes.insert(name, info);
        }
    }

    /// Every attribute `class` has, declared there or inherited.
    fn flattened(&self, class: &str) -> ClassInfo {
        let attrs = self
            .tree
            .declarations(class)
            .map(|(declaring, a)| {
                let info = AttrInfo {
                    class: declaring.name.clone(),
                    derived: self
                        .derived
                        .contains(&(declaring.name.clone(), a.name.clone())),
                    decl: a.clone(),
                };
                (a.name.clone(), info)
            })
            .collect();
        ClassInfo { attrs }
    }

    pub fn attr(&self, class: &str, attr: &str) -> Option<&AttrInfo> {
        self.classes.get(class)?.attrs.get(attr)
    }

    /// The type of `attr` when the object's class is not known statically (through a
    /// reference): every class declaring it must agree.
    pub fn attr_anywhere(&self, attr: &str) -> Result<ValueType, String> {
        let mut types = self
            .classes
            .values()
            .filter_map(|c| c.attrs.get(attr))
            .map(|a| a.decl.ty);
        let Some(first) = types.next() else {
            return Err(format!("no class declares an attribute {attr}"));
        };
        match types.find(|t| *t != first) {
            None => Ok(first),
            Some(other) => Err(format!(
                "attribute {attr} has type {first} in one class and {other} in another; \
                 the object behind this reference is not known here"
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_class_inherits_board_declarations_and_their_derived_marks() {
        let board = Board::new();
        let speed = AttrDecl::new("speed", ValueType::Real);
        board.define(ClassDef::new("Vehicle").attr(speed)).unwrap();
        let mut scope = Scope::from_board(&board);
        assert!(scope.classes.contains_key(THING) && scope.classes.contains_key("Plan"));
        scope.mark_derived([("Vehicle", "speed")]);
        let gsr = ClassDef::new("Gsr")
            .parent("Vehicle")
            .attr(AttrDecl::new("mode", ValueType::Str));
        scope.add_class(&gsr, &["mode".to_owned()]);
        let inherited = scope.attr("Gsr", "speed").unwrap();
        assert!(inherited.derived && inherited.class == "Vehicle");
        assert!(scope.attr("Gsr", "mode").is_some_and(|a| a.derived));
        assert!(scope.attr("Vehicle", "mode").is_none());
    }
}
