//! The schema: class definitions flattened for encoding, with their fingerprints.

use std::sync::Arc;

use rustc_hash::FxHashMap;
use slate_model::{AttrDecl, ClassDef, ClassTree, THING};

use crate::bits::BitWriter;
use crate::classes::write_decl;
use crate::quant;
use crate::value::ValueCodec;

/// The class definitions a sender encodes with and a receiver decodes with.
///
/// Built from `ClassDef`s, with inheritance flattened: a class's attributes are its
/// ancestors' declarations and its own. For each `(class, attribute)` it gives the
/// declaration (type, bounds, resolution, default packet), and for each class a 32-bit
/// *fingerprint* of its flattened declarations: a receiver whose fingerprint for a class
/// differs from the sender's refuses that class's values with
/// [`DecodeError::SchemaMismatch`](crate::DecodeError::SchemaMismatch) instead of reading
/// garbage. `Thing`, the root, is always present.
///
/// ```
/// use slate_model::{AttrDecl, ClassDef, ValueType};
/// use slate_wire::Schema;
///
/// let schema = Schema::new(&[
///     ClassDef::new("Vehicle").attr(
///         AttrDecl::new("speed", ValueType::Real).bounds(0.0, 20.0).resolution(0.01),
///     ),
///     ClassDef::new("Gsr").parent("Vehicle"),
/// ]);
/// assert_eq!(schema.value_bits("Gsr", "speed"), Some(11), "2001 steps");
/// assert_eq!(schema.fingerprint("Gsr"), schema.fingerprint("Vehicle"));
/// ```
#[derive(Clone, Debug, Default)]
pub struct Schema {
    classes: FxHashMap<Arc<str>, ClassSchema>,
    /// Which schema this is (a clone is the same one): an encoder's memo of what it
    /// resolved against a schema holds only for that schema.
    id: u64,
}

/// Ids of schemas made so far.
static SCHEMAS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

/// One class, flattened.
#[derive(Clone, Debug)]
pub(crate) struct ClassSchema {
    attrs: FxHashMap<Arc<str>, Arc<AttrSchema>>,
    /// Hash of the flattened declarations.
    pub fingerprint: u32,
}

/// One attribute declaration with what encoding needs precomputed.
#[derive(Debug)]
pub(crate) struct AttrSchema {
    /// The declaration.
    pub decl: AttrDecl,
    /// How its values are packed.
    pub codec: ValueCodec,
    /// Accuracy a packet has unless it says otherwise (declared default, else 0).
    pub default_accuracy: f64,
    /// Confidence a packet has unless it says otherwise (declared default, else 1).
    pub default_confidence: f64,
    /// Unit of the accuracy log scale: the resolution, else 1.
    pub accuracy_scale: f64,
}

impl AttrSchema {
    fn new(decl: &AttrDecl) -> Self {
        AttrSchema {
            codec: ValueCodec::new(decl),
            default_accuracy: quant::default_accuracy(decl),
            default_confidence: quant::default_confidence(decl),
            accuracy_scale: quant::accuracy_scale(decl),
            decl: decl.clone(),
        }
    }
}

impl ClassSchema {
    /// The attribute `name`, declared by the class or an ancestor.
    pub fn attr(&self, name: &str) -> Option<&Arc<AttrSchema>> {
        self.attrs.get(name)
    }
}

impl Schema {
    /// A schema of these classes, flattened by the rules of
    /// [`ClassTree`](slate_model::ClassTree): a class whose parent is missing keeps only
    /// the declarations found; an attribute redeclared below an ancestor keeps the
    /// ancestor's declaration (a board refuses both).
    pub fn new(classes: &[ClassDef]) -> Schema {
        Schema::from_tree(&ClassTree::new(classes))
    }

    /// A schema of the classes of a tree (every class, `Thing` included).
    pub fn from_tree(tree: &ClassTree) -> Schema {
        let mut shared = FxHashMap::default();
        let mut schema = Schema {
            classes: FxHashMap::default(),
            id: SCHEMAS.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
        };
        for name in tree.defs().map(|d| d.name.as_str()).chain([THING]) {
            let flat = flatten(tree.declarations(name), &mut shared);
            schema.classes.insert(name.into(), flat);
        }
        schema
    }

    /// Which schema this is: two schemas with the same id hold the same classes.
    pub(crate) fn id(&self) -> u64 {
        self.id
    }

    /// The fingerprint of a class's flattened declarations, if the class is known.
    pub fn fingerprint(&self, class: &str) -> Option<u32> {
        self.classes.get(class).map(|c| c.fingerprint)
    }

    /// The declaration of `attr` in `class` (declared there or by an ancestor).
    pub fn attr(&self, class: &str, attr: &str) -> Option<&AttrDecl> {
        Some(&self.class(class)?.attr(attr)?.decl)
    }

    /// Bits every value of `class.attr` takes on the wire, if that is fixed (bounded
    /// numbers and bools); `None` for variable-size encodings or unknown attributes.
    pub fn value_bits(&self, class: &str, attr: &str) -> Option<u64> {
        self.class(class)?.attr(attr)?.codec.fixed_bits()
    }

    /// Number of classes (including `Thing`).
    pub fn len(&self) -> usize {
        self.classes.len()
    }

    /// Is the schema empty? (Never: `Thing` is always there.)
    pub fn is_empty(&self) -> bool {
        self.classes.is_empty()
    }

    /// The flattened class `name`.
    pub(crate) fn class(&self, name: &str) -> Option<&ClassSchema> {
        self.classes.get(name)
    }
}

/// Declarations already prepared, by declaration: a class's declarations are shared
/// with every subclass's flattened set.
type Shared = FxHashMap<*const AttrDecl, Arc<AttrSchema>>;

/// Merges a class's declarations (root first, as the tree gives them) and fingerprints
/// them.
fn flatten<'a>(
    declarations: impl Iterator<Item = (&'a ClassDef, &'a AttrDecl)>,
    shared: &mut Shared,
) -> ClassSchema {
    let mut attrs = FxHashMap::default();
    let mut canonical = BitWriter::new();
    for (_, decl) in declarations {
        let prepared = shared
            .entry(std::ptr::from_ref(decl))
            .or_insert_with(|| Arc::new(AttrSchema::new(decl)));
        write_decl(&mut canonical, decl);
        attrs.insert(decl.name.as_str().into(), prepared.clone());
    }
    let mut bytes = (attrs.len() as u32).to_be_bytes().to_vec();
    bytes.extend(canonical.finish());
    ClassSchema {
        attrs,
        fingerprint: fnv1a(&bytes),
    }
}

/// 32-bit FNV-1a: stable across platforms and versions, unlike `std`'s hasher.
fn fnv1a(bytes: &[u8]) -> u32 {
    bytes.iter().fold(0x811c_9dc5, |h, b| {
        (h ^ u32::from(*b)).wrapping_mul(0x0100_0193)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use slate_model::ValueType;

    fn vehicle(max_speed: f64) -> ClassDef {
        ClassDef::new("Vehicle")
            .attr(AttrDecl::new("speed", ValueType::Real).bounds(0.0, max_speed))
    }

    /// `Gsr`, a subclass of `parent` with a `mode` of its own.
    fn gsr(parent: &str) -> ClassDef {
        ClassDef::new("Gsr")
            .parent(parent)
            .attr(AttrDecl::new("mode", ValueType::Str))
    }

    #[test]
    fn subclasses_inherit_their_ancestors_declarations() {
        let schema = Schema::new(&[gsr("Vehicle"), vehicle(20.0)]);
        assert!(schema.attr("Gsr", "speed").is_some());
        assert!(schema.attr("Gsr", "mode").is_some());
        assert!(schema.attr("Vehicle", "mode").is_none());
        assert_ne!(schema.fingerprint("Gsr"), schema.fingerprint("Vehicle"));
        assert_eq!(schema.len(), 3, "Gsr, Vehicle and Thing");
    }

    #[test]
    fn a_changed_declaration_changes_the_fingerprint() {
        let a = Schema::new(&[vehicle(20.0)]);
        let b = Schema::new(&[vehicle(30.0)]);
        assert_ne!(a.fingerprint("Vehicle"), b.fingerprint("Vehicle"));
        assert_eq!(
            a.fingerprint("Vehicle"),
            Schema::new(&[vehicle(20.0)]).fingerprint("Vehicle")
        );
    }

    #[test]
    fn the_fingerprint_is_stable_across_builds() {
        let schema = Schema::new(&[vehicle(20.0)]);
        assert_eq!(schema.fingerprint("Thing"), Some(fnv1a(&[0, 0, 0, 0])));
        assert_eq!(fnv1a(b"a"), 0xe40c_292c, "FNV-1a test vector");
    }

    #[test]
    fn cycles_and_missing_parents_do_not_hang() {
        let schema = Schema::new(&[
            ClassDef::new("A").parent("B"),
            ClassDef::new("B")
                .parent("A")
                .attr(AttrDecl::new("x", ValueType::Bool)),
            ClassDef::new("C").parent("Missing"),
        ]);
        assert!(schema.attr("A", "x").is_some());
        assert!(schema.fingerprint("C").is_some());
    }

    /// Fingerprints travel between builds: a refactoring of how the schema walks the class
    /// tree must leave every one as it was.
    #[test]
    fn fingerprints_of_a_three_level_tree_are_pinned() {
        let schema = Schema::new(&[
            gsr("Ground"),
            ClassDef::new("Vehicle")
                .attr(
                    AttrDecl::new("speed", ValueType::Real)
                        .bounds(0.0, 20.0)
                        .resolution(0.01),
                )
                .attr(AttrDecl::new("pos", ValueType::Vector(2)).default_packet(
                    vec![0.0, 0.0],
                    1.0,
                    0.5,
                )),
            ClassDef::new("Ground")
                .parent("Vehicle")
                .attr(AttrDecl::new("wheels", ValueType::Int).bounds(0.0, 8.0)),
        ]);
        let got = ["Thing", "Vehicle", "Ground", "Gsr"].map(|c| schema.fingerprint(c));
        let pinned = [0x4b95_f515, 0xf604_8744, 0x01a0_a3b9, 0xca15_29e6];
        assert_eq!(got, pinned.map(Some), "Thing, Vehicle, Ground, Gsr");
    }
}
