//! Class definitions: named classes with one parent and declared attributes.

use std::fmt;
use std::str::FromStr;
use std::time::Duration;

use crate::{Value, ValueError, ValueType};

/// Name of the root class every class descends from.
pub const THING: &str = "Thing";

/// How a receiving board merges a reported packet into its copy (applied by the ICI).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum MergePolicy {
    /// Last writer by timestamp, then source, wins (deterministic everywhere).
    #[default]
    Latest,
    /// The packet with the highest confidence wins.
    Confident,
    /// Independent estimates are combined using their accuracy.
    Fused,
    /// Only the owning module may write; other writes are rejected and counted.
    Owned,
}

impl MergePolicy {
    /// The lower-case name used in the language.
    pub fn name(self) -> &'static str {
        match self {
            MergePolicy::Latest => "latest",
            MergePolicy::Confident => "confident",
            MergePolicy::Fused => "fused",
            MergePolicy::Owned => "owned",
        }
    }
}

impl fmt::Display for MergePolicy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for MergePolicy {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        [
            MergePolicy::Latest,
            MergePolicy::Confident,
            MergePolicy::Fused,
            MergePolicy::Owned,
        ]
        .into_iter()
        .find(|m| m.name() == s)
        .ok_or_else(|| {
            format!("unknown merge policy {s:?}: expected latest, confident, fused or owned")
        })
    }
}

/// When an attribute's changes are reported to other boards (applied by the ICI).
/// The default reports every change.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReportPolicy {
    /// Never report more often than this.
    pub min_interval: Option<Duration>,
    /// Report at least this often, changed or not.
    pub heartbeat: Option<Duration>,
    /// Report only changes larger than this (in the attribute's unit).
    pub deadband: Option<f64>,
    /// Report only changes larger than the packet's accuracy.
    pub on_accuracy: bool,
}

/// The default packet an attribute declares (timestamp zero, source unknown).
#[derive(Clone, Debug, PartialEq)]
pub struct DefaultPacket {
    /// Default value.
    pub value: Value,
    /// Default accuracy.
    pub accuracy: f64,
    /// Default confidence.
    pub confidence: f64,
}

/// One attribute declaration of a class.
///
/// ```
/// use slate_model::{AttrDecl, ValueType};
/// let speed = AttrDecl::new("speed", ValueType::Real)
///     .unit("m/s")
///     .bounds(0.0, 50.0)
///     .resolution(0.01)
///     .default_packet(0.0, 0.1, 1.0);
/// assert_eq!(speed.unit.as_deref(), Some("m/s"));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct AttrDecl {
    /// Attribute name.
    pub name: String,
    /// Value type.
    pub ty: ValueType,
    /// Unit, for people and tools (`m`, `m/s`, `rad`).
    pub unit: Option<String>,
    /// Inclusive bounds for numbers (each element of a vector).
    pub bounds: Option<(f64, f64)>,
    /// Resolution of numbers, used by the wire format.
    pub resolution: Option<f64>,
    /// Default packet; without one, an unwritten attribute reads as [`Value::None`].
    pub default: Option<DefaultPacket>,
    /// Merge policy on receipt of reports.
    pub merge: MergePolicy,
    /// Report policy.
    pub report: ReportPolicy,
    /// Written only by the machinery that declared it, through
    /// [`Batch::write_guarded`](crate::Batch::write_guarded) (a `Plan`'s fields by the plan
    /// engine): a plain local write is refused, so the object cannot say what its machinery
    /// does not do. Packets merged from other boards are their machinery's and pass.
    pub guarded: bool,
}

impl AttrDecl {
    /// A declaration with a name and type and nothing else.
    pub fn new(name: &str, ty: ValueType) -> Self {
        AttrDecl {
            name: name.to_owned(),
            ty,
            unit: None,
            bounds: None,
            resolution: None,
            default: None,
            merge: MergePolicy::default(),
            report: ReportPolicy::default(),
            guarded: false,
        }
    }

    /// Sets the unit.
    pub fn unit(mut self, unit: &str) -> Self {
        self.unit = Some(unit.to_owned());
        self
    }

    /// Sets inclusive bounds.
    pub fn bounds(mut self, min: f64, max: f64) -> Self {
        self.bounds = Some((min, max));
        self
    }

    /// Sets the resolution.
    pub fn resolution(mut self, resolution: f64) -> Self {
        self.resolution = Some(resolution);
        self
    }

    /// Sets the default value, with accuracy 0 and confidence 1.
    pub fn default_value(self, value: impl Into<Value>) -> Self {
        self.default_packet(value, 0.0, 1.0)
    }

    /// Sets the default packet.
    pub fn default_packet(
        mut self,
        value: impl Into<Value>,
        accuracy: f64,
        confidence: f64,
    ) -> Self {
        self.default = Some(DefaultPacket {
            value: value.into(),
            accuracy,
            confidence,
        });
        self
    }

    /// Sets the merge policy.
    pub fn merge(mut self, merge: MergePolicy) -> Self {
        self.merge = merge;
        self
    }

    /// Sets the report policy.
    pub fn report(mut self, report: ReportPolicy) -> Self {
        self.report = report;
        self
    }

    /// Makes the attribute guarded (see [`AttrDecl::guarded`]).
    pub fn guarded(mut self) -> Self {
        self.guarded = true;
        self
    }

    /// Checks a value as a write to this attribute would: type, finiteness, bounds.
    /// Loaders call it before applying anything, so that a bad value fails a whole load
    /// rather than the middle of one.
    pub fn check_value(&self, value: &Value) -> Result<(), ValueError> {
        crate::packet::check_value(value, self.ty, self.bounds)
    }

    /// Checks an accuracy and a confidence as a write would (a missing one takes the
    /// declared default's, as a write does).
    pub fn check_quality(
        &self,
        accuracy: Option<f64>,
        confidence: Option<f64>,
    ) -> Result<(), ValueError> {
        let (acc, conf) = self.default_quality();
        crate::packet::check_quality(accuracy.unwrap_or(acc), confidence.unwrap_or(conf))
    }

    /// The accuracy and confidence a write that leaves them out gets: the declared
    /// default packet's, else 0 and 1.
    pub fn default_quality(&self) -> (f64, f64) {
        self.default
            .as_ref()
            .map_or((0.0, 1.0), |p| (p.accuracy, p.confidence))
    }
}

/// A class definition: a name, a parent and attribute declarations.
///
/// Instances and subclasses inherit every declaration; a subclass may not redeclare an
/// inherited attribute (write a class-level value on the subclass to change its default).
///
/// ```
/// use slate_model::{AttrDecl, ClassDef, ValueType};
/// let vehicle = ClassDef::new("Vehicle")
///     .attr(AttrDecl::new("speed", ValueType::Real).default_value(0.0));
/// let gsr = ClassDef::new("Gsr").parent("Vehicle");
/// assert_eq!(gsr.parent, "Vehicle");
/// # let _ = vehicle;
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct ClassDef {
    /// Class name.
    pub name: String,
    /// Parent class name ([`THING`] unless set).
    pub parent: String,
    /// Attributes this class declares (not the inherited ones).
    pub attrs: Vec<AttrDecl>,
}

impl ClassDef {
    /// A class directly under `Thing` with no attributes.
    pub fn new(name: &str) -> Self {
        ClassDef {
            name: name.to_owned(),
            parent: THING.to_owned(),
            attrs: Vec::new(),
        }
    }

    /// Sets the parent class.
    pub fn parent(mut self, parent: &str) -> Self {
        self.parent = parent.to_owned();
        self
    }

    /// Adds an attribute declaration.
    pub fn attr(mut self, decl: AttrDecl) -> Self {
        self.attrs.push(decl);
        self
    }
}

/// Is `name` usable as a class, object or attribute name?
/// Letters, digits and `_`, not starting with a digit.
pub(crate) fn valid_name(name: &str) -> bool {
    let mut chars = name.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_identifiers() {
        assert!(valid_name("gsr_1"));
        assert!(valid_name("_x"));
        assert!(!valid_name("1gsr"));
        assert!(!valid_name(""));
        assert!(!valid_name("a.b"));
    }

    #[test]
    fn merge_policies_parse() {
        assert_eq!("fused".parse::<MergePolicy>(), Ok(MergePolicy::Fused));
        assert!("newest".parse::<MergePolicy>().is_err());
    }
}
