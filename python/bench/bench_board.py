"""Python read/write throughput of a slate Board, against a plain dict and py_trees'
blackboard (py_trees.blackboard.Client get/set), measured in the same run.

    .venv/bin/python python/bench/bench_board.py [--ops N] [--repeat R]

Prints one JSON object. Every figure is operations per second, the best of R runs of N
operations each. Target: slate `read` at least 5x py_trees `get`. Build the extension with
`python/build.sh --release` first: a debug build (BUILD_PROFILE "debug") is several times
slower and its figures are not meaningful.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from collections.abc import Callable
from typing import Any

import py_trees

import slate

WORLD = """
class Vehicle { speed: real [m/s] = 0.0; mode: string = "auto"; }
object gsr : Vehicle;
"""


def rate(loop: Callable[[int], Any], ops: int, repeat: int) -> float:
    """Best operations per second of `loop(ops)` over `repeat` runs."""
    best = 0.0
    for _ in range(repeat):
        start = time.perf_counter()
        loop(ops)
        elapsed = time.perf_counter() - start
        best = max(best, ops / elapsed)
    return best


def slate_board() -> slate.Board:
    b = slate.Board(clock="manual")
    b.load(WORLD)
    return b


def bench_slate(ops: int, repeat: int) -> dict[str, float]:
    b = slate_board()
    read, write = b.read, b.write

    def reads(n: int) -> None:
        for _ in range(n):
            read("gsr", "speed")

    def read_values(n: int) -> None:
        for _ in range(n):
            read("gsr", "speed").value

    def writes(n: int) -> None:
        for i in range(n):
            write("gsr", "speed", 1.5)

    def writes_with_quality(n: int) -> None:
        for i in range(n):
            write("gsr", "speed", 1.5, accuracy=0.1, confidence=0.9)

    out = {
        "read": rate(reads, ops, repeat),
        "read_value": rate(read_values, ops, repeat),
        "write": rate(writes, ops, repeat),
        "write_with_quality": rate(writes_with_quality, ops, repeat),
    }

    # A board with a Python on-write function: every write calls into Python.
    f = slate_board()
    calls = []
    f.on_write("Vehicle", "speed", lambda call: calls.append(1))

    def writes_fn(n: int) -> None:
        for _ in range(n):
            f.write("gsr", "speed", 1.5)

    out["write_python_on_write"] = rate(writes_fn, max(ops // 20, 1), repeat)
    return out


def bench_dict(ops: int, repeat: int) -> dict[str, float]:
    d: dict[str, float] = {"gsr.speed": 0.0}

    def reads(n: int) -> None:
        for _ in range(n):
            d["gsr.speed"]

    def writes(n: int) -> None:
        for _ in range(n):
            d["gsr.speed"] = 1.5

    return {"read": rate(reads, ops, repeat), "write": rate(writes, ops, repeat)}


def bench_py_trees(ops: int, repeat: int) -> dict[str, float]:
    py_trees.blackboard.Blackboard.clear()
    writer = py_trees.blackboard.Client(name="bench_writer")
    writer.register_key(key="speed", access=py_trees.common.Access.WRITE)
    writer.set("speed", 0.0)
    reader = py_trees.blackboard.Client(name="bench_reader")
    reader.register_key(key="speed", access=py_trees.common.Access.READ)

    def reads(n: int) -> None:
        for _ in range(n):
            reader.get("speed")

    def writes(n: int) -> None:
        for _ in range(n):
            writer.set("speed", 1.5)

    return {"get": rate(reads, ops, repeat), "set": rate(writes, ops, repeat)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ops", type=int, default=200_000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    s = bench_slate(args.ops, args.repeat)
    d = bench_dict(args.ops, args.repeat)
    p = bench_py_trees(args.ops, args.repeat)
    result = {
        "benchmark": "python_board",
        "build_profile": slate.BUILD_PROFILE,
        "python": platform.python_version(),
        "ops_per_run": args.ops,
        "runs": args.repeat,
        "ops_per_second": {"slate": s, "dict": d, "py_trees": p},
        "ratios": {
            "slate_read_vs_py_trees_get": s["read"] / p["get"],
            "slate_write_vs_py_trees_set": s["write"] / p["set"],
            "dict_read_vs_slate_read": d["read"] / s["read"],
            "dict_write_vs_slate_write": d["write"] / s["write"],
        },
        "target": {"slate_read_vs_py_trees_get": 5.0},
    }
    result["target"]["met"] = result["ratios"]["slate_read_vs_py_trees_get"] >= 5.0
    json.dump(result, sys.stdout, indent=2)
    print()


if __name__ == "__main__":
    main()
