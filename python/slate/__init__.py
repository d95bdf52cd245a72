"""slate: a distributed blackboard world model for robots.

A :class:`Board` is one module's copy of the world model: classes (with inheritance),
objects, and attributes whose values are :class:`Packet` s (value, accuracy, confidence,
timestamp, source). Modules read and write it, attach active functions to attributes, watch
it change, and load classes, objects, rules and plans written in the slate language.

>>> import slate
>>> b = slate.Board(clock="manual")
>>> b.load("class Vehicle { speed: real [m/s] = 0.0; }")
Loaded(classes=['Vehicle'], objects=[], rules=0, plans=[])
>>> b.create("Vehicle", "gsr")
>>> _ = b.write("gsr", "speed", 2, accuracy=0.1, confidence=0.9)
>>> b.read("gsr", "speed").value
2.0
"""

from __future__ import annotations

from typing import Tuple, Union

from slate._slate import (
    BUILD_PROFILE,
    Ack,
    Acks,
    AccuracyError,
    AddressError,
    Batch,
    Board,
    Call,
    ChainError,
    Change,
    ChangeItem,
    Clock,
    ClockError,
    ConfidenceError,
    CreateError,
    DefineError,
    DeleteError,
    Diagnostic,
    Event,
    Events,
    Info,
    InvalidPacketError,
    Loaded,
    LoadError,
    Node,
    NodeError,
    OutOfBoundsError,
    Outbox,
    Packet,
    Plan,
    PlanError,
    PlanHandle,
    PlanMessage,
    ReadError,
    RecordedEvent,
    RecordedPacket,
    Recording,
    RecordingIter,
    Ref,
    Report,
    ReportItem,
    SlateError,
    UnknownAttributeError,
    UnknownClassError,
    UnknownObjectError,
    ValueTypeError,
    Watch,
    WriteError,
    __version__,
)

Value = Union[None, bool, int, float, str, Ref, Tuple[float, ...]]
"""What an attribute holds, as Python sees it (vectors are tuples of floats)."""

__all__ = [
    "BUILD_PROFILE",
    "Ack",
    "Acks",
    "AccuracyError",
    "AddressError",
    "Batch",
    "Board",
    "Call",
    "ChainError",
    "Change",
    "ChangeItem",
    "Clock",
    "ClockError",
    "ConfidenceError",
    "CreateError",
    "DefineError",
    "DeleteError",
    "Diagnostic",
    "Event",
    "Events",
    "Info",
    "InvalidPacketError",
    "LoadError",
    "Loaded",
    "Node",
    "NodeError",
    "OutOfBoundsError",
    "Outbox",
    "Packet",
    "Plan",
    "PlanError",
    "PlanHandle",
    "PlanMessage",
    "ReadError",
    "RecordedEvent",
    "RecordedPacket",
    "Recording",
    "RecordingIter",
    "Ref",
    "Report",
    "ReportItem",
    "SlateError",
    "UnknownAttributeError",
    "UnknownClassError",
    "UnknownObjectError",
    "Value",
    "ValueTypeError",
    "Watch",
    "WriteError",
    "__version__",
]
