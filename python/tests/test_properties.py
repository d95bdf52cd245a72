"""No sequence of Python-level operations crashes or hangs the process or leaves the board
inconsistent: random sequences of creations, deletions, reads, writes (good and bad
values), batches, clock moves, class deletions and active functions that call back into
the board, checked against a tiny reference model (a dict of values).

The machine runs in a child interpreter, so a crash (a signal) fails the test with the
child's output instead of killing the test runner.
"""

from __future__ import annotations

import math
from pathlib import Path
from collections.abc import Callable
from typing import Any

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, rule

import slate

from .conftest import assert_ran_cleanly, run_in_subprocess

WORLD = """
class A { x: real; y: int = 0; s: string = "a"; }
class B : A { z: real in 0 .. 10; }
"""
B_AGAIN = "class B : A { z: real in 0 .. 10; }"
ATTRS = {"A": {"x": "real", "y": "int", "s": "string"}}
ATTRS["B"] = {**ATTRS["A"], "z": "real"}
DEFAULTS: dict[str, Any] = {"x": None, "y": 0, "s": "a", "z": None}

names = st.sampled_from(["o1", "o2", "o3", "nobody"])
attrs = st.sampled_from(["x", "y", "s", "z", "w"])
values = st.one_of(
    st.none(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
)
seconds = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-5, 10**12))


def expected_after_write(ty: str, value: Any) -> Any:
    """What a read returns after `value` was accepted for an attribute of type `ty`."""
    return float(value) if ty == "real" and isinstance(value, int) else value


class BoardMachine(RuleBasedStateMachine):
    def __init__(self) -> None:
        super().__init__()
        self.board = slate.Board(clock="manual", address="t/r1/prop")
        self.board.load(WORLD)
        self.objects: dict[str, str] = {}  # name -> class
        self.values: dict[tuple[str, str], Any] = {}
        self.has_b = True
        self.revision = self.board.revision
        self.now = self.board.clock.now()

    # ----- the reference model -----

    def attr_type(self, name: str, attr: str) -> str | None:
        cls = self.objects.get(name)
        return ATTRS[cls].get(attr) if cls else None

    def expected(self, name: str, attr: str) -> Any:
        return self.values.get((name, attr), DEFAULTS[attr])

    # ----- operations -----

    @rule(name=names, cls=st.sampled_from(["A", "B", "C"]))
    def create(self, name: str, cls: str) -> None:
        ok = name not in self.objects and name not in ("A", "B") and (
            cls == "A" or (cls == "B" and self.has_b)
        )
        try:
            self.board.create(cls, name)
        except slate.SlateError:
            assert not ok, f"create({cls}, {name}) refused"
            return
        assert ok, f"create({cls}, {name}) accepted"
        self.objects[name] = cls

    @rule(name=names)
    def delete(self, name: str) -> None:
        try:
            self.board.delete(name)
        except slate.SlateError:
            assert name not in self.objects
            return
        assert name in self.objects
        del self.objects[name]
        self.values = {k: v for k, v in self.values.items() if k[0] != name}

    @rule(name=names, attr=attrs, value=values)
    def write(self, name: str, attr: str, value: Any) -> None:
        ty = self.attr_type(name, attr)
        try:
            self.board.write(name, attr, value)
        except slate.SlateError:
            return  # refused: nothing stored (the invariant checks the values)
        assert ty is not None, f"write to {name}.{attr} accepted"
        self.values[(name, attr)] = expected_after_write(ty, value)

    @rule(name=names, attr=attrs)
    def read(self, name: str, attr: str) -> None:
        try:
            packet = self.board.read(name, attr)
        except slate.SlateError:
            assert self.attr_type(name, attr) is None, f"read of {name}.{attr} refused"
            return
        assert self.attr_type(name, attr) is not None
        assert packet.value == self.expected(name, attr)

    @rule(ops=st.lists(st.tuples(names, attrs, values), min_size=1, max_size=4))
    def batch(self, ops: list[tuple[str, str, Any]]) -> None:
        staged = {}
        try:
            with self.board.batch() as tx:
                for name, attr, value in ops:
                    tx.write(name, attr, value)
                    ty = self.attr_type(name, attr)
                    staged[(name, attr)] = expected_after_write(ty or "", value)
        except slate.SlateError:
            return  # nothing of it applied (checked by the invariant)
        self.values.update(staged)

    @rule(by=seconds)
    def advance(self, by: float) -> None:
        try:
            self.board.clock.advance(by)
        except (slate.SlateError, ValueError, OverflowError):
            pass
        now = self.board.clock.now()
        assert now >= self.now
        self.now = now

    @rule()
    def delete_class_b(self) -> None:
        in_use = any(c == "B" for c in self.objects.values())
        try:
            self.board.delete_class("B")
        except slate.SlateError:
            assert in_use or not self.has_b
            return
        assert self.has_b and not in_use
        self.has_b = False

    @rule()
    def define_b_again(self) -> None:
        self.board.load(B_AGAIN)
        self.has_b = True

    @rule(where=st.sampled_from(["A", "o1", "o2"]), attr=st.sampled_from(["x", "y", "s"]))
    def attach_a_read_function_that_reads_itself_through_the_board(
        self, where: str, attr: str
    ) -> None:
        board = self.board

        def again(call: slate.Call) -> None:
            board.read(call.object, call.attr)  # a cycle: cut, the read is unchanged

        self.attach(board.on_read, where, attr, again)

    @rule(where=st.sampled_from(["A", "o1", "o2"]), attr=st.sampled_from(["x", "y", "s"]))
    def attach_a_write_function_that_writes_itself_through_the_board(
        self, where: str, attr: str
    ) -> None:
        def again(call: slate.Call) -> None:
            # A cycle: cut, so the write that triggered it is what stays.
            self.board.write(call.object, call.attr, call.packet.value)
            self.board.write(call.object, call.attr, "not the value")

        self.attach(self.board.on_write, where, attr, again)

    def attach(
        self,
        on: Callable[..., object],
        where: str,
        attr: str,
        function: Callable[[slate.Call], None],
    ) -> None:
        """Attaches `function` with `on`; refused only where nothing of that name exists."""
        try:
            on(where, attr, function)
        except slate.SlateError:
            assert where not in self.objects and where != "A"

    # ----- what must always hold -----

    @invariant()
    def the_board_holds_what_the_model_holds(self) -> None:
        b = self.board
        assert sorted(b.instances("A")) == sorted(self.objects)
        assert b.stats()["objects"] == len(self.objects)
        for name, cls in self.objects.items():
            info = b.info(name)
            assert info is not None and info.class_name == cls
            for attr in ATTRS[cls]:
                got = b.read(name, attr).value
                want = self.expected(name, attr)
                both_nan = isinstance(got, float) and isinstance(want, float)
                assert got == want or (both_nan and math.isnan(got) and math.isnan(want))
        assert (b.info("B") is not None) == self.has_b
        assert b.revision >= self.revision
        self.revision = b.revision


def run_machine() -> None:
    """Runs the machine in this process (the child's entry point)."""
    from hypothesis.stateful import run_state_machine_as_test

    run_state_machine_as_test(
        BoardMachine,
        settings=settings(
            max_examples=200,
            stateful_step_count=30,
            deadline=None,
            suppress_health_check=list(HealthCheck),
            database=None,
        ),
    )


def test_no_sequence_of_python_operations_crashes_or_corrupts_the_board() -> None:
    done = run_in_subprocess(
        "from tests.test_properties import run_machine; run_machine(); print('ok')",
        seconds=240.0,
        cwd=Path(__file__).resolve().parent.parent,
    )
    assert_ran_cleanly(done)
    assert done.stdout.strip().endswith("ok")
