//! The paper's Ground Surveillance Robot on one board: the navigation module writes the
//! vehicle's position (with an accuracy that grows between fixes), the proximity module
//! writes obstacles by range and bearing, an on-read active function turns those into
//! absolute positions, an on-write function slows the vehicle near obstacles, and a watch
//! shows every change as it happens.
//!
//! Run: `cargo run -p slate-model --example gsr_world`

use std::fmt::Write as _;
use std::time::Duration;

use slate_model::{
    AttrDecl, Board, ChangeItem, ClassDef, Clock, Context, Filter, FnError, NewObject, Update,
    Value, ValueType,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    print!("{}", world_tour()?);
    Ok(())
}

/// Builds the world, runs a few steps, and returns what happened as text.
pub fn world_tour() -> Result<String, Box<dyn std::error::Error>> {
    let mut out = String::new();
    let board = Board::builder()
        .clock(Clock::manual())
        .address("gsr/r1/nav".parse()?)
        .build();
    define_classes(&board)?;
    attach_functions(&board)?;
    let changes = board.watch(Filter::class("Obstacle").attr("range"))?;

    board.create_with(NewObject::new("Vehicle", "gsr").context(Context::Self_))?;
    let mut batch = board.batch();
    batch
        .write(
            "gsr",
            "position",
            Update::new([10.0, 20.0]).accuracy(0.5).confidence(0.95),
        )
        .write("gsr", "heading", Update::new(0.0).accuracy(0.02))
        .write("gsr", "speed", 2.0);
    writeln!(out, "navigation fix at revision {}", batch.commit()?)?;

    for (i, (range, bearing)) in [(12.0, 0.5), (4.0, -0.2)].into_iter().enumerate() {
        board.clock().advance(Duration::from_millis(500))?;
        let name = format!("obstacle{i}");
        let mut batch = board.batch();
        batch
            .create("Obstacle", &name)
            .write(&name, "observer", Value::reference("gsr"))
            .write(&name, "bearing", Update::new(bearing).accuracy(0.05))
            .write(
                &name,
                "range",
                Update::new(range).accuracy(0.3).confidence(0.8),
            );
        batch.commit()?;
        let p = board.read(&name, "position")?;
        writeln!(
            out,
            "{name}: range {range} m, bearing {bearing} rad -> absolute {} ±{:.2} m",
            p.value, p.accuracy
        )?;
    }
    writeln!(
        out,
        "gsr speed after the close obstacle: {}",
        board.read("gsr", "speed")?.value
    )?;

    // One class-level write reaches every obstacle without a value of its own.
    board.write("Obstacle", "clearance", 1.5)?;
    writeln!(
        out,
        "obstacle1 clearance (class-level): {}",
        board.read("obstacle1", "clearance")?.value
    )?;

    for change in std::iter::from_fn(|| changes.try_recv()) {
        for item in change.items {
            if let ChangeItem::Write {
                object,
                attr,
                packet,
            } = item
            {
                writeln!(
                    out,
                    "watch: revision {} {object}.{attr} = {}",
                    change.revision, packet.value
                )?;
            }
        }
    }
    writeln!(out, "\n{}", board.dump())?;
    Ok(out)
}

fn define_classes(board: &Board) -> Result<(), slate_model::Error> {
    board.define(
        ClassDef::new("Vehicle")
            .attr(AttrDecl::new("position", ValueType::Vector(2)).unit("m"))
            .attr(AttrDecl::new("heading", ValueType::Real).unit("rad"))
            .attr(
                AttrDecl::new("speed", ValueType::Real)
                    .unit("m/s")
                    .bounds(0.0, 10.0)
                    .default_value(0.0),
            ),
    )?;
    board.define(
        ClassDef::new("Obstacle")
            .attr(AttrDecl::new("observer", ValueType::Ref))
            .attr(
                AttrDecl::new("range", ValueType::Real)
                    .unit("m")
                    .bounds(0.0, 100.0),
            )
            .attr(AttrDecl::new("bearing", ValueType::Real).unit("rad"))
            .attr(AttrDecl::new("position", ValueType::Vector(2)).unit("m"))
            .attr(
                AttrDecl::new("clearance", ValueType::Real)
                    .unit("m")
                    .default_value(1.0),
            ),
    )?;
    Ok(())
}

fn attach_functions(board: &Board) -> Result<(), slate_model::Error> {
    // Derived on read: the obstacle's absolute position from the observer's pose and the
    // obstacle's range and bearing; accuracy combines both.
    board.on_read("Obstacle", "position", |call| {
        let obj = call.object().to_owned();
        let observer = call.read(&obj, "observer")?.value;
        let observer = observer.as_ref_name().ok_or("no observer")?;
        let pos = call.read(observer, "position")?;
        let heading = call.read(observer, "heading")?;
        let range = call.read(&obj, "range")?;
        let bearing = call.read(&obj, "bearing")?;
        let (p, h) = (
            pos.value.as_vector().ok_or("observer has no position")?,
            heading.value.as_f64().unwrap_or(0.0),
        );
        let (r, b) = (
            range.value.as_f64().unwrap_or(0.0),
            bearing.value.as_f64().unwrap_or(0.0),
        );
        let angle = h + b;
        let mut packet = call.packet().clone();
        packet.value = Value::from([p[0] + r * angle.cos(), p[1] + r * angle.sin()]);
        packet.accuracy = pos.accuracy + range.accuracy + r * (heading.accuracy + bearing.accuracy);
        packet.confidence = pos.confidence * range.confidence;
        packet.timestamp = range.timestamp.max(pos.timestamp);
        call.set_packet(packet);
        Ok(())
    })?;
    // On write: an obstacle closer than 5 m slows its observer down.
    board.on_write("Obstacle", "range", |call| {
        let close = call.packet().value.as_f64().is_some_and(|r| r < 5.0);
        if close {
            let observer = call.read(call.object(), "observer")?.value;
            let observer = observer
                .as_ref_name()
                .ok_or_else(|| FnError::from("no observer"))?;
            call.write(observer, "speed", 0.5)?;
        }
        Ok(())
    })?;
    Ok(())
}
