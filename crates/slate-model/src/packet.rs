//! Attribute packets: `value, accuracy, confidence, timestamp` plus the writing module.

use std::time::Duration;

use crate::{Address, Clock, Timestamp, Value, ValueType};

/// The paper's attribute packet: `<value, accuracy, confidence, timestamp>`, plus `source`.
#[derive(Clone, Debug, PartialEq)]
pub struct Packet {
    /// The attribute's value.
    pub value: Value,
    /// Potential deviation of the value, in the attribute's unit (a standard deviation
    /// unless the class says otherwise). Finite and non-negative.
    pub accuracy: f64,
    /// Probability in `[0, 1]` that the interpretation is correct.
    pub confidence: f64,
    /// When the packet was written (hybrid logical clock).
    pub timestamp: Timestamp,
    /// The module that wrote it.
    pub source: Address,
}

impl Packet {
    /// The packet of an attribute that was never written and has no default.
    pub fn none() -> Self {
        Packet {
            value: Value::None,
            accuracy: 0.0,
            confidence: 0.0,
            timestamp: Timestamp::ZERO,
            source: Address::unknown(),
        }
    }

    /// Whether the packet claims a time, and so has an age. A declared default,
    /// [`Packet::none`] and an initial value from a `.slate` file carry
    /// [`Timestamp::ZERO`]: they claim no time (so they lose to any packet written since)
    /// and must not read as fresh.
    ///
    /// ```
    /// use slate_model::{AttrDecl, Board, ClassDef, NewObject, ValueType};
    /// let board = Board::builder().build();
    /// let x = AttrDecl::new("x", ValueType::Real).default_value(1.0);
    /// board.define(ClassDef::new("V").attr(x)).unwrap();
    /// board.create_with(NewObject::new("V", "o")).unwrap();
    /// assert!(!board.read("o", "x").unwrap().has_time());
    /// board.write("o", "x", 2.0).unwrap();
    /// assert!(board.read("o", "x").unwrap().has_time());
    /// ```
    pub fn has_time(&self) -> bool {
        self.timestamp != Timestamp::ZERO
    }

    /// How long ago the packet was written, by `clock`'s physical time; `None` for a
    /// packet that claims no time ([`has_time`](Self::has_time)), which must not read as
    /// fresh nor as old.
    pub fn age(&self, clock: &Clock) -> Option<Duration> {
        self.has_time().then(|| clock.age(self.timestamp))
    }

    /// Whether this is a declared default (or [`Packet::none`]): no module wrote it, so
    /// it has neither a time nor a source. An initial value from a file has no time
    /// but has its writer as source.
    pub fn is_default(&self) -> bool {
        !self.has_time() && self.source.is_unknown()
    }
}

/// A write request: a value and, optionally, the other packet fields.
///
/// Fields left unset are filled in by the board: accuracy and confidence from the
/// attribute's declared default packet (else `0.0` and `1.0`), the timestamp from the
/// board's clock, the source from the board's address.
///
/// ```
/// use slate_model::Update;
/// let u = Update::new(2.5).accuracy(0.1).confidence(0.9);
/// assert_eq!(u.accuracy, Some(0.1));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Update {
    /// The new value.
    pub value: Value,
    /// Accuracy, if given.
    pub accuracy: Option<f64>,
    /// Confidence, if given.
    pub confidence: Option<f64>,
    /// Timestamp, if given (for example the time of measurement, or a remote packet's).
    pub timestamp: Option<Timestamp>,
    /// Source, if not the board itself.
    pub source: Option<Address>,
}

impl Update {
    /// An update of the value alone.
    pub fn new(value: impl Into<Value>) -> Self {
        Update {
            value: value.into(),
            accuracy: None,
            confidence: None,
            timestamp: None,
            source: None,
        }
    }

    /// Sets the accuracy.
    pub fn accuracy(mut self, accuracy: f64) -> Self {
        self.accuracy = Some(accuracy);
        self
    }

    /// Sets the confidence.
    pub fn confidence(mut self, confidence: f64) -> Self {
        self.confidence = Some(confidence);
        self
    }

    /// Sets the timestamp.
    pub fn timestamp(mut self, timestamp: Timestamp) -> Self {
        self.timestamp = Some(timestamp);
        self
    }

    /// Sets the source.
    pub fn source(mut self, source: Address) -> Self {
        self.source = Some(source);
        self
    }
}

impl<T: Into<Value>> From<T> for Update {
    fn from(value: T) -> Self {
        Update::new(value)
    }
}

impl From<Packet> for Update {
    fn from(p: Packet) -> Self {
        Update {
            value: p.value,
            accuracy: Some(p.accuracy),
            confidence: Some(p.confidence),
            timestamp: Some(p.timestamp),
            source: Some(p.source),
        }
    }
}

/// Why a value or packet is not acceptable for an attribute.
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ValueError {
    /// The value's type differs from the declared type.
    #[error("expected a value of type {expected}, got {found}")]
    WrongType {
        /// Declared type.
        expected: ValueType,
        /// The offending value.
        found: Value,
    },
    /// A real is NaN or infinite.
    #[error("value {0} is not finite")]
    NotFinite(Value),
    /// A number lies outside the declared bounds.
    #[error("value {value} is outside the declared bounds [{min}, {max}]")]
    OutOfBounds {
        /// The offending value.
        value: Value,
        /// Lower bound.
        min: f64,
        /// Upper bound.
        max: f64,
    },
    /// Accuracy is negative or not finite.
    #[error("accuracy {0} must be finite and >= 0")]
    Accuracy(f64),
    /// Confidence is outside `[0, 1]`.
    #[error("confidence {0} must be between 0 and 1")]
    Confidence(f64),
}

/// Checks the accuracy and confidence fields: accuracy finite and `>= 0`, confidence in
/// `[0, 1]` (what every write checks; a tool can check them before it writes).
pub fn check_quality(accuracy: f64, confidence: f64) -> Result<(), ValueError> {
    if !(accuracy.is_finite() && accuracy >= 0.0) {
        return Err(ValueError::Accuracy(accuracy));
    }
    if !(0.0..=1.0).contains(&confidence) {
        return Err(ValueError::Confidence(confidence));
    }
    Ok(())
}

/// Checks a value against a declared type and optional bounds: the type, finiteness,
/// and (for numbers and every component of a vector) the bounds. What every write
/// checks; the codec checks what it encodes with it too.
pub fn check_value(
    value: &Value,
    ty: ValueType,
    bounds: Option<(f64, f64)>,
) -> Result<(), ValueError> {
    if value.value_type() != Some(ty) {
        return Err(ValueError::WrongType {
            expected: ty,
            found: value.clone(),
        });
    }
    if value.reals().iter().any(|x| !x.is_finite()) {
        return Err(ValueError::NotFinite(value.clone()));
    }
    if let Some((min, max)) = bounds {
        let outside = match value {
            Value::Int(i) => !(min..=max).contains(&(*i as f64)),
            v => v.reals().iter().any(|x| !(min..=max).contains(x)),
        };
        if outside {
            return Err(ValueError::OutOfBounds {
                value: value.clone(),
                min,
                max,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quality_ranges_are_errors_not_clamps() {
        assert_eq!(check_quality(-0.1, 0.5), Err(ValueError::Accuracy(-0.1)));
        assert!(matches!(
            check_quality(f64::NAN, 0.5),
            Err(ValueError::Accuracy(_))
        ));
        assert_eq!(check_quality(0.0, 1.5), Err(ValueError::Confidence(1.5)));
        assert!(matches!(
            check_quality(0.0, f64::NAN),
            Err(ValueError::Confidence(_))
        ));
        assert_eq!(check_quality(0.0, 1.0), Ok(()));
    }

    #[test]
    fn values_are_checked_against_type_and_bounds() {
        let b = Some((0.0, 10.0));
        assert!(check_value(&Value::Real(5.0), ValueType::Real, b).is_ok());
        assert!(matches!(
            check_value(&Value::Int(5), ValueType::Real, b),
            Err(ValueError::WrongType { .. })
        ));
        assert!(matches!(
            check_value(&Value::Real(11.0), ValueType::Real, b),
            Err(ValueError::OutOfBounds { .. })
        ));
        assert!(matches!(
            check_value(&Value::Real(f64::INFINITY), ValueType::Real, None),
            Err(ValueError::NotFinite(_))
        ));
        assert!(matches!(
            check_value(&Value::from([1.0, 2.0, 3.0]), ValueType::Vector(2), None),
            Err(ValueError::WrongType { .. })
        ));
        assert!(matches!(
            check_value(&Value::from([1.0, 12.0]), ValueType::Vector(2), b),
            Err(ValueError::OutOfBounds { .. })
        ));
        assert!(check_value(&Value::Int(10), ValueType::Int, b).is_ok());
    }
}
