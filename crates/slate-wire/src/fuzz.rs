//! The fuzzing entry point, shared by the property tests and a future libFuzzer target.
//! Compiled only with the `testing` feature: it is test support, not part of the codec.

use slate_model::{Address, AttrDecl, ClassDef, ValueType};

use crate::{Decoder, EncodeError, Encoder, Message, Schema};

/// The class definitions [`fuzz_decode`] decodes against, so that tests and fuzzers can
/// build valid messages to mutate: every value type, bounded and unbounded, with and
/// without defaults.
pub fn fuzz_classes() -> Vec<ClassDef> {
    let gsr = ClassDef::new("Gsr")
        .parent("Vehicle")
        .attr(AttrDecl::new("battery", ValueType::Int).bounds(0.0, 100.0));
    let obstacle = ClassDef::new("Obstacle")
        .attr(AttrDecl::new("observer", ValueType::Ref))
        .attr(AttrDecl::new("size", ValueType::Real).bounds(0.0, 50.0))
        .attr(AttrDecl::new("note", ValueType::Real))
        .attr(AttrDecl::new("hits", ValueType::Int))
        .attr(AttrDecl::new("shape", ValueType::Vector(3)));
    vec![vehicle(), gsr, obstacle]
}

/// A vehicle with a quantised pose and speed, a bounded vector, text and a flag.
fn vehicle() -> ClassDef {
    let real = |name| AttrDecl::new(name, ValueType::Real);
    let coord = |name| real(name).bounds(-10_000.0, 10_000.0).resolution(0.01);
    ClassDef::new("Vehicle")
        .attr(coord("x"))
        .attr(coord("y"))
        .attr(
            real("heading")
                .bounds(0.0, std::f64::consts::TAU)
                .resolution(0.001),
        )
        .attr(
            real("speed")
                .bounds(0.0, 20.0)
                .resolution(0.01)
                .default_packet(0.0, 0.1, 0.9),
        )
        .attr(
            AttrDecl::new("goal", ValueType::Vector(2))
                .bounds(-100.0, 100.0)
                .resolution(0.5),
        )
        .attr(AttrDecl::new("mode", ValueType::Str).default_value("auto"))
        .attr(AttrDecl::new("alive", ValueType::Bool).default_value(true))
}

/// The address [`fuzz_decode`] pretends its input came from.
pub fn fuzz_source() -> Address {
    Address::new("team/r1/fuzz").unwrap_or_else(|_| Address::unknown())
}

/// Decodes arbitrary bytes against [`fuzz_classes`], as a libFuzzer target would.
///
/// It must never panic on any input. When the input decodes, the message is encoded
/// again by a fresh encoder and decoded by a fresh decoder, and must come back equal
/// (quantisation is idempotent); a mismatch panics, which is what a fuzzer looks for.
/// Re-encoding may refuse what a lenient decoder accepts (a `Names` entry of a class we
/// lack, two entries for one object, growth past the size limit): that is no failure.
pub fn fuzz_decode(bytes: &[u8]) {
    let schema = Schema::new(&fuzz_classes());
    let from = fuzz_source();
    let Ok(msg) = Decoder::new().decode(&from, bytes, &schema) else {
        return;
    };
    let again = match Encoder::new(from.clone()).encode(&msg, &schema) {
        Ok(again) => again,
        Err(
            EncodeError::UnknownClass { .. }
            | EncodeError::ConflictingEntry(_)
            | EncodeError::TooLarge { .. },
        ) => {
            return;
        }
        Err(e) => panic!("a decoded message does not encode again: {e}\n{msg:?}"),
    };
    let back: Result<Message, _> = Decoder::new().decode(&from, &again, &schema);
    assert_eq!(
        back.as_ref(),
        Ok(&msg),
        "decode(encode(decode(x))) != decode(x)"
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn garbage_does_not_panic() {
        for bytes in [
            &[][..],
            &[0x11],
            &[0x11, 0xff, 0xff],
            &[0x13, 0x05],
            &[0xff; 64],
        ] {
            fuzz_decode(bytes);
        }
    }

    #[test]
    fn the_fuzz_schema_knows_every_class() {
        let schema = Schema::new(&fuzz_classes());
        assert_eq!(schema.value_bits("Gsr", "x"), Some(21));
        assert_eq!(schema.value_bits("Gsr", "battery"), Some(7));
    }
}
