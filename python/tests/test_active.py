"""Python callables as active functions: on write, on read, chains, failures, threads."""

from __future__ import annotations

import gc
import threading
import weakref

import pytest

import slate

from .conftest import assert_ran_cleanly, run_in_subprocess, run_with_timeout


def test_on_write_runs_after_the_write_for_every_instance_of_subclasses(
    board: slate.Board,
) -> None:
    calls: list[tuple[str, str, object, object, str, int]] = []

    def record(call: slate.Call) -> None:
        previous = call.previous.value if call.previous else None
        calls.append(
            (call.object, call.attr, call.packet.value, previous, call.trigger, call.revision)
        )

    assert board.on_write("Vehicle", "speed", record) is record
    r1 = board.write("gsr", "speed", 1.0)
    r2 = board.write("r2", "speed", 2.0)  # a Rover: inherited from Vehicle
    r3 = board.write("gsr", "speed", 3)
    assert calls == [
        ("gsr", "speed", 1.0, None, "write", r1),
        ("r2", "speed", 2.0, None, "write", r2),
        ("gsr", "speed", 3.0, 1.0, "write", r3),
    ]


def test_on_write_as_a_decorator_on_one_object(board: slate.Board) -> None:
    seen: list[object] = []

    @board.on_write("gsr", "mode")
    def on_mode(call: slate.Call) -> None:
        seen.append(call.packet.value)

    board.write("gsr", "mode", "stopped")
    board.write("r2", "mode", "stopped")  # another object: not attached there
    assert seen == ["stopped"]
    assert callable(on_mode)


def test_active_function_reads_and_writes_through_the_call(board: slate.Board) -> None:
    @board.on_write("Vehicle", "speed")
    def follow(call: slate.Call) -> None:
        mode = call.read(call.object, "mode").value
        if mode == "auto":
            call.write(call.object, "count", 1, confidence=0.5)
        call.write("r2", "speed", call.packet.value)  # chains on to r2's own function

    board.write("gsr", "speed", 4.0)
    assert board.read("gsr", "count").value == 1
    assert board.read("gsr", "count").confidence == 0.5
    assert board.read("r2", "speed").value == 4.0
    assert board.read("r2", "count").value == 1


def test_call_instances_and_exists(board: slate.Board) -> None:
    found: list[object] = []

    @board.on_write("gsr", "mode")
    def look(call: slate.Call) -> None:
        found.append(call.instances("Vehicle"))
        found.append(call.exists("r2"))
        found.append(call.exists("ghost"))

    board.write("gsr", "mode", "look")
    assert found == [["gsr", "r2"], True, False]


def test_an_exception_is_isolated_and_reported_as_an_event(board: slate.Board) -> None:
    events = board.events()
    after: list[object] = []

    def broken(call: slate.Call) -> None:
        raise ValueError(f"no speed {call.packet.value} for me")

    board.on_write("Vehicle", "speed", broken)
    board.on_write("Vehicle", "speed", lambda call: after.append(call.packet.value))
    rev = board.write("gsr", "speed", 5.0)  # does not raise
    assert rev == board.revision
    assert board.read("gsr", "speed").value == 5.0  # the write stands
    assert after == [5.0]  # the other function still ran
    event = events.get(timeout=1.0)
    assert event is not None and event.kind == "function_failed"
    assert (event.object, event.attr, event.trigger) == ("gsr", "speed", "write")
    assert event.function is not None and "broken" in event.function
    assert event.error is not None
    assert event.error.startswith("ValueError: no speed 5.0 for me (at ")
    assert "test_active.py" in event.error and "in broken" in event.error
    assert board.stats()["function_failures"] == 1
    # The board is intact and keeps working.
    board.write("gsr", "mode", "manual")
    assert board.read("gsr", "mode").value == "manual"


def test_a_failed_write_inside_a_function_is_an_exception_there(board: slate.Board) -> None:
    caught: list[BaseException] = []

    @board.on_write("gsr", "mode")
    def bad(call: slate.Call) -> None:
        try:
            call.write("gsr", "speed", "fast")
        except slate.ValueTypeError as e:
            caught.append(e)
        call.write("ghost", "speed", 1.0)  # not caught: the function fails

    events = board.events()
    board.write("gsr", "mode", "x")
    assert len(caught) == 1 and "expected a value of type real" in str(caught[0])
    event = events.get(timeout=1.0)
    assert event is not None and event.error is not None
    assert event.error.startswith("UnknownObjectError: no object named ghost")


def test_a_cycle_is_cut_and_reported(board: slate.Board) -> None:
    events = board.events()

    @board.on_write("Vehicle", "count")
    def again(call: slate.Call) -> None:
        value = call.packet.value
        assert isinstance(value, int)
        call.write(call.object, "count", value + 1)

    board.write("gsr", "count", 1)
    # The function's own write of count is the cycle: refused, so count stays 1.
    assert board.read("gsr", "count").value == 1
    kinds = [e.kind for e in events.drain()]
    assert "chain_cut" in kinds and "function_failed" in kinds
    assert board.stats()["chain_cuts"] == 1


def test_a_deep_chain_is_cut_at_the_depth_limit() -> None:
    b = slate.Board(clock="manual", max_depth=3)
    b.define("Node", {"value": "int"})
    names = [f"n{i}" for i in range(8)]
    for n in names:
        b.create("Node", n)

    @b.on_write("Node", "value")
    def forward(call: slate.Call) -> None:
        i = names.index(call.object)
        if i + 1 < len(names):
            call.write(names[i + 1], "value", call.packet.value)

    events = b.events()
    b.write("n0", "value", 7)
    reached = [b.read(n, "value").value for n in names]
    assert reached[:4] == [7, 7, 7, 7] and reached[-1] is None
    assert any(e.kind == "chain_cut" for e in events.drain())


def test_on_read_replaces_the_value_returned(board: slate.Board) -> None:
    board.create("Obstacle", "rock")
    board.write("rock", "range", 4.0)

    @board.on_read("Obstacle", "position")
    def position(call: slate.Call) -> list[float]:
        r = call.read(call.object, "range").value
        assert isinstance(r, float)
        return [r, 0]

    p = board.read("rock", "position")
    assert p.value == (4.0, 0.0)
    board.write("rock", "position", [1.0, 1.0])  # stored, but the function still decides
    assert board.read("rock", "position").value == (4.0, 0.0)


def test_on_read_may_return_a_packet_or_none(board: slate.Board) -> None:
    board.write("gsr", "speed", 2.0, accuracy=0.1)

    @board.on_read("gsr", "speed")
    def decay(call: slate.Call) -> slate.Packet | None:
        if call.packet.value == 0.0:
            return None
        return slate.Packet(call.packet.value, accuracy=call.packet.accuracy * 10, confidence=0.5)

    p = board.read("gsr", "speed")
    assert (p.value, p.accuracy, p.confidence) == (2.0, 1.0, 0.5)
    assert p.timestamp == board.read("gsr", "mode").timestamp or p.timestamp > 0
    assert p.source == "team/r1/nav"  # kept from the packet read
    board.write("gsr", "speed", 0.0)
    assert board.read("gsr", "speed").confidence == 1.0


def test_on_read_returning_an_int_for_a_real_gives_a_float(board: slate.Board) -> None:
    board.on_read("Vehicle", "speed", lambda call: 3)
    value = board.read("gsr", "speed").value
    assert value == 3.0 and isinstance(value, float)


def test_on_read_returning_a_wrong_value_is_reported_and_ignored(board: slate.Board) -> None:
    events = board.events()
    board.write("gsr", "speed", 1.0)
    board.on_read("Vehicle", "speed", lambda call: "fast")
    assert board.read("gsr", "speed").value == 1.0
    event = events.get(timeout=1.0)
    assert event is not None and event.kind == "function_failed"
    assert event.error is not None and "invalid packet" in event.error


def test_a_call_is_only_valid_while_its_function_runs(board: slate.Board) -> None:
    kept: list[slate.Call] = []
    board.on_write("gsr", "mode", kept.append)
    board.write("gsr", "mode", "x")
    call = kept[0]
    assert call.object == "gsr" and call.packet.value == "x"
    with pytest.raises(slate.SlateError, match="Call is over"):
        call.read("gsr", "speed")


def test_attaching_to_unknown_names_or_non_callables_raises(board: slate.Board) -> None:
    with pytest.raises(slate.UnknownAttributeError):
        board.on_write("Vehicle", "altitude", lambda call: None)
    with pytest.raises(slate.UnknownObjectError):
        board.on_write("Submarine", "speed", lambda call: None)
    with pytest.raises(TypeError, match="must be callable"):
        board.on_write("Vehicle", "speed", 42)  # type: ignore[call-overload]


def test_functions_run_for_writes_from_many_threads_without_deadlock(
    board: slate.Board,
) -> None:
    counted: list[int] = []
    lock = threading.Lock()

    @board.on_write("Vehicle", "speed")
    def count(call: slate.Call) -> None:
        with lock:
            counted.append(1)
        call.write(call.object, "count", len(counted))
        call.read(call.object, "position")

    board.on_read("Vehicle", "position", lambda call: None)

    def writer(name: str) -> None:
        for i in range(50):
            board.write(name, "speed", float(i % 10))
            board.read(name, "position")

    def run() -> None:
        threads = [threading.Thread(target=writer, args=(n,)) for n in ("gsr", "r2", "gsr")]
        for t in threads:
            t.start()
        for t in threads:
            t.join()

    run_with_timeout(run)
    assert len(counted) == 150


def test_python_on_read_inside_plan_evaluation_with_concurrent_writers() -> None:
    """A plan condition reads an attribute computed by a Python on-read function: the plan
    engine runs it inside a snapshot (holding the board's read lock) while other Python
    threads write. Every board call releases the GIL, so nothing deadlocks. (The engine
    cannot see what a Python function reads, so the trigger also names `gsr.speed`.)"""
    b = slate.Board(clock="manual")
    b.load(
        """
        class Vehicle { speed: real = 0.0; doubled: real = 0.0; alerts: int = 0; }
        object gsr : Vehicle;
        plan fast {
            trigger: gsr.speed > 5.0 and gsr.doubled > 10.0;
            action { set gsr.alerts = 1; }
        }
        """
    )

    @b.on_read("Vehicle", "doubled")
    def doubled(call: slate.Call) -> float:
        speed = call.read(call.object, "speed").value
        assert isinstance(speed, float)
        return speed * 2

    def writer(offset: int) -> None:
        for i in range(100):
            b.write("gsr", "speed", float((i + offset) % 8))
            b.read("gsr", "doubled")

    def run() -> None:
        threads = [threading.Thread(target=writer, args=(k,)) for k in range(3)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()

    run_with_timeout(run)
    assert b.plan("fast").fired >= 1
    assert b.read("gsr", "alerts").value == 1


def test_a_board_and_its_functions_referring_to_it_are_garbage_collected() -> None:
    class Sentinel:
        pass

    b = slate.Board()
    b.define("Vehicle", {"speed": "real"})
    sentinel = Sentinel()
    alive = weakref.ref(sentinel)
    # The function refers to the board, which holds the function: a reference cycle.
    b.on_write("Vehicle", "speed", lambda call: (b, sentinel))
    b.on_read("Vehicle", "speed", lambda call: (b, sentinel) and None)
    del b, sentinel
    gc.collect()
    assert alive() is None


def test_a_read_function_that_reads_through_the_board_is_cut_instead_of_crashing() -> None:
    done = run_in_subprocess(
        """
        import slate
        b = slate.Board(clock="manual")
        b.load("class A { x: real; } object o : A;")
        b.write("o", "x", 1.0)
        errors = []
        def again(call):
            try:
                return b.read("o", "x").value + 1
            except slate.ChainError as e:
                errors.append(e)
                raise
        b.on_read("A", "x", again)
        events = b.events(timeout=0)
        assert b.read("o", "x").value == 1.0, "the failed function left the packet"
        assert len(errors) == 1, errors
        assert "o.x -> o.x" in str(errors[0]) or "cycle" in str(errors[0]).lower(), errors
        assert b.stats()["chain_cuts"] == 1
        print("ok")
        """
    )
    assert_ran_cleanly(done)
    assert done.stdout.strip() == "ok"


def test_a_write_function_that_writes_its_attribute_through_the_board_is_cut() -> None:
    done = run_in_subprocess(
        """
        import slate
        b = slate.Board(clock="manual")
        b.load("class A { x: real; } object o : A;")
        runs = []
        def again(call):
            runs.append(call.packet.value)
            b.write("o", "x", call.packet.value + 1)
        b.on_write("A", "x", again)
        b.write("o", "x", 1.0)
        assert runs == [1.0], runs
        assert b.read("o", "x").value == 1.0
        assert b.stats()["chain_cuts"] == 1
        print("ok")
        """
    )
    assert_ran_cleanly(done)
    assert done.stdout.strip() == "ok"
