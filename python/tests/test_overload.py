"""Overload on 127.0.0.1: a writer at full speed (another process) against a receiver
whose consumer is a Python on-write function, slower than the writer. Both are modules
of one robot: its link sends every update (the team link sends an attribute at most every
200 ms, so a writer on another robot cannot flood a receiver this way). Reports are best
effort, so the receiver gets the latest state, not every update (docs/ici.md, "What a
slow receiver gets"): the transport hands messages to the handler through a bounded
queue and drops publications when the handler is that far behind; the ICI sees the
gaps, and catch-up brings the writer's final values soon after the writer stops (0.3 s
here with a 1 ms consumer; before the queue, the consumer ran on Zenoh's receive thread,
every update was queued in TCP and Zenoh's buffers and drained, and the final values
came 14 s after the writer stopped)."""

from __future__ import annotations

import contextlib
import subprocess
import sys
import time
from collections.abc import Iterator
from typing import Any

import slate

from .conftest import free_endpoint

# Seconds the receiver may take, after the writer stops, to hold its final values: the
# issue's bound is 2 s; the test allows more and asserts the end state, not the time.
CONVERGE_WITHIN = 6.0

ATTRS = ["a0", "a1", "a2", "a3"]
WORLD = "class Counters {\n" + "".join(f"    {a}: int = 0;\n" for a in ATTRS) + "}\n"

# The writer: meets the receiver, writes every attribute as fast as it can for `seconds`,
# prints its final value, and stays (so that catch-up can still ask it) until its stdin
# closes.
WRITER = f"""
import sys, time, slate
endpoint, seconds = sys.argv[1], float(sys.argv[2])
board = slate.Board(address="t/r1/writer")
board.load({WORLD!r} + "object gsr : Counters context self;")
with slate.Node("t/r1/writer", board, listen=[endpoint], export=["Thing"]) as node:
    deadline = time.monotonic() + 20
    while not node.peers() and time.monotonic() < deadline:
        time.sleep(0.01)
    print("met", flush=True)
    end, n = time.monotonic() + seconds, 0
    while time.monotonic() < end:
        for a in {ATTRS!r}:
            board.write("gsr", a, n)
        n += 1
    print("done", n - 1, flush=True)
    sys.stdin.read()
"""


@contextlib.contextmanager
def writer_met(
    script: str, endpoint: str, seconds: str, board: slate.Board, **node_args: Any
) -> Iterator[tuple[slate.Node, int]]:
    """Runs `script` as the writer (another process) for `seconds`, with a node for
    `board` that connects to it; yields the node and the writer's final value once it
    stopped writing, and stops the writer (by its process) on leaving."""
    writer = subprocess.Popen(
        [sys.executable, "-c", script, endpoint, seconds],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        with slate.Node(board.address or "", board, connect=[endpoint], **node_args) as node:
            assert writer.stdout is not None
            assert writer.stdout.readline().strip() == "met"
            done = writer.stdout.readline().split()
            assert done[:1] == ["done"], done
            yield node, int(done[1])
    finally:
        if writer.stdin:
            writer.stdin.close()
        try:
            writer.wait(timeout=10)
        except subprocess.TimeoutExpired:
            writer.kill()
            writer.wait(timeout=5)


def final_values_held(board: slate.Board, final: int) -> bool:
    """Does `board` hold `final` in every attribute of gsr?"""
    try:
        return all(board.read("gsr", a).value == final for a in ATTRS)
    except (KeyError, slate.SlateError):
        return False


def test_a_slow_python_receiver_holds_the_writers_final_values_and_counts_what_it_dropped() -> None:
    endpoint = free_endpoint()
    board = slate.Board(address="t/r1/receiver")
    board.load(WORLD)
    consumed = [0]

    @board.on_write("Counters", "a0")
    def consume(call: slate.Call) -> None:
        # A consumer with 1 ms of work per update: the writer writes a0 about 3000
        # times a second, three times what this one can take.
        time.sleep(0.001)
        consumed[0] += 1

    with writer_met(WRITER, endpoint, "3", board, export=["Thing"]) as (node, final):
        stopped = time.monotonic()
        # The board converges on the writer's final values (bounded wait; the
        # catch-up that brings them is asked for 300 ms after a gap opens).
        while time.monotonic() < stopped + CONVERGE_WITHIN and not final_values_held(board, final):
            time.sleep(0.05)
        assert final_values_held(board, final), [board.read("gsr", a).value for a in ATTRS]
        stats = node.stats()
        # The receiver did not see every update: the network dropped some, which
        # opened gaps in the writer's stream that catch-up closed. (Not always counted
        # in `gaps`, which counts the gaps that asked for a catch-up: one already asked
        # for, such as the node's second greeting a second after it met the writer,
        # may close them first.)
        assert 0 < consumed[0] < final + 1, (consumed[0], final)
        assert stats["catch_up"]["completed"] > 0, stats["catch_up"]
        # Some were dropped here, by the transport's full receive queue, and counted.
        assert stats["drops"]["behind_dropped"] > 0, stats["drops"]


# Seconds the receiver of a lossless class may take to work through the backlog.
LOSSLESS_DRAIN_WITHIN = 60.0

# A writer of ordinary counters and of one lossless class, for the test below: it writes
# ev.seq = n after the counters of each round, as fast as the receiver lets it.
EVENTS_WORLD = WORLD + "class Events { seq: int = 0; }\n"
LOSSLESS_WRITER = f"""
import sys, time, slate
endpoint, seconds = sys.argv[1], float(sys.argv[2])
board = slate.Board(address="t/r1/writer")
board.load({EVENTS_WORLD!r} + "object gsr : Counters context self; object ev : Events context self;")
with slate.Node("t/r1/writer", board, listen=[endpoint], export=["Thing"], lossless=["Events"]) as node:
    deadline = time.monotonic() + 20
    while not node.peers() and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(0.5)  # the receiver's hello (its interest) has arrived
    print("met", flush=True)
    end, n = time.monotonic() + seconds, 0
    while time.monotonic() < end:
        for a in {ATTRS!r}:
            board.write("gsr", a, n)
        board.write("ev", "seq", n)
        n += 1
    print("done", n - 1, flush=True)
    sys.stdin.read()
"""


def test_a_slow_receiver_gets_every_update_of_a_lossless_class_and_the_latest_state_of_the_others() -> None:
    endpoint = free_endpoint()
    board = slate.Board(address="t/r1/receiver")
    board.load(EVENTS_WORLD)
    consumed = [0]
    events: list[int] = []

    @board.on_write("Counters", "a0")
    def consume(call: slate.Call) -> None:
        time.sleep(0.001)  # slower than the writer, as above
        consumed[0] += 1

    @board.on_write("Events", "seq")
    def record(call: slate.Call) -> None:
        events.append(call.packet.value)

    with writer_met(LOSSLESS_WRITER, endpoint, "1", board, export=["Thing"]) as (node, final):
        stopped = time.monotonic()
        # The writer was held back only once TCP's and Zenoh's buffers were full: the
        # receiver works through that backlog (several MB) after it stops.
        while time.monotonic() < stopped + LOSSLESS_DRAIN_WITHIN and not (
            final_values_held(board, final) and events[-1:] == [final]
        ):
            time.sleep(0.05)
        assert final_values_held(board, final), [board.read("gsr", a).value for a in ATTRS]
        # Every update of the lossless class, in order, from the first one it was sent.
        assert events, "no event arrived"
        first = events[0]
        assert first <= 1, first
        assert events == list(range(first, final + 1)), (len(events), first, final)
        # The ordinary class still gets the latest state only: the receiver's queue
        # dropped some of its reports, and catch-up closed the gaps.
        stats = node.stats()
        assert stats["drops"]["behind_dropped"] > 0, stats["drops"]
        assert consumed[0] < final + 1, (consumed[0], final)
