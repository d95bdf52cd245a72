//! slate's world model: the paper's blackboard for one module.
//!
//! A [`Board`] holds a class tree (classes with one parent, root `Thing`) and objects.
//! Every attribute holds a [`Packet`]: value, accuracy, confidence, timestamp and source.
//! Objects store only what they wrote; everything else resolves through their class
//! chain (class-level values, then declared defaults). Active functions run when an
//! attribute is read or written. The board's methods are the paper's SBIPs: define,
//! create, delete, read, write, batch, query, watch.
//!
//! ```
//! use slate_model::{AttrDecl, Board, ClassDef, Clock, Update, ValueType};
//!
//! let board = Board::builder().clock(Clock::manual()).build();
//! board.define(ClassDef::new("Obstacle").attr(
//!     AttrDecl::new("clearance", ValueType::Real).unit("m").default_value(1.0),
//! ))?;
//! board.define(ClassDef::new("Rock").parent("Obstacle"))?;
//! board.create("Rock", "r1")?;
//! board.create("Rock", "r2")?;
//!
//! // One class-level write changes what every instance without its own value reads.
//! board.write("Obstacle", "clearance", 2.0)?;
//! assert_eq!(board.read("r1", "clearance")?.value.as_f64(), Some(2.0));
//!
//! // An instance's own value wins over its class's.
//! board.write("r2", "clearance", Update::new(0.5).accuracy(0.05).confidence(0.8))?;
//! assert_eq!(board.read("r2", "clearance")?.confidence, 0.8);
//! # Ok::<(), slate_model::Error>(())
//! ```
#![warn(missing_docs)]

mod active;
mod address;
mod authority;
mod board;
mod builtin;
mod class;
mod class_tree;
mod clock;
mod error;
mod every;
mod id;
pub mod memo;
mod packet;
mod umbrella;
mod value;
mod wake;

pub use active::{ActiveFn, Call, CallToken, FnError, FnRef, Trigger};
pub use address::{Address, AddressError, Context};
pub use authority::{
    AddressPattern, PatternError, WriteAuthority, WriteRule, listed as listed_patterns,
};
pub use board::{
    Batch, Board, BoardBuilder, BoardEvent, BoardStats, Change, ChangeHook, ChangeItem, Cursor,
    DEFAULT_MAX_DEPTH, Filter, Gather, MAX_NESTED_FUNCTIONS, Merged, NewObject, Normaliser,
    ObjectInfo, Query, ReadSet, ReadTrace, RevisedItem, Snapshot, TouchKind, Touched, Watch,
};
pub use builtin::{
    MODULE_CLASS, PLAN_CLASS, builtin_classes, is_builtin, module_class, plan_class,
};
pub use class::{AttrDecl, ClassDef, DefaultPacket, MergePolicy, ReportPolicy, THING};
pub use class_tree::{ClassTree, Lineage};
pub use clock::{
    Clock, ClockDriftError, ClockError, ClockListener, DEFAULT_MAX_DRIFT, LOGICAL_BITS,
    MANUAL_EPOCH, MAX_TIME, Timestamp,
};
pub use error::{
    BatchError, ChainError, CreateError, DefineError, DeleteError, LookupError, ReadError,
    WriteError,
};
pub use every::{Every, EveryPer};
pub use id::{AttrId, Key, ObjectId};
pub use packet::{Packet, Update, ValueError, check_quality, check_value};
pub use umbrella::Error;
pub use value::{Value, ValueType};
pub use wake::{Wake, WakingSender};
