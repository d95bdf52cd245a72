//! One error enum per board operation.

use std::time::Duration;

use crate::{Address, Timestamp, ValueError};

/// Error of [`Board::define`](crate::Board::define).
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DefineError {
    /// The class name is not an identifier.
    #[error(
        "{0:?} is not a valid class name: use letters, digits and '_', not starting with a digit"
    )]
    BadName(String),
    /// A class of that name exists with a different definition.
    #[error("class {name} is already defined differently: {difference}")]
    Conflict {
        /// Class name.
        name: String,
        /// What differs.
        difference: String,
    },
    /// An object (not a class) already has this name.
    #[error("{0} is already the name of an object")]
    NameTaken(String),
    /// The parent class does not exist.
    #[error("class {class}: parent class {parent} is not defined")]
    UnknownParent {
        /// Class name.
        class: String,
        /// Missing parent.
        parent: String,
    },
    /// An attribute is declared twice, or redeclares an inherited one.
    #[error("class {class}: attribute {attr} is already declared{}", inherited_from.as_ref().map(|c| format!(" by {c}")).unwrap_or_default())]
    DuplicateAttr {
        /// Class name.
        class: String,
        /// Attribute name.
        attr: String,
        /// The ancestor that declares it, if inherited.
        inherited_from: Option<String>,
    },
    /// An attribute name is not an identifier.
    #[error("class {class}: {attr:?} is not a valid attribute name")]
    BadAttrName {
        /// Class name.
        class: String,
        /// Attribute name.
        attr: String,
    },
    /// A declared default packet does not fit its declaration.
    #[error("class {class}: default of {attr}: {source}")]
    BadDefault {
        /// Class name.
        class: String,
        /// Attribute name.
        attr: String,
        /// Why.
        source: ValueError,
    },
    /// Bounds with min > max or non-finite, or a non-positive resolution.
    #[error("class {class}: attribute {attr}: {why}")]
    BadDecl {
        /// Class name.
        class: String,
        /// Attribute name.
        attr: String,
        /// Why.
        why: String,
    },
}

/// Error of [`Board::create`](crate::Board::create).
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CreateError {
    /// The object name is not an identifier.
    #[error(
        "{0:?} is not a valid object name: use letters, digits and '_', not starting with a digit"
    )]
    BadName(String),
    /// The class does not exist.
    #[error("class {0} is not defined")]
    UnknownClass(String),
    /// The name is taken by another object or a class.
    #[error("{0} already exists")]
    Exists(String),
}

/// Error of [`Board::delete`](crate::Board::delete) and
/// [`Board::delete_class`](crate::Board::delete_class).
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DeleteError {
    /// Nothing of that name exists.
    #[error("no object named {0}")]
    UnknownObject(String),
    /// `delete` names a class, or `delete_class` an instance.
    #[error("{name} is {what}; use {use_instead}")]
    WrongKind {
        /// The name given.
        name: String,
        /// "a class" or "an object".
        what: &'static str,
        /// The call to use instead.
        use_instead: &'static str,
    },
    /// The class still has instances or subclasses.
    #[error(
        "class {class} still has {instances} instance(s) and {subclasses} subclass(es); delete them first"
    )]
    ClassInUse {
        /// Class name.
        class: String,
        /// Number of instances of this exact class.
        instances: usize,
        /// Number of direct subclasses.
        subclasses: usize,
    },
    /// The root class cannot be deleted.
    #[error("the root class Thing cannot be deleted")]
    Root,
}

/// Error of reads.
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ReadError {
    /// No object or class of that name (or the id is stale: the object was deleted).
    #[error("no object named {0}")]
    UnknownObject(String),
    /// The object's class chain declares no such attribute.
    #[error("{object} has no attribute {attr} (its class does not declare it)")]
    UnknownAttribute {
        /// Object name.
        object: String,
        /// Attribute name.
        attr: String,
    },
    /// The read was refused to stop a chain of active functions.
    #[error(transparent)]
    Chain(#[from] ChainError),
}

/// Error of writes.
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum WriteError {
    /// No object or class of that name (or the id is stale).
    #[error("no object named {0}")]
    UnknownObject(String),
    /// The object's class chain declares no such attribute.
    #[error("{object} has no attribute {attr} (its class does not declare it)")]
    UnknownAttribute {
        /// Object name.
        object: String,
        /// Attribute name.
        attr: String,
    },
    /// The value or packet does not fit the declaration.
    #[error("{object}.{attr}: {source}")]
    Invalid {
        /// Object name.
        object: String,
        /// Attribute name.
        attr: String,
        /// Why.
        source: ValueError,
    },
    /// The write was refused to stop a chain of active functions.
    #[error(transparent)]
    Chain(#[from] ChainError),
    /// The write was attempted inside a snapshot (by an on-read function run for it),
    /// which may not write.
    #[error("writes are not allowed inside a snapshot")]
    ReadOnly,
    /// An own write stamped older than the packet the object holds: every receiver
    /// would keep the held packet, so storing it here would make the copies differ.
    #[error(
        "{object}.{attr}: the write is older than the stored packet (stamp {stamp}, stored {held} from {held_source}); write without a timestamp or with a newer one"
    )]
    Superseded {
        /// Object name.
        object: String,
        /// Attribute name.
        attr: String,
        /// The write's timestamp.
        stamp: Timestamp,
        /// The held packet's timestamp.
        held: Timestamp,
        /// The held packet's source.
        held_source: Address,
    },
    /// An `owned` attribute written by a module that does not own the object: every
    /// other board refuses such a packet, so this one does too.
    #[error(
        "{object}.{attr} is owned by {owner}; {writer} may not write it (write it from {owner}, or declare the attribute with another merge policy)"
    )]
    NotOwner {
        /// Object name.
        object: String,
        /// Attribute name.
        attr: String,
        /// The object's owner.
        owner: Address,
        /// The write's source.
        writer: Address,
    },
    /// A write by a module the board's rules do not let write it (`[authority] writes`,
    /// [`WriteAuthority`](crate::WriteAuthority)).
    #[error("{writer} may not write {target} on this board: {rule} ([authority] writes)")]
    Unauthorised {
        /// `object.attr`, or the object created.
        target: String,
        /// The module that would write.
        writer: Address,
        /// The rule that refuses it.
        rule: String,
    },
    /// An own write stamped further ahead of this board's clock than it tolerates: every
    /// receiver would refuse it.
    #[error(
        "{object}.{attr}: timestamp {stamp} is {ahead:?} ahead of this board's clock, more than the allowed {max:?}; write without a timestamp or fix the clock"
    )]
    FromTheFuture {
        /// Object name.
        object: String,
        /// Attribute name.
        attr: String,
        /// The write's timestamp.
        stamp: Timestamp,
        /// How far ahead of the board's physical time it is.
        ahead: Duration,
        /// The clock's tolerance.
        max: Duration,
    },
    /// The attribute is guarded: only the machinery that declared it writes it (a
    /// `Plan`'s fields are the plan engine's).
    #[error(
        "{object}.{attr} is written only by the machinery that keeps it (a Plan's fields by \
         its plan engine: cancel a plan through the engine, e.g. `slate plan cancel`)"
    )]
    Guarded {
        /// Object name.
        object: String,
        /// Attribute name.
        attr: String,
    },
}

/// Error of [`Batch::commit`](crate::Batch::commit): nothing of the batch was applied.
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BatchError {
    /// Operation `index` (0-based) failed to write.
    #[error("batch operation {index}: {source}")]
    Write {
        /// Position of the failing operation.
        index: usize,
        /// Why.
        source: WriteError,
    },
    /// Operation `index` failed to create.
    #[error("batch operation {index}: {source}")]
    Create {
        /// Position of the failing operation.
        index: usize,
        /// Why.
        source: CreateError,
    },
    /// Operation `index` failed to delete.
    #[error("batch operation {index}: {source}")]
    Delete {
        /// Position of the failing operation.
        index: usize,
        /// Why.
        source: DeleteError,
    },
    /// Batches may not be committed inside a snapshot.
    #[error("writes are not allowed inside a snapshot")]
    ReadOnly,
}

/// Error of [`Board::watch`](crate::Board::watch) and active-function attachment.
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LookupError {
    /// No object or class of that name.
    #[error("no object or class named {0}")]
    UnknownObject(String),
    /// No class of that name.
    #[error("no class named {0}")]
    UnknownClass(String),
    /// The attribute is not declared.
    #[error("{object} has no attribute {attr} (its class does not declare it)")]
    UnknownAttribute {
        /// Object or class name.
        object: String,
        /// Attribute name.
        attr: String,
    },
}

/// Why a chain of active functions was cut.
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ChainError {
    /// The chain became deeper than the board's limit.
    #[error("active function chain deeper than {limit} at {object}.{attr}")]
    DepthLimit {
        /// The configured depth limit.
        limit: usize,
        /// Object the refused access was for.
        object: String,
        /// Attribute the refused access was for.
        attr: String,
    },
    /// The chain came back to an attribute it is already handling.
    #[error("active function cycle: {}", path.join(" -> "))]
    Cycle {
        /// `object.attr` steps of the cycle, first and last equal.
        path: Vec<String>,
    },
    /// The call token was taken on another board: its chain means nothing here.
    #[error(
        "the call token belongs to another board; read and write this board with its own methods"
    )]
    ForeignToken,
}
