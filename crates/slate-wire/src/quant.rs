//! Quantisation rules: numbers from declared bounds and resolution, accuracy on a log
//! scale, confidence in 1/255 steps.

use slate_model::{AttrDecl, Packet, Value, ValueType};

use crate::DecodeError;
use crate::bits::{BitReader, BitWriter, width};
use crate::value::{read_real, write_real};

/// A real quantised from bounds and resolution: `q = round((v - min) / res)` in
/// `width(steps)` bits, read back as `min + q * res` (capped at `max`). The error is at
/// most `res / 2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Quant {
    min: f64,
    max: f64,
    res: f64,
    steps: u64,
    /// Bits per value.
    pub bits: u32,
}

/// Above this many steps a quantised real would lose integer precision in an `f64`.
const MAX_STEPS: f64 = (1u64 << 52) as f64;

impl Quant {
    /// The quantiser for these bounds and resolution, if both are declared and usable.
    pub fn new(bounds: Option<(f64, f64)>, res: Option<f64>) -> Option<Quant> {
        let (min, max) = bounds?;
        let res = res?;
        let usable = min.is_finite() && max.is_finite() && min <= max;
        if !(usable && res.is_finite() && res > 0.0) {
            return None;
        }
        let steps = ((max - min) / res).round();
        if steps.is_nan() || steps >= MAX_STEPS {
            return None;
        }
        let steps = steps as u64;
        Some(Quant {
            min,
            max,
            res,
            steps,
            bits: width(steps),
        })
    }

    /// The code of `v` (which lies within the bounds).
    pub fn code(&self, v: f64) -> u64 {
        let q = ((v - self.min) / self.res).round();
        (q.max(0.0) as u64).min(self.steps)
    }

    /// The value of code `q`.
    pub fn value(&self, q: u64) -> Result<f64, DecodeError> {
        if q > self.steps {
            return Err(DecodeError::BadValue(
                "quantised code beyond the declared bounds",
            ));
        }
        Ok(self.decoded(q))
    }

    /// What a receiver reads of `v`.
    pub fn snap(&self, v: f64) -> f64 {
        self.decoded(self.code(v))
    }

    fn decoded(&self, q: u64) -> f64 {
        (self.min + q as f64 * self.res).min(self.max)
    }

    /// Writes `v`.
    pub fn write(&self, w: &mut BitWriter, v: f64) {
        w.bits(self.code(v), self.bits);
    }

    /// Reads a value.
    pub fn read(&self, r: &mut BitReader) -> Result<f64, DecodeError> {
        let q = r.bits(self.bits)?;
        self.value(q)
    }
}

/// An integer within declared bounds: `v - min` in `width(max - min)` bits, exact.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct IntRange {
    min: i64,
    span: u64,
    /// Bits per value.
    pub bits: u32,
}

impl IntRange {
    /// The range of integers within these bounds, if there is at least one.
    pub fn new(bounds: Option<(f64, f64)>) -> Option<IntRange> {
        let (min, max) = bounds?;
        let (lo, hi) = (min.ceil(), max.floor());
        let representable = -9.2e18..=9.2e18;
        if !(representable.contains(&lo) && representable.contains(&hi) && lo <= hi) {
            return None;
        }
        let span = (hi as i64).abs_diff(lo as i64);
        Some(IntRange {
            min: lo as i64,
            span,
            bits: width(span),
        })
    }

    /// Writes `v` (which lies within the bounds).
    pub fn write(&self, w: &mut BitWriter, v: i64) {
        w.bits(v.abs_diff(self.min).min(self.span), self.bits);
    }

    /// Reads a value.
    pub fn read(&self, r: &mut BitReader) -> Result<i64, DecodeError> {
        let q = r.bits(self.bits)?;
        if q > self.span {
            return Err(DecodeError::BadValue("integer beyond the declared bounds"));
        }
        Ok(self.min.wrapping_add_unsigned(q))
    }
}

/// Bits of an accuracy code.
pub(crate) const ACCURACY_BITS: u32 = 6;
/// Accuracy code that means "an exact real follows".
const ACCURACY_ESCAPE: u64 = (1 << ACCURACY_BITS) - 1;
/// Accuracy code that means exactly one scale unit (the resolution).
const ACCURACY_ONE: i64 = 17;
/// Accuracy codes per doubling.
const ACCURACY_PER_OCTAVE: f64 = 4.0;

/// The accuracy of code `k` below `ACCURACY_ESCAPE`: 0 for code 0, else
/// `scale * 2^((k - 17) / 4)`.
fn accuracy_of(k: u64, scale: f64) -> f64 {
    if k == 0 {
        return 0.0;
    }
    scale * ((k as i64 - ACCURACY_ONE) as f64 / ACCURACY_PER_OCTAVE).exp2()
}

/// Accuracy a packet of `decl` has unless it says otherwise (the declared default, else 0).
pub(crate) fn default_accuracy(decl: &AttrDecl) -> f64 {
    decl.default.as_ref().map_or(0.0, |d| d.accuracy)
}

/// Confidence a packet of `decl` has unless it says otherwise (the declared default, else 1).
pub(crate) fn default_confidence(decl: &AttrDecl) -> f64 {
    decl.default.as_ref().map_or(1.0, |d| d.confidence)
}

/// The unit of `decl`'s accuracy log scale: its resolution, else 1.
pub(crate) fn accuracy_scale(decl: &AttrDecl) -> f64 {
    let scale = decl.resolution.filter(|r| r.is_finite() && *r > 0.0);
    scale.unwrap_or(1.0)
}

/// The code of accuracy `a`, or `None` if it is beyond the log scale (escape).
fn accuracy_code(a: f64, scale: f64) -> Option<u64> {
    let smallest = accuracy_of(1, scale);
    if a < smallest / 2.0 {
        return Some(0);
    }
    if a <= smallest {
        return Some(1);
    }
    let k = (ACCURACY_PER_OCTAVE * (a / scale).log2()).round() as i64 + ACCURACY_ONE;
    (k < ACCURACY_ESCAPE as i64).then_some(k as u64)
}

/// Writes an accuracy (finite, `>= 0`) on the log scale relative to `scale` (the
/// attribute's resolution, or 1): code 0 is 0, codes 1..=62 are `scale * 2^((k-17)/4)`
/// (a relative error of at most 9 %), code 63 escapes to an exact real.
pub(crate) fn write_accuracy(w: &mut BitWriter, a: f64, scale: f64) {
    match accuracy_code(a, scale) {
        Some(k) => w.bits(k, ACCURACY_BITS),
        None => {
            w.bits(ACCURACY_ESCAPE, ACCURACY_BITS);
            write_real(w, a);
        }
    }
}

/// Reads an accuracy written by [`write_accuracy`].
pub(crate) fn read_accuracy(r: &mut BitReader, scale: f64) -> Result<f64, DecodeError> {
    match r.bits(ACCURACY_BITS)? {
        ACCURACY_ESCAPE => {
            let a = read_real(r)?;
            if a < 0.0 || accuracy_code(a, scale).is_some() {
                return Err(DecodeError::BadValue("escaped accuracy that has a code"));
            }
            Ok(a)
        }
        k => Ok(accuracy_of(k, scale)),
    }
}

/// Bits of a confidence code.
pub(crate) const CONFIDENCE_BITS: u32 = 8;
const CONFIDENCE_STEPS: f64 = 255.0;

/// The code of a confidence in `[0, 1]`: `round(c * 255)`.
fn confidence_code(c: f64) -> u64 {
    (c * CONFIDENCE_STEPS).round().clamp(0.0, CONFIDENCE_STEPS) as u64
}

fn confidence_of(code: u64) -> f64 {
    code as f64 / CONFIDENCE_STEPS
}

/// Writes a confidence in `[0, 1]` as `round(c * 255)` in 8 bits (error at most 1/510).
pub(crate) fn write_confidence(w: &mut BitWriter, c: f64) {
    w.bits(confidence_code(c), CONFIDENCE_BITS);
}

/// Reads a confidence written by [`write_confidence`].
pub(crate) fn read_confidence(r: &mut BitReader) -> Result<f64, DecodeError> {
    Ok(confidence_of(r.bits(CONFIDENCE_BITS)?))
}

/// Makes `packet` what a receiver decodes from it, given the attribute's declaration:
/// a bounded real (or vector) on its resolution's grid, an accuracy other than the
/// default on its log scale, a confidence other than the default in 1/255 steps. The
/// codec's own arithmetic, without the bits: a writer that stores its packets this way
/// holds exactly what its receivers decode.
pub fn quantise(decl: &AttrDecl, packet: &mut Packet) {
    if let Some(q) = Quant::new(decl.bounds, decl.resolution) {
        match &mut packet.value {
            Value::Real(x) if decl.ty == ValueType::Real => *x = q.snap(*x),
            Value::Vector(v)
                if matches!(decl.ty, ValueType::Vector(_))
                    && v.iter().any(|x| q.snap(*x) != *x) =>
            {
                *v = v.iter().map(|x| q.snap(*x)).collect();
            }
            _ => {}
        }
    }
    if packet.accuracy != default_accuracy(decl) {
        let scale = accuracy_scale(decl);
        if let Some(k) = accuracy_code(packet.accuracy, scale) {
            packet.accuracy = accuracy_of(k, scale);
        }
    }
    if packet.confidence != default_confidence(decl) {
        packet.confidence = confidence_of(confidence_code(packet.confidence));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn roundtrip<T>(write: impl Fn(&mut BitWriter), read: impl Fn(&mut BitReader) -> T) -> T {
        let mut w = BitWriter::new();
        write(&mut w);
        let bytes = w.finish();
        read(&mut BitReader::new(&bytes))
    }

    #[test]
    fn reals_quantise_within_half_a_resolution() {
        let q = Quant::new(Some((0.0, 1000.0)), Some(0.01)).unwrap();
        assert_eq!(q.bits, 17, "100 001 codes");
        for v in [0.0, 0.004, 0.005, 123.456, 999.995, 1000.0] {
            let back = roundtrip(|w| q.write(w, v), |r| q.read(r).unwrap());
            assert!((back - v).abs() <= 0.005 + 1e-9, "{v} -> {back}");
            assert!((0.0..=1000.0).contains(&back));
        }
    }

    #[test]
    fn a_span_not_a_multiple_of_the_resolution_stays_in_bounds() {
        let q = Quant::new(Some((0.0, 1.0)), Some(0.3)).unwrap();
        assert!((q.value(3).unwrap() - 0.9).abs() < 1e-12);
        let top = Quant::new(Some((0.0, 1.0)), Some(0.4)).unwrap();
        assert_eq!(top.value(top.code(1.0)).unwrap(), 1.0, "capped at max");
        assert!(q.value(4).is_err());
    }

    #[test]
    fn unusable_declarations_have_no_quantiser() {
        assert!(Quant::new(None, Some(0.1)).is_none());
        assert!(Quant::new(Some((0.0, 1.0)), None).is_none());
        assert!(Quant::new(Some((0.0, 1.0)), Some(0.0)).is_none());
        assert!(Quant::new(Some((0.0, 1e300)), Some(1e-300)).is_none());
    }

    #[test]
    fn bounded_ints_are_exact() {
        let range = IntRange::new(Some((-3.5, 12.0))).unwrap();
        assert_eq!(range.bits, 4, "-3..=12 is 16 values");
        for v in [-3, 0, 12] {
            assert_eq!(roundtrip(|w| range.write(w, v), |r| range.read(r)), Ok(v));
        }
        let full = IntRange::new(Some((-9e18, 9e18))).unwrap();
        assert_eq!(
            roundtrip(|w| full.write(w, -9e18 as i64), |r| full.read(r)),
            Ok(-9e18 as i64)
        );
    }

    #[test]
    fn accuracy_is_within_a_twelfth_of_an_octave() {
        for a in [0.0, 0.000_1, 0.000_7, 0.01, 0.05, 0.3, 3.0, 20.0] {
            let back = roundtrip(|w| write_accuracy(w, a, 0.01), |r| read_accuracy(r, 0.01));
            let back = back.unwrap();
            let tolerance = (a * 0.091).max(0.01 / 32.0);
            assert!((back - a).abs() <= tolerance, "{a} -> {back}");
        }
    }

    #[test]
    fn huge_accuracy_escapes_to_an_exact_real() {
        let back = roundtrip(|w| write_accuracy(w, 1e6, 0.01), |r| read_accuracy(r, 0.01));
        assert_eq!(back, Ok(1e6));
    }

    #[test]
    fn confidence_steps_are_1_255() {
        for c in [0.0, 0.5, 0.8, 1.0] {
            let back = roundtrip(|w| write_confidence(w, c), |r| read_confidence(r).unwrap());
            assert!((back - c).abs() <= 0.5 / 255.0);
        }
    }
}
