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
        let span = (max - min) / res;
        if span >= MAX_STEPS {
            return None;
        }
        let steps = round_half_up(span);
        if steps >= MAX_STEPS as u64 {
            return None;
        }
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
        round_half_up((v - self.min) / self.res).min(self.steps)
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

/// `x.round()` as an integer, for `x >= 0` (0 for a negative `x` or NaN, `u64::MAX` at
/// most). On baseline x86-64 `f64::round` is a library call, and every update rounds a
/// real two or three times.
fn round_half_up(x: f64) -> u64 {
    let whole = x as u64;
    if x - whole as f64 >= 0.5 {
        whole.saturating_add(1)
    } else {
        whole
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
/// `2^((k - 17) / 4)` for every code `k` below `ACCURACY_ESCAPE` (a test checks each
/// against `exp2`): a table, because an accuracy is coded and decoded on every update.
/// Entry 0 is never read (code 0 is an accuracy of 0); it keeps codes and indices equal.
#[allow(clippy::approx_constant, clippy::excessive_precision)]
const ACCURACY_STEPS: [f64; ACCURACY_ESCAPE as usize] = [
    0.052556025953357156,
    0.0625,
    0.07432544468767006,
    0.08838834764831845,
    0.10511205190671431,
    0.125,
    0.14865088937534013,
    0.1767766952966369,
    0.21022410381342863,
    0.25,
    0.29730177875068026,
    0.3535533905932738,
    0.42044820762685725,
    0.5,
    0.5946035575013605,
    0.7071067811865476,
    0.8408964152537145,
    1.0,
    1.189207115002721,
    1.4142135623730951,
    1.681792830507429,
    2.0,
    2.378414230005442,
    2.8284271247461903,
    3.363585661014858,
    4.0,
    4.756828460010884,
    5.656854249492381,
    6.727171322029716,
    8.0,
    9.513656920021768,
    11.313708498984761,
    13.454342644059432,
    16.0,
    19.027313840043536,
    22.627416997969522,
    26.908685288118864,
    32.0,
    38.05462768008707,
    45.254833995939045,
    53.81737057623773,
    64.0,
    76.10925536017415,
    90.50966799187809,
    107.63474115247546,
    128.0,
    152.2185107203483,
    181.01933598375618,
    215.2694823049509,
    256.0,
    304.4370214406966,
    362.03867196751236,
    430.5389646099018,
    512.0,
    608.8740428813932,
    724.0773439350247,
    861.0779292198037,
    1024.0,
    1217.7480857627863,
    1448.1546878700494,
    1722.1558584396073,
    2048.0,
    2435.4961715255727,
];

/// Where `4 * log2(m)` rounds up to the next quarter octave, for a mantissa `m` in
/// `[1, 2)`: `2^(1/8)`, `2^(3/8)`, `2^(5/8)`, `2^(7/8)`.
#[allow(clippy::excessive_precision)]
const QUARTER_MIDPOINTS: [f64; 4] = [
    1.0905077326652577,
    1.2968395546510096,
    1.5422108254079407,
    1.8340080864093424,
];

/// The accuracy of code `k` below `ACCURACY_ESCAPE`: 0 for code 0, else
/// `scale * 2^((k - 17) / 4)`.
fn accuracy_of(k: u64, scale: f64) -> f64 {
    if k == 0 {
        return 0.0;
    }
    scale * ACCURACY_STEPS[k as usize]
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

/// The code of accuracy `a` (finite, `>= 0`), or `None` if it is beyond the log scale
/// (escape): `round(4 * log2(a / scale)) + 17`, taken from the binary exponent of
/// `a / scale` and where its mantissa falls among the quarter octaves (no `log2`).
fn accuracy_code(a: f64, scale: f64) -> Option<u64> {
    let smallest = accuracy_of(1, scale);
    if a < smallest / 2.0 {
        return Some(0);
    }
    if a <= smallest {
        return Some(1);
    }
    let bits = (a / scale).to_bits();
    let exponent = ((bits >> 52) & 0x7ff) as i64 - 1023;
    let mantissa = f64::from_bits((bits & ((1 << 52) - 1)) | (1023 << 52));
    let quarter = QUARTER_MIDPOINTS.iter().filter(|m| mantissa >= **m).count() as i64;
    let k = 4 * exponent + quarter + ACCURACY_ONE;
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
            if !(a.is_finite() && a >= 0.0) || accuracy_code(a, scale).is_some() {
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
    round_half_up(c * CONFIDENCE_STEPS).min(CONFIDENCE_STEPS as u64)
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
    fn rounding_half_up_is_round() {
        let half_below = 0.5 - f64::EPSILON / 4.0;
        for x in [
            0.0,
            0.3,
            0.5,
            half_below,
            1.5,
            2.4999,
            2.5,
            1e15 + 0.5,
            4503599627370495.5,
        ] {
            assert_eq!(round_half_up(x), x.round() as u64, "{x}");
        }
        assert_eq!(round_half_up(-0.7), 0);
        assert_eq!(round_half_up(f64::NAN), 0);
        assert_eq!(round_half_up(1e300), u64::MAX);
    }

    #[test]
    fn the_accuracy_tables_are_the_powers_they_stand_for() {
        for (k, step) in ACCURACY_STEPS.iter().enumerate() {
            let exact = ((k as i64 - ACCURACY_ONE) as f64 / 4.0).exp2();
            assert_eq!(step.to_bits(), exact.to_bits(), "code {k}");
        }
        for (i, m) in QUARTER_MIDPOINTS.iter().enumerate() {
            let exact = ((2 * i + 1) as f64 / 8.0).exp2();
            assert_eq!(m.to_bits(), exact.to_bits(), "midpoint {i}");
        }
    }

    #[test]
    fn accuracy_codes_round_the_log_to_the_nearest_quarter_octave() {
        let by_log = |a: f64, scale: f64| {
            let k = (4.0 * (a / scale).log2()).round() as i64 + ACCURACY_ONE;
            (k < ACCURACY_ESCAPE as i64).then_some(k as u64)
        };
        let mut a: f64 = 1e-4;
        while a < 1e4 {
            for scale in [0.01f64, 0.5, 1.0, 3.0] {
                let x = 4.0 * (a / scale).log2();
                let near_a_midpoint = (x - x.floor() - 0.5).abs() < 1e-9;
                if a > accuracy_of(1, scale) && !near_a_midpoint {
                    assert_eq!(accuracy_code(a, scale), by_log(a, scale), "{a} at {scale}");
                }
                // Coding a decoded accuracy gives its code back (a writer stores what
                // its receivers decode).
                if let Some(k) = accuracy_code(a, scale) {
                    assert_eq!(accuracy_code(accuracy_of(k, scale), scale), Some(k));
                }
            }
            a *= 1.0137;
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
