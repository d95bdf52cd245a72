//! What the checker knows about the world a file is loaded into: the classes (with their
//! flattened attributes) and the objects, from the board and from the file itself.

use std::collections::HashMap;

use slate_model::{AttrDecl, Board, ClassDef, THING, ValueType};

/// One attribute as the checker sees it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct AttrInfo {
    pub ty: ValueType,
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
    pub classes: HashMap<String, ClassInfo>,
    /// Object name to class name.
    pub objects: HashMap<String, String>,
}

impl Scope {
    /// The classes and objects a board holds now.
    pub fn from_board(board: &Board) -> Self {
        let mut scope = Scope::default();
        scope.classes.insert(THING.to_owned(), ClassInfo::default());
        for def in board.class_defs() {
            scope.add_class(&def, &[]);
        }
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
        let mut attrs = self
            .classes
            .get(&def.parent)
            .map(|p| p.attrs.clone())
            .unwrap_or_default();
        for a in &def.attrs {
            let info = AttrInfo {
                ty: a.ty,
                class: def.name.clone(),
                derived: derived.contains(&a.name),
                decl: a.clone(),
            };
            attrs.insert(a.name.clone(), info);
        }
        self.classes.insert(def.name.clone(), ClassInfo { attrs });
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
            .map(|a| a.ty);
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
