"""Type stubs of the native module slate._slate (checked against it by mypy.stubtest)."""

import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from types import TracebackType
from typing import Any, Literal, TypeVar, final, overload

__all__ = [
    "SlateError",
    "UnknownObjectError",
    "UnknownClassError",
    "UnknownAttributeError",
    "ReadError",
    "WriteError",
    "ValueTypeError",
    "InvalidPacketError",
    "AccuracyError",
    "ConfidenceError",
    "OutOfBoundsError",
    "ChainError",
    "DefineError",
    "CreateError",
    "DeleteError",
    "LoadError",
    "ClockError",
    "AddressError",
    "NodeError",
    "PlanError",
    "Board",
    "Batch",
    "Info",
    "Packet",
    "Ref",
    "Clock",
    "Watch",
    "Change",
    "ChangeItem",
    "Event",
    "Events",
    "Call",
    "Loaded",
    "Plan",
    "Report",
    "ReportItem",
    "PlanMessage",
    "Outbox",
    "Diagnostic",
    "Node",
    "PlanHandle",
    "Acks",
    "Ack",
    "Recording",
    "RecordingIter",
    "RecordedPacket",
    "RecordedEvent",
    "__version__",
    "BUILD_PROFILE",
]

__version__: str
BUILD_PROFILE: Literal["debug", "release"]

_Value = None | bool | int | float | str | Ref | tuple[float, ...]
"""What an attribute holds, as read back (vectors are tuples of floats)."""

_ValueLike = _Value | Sequence[float]
"""What may be written: a Value, or any list or tuple of numbers for a vector."""

_ContextName = Literal["self", "surroundings", "system"]
_ActiveFunction = Callable[[Call], Any]
_F = TypeVar("_F", bound=_ActiveFunction)

# ----- exceptions (mirroring the core's error enums) -----

class SlateError(Exception):
    """Base class of every error slate raises."""

class UnknownObjectError(SlateError, LookupError):
    """No object or class of that name exists on the board."""

class UnknownClassError(UnknownObjectError):
    """No class of that name exists on the board."""

class UnknownAttributeError(SlateError, LookupError):
    """The object's class (and its ancestors) declare no attribute of that name."""

class ReadError(SlateError):
    """A read failed for another reason than a missing object or attribute."""

class WriteError(SlateError):
    """A write was refused; nothing was stored."""

class ValueTypeError(WriteError, TypeError):
    """The value's type is not the attribute's declared type (or not a slate value)."""

class InvalidPacketError(WriteError, ValueError):
    """The value or packet does not fit: not finite, bad accuracy, confidence or bounds."""

class AccuracyError(InvalidPacketError):
    """Accuracy is negative or not finite."""

class ConfidenceError(InvalidPacketError):
    """Confidence is outside [0, 1]."""

class OutOfBoundsError(InvalidPacketError):
    """The value lies outside the attribute's declared bounds."""

class ChainError(SlateError):
    """A chain of active functions was cut: too deep, or a cycle."""

class DefineError(SlateError):
    """A class definition was refused."""

class CreateError(SlateError):
    """An object could not be created (bad name, or the name exists)."""

class DeleteError(SlateError):
    """An object or class could not be deleted."""

class LoadError(SlateError):
    """A .slate source did not load; nothing of it was applied."""

    diagnostics: list[Diagnostic]
    file: str
    line: int
    column: int

class ClockError(SlateError):
    """The clock cannot be moved like that (a system clock, backwards, or past 2112)."""

class AddressError(SlateError, ValueError):
    """Not a module address of the form team/robot/module."""

class NodeError(SlateError):
    """A node did not start: the network, its board or its sources refused."""

class PlanError(SlateError):
    """A plan could not be sent or cancelled: not one plan, or the circuit refused it."""

# ----- values and packets -----

@final
class Ref:
    """A token naming another object: the value of a `ref` attribute."""

    def __new__(cls, name: str) -> Ref: ...
    @property
    def name(self) -> str: ...
    def __eq__(self, other: object, /) -> bool: ...
    def __hash__(self) -> int: ...

@final
class Packet:
    """An attribute packet: value, accuracy, confidence, timestamp, source."""

    def __new__(
        cls,
        value: _ValueLike,
        accuracy: float = 0.0,
        confidence: float = 1.0,
        timestamp: float | None = None,
        source: str | None = None,
    ) -> Packet: ...
    @property
    def value(self) -> Any:
        """A Value: its Python type follows the attribute's declared type, which a type
        checker cannot know (int, float, bool, str, Ref, tuple of floats, or None)."""
    @property
    def accuracy(self) -> float: ...
    @property
    def confidence(self) -> float: ...
    @property
    def timestamp(self) -> float:
        """Seconds since the Unix epoch, to the microsecond (0.0: never written)."""
    @property
    def stamp(self) -> int:
        """The full hybrid-clock stamp: microseconds since the epoch in the high bits, a
        counter in the low 12. Orders writes made at one instant; 0: never written."""
    @property
    def source(self) -> str: ...
    def __eq__(self, other: object, /) -> bool: ...
    __hash__: None  # type: ignore[assignment]

@final
class Clock:
    """A board's clock: the system clock, or a manual clock that moves when told to."""

    def __new__(cls, kind: Literal["system", "manual"] = "system") -> Clock: ...
    @property
    def is_manual(self) -> bool: ...
    def now(self) -> float: ...
    def advance(self, seconds: float) -> None: ...
    def set(self, seconds: float) -> None: ...

# ----- the board -----

@final
class Info:
    """What a board knows about an object or class."""

    @property
    def name(self) -> str: ...
    @property
    def class_name(self) -> str: ...
    @property
    def is_class(self) -> bool: ...
    @property
    def context(self) -> _ContextName: ...
    @property
    def owner(self) -> str: ...

@final
class Board:
    """A module's blackboard: classes, objects, and attribute packets."""

    def __new__(
        cls,
        clock: Literal["system", "manual"] | Clock | None = None,
        address: str | None = None,
        max_depth: int | None = None,
    ) -> Board: ...
    @property
    def address(self) -> str: ...
    @property
    def clock(self) -> Clock: ...
    @property
    def revision(self) -> int: ...
    def load(self, source: str | os.PathLike[str], *, name: str | None = None) -> Loaded: ...
    def define(
        self, name: str, attrs: dict[str, str] | None = None, *, parent: str | None = None
    ) -> None: ...
    def create(
        self,
        class_name: str,
        name: str,
        *,
        context: _ContextName | None = None,
        owner: str | None = None,
    ) -> None: ...
    def delete(self, name: str) -> int: ...
    def delete_class(self, name: str) -> None:
        """Deletes a class without instances or subclasses."""
    def read(self, object: str, attr: str) -> Packet: ...
    def write(
        self,
        object: str,
        attr: str,
        value: _ValueLike,
        *,
        accuracy: float | None = None,
        confidence: float | None = None,
        timestamp: float | None = None,
        source: str | None = None,
    ) -> int: ...
    def batch(self) -> Batch: ...
    def instances(
        self, class_name: str, *, context: _ContextName | None = None, owner: str | None = None
    ) -> list[str]: ...
    def info(self, name: str) -> Info | None: ...
    def __contains__(self, name: str, /) -> bool: ...
    @overload
    def on_write(self, target: str, attr: str, fn: _F) -> _F: ...
    @overload
    def on_write(self, target: str, attr: str, fn: None = None) -> Callable[[_F], _F]: ...
    @overload
    def on_read(self, target: str, attr: str, fn: _F) -> _F: ...
    @overload
    def on_read(self, target: str, attr: str, fn: None = None) -> Callable[[_F], _F]: ...
    def watch(
        self, target: str | None = None, attr: str | None = None, *, timeout: float | None = None
    ) -> Watch: ...
    def events(self, *, timeout: float | None = None) -> Events: ...
    def plan_events(self, *, timeout: float | None = None) -> Events: ...
    def outgoing(self, *, timeout: float | None = None) -> Outbox: ...
    def plan(self, name: str) -> Plan: ...
    def plans(self) -> list[Plan]: ...
    def stats(self) -> dict[str, int]: ...
    def dump(self) -> str: ...

@final
class Batch:
    """An atomic batch: applied all together at commit, or not at all."""

    def write(
        self,
        object: str,
        attr: str,
        value: _ValueLike,
        *,
        accuracy: float | None = None,
        confidence: float | None = None,
        timestamp: float | None = None,
        source: str | None = None,
    ) -> None: ...
    def create(
        self,
        class_name: str,
        name: str,
        *,
        context: _ContextName | None = None,
        owner: str | None = None,
    ) -> None: ...
    def delete(self, name: str) -> None: ...
    def commit(self) -> int: ...
    def discard(self) -> None: ...
    @property
    def revision(self) -> int | None: ...
    def __len__(self) -> int: ...
    def __enter__(self) -> Batch: ...
    def __exit__(
        self,
        exc_type: type[BaseException] | None = None,
        exc_value: BaseException | None = None,
        traceback: TracebackType | None = None,
    ) -> bool: ...

# ----- active functions -----

@final
class Call:
    """What an active function receives; valid only while it runs."""

    @property
    def object(self) -> str: ...
    @property
    def attr(self) -> str: ...
    @property
    def trigger(self) -> Literal["read", "write"]: ...
    @property
    def packet(self) -> Packet: ...
    @property
    def previous(self) -> Packet | None: ...
    @property
    def revision(self) -> int: ...
    def read(self, object: str, attr: str) -> Packet: ...
    def write(
        self,
        object: str,
        attr: str,
        value: _ValueLike,
        *,
        accuracy: float | None = None,
        confidence: float | None = None,
        timestamp: float | None = None,
        source: str | None = None,
    ) -> int: ...
    def instances(self, class_name: str) -> list[str]: ...
    def exists(self, name: str) -> bool: ...

# ----- watching and events -----

@final
class ChangeItem:
    """One item of a change: an attribute written, or an object created or deleted."""

    @property
    def kind(self) -> Literal["write", "create", "delete"]: ...
    @property
    def object(self) -> str: ...
    @property
    def attr(self) -> str | None: ...
    @property
    def class_name(self) -> str | None: ...
    @property
    def packet(self) -> Packet | None: ...

@final
class Change:
    """The changes one revision made that match a watch."""

    @property
    def revision(self) -> int: ...
    @property
    def items(self) -> list[ChangeItem]: ...

@final
class Watch:
    """A subscription to a board's changes; iterate it, or `get` with a timeout."""

    def get(self, timeout: float | None = None) -> Change | None: ...
    def drain(self) -> list[Change]: ...
    @property
    def pending(self) -> int: ...
    def close(self) -> None: ...
    def __iter__(self) -> Iterator[Change]: ...
    def __next__(self) -> Change: ...
    def __enter__(self) -> Watch: ...
    def __exit__(
        self,
        exc_type: type[BaseException] | None = None,
        exc_value: BaseException | None = None,
        traceback: TracebackType | None = None,
    ) -> bool: ...

_EventKind = Literal[
    "function_failed",
    "chain_cut",
    "future_stamp",
    "class_conflict",
    "not_owner",
    "unauthorised",
    "object_limit",
    "name_limit",
    "module_limit",
    "other",
    "installed",
    "initiated",
    "triggered",
    "terminated",
    "cancelled",
    "failed",
]

@final
class Event:
    """Something a board or its plans report about themselves."""

    @property
    def kind(self) -> _EventKind: ...
    @property
    def plan(self) -> str | None: ...
    @property
    def function(self) -> str | None: ...
    @property
    def object(self) -> str | None: ...
    @property
    def attr(self) -> str | None: ...
    @property
    def trigger(self) -> str | None: ...
    @property
    def source(self) -> str | None: ...
    @property
    def error(self) -> str | None: ...
    @property
    def fired(self) -> int | None: ...
    @property
    def suppressed(self) -> int | None: ...

@final
class Events:
    """A subscription to board events or plan events."""

    def get(self, timeout: float | None = None) -> Event | None: ...
    def drain(self) -> list[Event]: ...
    def close(self) -> None: ...
    def __iter__(self) -> Iterator[Event]: ...
    def __next__(self) -> Event: ...
    def __enter__(self) -> Events: ...
    def __exit__(
        self,
        exc_type: type[BaseException] | None = None,
        exc_value: BaseException | None = None,
        traceback: TracebackType | None = None,
    ) -> bool: ...

# ----- plans -----

@final
class Diagnostic:
    """One problem in a .slate source, with its position."""

    @property
    def file(self) -> str: ...
    @property
    def line(self) -> int: ...
    @property
    def column(self) -> int: ...
    @property
    def message(self) -> str: ...
    @property
    def severity(self) -> Literal["error", "warning"]: ...
    @property
    def stage(self) -> Literal["lex", "parse", "check"]: ...

@final
class Loaded:
    """What a load added to the board."""

    @property
    def classes(self) -> list[str]: ...
    @property
    def objects(self) -> list[str]: ...
    @property
    def rules(self) -> int: ...
    @property
    def plans(self) -> list[str]: ...

@final
class Plan:
    """A plan installed on a board: a live view of its progress."""

    @property
    def name(self) -> str: ...
    @property
    def state(self) -> Literal["pending", "active", "terminated", "cancelled"]: ...
    @property
    def fired(self) -> int: ...
    @property
    def last_error(self) -> str | None: ...
    def cancel(self) -> bool: ...

@final
class ReportItem:
    """One reported assertion."""

    @property
    def object(self) -> str: ...
    @property
    def attr(self) -> str: ...
    @property
    def packet(self) -> Packet: ...

@final
class Report:
    """A report made by a `report` action."""

    @property
    def origin(self) -> str: ...
    @property
    def to(self) -> str | None: ...
    @property
    def items(self) -> list[ReportItem]: ...

@final
class PlanMessage:
    """A plan sent to another module by a `send` action."""

    @property
    def origin(self) -> str: ...
    @property
    def name(self) -> str: ...
    @property
    def text(self) -> str: ...
    @property
    def to(self) -> str: ...

@final
class Outbox:
    """A subscription to the reports and plans a board sends out."""

    def get(self, timeout: float | None = None) -> Report | PlanMessage | None: ...
    def drain(self) -> list[Report | PlanMessage]: ...
    def close(self) -> None: ...
    def __iter__(self) -> Iterator[Report | PlanMessage]: ...
    def __next__(self) -> Report | PlanMessage: ...
    def __enter__(self) -> Outbox: ...
    def __exit__(
        self,
        exc_type: type[BaseException] | None = None,
        exc_value: BaseException | None = None,
        traceback: TracebackType | None = None,
    ) -> bool: ...

# ----- the node -----

_StepName = Literal[
    "received",
    "accepted",
    "rejected",
    "initiated",
    "triggered",
    "terminated",
    "cancelled",
    "destination_lost",
]

@final
class Node:
    """One module on the network: a board, its plan engine, its ICI over Zenoh and its
    plan circuits. A `with` block closes it. It starts from `slate node`'s settings:
    on the team link an attribute goes at most every 200 ms, with its last value."""

    def __new__(
        cls,
        address: str,
        board: Board | None = None,
        *,
        connect: Sequence[str] | None = None,
        listen: Sequence[str] | None = None,
        mode: Literal["peer", "router", "client"] = "peer",
        interest: Sequence[str] | None = None,
        export: Sequence[str] | None = None,
        lossless: Sequence[str] | None = None,
        dashboard: str | None = None,
        record: str | os.PathLike[str] | None = None,
        state: str | os.PathLike[str] | None = None,
        plans_from: Sequence[str] | None = None,
        writes: Mapping[str, Sequence[str]] | None = None,
    ) -> Node:
        """`lossless=`: classes whose every update this node's receivers get, in
        order, as `lossless` in a node's config: a receiver that cannot keep up slows
        this node's writes of them down instead of losing updates (default: none; every
        other class is sent best effort, a slow receiver getting the latest state).
        `record=`: record the board to this MCAP file from the start
        (docs/recording.md). `state=`: keep the board in this directory and restore it
        first, before the node joins the team (docs/design.md, "A restart with its
        board"); load the board's files before making the node, or their objects clash
        with the restored ones. A damaged state directory raises NodeError naming it.
        `plans_from=`: who may send this node plans, as `[authority] plans_from` in a
        node's config: "robot", "operators" and address patterns like "t/*/planner"
        (default: its robot's modules and the team's operators; docs/security.md).
        `writes=`: who besides this module may write what on its board, as
        `[authority.writes]`: `{"Vehicle.mode": ["robot"], "Target": ["t/*/exec"]}`
        (default: anyone; a class or attribute no loaded file declares raises
        NodeError)."""
    @property
    def address(self) -> str: ...
    @property
    def board(self) -> Board: ...
    @property
    def listening(self) -> list[str]: ...
    @property
    def dashboard_url(self) -> str | None: ...
    @property
    def closed(self) -> bool: ...
    @property
    def restored(self) -> dict[Literal["objects", "packets", "refused"], int] | None:
        """What `state=` gave back when the node started; None without it."""
    def peers(self) -> list[str]: ...
    def send_plan(self, source: str, *, to: str) -> PlanHandle: ...
    def snapshot(self) -> dict[str, Any]: ...
    def stats(self) -> dict[str, Any]:
        """The node's counters as `slate stats --format json` prints them: `traffic`,
        `drops` (`behind_dropped`: publications its transport dropped while this module
        was too far behind to take them), `catch_up` (`gaps`: what the network lost or
        dropped), `merges`, `plans` (received, ..., `resent`), `peers`."""
    def close(self) -> None: ...
    def __enter__(self) -> Node: ...
    def __exit__(
        self,
        exc_type: type[BaseException] | None = None,
        exc_value: BaseException | None = None,
        traceback: TracebackType | None = None,
    ) -> bool: ...

@final
class PlanHandle:
    """A plan sent to another module: its circuit, and its acknowledgements."""

    @property
    def circuit(self) -> int: ...
    @property
    def name(self) -> str: ...
    @property
    def to(self) -> str: ...
    @property
    def acks(self) -> Acks: ...
    @property
    def done(self) -> bool: ...
    def get(self, timeout: float | None = None) -> Ack | None: ...
    def cancel(self) -> None: ...

@final
class Acks:
    """The acknowledgements of a plan as they arrive (ends after the last one)."""

    def __iter__(self) -> Iterator[Ack]: ...
    def __next__(self) -> Ack: ...

@final
class Ack:
    """One step of a plan's progression, as its destination acknowledged it."""

    @property
    def step(self) -> _StepName: ...
    @property
    def ok(self) -> bool: ...
    @property
    def detail(self) -> str: ...
    @property
    def last(self) -> bool: ...
    def __eq__(self, other: object, /) -> bool: ...
    def __hash__(self) -> int: ...

# ----- recordings -----

_RecordedValue = None | bool | int | float | str | list[float]

@final
class Recording:
    """An MCAP recording of a board (docs/recording.md), read into memory. Iterating
    yields every packet and event in the file's order (a class channel's message yields
    each packet it holds); a file cut off by a crash is read up to its last complete
    chunk. Files recorded with one packet a message read the same. Raises OSError if the
    file cannot be read, ValueError if it is not an MCAP recording."""

    def __new__(cls, path: str | os.PathLike[str]) -> Recording: ...
    @property
    def path(self) -> str: ...
    @property
    def address(self) -> str | None:
        """The recording board's address, if the file says it."""
    @property
    def complete(self) -> bool:
        """False when the file was cut off (no footer: a crash)."""
    def __iter__(self) -> Iterator[RecordedPacket | RecordedEvent]: ...
    def __len__(self) -> int:
        """The packets and events."""
    def packets(self) -> Iterator[RecordedPacket]:
        """The packets only."""
    def events(self) -> Iterator[RecordedEvent]:
        """Everything but the packets."""

@final
class RecordingIter:
    """An iterator over a recording's messages (what `Recording`'s `__iter__`,
    `packets()` and `events()` return)."""

    def __iter__(self) -> RecordingIter: ...
    def __next__(self) -> RecordedPacket | RecordedEvent: ...

@final
class RecordedPacket:
    """A packet as recorded, written to `object.attr`."""

    @property
    def time(self) -> float:
        """When the recording board handled the message that holds it (its first
        packet's turn), seconds since the Unix epoch."""
    @property
    def object(self) -> str: ...
    @property
    def attr(self) -> str: ...
    @property
    def value(self) -> _RecordedValue:
        """As JSON has it: a reference is its object's name, a vector a list."""
    @property
    def accuracy(self) -> float: ...
    @property
    def confidence(self) -> float: ...
    @property
    def timestamp(self) -> float:
        """The packet's stamp, seconds since the Unix epoch."""
    @property
    def stamp(self) -> int:
        """The full hybrid-clock stamp (as Packet.stamp)."""
    @property
    def source(self) -> str: ...
    @property
    def revision(self) -> int: ...

@final
class RecordedEvent:
    """Any other message: objects, classes, plan events, circuit steps, liveliness, board
    events, counters."""

    @property
    def time(self) -> float: ...
    @property
    def topic(self) -> str: ...
    @property
    def kind(
        self,
    ) -> Literal[
        "objects", "classes", "plans", "circuits", "liveliness", "events", "links", "recorder"
    ]: ...
    @property
    def data(self) -> dict[str, Any]:
        """The message's JSON (docs/recording.md lists the fields of each channel)."""
