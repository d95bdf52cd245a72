use slate_model::{
    AttrDecl, ClassDef, Context, CreateError, DefineError, DeleteError, NewObject, Query,
    ReadError, Value, ValueType,
};

use crate::support::{board, with_vehicle};

#[test]
fn inheritance_through_three_levels_with_class_level_values() {
    let b = board();
    b.create("Gsr", "gsr").unwrap();
    // Declared default on Vehicle, two levels above Gsr.
    assert_eq!(b.read("gsr", "mode").unwrap().value, Value::from("idle"));
    // A class-level value on the middle class overrides the declared default.
    b.write("GroundVehicle", "mode", "patrol").unwrap();
    assert_eq!(b.read("gsr", "mode").unwrap().value, Value::from("patrol"));
    // The nearest class-level value wins.
    b.write("Gsr", "mode", "survey").unwrap();
    b.write("Vehicle", "mode", "parked").unwrap();
    assert_eq!(b.read("gsr", "mode").unwrap().value, Value::from("survey"));
    // The object's own value wins over all of them.
    b.write("gsr", "mode", "manual").unwrap();
    assert_eq!(b.read("gsr", "mode").unwrap().value, Value::from("manual"));
    // Classes read through their own chain too.
    assert_eq!(
        b.read("GroundVehicle", "mode").unwrap().value,
        Value::from("patrol")
    );
    assert_eq!(
        b.read("Vehicle", "mode").unwrap().value,
        Value::from("parked")
    );
}

#[test]
fn a_class_level_write_changes_what_every_instance_reads() {
    let b = board();
    for i in 0..50 {
        b.create("Obstacle", &format!("o{i}")).unwrap();
    }
    b.write("o7", "range", 3.0).unwrap();
    b.write("Obstacle", "range", 12.5).unwrap();
    for i in 0..50 {
        let expected = if i == 7 { 3.0 } else { 12.5 };
        assert_eq!(
            b.read(&format!("o{i}"), "range").unwrap().value.as_f64(),
            Some(expected),
            "o{i}"
        );
    }
}

#[test]
fn unwritten_attribute_without_default_reads_none() {
    let b = with_vehicle();
    let p = b.read("v", "position").unwrap();
    assert_eq!(p.value, Value::None);
    assert_eq!(p.confidence, 0.0);
}

#[test]
fn identical_redefinition_is_accepted_and_a_different_one_conflicts() {
    let b = board();
    let again = ClassDef::new("Obstacle").attr(
        AttrDecl::new("range", ValueType::Real)
            .unit("m")
            .default_value(100.0),
    );
    assert!(b.define(again).is_ok());
    let other = ClassDef::new("Obstacle").attr(AttrDecl::new("range", ValueType::Int));
    match b.define(other) {
        Err(DefineError::Conflict { name, difference }) => {
            assert_eq!(name, "Obstacle");
            assert!(difference.contains("range"), "{difference}");
        }
        other => panic!("expected a conflict, got {other:?}"),
    }
    let moved = ClassDef::new("Obstacle").parent("Vehicle").attr(
        AttrDecl::new("range", ValueType::Real)
            .unit("m")
            .default_value(100.0),
    );
    assert!(matches!(b.define(moved), Err(DefineError::Conflict { .. })));
}

#[test]
fn definitions_are_checked() {
    let b = board();
    assert!(matches!(
        b.define(ClassDef::new("X").parent("Nope")),
        Err(DefineError::UnknownParent { .. })
    ));
    assert!(matches!(
        b.define(ClassDef::new("9x")),
        Err(DefineError::BadName(_))
    ));
    let redeclare = ClassDef::new("Fast")
        .parent("Vehicle")
        .attr(AttrDecl::new("speed", ValueType::Real));
    assert!(matches!(
        b.define(redeclare),
        Err(DefineError::DuplicateAttr { inherited_from: Some(ref c), .. }) if c == "Vehicle"
    ));
    let twice = ClassDef::new("T")
        .attr(AttrDecl::new("a", ValueType::Int))
        .attr(AttrDecl::new("a", ValueType::Int));
    assert!(matches!(
        b.define(twice),
        Err(DefineError::DuplicateAttr {
            inherited_from: None,
            ..
        })
    ));
    let bad_default = ClassDef::new("T").attr(
        AttrDecl::new("a", ValueType::Real)
            .bounds(0.0, 1.0)
            .default_value(2.0),
    );
    assert!(matches!(
        b.define(bad_default),
        Err(DefineError::BadDefault { .. })
    ));
    let bad_bounds = ClassDef::new("T").attr(AttrDecl::new("a", ValueType::Real).bounds(2.0, 1.0));
    assert!(matches!(
        b.define(bad_bounds),
        Err(DefineError::BadDecl { .. })
    ));
    b.create("Vehicle", "car").unwrap();
    assert!(matches!(
        b.define(ClassDef::new("car")),
        Err(DefineError::NameTaken(_))
    ));
}

#[test]
fn deleting_a_class_in_use_is_refused() {
    let b = board();
    match b.delete_class("Vehicle") {
        Err(DeleteError::ClassInUse {
            subclasses: 1,
            instances: 0,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    b.create("Obstacle", "rock").unwrap();
    let err = b.delete_class("Obstacle").unwrap_err();
    assert!(err.to_string().contains("delete them first"), "{err}");
    b.delete("rock").unwrap();
    b.delete_class("Obstacle").unwrap();
    assert!(b.class_def("Obstacle").is_none());
    assert!(matches!(b.delete_class("Thing"), Err(DeleteError::Root)));
    assert!(matches!(b.delete_class("Gsr"), Ok(())));
}

#[test]
fn classes_defined_at_runtime_get_instances_and_can_be_listed() {
    let b = board();
    let defs = b.class_defs();
    let names: Vec<&str> = defs.iter().map(|d| d.name.as_str()).collect();
    // The built-in classes come first: every board has them from the start.
    assert_eq!(
        names,
        [
            "Module",
            "Plan",
            "Vehicle",
            "GroundVehicle",
            "Gsr",
            "Obstacle"
        ]
    );
    // A second board built from the first's definitions (a "download") has the same tree.
    let copy = slate_model::Board::new();
    for d in defs {
        copy.define(d).unwrap();
    }
    copy.create("Gsr", "g").unwrap();
    assert_eq!(copy.read("g", "mode").unwrap().value, Value::from("idle"));
}

#[test]
fn objects_have_owner_and_context_and_queries_filter_on_context() {
    let b = board();
    let owner = "team/r2/nav".parse().unwrap();
    b.create_with(NewObject::new("Gsr", "me").context(Context::Self_))
        .unwrap();
    b.create_with(
        NewObject::new("Gsr", "buddy")
            .context(Context::System)
            .owner(owner),
    )
    .unwrap();
    b.create("Vehicle", "stranger").unwrap();
    let info = b.info("buddy").unwrap();
    assert_eq!(
        (info.class.as_ref(), info.context, info.owner.as_str()),
        ("Gsr", Context::System, "team/r2/nav")
    );
    assert_eq!(b.info("me").unwrap().owner, *b.address());
    assert_eq!(b.is_instance_of("buddy", "Gsr"), Some(true));
    assert_eq!(
        b.is_instance_of("buddy", "Vehicle"),
        Some(false),
        "a subclass's"
    );
    assert_eq!(b.is_instance_of("Gsr", "Vehicle"), Some(false), "a class");
    assert_eq!(b.is_instance_of("nobody", "Gsr"), None);
    let names = |ids: Vec<slate_model::ObjectId>| {
        let mut n: Vec<String> = ids
            .into_iter()
            .map(|i| b.name_of(i).unwrap().to_string())
            .collect();
        n.sort();
        n
    };
    assert_eq!(
        names(b.instances("Vehicle").unwrap()),
        ["buddy", "me", "stranger"]
    );
    assert_eq!(
        names(b.instances("GroundVehicle").unwrap()),
        ["buddy", "me"]
    );
    assert_eq!(
        names(
            b.query(&Query::class("Vehicle").context(Context::System))
                .unwrap()
        ),
        ["buddy"]
    );
    let r2: slate_model::Address = "team/r2/nav".parse().unwrap();
    assert_eq!(
        names(b.query(&Query::class("Vehicle").owner(r2)).unwrap()),
        ["buddy"]
    );
    assert_eq!(
        names(
            b.query(&Query::class("Vehicle").context(Context::Surroundings))
                .unwrap()
        ),
        ["stranger"]
    );
}

#[test]
fn creation_errors_are_clear() {
    let b = board();
    assert_eq!(
        b.create("Nope", "x"),
        Err(CreateError::UnknownClass("Nope".into()))
    );
    b.create("Vehicle", "x").unwrap();
    assert_eq!(
        b.create("Vehicle", "x"),
        Err(CreateError::Exists("x".into()))
    );
    assert_eq!(
        b.create("Vehicle", "Vehicle"),
        Err(CreateError::Exists("Vehicle".into()))
    );
    assert!(matches!(
        b.create("Vehicle", "has space"),
        Err(CreateError::BadName(_))
    ));
    assert!(matches!(
        b.delete("Vehicle"),
        Err(DeleteError::WrongKind { .. })
    ));
    assert!(matches!(
        b.delete("ghost"),
        Err(DeleteError::UnknownObject(_))
    ));
}

#[test]
fn references_to_deleted_objects_dangle_and_resolve_again_by_name() {
    let b = board();
    b.create("Vehicle", "chaser").unwrap();
    b.create("Vehicle", "quarry").unwrap();
    b.write("chaser", "target", Value::reference("quarry"))
        .unwrap();
    let old = b.key("quarry", "speed").unwrap();
    b.delete("quarry").unwrap();
    // The reference is kept as written...
    let token = b.read("chaser", "target").unwrap().value;
    assert_eq!(token, Value::reference("quarry"));
    // ...following it fails with UnknownObject, and a stale key fails the same way.
    let name = token.as_ref_name().unwrap();
    assert_eq!(
        b.read(name, "speed"),
        Err(ReadError::UnknownObject("quarry".into()))
    );
    assert!(matches!(b.read_key(old), Err(ReadError::UnknownObject(_))));
    // A new object of that name is what the token names from now on; the old key stays stale.
    b.create("Vehicle", "quarry").unwrap();
    b.write("quarry", "speed", 4.0).unwrap();
    assert_eq!(b.read(name, "speed").unwrap().value.as_f64(), Some(4.0));
    assert!(b.read_key(old).is_err());
    // Writing a token to an object that does not exist (yet) is allowed.
    b.write("chaser", "target", Value::reference("not_yet"))
        .unwrap();
}

#[test]
fn redefining_the_root_class_names_what_differs() {
    let b = slate_model::Board::new();
    let err = b.define(ClassDef::new("Thing")).unwrap_err().to_string();
    assert!(err.contains("root class"), "{err}");
    assert!(!err.contains("  "), "{err}");
}

#[test]
fn the_class_tree_of_a_board_has_the_boards_chains_and_declarations() {
    let b = board();
    let tree = b.class_tree();
    for def in b.class_defs() {
        let id = b.info(&def.name).unwrap().id;
        let by_board: Vec<String> = b
            .lineage(id)
            .into_iter()
            .map(|c| b.name_of(c).unwrap().to_string())
            .collect();
        let by_tree: Vec<String> = tree
            .lineage(&def.name)
            .unwrap()
            .iter()
            .map(|c| c.to_string())
            .collect();
        assert_eq!(by_board, by_tree, "chain of {}", def.name);
        for (_, decl) in tree.declarations(&def.name) {
            assert_eq!(b.attr_decl(&def.name, &decl.name).as_ref(), Some(decl));
        }
    }
    assert_eq!(tree.len(), b.class_defs().len() + 1, "and Thing");
    assert!(b.attr_decl("Gsr", "nothing").is_none());
    assert!(b.attr_decl("Nothing", "mode").is_none());
}
