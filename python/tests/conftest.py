"""Shared fixtures: a small world after the paper's Ground Surveillance Robot."""

from __future__ import annotations

import os
import random
import socket
import subprocess
import sys
import textwrap
import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest

import slate

WORLD = """
class Vehicle {
    position: vec<2> [m] = [0.0, 0.0] accuracy 100.0 confidence 0.0;
    speed: real [m/s] in 0 .. 10 = 0.0;
    count: int = 0;
    mode: string = "auto";
    alive: bool = true;
    target: ref;
}
class Rover : Vehicle { wheels: int = 6; }
class Obstacle {
    position: vec<2> [m];
    range: real [m];
    clearance: real [m] = 1.5;
}
object gsr : Vehicle context self owner "team/r1/nav";
object r2 : Rover context system;
"""


@pytest.fixture
def board() -> slate.Board:
    """A board on a manual clock with the world loaded."""
    b = slate.Board(clock="manual", address="team/r1/nav")
    b.load(WORLD, name="world.slate")
    return b


@pytest.fixture
def world_file(tmp_path: Path) -> Path:
    path = tmp_path / "world.slate"
    path.write_text(WORLD)
    return path


def free_endpoint() -> str:
    """A Zenoh endpoint on 127.0.0.1 whose port is free and below the kernel's ephemeral
    range, as the Rust tests' `slate_testing::free_ports` draws them: a node connecting
    to a mate before it listens can take a port in that range by a TCP self-connect."""
    try:
        with open("/proc/sys/net/ipv4/ip_local_port_range") as f:
            ephemeral = int(f.read().split()[0])
    except (OSError, ValueError, IndexError):
        ephemeral = 32768
    draw = random.Random(os.getpid() ^ time.time_ns())
    for _ in range(200):
        port = draw.randrange(10_000, max(ephemeral, 10_001))
        with socket.socket() as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                continue
        return f"tcp/127.0.0.1:{port}"
    raise RuntimeError(f"no free TCP port on 127.0.0.1 below {ephemeral}")


def run_with_timeout(fn: Callable[[], object], seconds: float = 20.0) -> None:
    """Runs `fn` in a daemon thread and fails if it does not finish in time (a deadlock
    then fails the test instead of hanging the suite). Exceptions are re-raised."""
    errors: list[BaseException] = []

    def target() -> None:
        try:
            fn()
        except BaseException as e:  # noqa: BLE001 - re-raised in the test's thread
            errors.append(e)

    t = threading.Thread(target=target, daemon=True)
    t.start()
    t.join(seconds)
    assert not t.is_alive(), f"did not finish within {seconds} s (deadlock?)"
    if errors:
        raise errors[0]


def run_in_subprocess(
    code: str, seconds: float = 60.0, cwd: Path | None = None
) -> subprocess.CompletedProcess[str]:
    """Runs Python `code` in a fresh interpreter, so that a crash (a signal) fails the
    calling test with the child's output instead of killing the test runner (and a hang
    fails it after `seconds`)."""
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=seconds,
        check=False,
        cwd=cwd,
    )


def assert_ran_cleanly(done: subprocess.CompletedProcess[str]) -> None:
    """The child exited with status 0 (a negative status is the signal that killed it)."""
    assert done.returncode == 0, (
        f"exit status {done.returncode}\nstdout:\n{done.stdout}\nstderr:\n{done.stderr[-3000:]}"
    )
