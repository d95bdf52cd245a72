//! A small world shared by the tests: Thing > Vehicle > GroundVehicle > Gsr, plus Obstacle.

use slate_model::{AttrDecl, Board, ClassDef, Clock, ValueType};

pub fn board() -> Board {
    let b = Board::builder().clock(Clock::manual()).build();
    b.define(
        ClassDef::new("Vehicle")
            .attr(
                AttrDecl::new("speed", ValueType::Real)
                    .unit("m/s")
                    .bounds(0.0, 50.0)
                    .default_packet(0.0, 0.5, 0.5),
            )
            .attr(AttrDecl::new("position", ValueType::Vector(2)).unit("m"))
            .attr(AttrDecl::new("mode", ValueType::Str).default_value("idle"))
            .attr(AttrDecl::new("wheels", ValueType::Int).bounds(0.0, 16.0))
            .attr(AttrDecl::new("target", ValueType::Ref)),
    )
    .unwrap();
    b.define(
        ClassDef::new("GroundVehicle")
            .parent("Vehicle")
            .attr(AttrDecl::new("armed", ValueType::Bool).default_value(false)),
    )
    .unwrap();
    b.define(ClassDef::new("Gsr").parent("GroundVehicle"))
        .unwrap();
    b.define(
        ClassDef::new("Obstacle").attr(
            AttrDecl::new("range", ValueType::Real)
                .unit("m")
                .default_value(100.0),
        ),
    )
    .unwrap();
    b
}

/// The world of [`board`] with one `Vehicle`, `v`.
pub fn with_vehicle() -> Board {
    let b = board();
    b.create("Vehicle", "v").unwrap();
    b
}
