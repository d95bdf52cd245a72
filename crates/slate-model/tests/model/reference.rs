//! Model-based property test: random operation sequences run against the real board and
//! a tiny reference model (plain maps, no cleverness); every read must agree.

use std::collections::BTreeMap;

use proptest::prelude::*;
use slate_model::{Board, Clock, Update, Value};

use crate::support::board;

const OBJECTS: [&str; 5] = ["a", "b", "c", "d", "e"];
const CLASSES: [&str; 5] = ["Vehicle", "GroundVehicle", "Gsr", "Obstacle", "Thing"];
const ATTRS: [&str; 6] = ["speed", "mode", "wheels", "armed", "range", "position"];

type Fields = (Value, f64, f64);

#[derive(Clone, Debug)]
struct Decl {
    class: &'static str,
    kind: &'static str,
    bounds: Option<(f64, f64)>,
    default: Option<Fields>,
}

/// The reference model: what the world module in `world.rs` declares, and plain maps.
#[derive(Clone, Debug, Default)]
struct Model {
    objects: BTreeMap<&'static str, &'static str>,
    values: BTreeMap<(&'static str, &'static str), Fields>,
}

fn parent(class: &str) -> Option<&'static str> {
    match class {
        "Gsr" => Some("GroundVehicle"),
        "GroundVehicle" => Some("Vehicle"),
        "Vehicle" | "Obstacle" => Some("Thing"),
        _ => None,
    }
}

fn decl(attr: &str) -> Decl {
    let d = |class, kind, bounds, default| Decl {
        class,
        kind,
        bounds,
        default,
    };
    match attr {
        "speed" => d(
            "Vehicle",
            "real",
            Some((0.0, 50.0)),
            Some((Value::Real(0.0), 0.5, 0.5)),
        ),
        "mode" => d(
            "Vehicle",
            "str",
            None,
            Some((Value::from("idle"), 0.0, 1.0)),
        ),
        "wheels" => d("Vehicle", "int", Some((0.0, 16.0)), None),
        "armed" => d(
            "GroundVehicle",
            "bool",
            None,
            Some((Value::Bool(false), 0.0, 1.0)),
        ),
        "range" => d(
            "Obstacle",
            "real",
            None,
            Some((Value::Real(100.0), 0.0, 1.0)),
        ),
        _ => d("Vehicle", "vec2", None, None),
    }
}

impl Model {
    fn is_class(name: &str) -> bool {
        CLASSES.contains(&name)
    }

    /// The class chain of a target, starting where class-level values are looked up.
    fn chain(&self, target: &'static str) -> Option<Vec<&'static str>> {
        let mut c = if Self::is_class(target) {
            parent(target)
        } else {
            Some(*self.objects.get(target)?)
        };
        let mut out = Vec::new();
        while let Some(class) = c {
            out.push(class);
            c = parent(class);
        }
        Some(out)
    }

    fn has_attr(&self, target: &'static str, attr: &str) -> bool {
        let d = decl(attr);
        let own_class = Self::is_class(target).then_some(target);
        own_class
            .into_iter()
            .chain(self.chain(target).unwrap_or_default())
            .any(|c| c == d.class)
    }

    fn exists(&self, target: &str) -> bool {
        Self::is_class(target) || self.objects.contains_key(target)
    }

    fn read(&self, target: &'static str, attr: &'static str) -> Result<Fields, ()> {
        if !self.exists(target) || !self.has_attr(target, attr) {
            return Err(());
        }
        if let Some(v) = self.values.get(&(target, attr)) {
            return Ok(v.clone());
        }
        let d = decl(attr);
        for class in self.chain(target).unwrap_or_default() {
            if let Some(v) = self.values.get(&(class, attr)) {
                return Ok(v.clone());
            }
            if class == d.class {
                break;
            }
        }
        Ok(d.default.unwrap_or((Value::None, 0.0, 0.0)))
    }

    fn write(&mut self, target: &'static str, attr: &'static str, w: &Write) -> Result<(), ()> {
        if !self.exists(target) || !self.has_attr(target, attr) {
            return Err(());
        }
        let d = decl(attr);
        let type_ok = matches!(
            (d.kind, &w.value),
            ("real", Value::Real(_))
                | ("int", Value::Int(_))
                | ("str", Value::Str(_))
                | ("bool", Value::Bool(_))
        ) || (d.kind == "vec2" && w.value.as_vector().is_some_and(|v| v.len() == 2));
        let in_bounds = d
            .bounds
            .is_none_or(|(lo, hi)| w.value.as_f64().is_none_or(|x| (lo..=hi).contains(&x)));
        let (da, dc) = d.default.as_ref().map_or((0.0, 1.0), |f| (f.1, f.2));
        let (acc, conf) = (w.accuracy.unwrap_or(da), w.confidence.unwrap_or(dc));
        if !type_ok || !in_bounds || acc < 0.0 || !(0.0..=1.0).contains(&conf) {
            return Err(());
        }
        self.values
            .insert((target, attr), (w.value.clone(), acc, conf));
        Ok(())
    }

    fn create(&mut self, class: &'static str, name: &'static str) -> Result<(), ()> {
        if class == "Thing" || self.objects.contains_key(name) {
            // The board allows instances of Thing; the model keeps it simple and so does
            // the generator: it never creates Things (see `op`).
            return Err(());
        }
        self.objects.insert(name, class);
        Ok(())
    }

    fn delete(&mut self, name: &'static str) -> Result<(), ()> {
        self.objects.remove(name).ok_or(())?;
        self.values.retain(|(t, _), _| *t != name);
        Ok(())
    }
}

#[derive(Clone, Debug)]
struct Write {
    value: Value,
    accuracy: Option<f64>,
    confidence: Option<f64>,
}

#[derive(Clone, Debug)]
enum Op {
    Create(&'static str, &'static str),
    Delete(&'static str),
    Write(&'static str, &'static str, Write),
    Read(&'static str, &'static str),
    Batch(Vec<Op>),
}

fn value() -> impl Strategy<Value = Value> {
    prop_oneof![
        (-2i64..20).prop_map(Value::Int),
        (-5.0f64..60.0).prop_map(Value::Real),
        prop::sample::select(vec!["idle", "go", "stop"]).prop_map(Value::from),
        any::<bool>().prop_map(Value::Bool),
        (-1.0f64..1.0, -1.0f64..1.0).prop_map(|(x, y)| Value::from([x, y])),
    ]
}

fn write() -> impl Strategy<Value = Write> {
    let acc = prop::option::of(prop::sample::select(vec![-1.0, 0.0, 0.1, 0.5]));
    let conf = prop::option::of(prop::sample::select(vec![0.0, 0.3, 1.0, 1.5]));
    (value(), acc, conf).prop_map(|(value, accuracy, confidence)| Write {
        value,
        accuracy,
        confidence,
    })
}

fn target() -> impl Strategy<Value = &'static str> {
    prop_oneof![4 => prop::sample::select(OBJECTS.to_vec()), 1 => prop::sample::select(CLASSES.to_vec())]
}

fn simple_op() -> impl Strategy<Value = Op> {
    let attr = || prop::sample::select(ATTRS.to_vec());
    prop_oneof![
        2 => (prop::sample::select(CLASSES[..4].to_vec()), prop::sample::select(OBJECTS.to_vec()))
            .prop_map(|(c, n)| Op::Create(c, n)),
        1 => prop::sample::select(OBJECTS.to_vec()).prop_map(Op::Delete),
        5 => (target(), attr(), write()).prop_map(|(t, a, w)| Op::Write(t, a, w)),
        3 => (target(), attr()).prop_map(|(t, a)| Op::Read(t, a)),
    ]
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        8 => simple_op(),
        1 => prop::collection::vec(simple_op(), 1..6).prop_map(|ops| Op::Batch(ops.into_iter().filter(|o| !matches!(o, Op::Read(..))).collect())),
    ]
}

fn update(w: &Write) -> Update {
    let mut u = Update::new(w.value.clone());
    u.accuracy = w.accuracy;
    u.confidence = w.confidence;
    u
}

fn check_read(
    board: &Board,
    model: &Model,
    t: &'static str,
    a: &'static str,
) -> Result<(), TestCaseError> {
    let real = board.read(t, a);
    match (model.read(t, a), real) {
        (Ok((v, acc, conf)), Ok(p)) => {
            prop_assert_eq!(&p.value, &v, "{}.{} value", t, a);
            prop_assert_eq!(
                (p.accuracy, p.confidence),
                (acc, conf),
                "{}.{} quality",
                t,
                a
            );
        }
        (Err(()), Err(_)) => {}
        (m, r) => prop_assert!(false, "{}.{}: model {:?}, board {:?}", t, a, m, r),
    }
    Ok(())
}

fn apply(board: &Board, model: &mut Model, op: &Op) -> Result<(), TestCaseError> {
    match op {
        Op::Create(c, n) => prop_assert_eq!(
            model.create(c, n).is_ok(),
            board.create(c, n).is_ok(),
            "create {} {}",
            c,
            n
        ),
        Op::Delete(n) => prop_assert_eq!(
            model.delete(n).is_ok(),
            board.delete(n).is_ok(),
            "delete {}",
            n
        ),
        Op::Write(t, a, w) => {
            let real = board.write(t, a, update(w));
            prop_assert_eq!(
                model.write(t, a, w).is_ok(),
                real.is_ok(),
                "write {}.{} {:?}: {:?}",
                t,
                a,
                w,
                real
            );
        }
        Op::Read(t, a) => check_read(board, model, t, a)?,
        Op::Batch(ops) => {
            let mut trial = model.clone();
            let model_ok = ops.iter().all(|o| match o {
                Op::Create(c, n) => trial.create(c, n).is_ok(),
                Op::Delete(n) => trial.delete(n).is_ok(),
                Op::Write(t, a, w) => trial.write(t, a, w).is_ok(),
                _ => true,
            });
            let mut batch = board.batch();
            for o in ops {
                match o {
                    Op::Create(c, n) => drop(batch.create(c, n)),
                    Op::Delete(n) => drop(batch.delete(n)),
                    Op::Write(t, a, w) => drop(batch.write(t, a, update(w))),
                    _ => {}
                }
            }
            let real = batch.commit();
            prop_assert_eq!(model_ok, real.is_ok(), "batch {:?}: {:?}", ops, real);
            if model_ok {
                *model = trial;
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn board_agrees_with_the_reference_model(ops in prop::collection::vec(op(), 1..60)) {
        let board = board();
        let _ = Clock::manual();
        let mut model = Model::default();
        for op in &ops {
            apply(&board, &mut model, op)?;
        }
        // Finally every read of every target and attribute agrees.
        for t in OBJECTS.iter().chain(CLASSES.iter()) {
            for a in ATTRS {
                check_read(&board, &model, t, a)?;
            }
        }
    }
}
