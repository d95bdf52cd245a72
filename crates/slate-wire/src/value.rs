//! Values on the wire: packed from the declaration when it allows, general encodings
//! otherwise, and the tagged form used where no declaration applies.

use std::sync::Arc;

use slate_model::{AttrDecl, Value, ValueError, ValueType};

use crate::bits::{BitReader, BitWriter};
use crate::quant::{IntRange, Quant};
use crate::{DecodeError, MAX_NAME_BYTES, MAX_TEXT_BYTES};

/// How one attribute's value is written, derived from its declaration.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum ValueCodec {
    /// One bit.
    Bool,
    /// Bounded: offset in fixed bits; else zigzag varint.
    Int(Option<IntRange>),
    /// Quantised from bounds and resolution; else a general real.
    Real(Option<Quant>),
    /// `n` reals, each quantised or general.
    Vector(u16, Option<Quant>),
    /// Length-prefixed UTF-8.
    Str,
    /// Length-prefixed UTF-8 object name.
    Ref,
}

impl ValueCodec {
    /// The codec a declaration implies.
    pub fn new(decl: &AttrDecl) -> Self {
        let quant = || Quant::new(decl.bounds, decl.resolution);
        match decl.ty {
            ValueType::Bool => ValueCodec::Bool,
            ValueType::Int => ValueCodec::Int(IntRange::new(decl.bounds)),
            ValueType::Real => ValueCodec::Real(quant()),
            ValueType::Vector(n) => ValueCodec::Vector(n, quant()),
            ValueType::Str => ValueCodec::Str,
            ValueType::Ref => ValueCodec::Ref,
        }
    }

    /// Bits every value takes, if that is fixed.
    pub fn fixed_bits(&self) -> Option<u64> {
        match self {
            ValueCodec::Bool => Some(1),
            ValueCodec::Int(Some(range)) => Some(range.bits.into()),
            ValueCodec::Real(Some(q)) => Some(q.bits.into()),
            ValueCodec::Vector(n, Some(q)) => Some(u64::from(*n) * u64::from(q.bits)),
            _ => None,
        }
    }

    /// Writes `value`, which [`check_value`] accepted for this declaration.
    pub fn write(&self, w: &mut BitWriter, value: &Value) {
        match (self, value) {
            (ValueCodec::Bool, Value::Bool(b)) => w.bit(*b),
            (ValueCodec::Int(Some(range)), Value::Int(i)) => range.write(w, *i),
            (ValueCodec::Int(None), Value::Int(i)) => w.ivar(*i),
            (ValueCodec::Real(q), Value::Real(x)) => write_number(w, *q, *x),
            (ValueCodec::Vector(_, q), Value::Vector(v)) => {
                v.iter().for_each(|x| write_number(w, *q, *x));
            }
            (ValueCodec::Str, Value::Str(s)) | (ValueCodec::Ref, Value::Ref(s)) => w.str(s),
            _ => debug_assert!(false, "{value:?} was not checked against {self:?}"),
        }
    }

    /// Reads a value.
    pub fn read(&self, r: &mut BitReader) -> Result<Value, DecodeError> {
        Ok(match self {
            ValueCodec::Bool => Value::Bool(r.bit()?),
            ValueCodec::Int(Some(range)) => Value::Int(range.read(r)?),
            ValueCodec::Int(None) => Value::Int(r.ivar()?),
            ValueCodec::Real(q) => Value::Real(read_number(r, *q)?),
            ValueCodec::Vector(n, q) => Value::Vector(read_vector(r, usize::from(*n), *q)?),
            ValueCodec::Str => Value::Str(r.str("string value", MAX_TEXT_BYTES)?.into()),
            ValueCodec::Ref => Value::Ref(r.str("reference", MAX_NAME_BYTES)?.into()),
        })
    }
}

fn write_number(w: &mut BitWriter, q: Option<Quant>, x: f64) {
    match q {
        Some(q) => q.write(w, x),
        None => write_real(w, x),
    }
}

fn read_number(r: &mut BitReader, q: Option<Quant>) -> Result<f64, DecodeError> {
    match q {
        Some(q) => q.read(r),
        None => read_real(r),
    }
}

/// Reads `n` reals; the message's element budget bounds what is allocated.
fn read_vector(r: &mut BitReader, n: usize, q: Option<Quant>) -> Result<Arc<[f64]>, DecodeError> {
    r.spend_elements(n)?;
    let mut v = Vec::new();
    for _ in 0..n {
        v.push(read_number(r, q)?);
    }
    Ok(v.into())
}

/// Writes a finite real: a 0 bit and its `f32` bits when that is exact, else a 1 bit
/// and its `f64` bits.
pub(crate) fn write_real(w: &mut BitWriter, x: f64) {
    let narrow = x as f32;
    if f64::from(narrow) == x {
        w.bit(false);
        w.bits(narrow.to_bits().into(), 32);
    } else {
        w.bit(true);
        w.bits(x.to_bits(), 64);
    }
}

/// Reads a real written by [`write_real`]; it must be finite.
pub(crate) fn read_real(r: &mut BitReader) -> Result<f64, DecodeError> {
    let x = if r.bit()? {
        f64::from_bits(r.bits(64)?)
    } else {
        f64::from(f32::from_bits(r.bits(32)? as u32))
    };
    if !x.is_finite() {
        return Err(DecodeError::BadValue("real is not finite"));
    }
    Ok(x)
}

/// Tags of [`write_tagged`] values.
const TAG_NONE: u64 = 0;
const TAG_INT: u64 = 1;
const TAG_REAL: u64 = 2;
const TAG_BOOL: u64 = 3;
const TAG_STR: u64 = 4;
const TAG_REF: u64 = 5;
const TAG_VECTOR: u64 = 6;
const TAG_BITS: u32 = 3;

/// Writes a value with its type (no declaration needed): a 3-bit tag, then the general
/// encoding (zigzag varint, real, bit, string, or varint length and reals).
pub(crate) fn write_tagged(w: &mut BitWriter, value: &Value) {
    w.bits(tag_of(value), TAG_BITS);
    match value {
        Value::None => {}
        Value::Int(i) => w.ivar(*i),
        Value::Real(x) => write_real(w, *x),
        Value::Bool(b) => w.bit(*b),
        Value::Str(s) | Value::Ref(s) => w.str(s),
        Value::Vector(v) => {
            w.uvar(v.len() as u64);
            v.iter().for_each(|x| write_real(w, *x));
        }
    }
}

fn tag_of(value: &Value) -> u64 {
    match value {
        Value::None => TAG_NONE,
        Value::Int(_) => TAG_INT,
        Value::Real(_) => TAG_REAL,
        Value::Bool(_) => TAG_BOOL,
        Value::Str(_) => TAG_STR,
        Value::Ref(_) => TAG_REF,
        Value::Vector(_) => TAG_VECTOR,
    }
}

/// Reads a value written by [`write_tagged`].
pub(crate) fn read_tagged(r: &mut BitReader) -> Result<Value, DecodeError> {
    Ok(match r.bits(TAG_BITS)? {
        TAG_NONE => Value::None,
        TAG_INT => Value::Int(r.ivar()?),
        TAG_REAL => Value::Real(read_real(r)?),
        TAG_BOOL => Value::Bool(r.bit()?),
        TAG_STR => Value::Str(r.str("string value", MAX_TEXT_BYTES)?.into()),
        TAG_REF => Value::Ref(r.str("reference", MAX_NAME_BYTES)?.into()),
        TAG_VECTOR => {
            let n = r.count("vector length", usize::from(u16::MAX))?;
            Value::Vector(read_vector(r, n, None)?)
        }
        _ => return Err(DecodeError::BadValue("reserved value tag")),
    })
}

/// Checks that a value can be written for a declaration: its type, finiteness, bounds
/// (as the board checks them), and the wire's length limits for text. `Value::None` is
/// always allowed.
pub(crate) fn check_value(value: &Value, decl: &AttrDecl) -> Result<(), ValueError> {
    if value.is_none() {
        return Ok(());
    }
    if too_long(value) {
        return Err(ValueError::WrongType {
            expected: decl.ty,
            found: value.clone(),
        });
    }
    slate_model::check_value(value, decl.ty, decl.bounds)
}

/// Text longer than the wire carries.
fn too_long(value: &Value) -> bool {
    match value {
        Value::Str(s) => s.len() > MAX_TEXT_BYTES,
        Value::Ref(s) => s.len() > MAX_NAME_BYTES,
        _ => false,
    }
}

/// Checks the accuracy (finite, `>= 0`) and confidence (`[0, 1]`) fields.
pub(crate) fn check_quality(accuracy: f64, confidence: f64) -> Result<(), ValueError> {
    if !(accuracy.is_finite() && accuracy >= 0.0) {
        return Err(ValueError::Accuracy(accuracy));
    }
    if !(0.0..=1.0).contains(&confidence) {
        return Err(ValueError::Confidence(confidence));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn roundtrip(codec: &ValueCodec, value: &Value) -> (Value, u64) {
        let mut w = BitWriter::new();
        codec.write(&mut w, value);
        let bits = w.len_bits();
        let bytes = w.finish();
        (codec.read(&mut BitReader::new(&bytes)).unwrap(), bits)
    }

    #[test]
    fn declared_bounds_give_fixed_widths() {
        let pose = AttrDecl::new("xy", ValueType::Vector(2))
            .bounds(-10_000.0, 10_000.0)
            .resolution(0.01);
        let codec = ValueCodec::new(&pose);
        assert_eq!(codec.fixed_bits(), Some(42));
        let (back, bits) = roundtrip(&codec, &Value::from([12.344, -9_999.999]));
        assert_eq!(bits, 42);
        let back = back.as_vector().unwrap().to_vec();
        assert!((back[0] - 12.344).abs() <= 0.005 && (back[1] + 9_999.999).abs() <= 0.005);
    }

    #[test]
    fn undeclared_reals_use_f32_when_exact() {
        let codec = ValueCodec::new(&AttrDecl::new("r", ValueType::Real));
        assert_eq!(roundtrip(&codec, &Value::Real(1.5)), (Value::Real(1.5), 33));
        assert_eq!(roundtrip(&codec, &Value::Real(0.1)), (Value::Real(0.1), 65));
    }

    #[test]
    fn unbounded_ints_are_zigzag_varints() {
        let codec = ValueCodec::new(&AttrDecl::new("n", ValueType::Int));
        assert_eq!(roundtrip(&codec, &Value::Int(-3)), (Value::Int(-3), 8));
        assert_eq!(
            roundtrip(&codec, &Value::Int(i64::MIN)).0,
            Value::Int(i64::MIN)
        );
    }

    #[test]
    fn tagged_values_roundtrip_exactly() {
        for v in [
            Value::None,
            Value::Int(-7),
            Value::Real(0.1),
            Value::Bool(true),
            Value::from("auto"),
            Value::reference("r1"),
            Value::from([1.0, 2.5, -0.1]),
        ] {
            let mut w = BitWriter::new();
            write_tagged(&mut w, &v);
            let bytes = w.finish();
            assert_eq!(read_tagged(&mut BitReader::new(&bytes)), Ok(v));
        }
        assert!(read_tagged(&mut BitReader::new(&[0xe0])).is_err(), "tag 7");
    }

    #[test]
    fn values_are_checked_before_writing() {
        let decl = AttrDecl::new("s", ValueType::Real).bounds(0.0, 10.0);
        assert!(check_value(&Value::Real(5.0), &decl).is_ok());
        assert!(check_value(&Value::None, &decl).is_ok());
        assert!(matches!(
            check_value(&Value::Real(11.0), &decl),
            Err(ValueError::OutOfBounds { .. })
        ));
        assert!(matches!(
            check_value(&Value::Int(1), &decl),
            Err(ValueError::WrongType { .. })
        ));
        assert!(matches!(
            check_value(&Value::Real(f64::NAN), &decl),
            Err(ValueError::NotFinite(_))
        ));
        assert_eq!(check_quality(-1.0, 0.5), Err(ValueError::Accuracy(-1.0)));
        assert_eq!(check_quality(0.0, 1.5), Err(ValueError::Confidence(1.5)));
    }
}
