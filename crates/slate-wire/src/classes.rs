//! The `Classes` body: class definitions in full (every `AttrDecl` field).

use std::time::Duration;

use slate_model::{AttrDecl, ClassDef, DefaultPacket, MergePolicy, ReportPolicy, Value, ValueType};

use crate::bits::{BitReader, BitWriter};
use crate::error::check_len;
use crate::text::{check_name, read_name};
use crate::value::{read_real, read_tagged, write_real, write_tagged};
use crate::{DecodeError, EncodeError, MAX_ITEMS, MAX_NAME_BYTES, MAX_TEXT_BYTES};

/// Checks that every class can be written (names, sizes, finite numbers).
pub(crate) fn check_classes(defs: &[ClassDef]) -> Result<(), EncodeError> {
    check_len("classes in a message", defs.len(), MAX_ITEMS)?;
    for def in defs {
        check_name(&def.name)?;
        check_name(&def.parent)?;
        check_len("attributes of a class", def.attrs.len(), MAX_ITEMS)?;
        for decl in &def.attrs {
            check_decl(decl).map_err(|reason| EncodeError::BadClass {
                class: def.name.clone(),
                reason,
            })?;
            check_name(&decl.name)?;
        }
    }
    Ok(())
}

fn check_decl(decl: &AttrDecl) -> Result<(), &'static str> {
    if decl_reals(decl).iter().any(|x| !x.is_finite()) {
        return Err("a number of an attribute declaration is not finite");
    }
    if decl.unit.as_ref().is_some_and(|u| u.len() > MAX_NAME_BYTES) {
        return Err("a unit is longer than the name limit");
    }
    let too_long = match decl.default.as_ref().map(|d| &d.value) {
        Some(Value::Str(s)) => s.len() > MAX_TEXT_BYTES,
        Some(Value::Ref(s)) => s.len() > MAX_NAME_BYTES,
        Some(Value::Vector(v)) => v.len() > usize::from(u16::MAX),
        _ => false,
    };
    if too_long {
        return Err("a default value is longer than the wire carries");
    }
    Ok(())
}

/// Every real a declaration holds.
fn decl_reals(d: &AttrDecl) -> Vec<f64> {
    let mut reals: Vec<f64> = [d.resolution, d.report.deadband]
        .into_iter()
        .flatten()
        .collect();
    if let Some((min, max)) = d.bounds {
        reals.extend([min, max]);
    }
    if let Some(p) = &d.default {
        reals.extend([p.accuracy, p.confidence]);
        if let Value::Real(x) = p.value {
            reals.push(x);
        }
        reals.extend(p.value.as_vector().unwrap_or(&[]));
    }
    reals
}

/// Writes the definitions (checked by [`check_classes`]).
pub(crate) fn write_classes(w: &mut BitWriter, defs: &[ClassDef]) {
    w.uvar(defs.len() as u64);
    for def in defs {
        w.str(&def.name);
        w.str(&def.parent);
        w.uvar(def.attrs.len() as u64);
        def.attrs.iter().for_each(|d| write_decl(w, d));
    }
}

/// Reads definitions written by [`write_classes`].
pub(crate) fn read_classes(r: &mut BitReader) -> Result<Vec<ClassDef>, DecodeError> {
    let n = r.count("classes in a message", MAX_ITEMS)?;
    let mut defs = Vec::new();
    for _ in 0..n {
        let mut def = ClassDef::new(&read_name(r)?).parent(&read_name(r)?);
        for _ in 0..r.count("attributes of a class", MAX_ITEMS)? {
            def.attrs.push(read_decl(r)?);
        }
        defs.push(def);
    }
    Ok(defs)
}

/// Writes one declaration: name, type, presence flags, then the present fields. This is
/// also the canonical form the schema fingerprint hashes.
pub(crate) fn write_decl(w: &mut BitWriter, d: &AttrDecl) {
    w.str(&d.name);
    write_type(w, d.ty);
    write_flags(w, d);
    w.bits(merge_number(d.merge), 2);
    if let Some(unit) = &d.unit {
        w.str(unit);
    }
    if let Some((min, max)) = d.bounds {
        write_real(w, min);
        write_real(w, max);
    }
    d.resolution.iter().for_each(|x| write_real(w, *x));
    if let Some(p) = &d.default {
        write_tagged(w, &p.value);
        write_real(w, p.accuracy);
        write_real(w, p.confidence);
    }
    let p = &d.report;
    [p.min_interval, p.heartbeat]
        .iter()
        .flatten()
        .for_each(|t| write_duration(w, *t));
    p.deadband.iter().for_each(|x| write_real(w, *x));
}

/// The presence flags, high bit first: unit, bounds, resolution, default, min interval,
/// heartbeat, deadband, on-accuracy.
fn write_flags(w: &mut BitWriter, d: &AttrDecl) {
    let p = &d.report;
    let flags = [
        d.unit.is_some(),
        d.bounds.is_some(),
        d.resolution.is_some(),
        d.default.is_some(),
        p.min_interval.is_some(),
        p.heartbeat.is_some(),
        p.deadband.is_some(),
        p.on_accuracy,
    ];
    flags.into_iter().for_each(|f| w.bit(f));
}

fn read_decl(r: &mut BitReader) -> Result<AttrDecl, DecodeError> {
    let mut d = AttrDecl::new(&read_name(r)?, read_type(r)?);
    let flags = r.bits(8)?;
    let has = |bit: u32| flags & (1 << (7 - bit)) != 0;
    d.merge = merge_of(r.bits(2)?);
    if has(0) {
        d.unit = Some(r.str("unit length", MAX_NAME_BYTES)?);
    }
    if has(1) {
        d.bounds = Some((read_real(r)?, read_real(r)?));
    }
    if has(2) {
        d.resolution = Some(read_real(r)?);
    }
    if has(3) {
        d.default = Some(read_default(r)?);
    }
    d.report = read_policy(r, |bit| has(bit + 4))?;
    Ok(d)
}

fn read_default(r: &mut BitReader) -> Result<DefaultPacket, DecodeError> {
    Ok(DefaultPacket {
        value: read_tagged(r)?,
        accuracy: read_real(r)?,
        confidence: read_real(r)?,
    })
}

/// Reads the report policy; `has(0..4)` are the min-interval, heartbeat, deadband and
/// on-accuracy flags.
fn read_policy(r: &mut BitReader, has: impl Fn(u32) -> bool) -> Result<ReportPolicy, DecodeError> {
    let min_interval = has(0).then(|| read_duration(r)).transpose()?;
    let heartbeat = has(1).then(|| read_duration(r)).transpose()?;
    let deadband = has(2).then(|| read_real(r)).transpose()?;
    Ok(ReportPolicy {
        min_interval,
        heartbeat,
        deadband,
        on_accuracy: has(3),
    })
}

const TYPES: [ValueType; 5] = [
    ValueType::Int,
    ValueType::Real,
    ValueType::Bool,
    ValueType::Str,
    ValueType::Ref,
];

/// A value type: 3 bits (int, real, bool, string, ref, vector), a vector's length after.
fn write_type(w: &mut BitWriter, ty: ValueType) {
    match ty {
        ValueType::Vector(n) => {
            w.bits(5, 3);
            w.uvar(n.into());
        }
        other => w.bits(
            TYPES.iter().position(|t| *t == other).unwrap_or(0) as u64,
            3,
        ),
    }
}

fn read_type(r: &mut BitReader) -> Result<ValueType, DecodeError> {
    match r.bits(3)? as usize {
        5 => Ok(ValueType::Vector(
            r.count("vector length", u16::MAX.into())? as u16,
        )),
        n => TYPES
            .get(n)
            .copied()
            .ok_or(DecodeError::BadValue("reserved value type")),
    }
}

const MERGES: [MergePolicy; 4] = [
    MergePolicy::Latest,
    MergePolicy::Confident,
    MergePolicy::Fused,
    MergePolicy::Owned,
];

fn merge_number(m: MergePolicy) -> u64 {
    MERGES.iter().position(|x| *x == m).unwrap_or(0) as u64
}

fn merge_of(n: u64) -> MergePolicy {
    MERGES[n as usize & 3]
}

/// A duration: whole seconds, then nanoseconds, as varints.
fn write_duration(w: &mut BitWriter, t: Duration) {
    w.uvar(t.as_secs());
    w.uvar(t.subsec_nanos().into());
}

fn read_duration(r: &mut BitReader) -> Result<Duration, DecodeError> {
    let secs = r.uvar()?;
    let nanos = r.uvar()?;
    if nanos >= 1_000_000_000 {
        return Err(DecodeError::BadValue("duration nanoseconds out of range"));
    }
    Ok(Duration::new(secs, nanos as u32))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn full_class() -> ClassDef {
        let policy = ReportPolicy {
            min_interval: Some(Duration::from_millis(200)),
            heartbeat: Some(Duration::from_secs(5)),
            deadband: Some(0.05),
            on_accuracy: true,
        };
        ClassDef::new("Vehicle")
            .parent("Thing")
            .attr(
                AttrDecl::new("heading", ValueType::Real)
                    .unit("rad")
                    .bounds(-3.2, 3.2)
                    .resolution(0.001)
                    .default_packet(0.0, 3.2, 0.5)
                    .merge(MergePolicy::Fused)
                    .report(policy),
            )
            .attr(AttrDecl::new("goal", ValueType::Vector(2)).default_value([1.0, 2.0]))
            .attr(AttrDecl::new("mode", ValueType::Str).default_value("auto"))
            .attr(AttrDecl::new("n", ValueType::Int).merge(MergePolicy::Owned))
    }

    #[test]
    fn class_definitions_roundtrip_in_full() {
        let defs = vec![full_class(), ClassDef::new("Gsr").parent("Vehicle")];
        check_classes(&defs).unwrap();
        let mut w = BitWriter::new();
        write_classes(&mut w, &defs);
        let bytes = w.finish();
        let mut r = BitReader::new(&bytes);
        assert_eq!(read_classes(&mut r), Ok(defs));
        r.finish().unwrap();
    }

    #[test]
    fn unwritable_definitions_are_refused() {
        let nan =
            ClassDef::new("C").attr(AttrDecl::new("x", ValueType::Real).bounds(0.0, f64::NAN));
        assert!(matches!(
            check_classes(&[nan]),
            Err(EncodeError::BadClass { .. })
        ));
        let bad = ClassDef::new("C").attr(AttrDecl::new("a b", ValueType::Real));
        assert!(matches!(
            check_classes(&[bad]),
            Err(EncodeError::BadName(_))
        ));
    }
}
