//! Packets as every receiver will decode them: the writer stores its own packets that
//! way (and fuses its own estimate that way), so every board holds the same packet. The
//! arithmetic is slate-wire's ([`slate_wire::quantise`]); a property test here checks it
//! against a slate-wire round trip, so the two cannot drift apart unnoticed.

use slate_model::{AttrDecl, Board, Normaliser, Packet, Update};
use slate_wire::quantise;

use super::classes::Catalog;

/// The board's [`Normaliser`] while an ICI runs it: every packet the module writes is
/// stored quantised, so the writer holds exactly what its receivers decode.
pub(crate) struct Quantiser;

impl Normaliser for Quantiser {
    fn normalise(&self, decl: &AttrDecl, packet: &mut Packet) {
        quantise(decl, packet);
    }
}

/// Stores the quantised form of the packets the board wrote itself before its ICI
/// started (from then on the [`Quantiser`] does it), in one batch.
pub(crate) fn settle(board: &Board) {
    let catalog = Catalog::new(board);
    let mut batch = board.batch();
    {
        let snap = board.snapshot();
        for id in snap.objects() {
            let Some(info) = snap.info(id) else { continue };
            let class = if info.is_class {
                &info.name
            } else {
                &info.class
            };
            let own = snap.own_values(id).into_iter();
            for (attr, packet, _) in own.filter(|(_, p, _)| p.source == *board.address()) {
                let Some(decl) = catalog.decl(class, &attr) else {
                    continue;
                };
                let mut q = packet.clone();
                quantise(decl, &mut q);
                if q != packet {
                    batch.write_shared(info.name.clone(), attr, Update::from(q));
                }
            }
        }
    }
    if !batch.is_empty()
        && let Err(e) = batch.commit()
    {
        tracing::warn!(error = %e, "own packets written before the ICI started stay exact");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use slate_model::{Address, ClassDef, MANUAL_EPOCH, Timestamp, Value, ValueType};
    use slate_wire::{Assertion, Decoder, Encoder, Message, ObjectEntry, Report, Schema};

    fn quantised(decl: &AttrDecl, packet: &Packet) -> Packet {
        let mut q = packet.clone();
        quantise(decl, &mut q);
        q
    }

    /// What a receiver decodes, through slate-wire.
    fn decoded(decl: &AttrDecl, packet: &Packet) -> Packet {
        let me = Address::new("t/r1/a").unwrap();
        let schema = Schema::new(&[ClassDef::new("T").attr(decl.clone())]);
        let msg = Message::Report(Report {
            seq: 1,
            items: vec![Assertion {
                object: ObjectEntry::new("t", "T").owner(me.clone()),
                attr: decl.name.as_str().into(),
                packet: packet.clone(),
            }],
        });
        let bytes = Encoder::new(me.clone()).encode(&msg, &schema).unwrap();
        match Decoder::new().decode(&me, &bytes, &schema).unwrap() {
            Message::Report(mut r) => r.items.pop().unwrap().packet,
            other => panic!("{other:?}"),
        }
    }

    fn packet(value: Value, accuracy: f64, confidence: f64) -> Packet {
        Packet {
            value,
            accuracy,
            confidence,
            timestamp: Timestamp::from_duration(MANUAL_EPOCH),
            source: Address::new("t/r1/a").unwrap(),
        }
    }

    #[test]
    fn a_bounded_real_snaps_to_its_resolution_and_qualities_to_their_scales() {
        let decl = AttrDecl::new("v", ValueType::Real)
            .bounds(0.0, 100.0)
            .resolution(0.5);
        let p = packet(Value::Real(10.2), 0.3, 0.333);
        let q = quantised(&decl, &p);
        assert_eq!(q.value.as_f64(), Some(10.0));
        assert_eq!(q, decoded(&decl, &p));
    }

    fn decl_strategy() -> impl Strategy<Value = AttrDecl> {
        let bounds = prop_oneof![
            Just(None),
            (-1e4f64..1e4, 0.0f64..1e4).prop_map(|(lo, span)| Some((lo, lo + span))),
        ];
        let res = prop_oneof![Just(None), (1e-4f64..10.0).prop_map(Some)];
        let default = prop_oneof![Just(None), (0.0f64..5.0, 0.0f64..=1.0).prop_map(Some),];
        (bounds, res, default, any::<bool>()).prop_map(|(b, r, d, vector)| {
            let ty = if vector {
                ValueType::Vector(2)
            } else {
                ValueType::Real
            };
            let mut decl = AttrDecl::new("v", ty);
            if let Some((lo, hi)) = b {
                decl = decl.bounds(lo, hi);
            }
            if let Some(r) = r {
                decl = decl.resolution(r);
            }
            if let Some((acc, conf)) = d {
                let zero = if vector {
                    Value::Vector(vec![0.0, 0.0].into())
                } else {
                    Value::Real(0.0)
                };
                decl.default = Some(slate_model::DefaultPacket {
                    value: zero,
                    accuracy: acc,
                    confidence: conf,
                });
            }
            decl
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]

        #[test]
        fn the_arithmetic_is_the_codec(
            decl in decl_strategy(),
            x in 0.0f64..=1.0,
            y in 0.0f64..=1.0,
            accuracy in prop_oneof![Just(0.0), 0.0f64..1e-3, 0.0f64..1e5],
            confidence in prop_oneof![Just(1.0), Just(0.0), 0.0f64..=1.0],
        ) {
            let (lo, hi) = decl.bounds.unwrap_or((-1e6, 1e6));
            let at = |t: f64| lo + t * (hi - lo);
            let value = match decl.ty {
                ValueType::Vector(_) => Value::Vector(vec![at(x), at(y)].into()),
                _ => Value::Real(at(x)),
            };
            let p = packet(value, accuracy, confidence);
            prop_assert_eq!(quantised(&decl, &p), decoded(&decl, &p));
        }
    }
}
