//! Looking at a board as a whole: the attributes an object has (its class chain's
//! declarations) and their packets. The dashboard and the CLI's `get` use these.

use slate_model::{AttrDecl, Board, ClassDef, ClassTree, Packet, THING, Value, ValueType};

/// The classes of a board, to walk class chains without asking the board again: the
/// board's [`ClassTree`] (its rules for chains and inherited declarations), with chains
/// as people read them, without `Thing`.
pub struct Classes(ClassTree);

impl Classes {
    /// The board's classes now.
    pub fn of(board: &Board) -> Self {
        Classes(board.class_tree())
    }

    /// Every class but `Thing`, by name.
    pub fn defs(&self) -> impl Iterator<Item = &ClassDef> {
        self.0.defs()
    }

    /// `class` and its ancestors, class first, up to (and without) `Thing`; empty for a
    /// class it does not know.
    pub fn lineage(&self, class: &str) -> Vec<&str> {
        self.0
            .lineage(class)
            .into_iter()
            .flat_map(|l| l.iter())
            .map(|c| &**c)
            .filter(|c| *c != THING)
            .collect()
    }

    /// The declaration of `attr` that an instance of `class` (or the class itself) has.
    pub fn decl(&self, class: &str, attr: &str) -> Option<&AttrDecl> {
        self.0.decl(class, attr)
    }

    /// Every attribute an instance of `class` has, inherited ones first.
    pub fn attributes(&self, class: &str) -> Vec<&str> {
        self.0
            .declarations(class)
            .map(|(_, a)| a.name.as_str())
            .collect()
    }
}

/// Every attribute of `object` (an object or a class) that has a value, with the packet a
/// read returns (own, class-level, or default; on-read functions applied). `None` if
/// there is no such object.
pub fn packets(board: &Board, classes: &Classes, object: &str) -> Option<Vec<(String, Packet)>> {
    let info = board.info(object)?;
    let class = if info.is_class { object } else { &*info.class };
    let list = classes
        .attributes(class)
        .into_iter()
        .filter_map(|attr| {
            let p = board.read(object, attr).ok()?;
            (!p.value.is_none()).then(|| (attr.to_owned(), p))
        })
        .collect();
    Some(list)
}

/// A value typed on a command line, read as the declared type: `2.5`, `3`, `true`,
/// `auto` or `"auto"`, `&gsr` or `gsr` for a reference, `[1.5, 2]` or `1.5,2` for a
/// vector. An integer is accepted for a real.
pub fn parse_value(text: &str, ty: ValueType) -> Result<Value, String> {
    let t = text.trim();
    let bad = || format!("{text:?} is not a {ty}");
    match ty {
        ValueType::Int => t.parse::<i64>().map(Value::Int).map_err(|_| bad()),
        ValueType::Real => real(t).map(Value::Real).ok_or_else(bad),
        ValueType::Bool => match t {
            "true" => Ok(Value::Bool(true)),
            "false" => Ok(Value::Bool(false)),
            _ => Err(format!("{text:?} is not a bool (true or false)")),
        },
        ValueType::Str => {
            let unquoted = t.strip_prefix('"').and_then(|s| s.strip_suffix('"'));
            Ok(Value::from(unquoted.unwrap_or(text)))
        }
        ValueType::Ref => Ok(Value::reference(t.strip_prefix('&').unwrap_or(t))),
        ValueType::Vector(n) => {
            let inner = t
                .strip_prefix('[')
                .and_then(|s| s.strip_suffix(']'))
                .unwrap_or(t);
            let xs: Option<Vec<f64>> = inner.split(',').map(|x| real(x.trim())).collect();
            match xs {
                Some(xs) if xs.len() == usize::from(n) => Ok(Value::from(xs)),
                _ => Err(format!("{text:?} is not a vec<{n}> (like [1.5, 2.0])")),
            }
        }
    }
}

fn real(t: &str) -> Option<f64> {
    t.parse::<f64>().ok().filter(|x| x.is_finite())
}

#[cfg(test)]
mod tests {

    use super::*;

    #[test]
    fn attributes_follow_the_class_chain() {
        let board = Board::new();
        board
            .define(
                ClassDef::new("Vehicle")
                    .attr(AttrDecl::new("speed", ValueType::Real).default_value(0.0)),
            )
            .unwrap();
        board
            .define(
                ClassDef::new("Rover")
                    .parent("Vehicle")
                    .attr(AttrDecl::new("wheels", ValueType::Int)),
            )
            .unwrap();
        board.create("Rover", "r2").unwrap();
        let classes = Classes::of(&board);
        assert_eq!(classes.lineage("Rover"), ["Rover", "Vehicle"]);
        assert_eq!(classes.attributes("Rover"), ["speed", "wheels"]);
        let got = packets(&board, &classes, "r2").unwrap();
        assert_eq!(got.len(), 1, "wheels has no value: {got:?}");
        assert_eq!(got[0].0, "speed");
        board.write("r2", "wheels", 6).unwrap();
        assert_eq!(packets(&board, &classes, "r2").unwrap().len(), 2);
        assert!(packets(&board, &classes, "nothing").is_none());
        assert_eq!(
            classes.decl("Rover", "speed").map(|d| d.ty),
            Some(ValueType::Real)
        );
        assert!(classes.decl("Vehicle", "wheels").is_none());
    }

    #[test]
    fn a_class_chain_deeper_than_64_is_read_whole() {
        let board = Board::new();
        board
            .define(ClassDef::new("C0").attr(AttrDecl::new("x", ValueType::Int)))
            .unwrap();
        for i in 1..70 {
            let def = ClassDef::new(&format!("C{i}")).parent(&format!("C{}", i - 1));
            board.define(def).unwrap();
        }
        let classes = Classes::of(&board);
        assert_eq!(classes.lineage("C69").len(), 70);
        assert_eq!(classes.attributes("C69"), ["x"]);
        assert!(classes.decl("C69", "x").is_some());
    }

    #[test]
    fn command_line_values_follow_the_declared_type() {
        assert_eq!(parse_value("3", ValueType::Real), Ok(Value::Real(3.0)));
        assert_eq!(parse_value("-2", ValueType::Int), Ok(Value::Int(-2)));
        assert_eq!(parse_value("true", ValueType::Bool), Ok(Value::Bool(true)));
        assert_eq!(
            parse_value("\"auto\"", ValueType::Str),
            Ok(Value::from("auto"))
        );
        assert_eq!(parse_value("auto", ValueType::Str), Ok(Value::from("auto")));
        assert_eq!(
            parse_value("&gsr", ValueType::Ref),
            Ok(Value::reference("gsr"))
        );
        assert_eq!(
            parse_value("[1, 2.5]", ValueType::Vector(2)),
            Ok(Value::from(vec![1.0, 2.5]))
        );
        assert_eq!(
            parse_value("1,2.5", ValueType::Vector(2)),
            Ok(Value::from(vec![1.0, 2.5]))
        );
        for (text, ty) in [
            ("fast", ValueType::Real),
            ("1.5", ValueType::Int),
            ("yes", ValueType::Bool),
            ("[1]", ValueType::Vector(2)),
            ("inf", ValueType::Real),
        ] {
            assert!(parse_value(text, ty).is_err(), "{text} as {ty}");
        }
    }
}
