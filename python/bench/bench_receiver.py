"""What a slate receiver spends per update delivered to Python, with a writer at full speed.

Two processes on 127.0.0.1, each a `slate.Node` (modules of one robot): the writer makes one
`Board.write` per update, round-robin over 100 objects, as fast as a Python loop can for
`DUR` seconds (3); the receiver's sink reads each packet's value, accuracy, confidence and
timestamp and counts it, either from a Python thread iterating a watch of `Data.x`
(`MODE=watch`, the default) or in an on-write function on `Data.x` (`MODE=onwrite`, run on
the thread that merges each report). Like the peer harness's throughput rows
(docs/performance.md, *Side by side with the peers*), alone.

    .venv/bin/python python/bench/bench_receiver.py
    MODE=onwrite PYTHONPATH=/path/to/another/build .venv/bin/python python/bench/bench_receiver.py

Prints one JSON object: updates written and delivered, the receiver's CPU seconds from the
writer's start until its count is stable (all threads, and per thread name), CPU µs per
delivered update, the receiver's `drops` (`behind_dropped`: dropped at the transport's queue
to its handler), and whether the receiver's board then held the writer's final values. To
compare builds, alternate them in one session (`PYTHONPATH` pointing at each build's `slate`
package): the box's other load moves the absolute figures, not the ratio. Build with
`python/build.sh --release` first.
"""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys
import threading
import time

WORLD = "class Data { x: real; y: real; }"
NAMES = [f"d{i}" for i in range(100)]
WRITER = "bench/r1/writer"
RECEIVER = "bench/r1/receiver"


def threads_cpu() -> dict[str, float]:
    """CPU seconds of this process's threads, summed by thread name."""
    out: dict[str, float] = {}
    tick = os.sysconf("SC_CLK_TCK")
    for t in os.listdir("/proc/self/task"):
        try:
            with open(f"/proc/self/task/{t}/stat") as f:
                s = f.read()
        except OSError:
            continue
        name = s[s.index("(") + 1 : s.rindex(")")]
        fields = s[s.rindex(")") + 2 :].split()
        out[name] = out.get(name, 0.0) + (int(fields[11]) + int(fields[12])) / tick
    return out


def receiver(port: int, mode: str) -> None:
    import slate

    board = slate.Board(address=RECEIVER)
    board.load(WORLD)
    lock = threading.Lock()
    count = [0]
    if mode == "watch":
        watch = board.watch("Data", "x")

        def sink() -> None:
            for change in watch:
                for item in change.items:
                    p = item.packet
                    if p is not None:
                        (p.value, p.accuracy, p.confidence, p.timestamp)
                        with lock:
                            count[0] += 1

        threading.Thread(target=sink, daemon=True).start()
    else:

        def on_write(call: slate.Call) -> None:
            p = call.packet
            (p.value, p.accuracy, p.confidence, p.timestamp)
            with lock:
                count[0] += 1

        board.on_write("Data", "x", on_write)
    with slate.Node(RECEIVER, board, listen=[f"tcp/127.0.0.1:{port}"]) as node:
        print("ready", flush=True)
        for line in sys.stdin:
            if line.startswith("start"):
                cpu0, threads0 = time.process_time(), threads_cpu()
                with lock:
                    n0 = count[0]
                print("ok", flush=True)
            elif line.startswith("stop"):
                last = -1
                while True:  # until the count is stable
                    with lock:
                        n = count[0]
                    if n == last:
                        break
                    last = n
                    time.sleep(0.3)
                cpu1, threads1 = time.process_time(), threads_cpu()
                final = [board.read(name, "x").value for name in NAMES]
                used = {k: round(v - threads0.get(k, 0.0), 2) for k, v in threads1.items()}
                result = {
                    "delivered": n - n0,
                    "cpu_s": round(cpu1 - cpu0, 3),
                    "threads_cpu_s": {k: v for k, v in used.items() if v > 0.05},
                    "drops": node.stats()["drops"],
                    "final": final,
                }
                print(json.dumps(result), flush=True)
                return


def main() -> None:
    import slate

    port = int(os.environ.get("PORT", "17647"))
    mode = os.environ.get("MODE", "watch")
    seconds = float(os.environ.get("DUR", "3"))
    child = subprocess.Popen(
        [sys.executable, __file__, "--receiver", str(port), mode],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert child.stdin is not None and child.stdout is not None
    try:
        assert child.stdout.readline().strip() == "ready"
        board = slate.Board(address=WRITER)
        board.load(WORLD)
        for name in NAMES:
            board.create("Data", name)
        rng = random.Random(1)
        with slate.Node(WRITER, board, connect=[f"tcp/127.0.0.1:{port}"]) as node:
            deadline = time.monotonic() + 15
            while node.peers() != [RECEIVER]:
                assert time.monotonic() < deadline, "the receiver did not come up"
                time.sleep(0.01)
            for name in NAMES:
                board.write(name, "x", 0.0)
            time.sleep(1.5)  # past the greeting and its catch-up
            child.stdin.write("start\n")
            child.stdin.flush()
            assert child.stdout.readline().strip() == "ok"
            written = 0
            t0 = time.perf_counter()
            while time.perf_counter() - t0 < seconds:
                for name in NAMES:
                    board.write(name, "x", rng.uniform(-100, 100), accuracy=rng.random(), confidence=rng.random())
                written += len(NAMES)
            took = time.perf_counter() - t0
            time.sleep(0.5)
            child.stdin.write("stop\n")
            child.stdin.flush()
            result = json.loads(child.stdout.readline())
            result["final_values_held"] = result.pop("final") == [board.read(n, "x").value for n in NAMES]
        result.update(
            mode=mode,
            written=written,
            writes_per_s=round(written / took),
            cpu_us_per_delivered=round(1e6 * result["cpu_s"] / max(1, result["delivered"]), 3),
            build=slate.BUILD_PROFILE,
            slate=os.path.dirname(slate.__file__),
        )
        print(json.dumps(result), flush=True)
    finally:
        try:
            child.wait(10)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()


if __name__ == "__main__":
    if sys.argv[1:2] == ["--receiver"]:
        receiver(int(sys.argv[2]), sys.argv[3])
    else:
        main()
