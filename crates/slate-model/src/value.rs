//! Attribute values and their types.

use std::fmt;
use std::sync::Arc;

/// The type an attribute is declared with. A value never changes type silently.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ValueType {
    /// 64-bit signed integer.
    Int,
    /// 64-bit float; always finite.
    Real,
    /// `true` or `false`.
    Bool,
    /// UTF-8 text.
    Str,
    /// A token naming another object (see [`Value::Ref`]).
    Ref,
    /// A fixed-size vector of reals (positions, poses), of the given length.
    Vector(u16),
}

impl fmt::Display for ValueType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ValueType::Int => f.write_str("int"),
            ValueType::Real => f.write_str("real"),
            ValueType::Bool => f.write_str("bool"),
            ValueType::Str => f.write_str("string"),
            ValueType::Ref => f.write_str("ref"),
            ValueType::Vector(n) => write!(f, "vec<{n}>"),
        }
    }
}

/// The value field of an attribute packet.
///
/// Cloning is cheap: text, references and vectors are shared, not copied.
///
/// A [`Value::Ref`] is the paper's *token*: it names another object. References are
/// names, not pointers, so they mean the same thing on every board. A reference to an
/// object that does not exist (never created here, or deleted) is *dangling*: it is
/// stored and read back unchanged, and following it fails with
/// [`ReadError::UnknownObject`](crate::ReadError::UnknownObject). If an object of that
/// name is created (again) later, the reference resolves to it.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Value {
    /// Never written: the attribute has no value and no declared default.
    #[default]
    None,
    /// An integer.
    Int(i64),
    /// A real number.
    Real(f64),
    /// A boolean.
    Bool(bool),
    /// Text.
    Str(Arc<str>),
    /// A token naming another object.
    Ref(Arc<str>),
    /// A fixed-size vector of reals.
    Vector(Arc<[f64]>),
}

impl Value {
    /// The type of this value, or `None` for [`Value::None`].
    pub fn value_type(&self) -> Option<ValueType> {
        Some(match self {
            Value::None => return None,
            Value::Int(_) => ValueType::Int,
            Value::Real(_) => ValueType::Real,
            Value::Bool(_) => ValueType::Bool,
            Value::Str(_) => ValueType::Str,
            Value::Ref(_) => ValueType::Ref,
            Value::Vector(v) => ValueType::Vector(v.len().min(u16::MAX as usize) as u16),
        })
    }

    /// Is this [`Value::None`]?
    pub fn is_none(&self) -> bool {
        matches!(self, Value::None)
    }

    /// A reference to the object named `name`.
    pub fn reference(name: &str) -> Value {
        Value::Ref(name.into())
    }

    /// The value as a real, converting integers; `None` for other types.
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Value::Real(x) => Some(*x),
            Value::Int(i) => Some(*i as f64),
            _ => None,
        }
    }

    /// The vector's elements, if this is a vector.
    pub fn as_vector(&self) -> Option<&[f64]> {
        match self {
            Value::Vector(v) => Some(v),
            _ => None,
        }
    }

    /// The name this reference points to, if this is a reference.
    pub fn as_ref_name(&self) -> Option<&str> {
        match self {
            Value::Ref(r) => Some(r),
            _ => None,
        }
    }

    /// The value for people to read: a string without its quotes, anything else as the
    /// language writes it (`2.5`, `[1.0, 2.0]`, `&r1`). Every view of a board (the
    /// dashboards, `slate get`) shows values this way, so one value reads the same in each.
    pub fn plain_text(&self) -> String {
        match self {
            Value::Str(s) => s.to_string(),
            other => other.to_string(),
        }
    }

    /// The reals this value is made of (one for a real or integer, n for a vector).
    pub(crate) fn reals(&self) -> &[f64] {
        match self {
            Value::Real(x) => std::slice::from_ref(x),
            Value::Vector(v) => v,
            _ => &[],
        }
    }
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::None => f.write_str("none"),
            Value::Int(i) => write!(f, "{i}"),
            Value::Real(x) => write!(f, "{x:?}"),
            Value::Bool(b) => write!(f, "{b}"),
            Value::Str(s) => write!(f, "{s:?}"),
            Value::Ref(r) => write!(f, "&{r}"),
            Value::Vector(v) => {
                f.write_str("[")?;
                for (i, x) in v.iter().enumerate() {
                    if i > 0 {
                        f.write_str(", ")?;
                    }
                    write!(f, "{x:?}")?;
                }
                f.write_str("]")
            }
        }
    }
}

impl From<i64> for Value {
    fn from(v: i64) -> Self {
        Value::Int(v)
    }
}
impl From<i32> for Value {
    fn from(v: i32) -> Self {
        Value::Int(v.into())
    }
}
impl From<f64> for Value {
    fn from(v: f64) -> Self {
        Value::Real(v)
    }
}
impl From<bool> for Value {
    fn from(v: bool) -> Self {
        Value::Bool(v)
    }
}
impl From<&str> for Value {
    fn from(v: &str) -> Self {
        Value::Str(v.into())
    }
}
impl From<String> for Value {
    fn from(v: String) -> Self {
        Value::Str(v.into())
    }
}
impl<const N: usize> From<[f64; N]> for Value {
    fn from(v: [f64; N]) -> Self {
        Value::Vector(Arc::from(&v[..]))
    }
}
impl From<Vec<f64>> for Value {
    fn from(v: Vec<f64>) -> Self {
        Value::Vector(v.into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn types_of_values() {
        assert_eq!(Value::from(1).value_type(), Some(ValueType::Int));
        assert_eq!(Value::from(1.0).value_type(), Some(ValueType::Real));
        assert_eq!(
            Value::from([1.0, 2.0]).value_type(),
            Some(ValueType::Vector(2))
        );
        assert_eq!(Value::reference("gsr").value_type(), Some(ValueType::Ref));
        assert_eq!(Value::None.value_type(), None);
    }

    #[test]
    fn display_is_readable() {
        assert_eq!(Value::from([1.0, 2.5]).to_string(), "[1.0, 2.5]");
        assert_eq!(Value::reference("gsr").to_string(), "&gsr");
        assert_eq!(Value::from("auto").to_string(), "\"auto\"");
        assert_eq!(ValueType::Vector(3).to_string(), "vec<3>");
    }
}
