"""Bytes on the radio: what one attribute update and an idle minute cost a team link,
counted on the harness's frames (both directions, Ethernet, IP and transport headers
included), beside raw Zenoh puts of a payload as large between the same namespaces.

    sudo python3 scripts/reallink/harness.py bytes                  # TCP links
    sudo python3 scripts/reallink/harness.py bytes --protocol udp   # UDP links

Two robots, one module each: `rl/r1/writer` (robot r1) increments `gsr.count` at 20 Hz
for `updates` writes, pauses, then at 200 Hz for ten times as many; `rl/r2/nav` (robot
r2) receives them over the team link (the only link between two robots). Then both
stay idle. The bytes of a phase are the radio's counters over a window inside it (the
first and last tenth left out, so that start-up and the pause are not counted), divided
by the writer's updates in that window; idle bytes per second likewise over a window
that starts a few seconds after the last update. The baseline is the same three phases
with the Python `zenoh` package (a publisher in r1's namespace, a subscriber in r2's,
one TCP or UDP link like slate's, Zenoh's defaults), run after slate's nodes stopped,
on the same radio. It needs an interpreter that imports `zenoh` (`--zenoh-python`, else
`$ZENOH_PYTHON`, else this one); without one the baseline is reported as skipped.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

# Zenoh's key for the baseline, and the payload it puts: as large as the report of one
# small integer attribute (docs/performance.md, *Bytes on the radio*).
RAW_KEY = "rl/raw/count"
RAW_PAYLOAD = 8

RAW_SCRIPT = r"""
import json, sys, time, zenoh
role, endpoint, updates, idle, size = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5])
conf = zenoh.Config()
conf.insert_json5("scouting/multicast/enabled", "false")
conf.insert_json5("timestamping/enabled", "{ router: false, peer: false, client: false }")
conf.insert_json5("listen/endpoints" if role == "sub" else "connect/endpoints", json.dumps([endpoint]))
if role == "pub":
    conf.insert_json5("listen/endpoints", "[]")
session = zenoh.open(conf)
def say(*words):
    print(" ".join(str(w) for w in words), flush=True)
if role == "sub":
    got = [0]
    def on(sample):
        got[0] += 1
    sub = session.declare_subscriber("rl/raw/**", on)
    say("ready")
    for line in sys.stdin:
        if line.strip() == "count":
            say("count", got[0])
    session.close()
    sys.exit(0)
pub = session.declare_publisher("rl/raw/count")
time.sleep(2.0)
payload = bytes(size)
for name, hz, n in (("20hz", 20, updates), ("200hz", 200, updates * 10)):
    say("begin", name)
    start = time.monotonic()
    for i in range(n):
        pub.put(payload)
        time.sleep(max(0.0, start + (i + 1) / hz - time.monotonic()))
    say("end", name, n)
    time.sleep(3.0)
say("begin", "idle")
time.sleep(idle)
say("end", "idle", 0)
session.close()
"""


def writer_plans(updates: int) -> str:
    """The writer's plans: `updates` writes at 20 Hz, a 5 s pause, ten times as many at
    200 Hz (initiation is latched: the second plan starts once the count has rested)."""
    fast = updates * 11
    return f"""// The bytes run's writer: {updates} updates at 20 Hz, then {updates * 10} at 200 Hz.
plan write_20hz {{
    termination: gsr.count >= {updates};
    every 50ms;
    action {{ set gsr.count = gsr.count + 1; }}
}}
plan write_200hz {{
    initiation: gsr.count >= {updates} and age(gsr.count) > 5s;
    termination: gsr.count >= {fast};
    every 5ms;
    action {{ set gsr.count = gsr.count + 1; }}
}}
"""


class Sampler:
    """Samples (time, writer's count, receiver's count, radio counters) every 100 ms."""

    def __init__(self, team: Any) -> None:
        self.team = team
        self.samples: list[tuple[float, int | None, int | None, dict[str, int]]] = []
        self.stopping = threading.Event()
        self.thread = threading.Thread(target=self._run, name="bytes-sampler", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self.stopping.wait(0.1):
            counts = self.team.counts()
            self.samples.append(
                (time.time(), counts.get("rl/r1/writer"), counts.get("rl/r2/nav"), directed(self.team.radio))
            )

    def stop(self) -> None:
        self.stopping.set()
        self.thread.join(timeout=3)


def directed(radio: Any) -> dict[str, int]:
    """The radio's delivered frames and bytes of each direction between r1 and r2."""
    c = radio.counters()
    return {
        "fwd_bytes": c[(0, 1)]["delivered_bytes"],
        "fwd_frames": c[(0, 1)]["delivered_frames"],
        "back_bytes": c[(1, 0)]["delivered_bytes"],
        "back_frames": c[(1, 0)]["delivered_frames"],
    }


def cost(a: dict[str, int], b: dict[str, int], per: float) -> dict[str, float]:
    """The bytes and frames from counters `a` to `b`, divided by `per` (updates or
    seconds), each direction and both."""
    d = {k: (b[k] - a[k]) / per for k in a}
    d["bytes"] = d["fwd_bytes"] + d["back_bytes"]
    d["frames"] = d["fwd_frames"] + d["back_frames"]
    return {k: round(v, 2) for k, v in d.items()}


def phase_cost(samples: list[Any], lo: int, hi: int) -> dict[str, Any] | None:
    """Cost per update over the samples whose writer count lies in [lo, hi]."""
    inside = [s for s in samples if s[1] is not None and lo <= s[1] <= hi]
    if len(inside) < 2 or inside[-1][1] == inside[0][1]:
        return None
    first, last = inside[0], inside[-1]
    updates = last[1] - first[1]
    out: dict[str, Any] = cost(first[3], last[3], updates)
    out["updates"] = updates
    out["rate_hz"] = round(updates / (last[0] - first[0]), 1)
    return out


def wait_for(team: Any, want: int, deadline: float) -> bool:
    """Waits until both boards hold gsr.count >= want."""
    while time.time() < deadline:
        counts = team.counts()
        if all(c is not None and c >= want for c in counts.values()):
            return True
        time.sleep(0.2)
    return False


def slate_run(team: Any, updates: int, idle: float) -> dict[str, Any]:
    """Starts the receiver, then the writer; measures the three phases on the radio."""
    nav, writer = team.mods[1], team.mods[0]
    team.start_module(nav)
    time.sleep(1.0)
    team.start_module(writer)
    from harness import Boards  # the harness imports this module: import here

    team.boards = Boards(team.nets.names, team.mods)
    sampler = Sampler(team)
    try:
        fast = updates * 11
        if not wait_for(team, fast, time.time() + 60 + updates * 0.2):
            return {"ok": False, "why": "the writer's updates did not all arrive", "counts": team.counts()}
        time.sleep(3.0)
        idle_from = directed(team.radio)
        time.sleep(idle)
        idle_cost = cost(idle_from, directed(team.radio), idle)
    finally:
        sampler.stop()
    margin = updates // 10
    return {
        "ok": True,
        "20hz": phase_cost(sampler.samples, margin, updates - margin),
        "200hz": phase_cost(sampler.samples, updates + margin * 10, fast - margin * 10),
        "idle_per_s": idle_cost,
    }


def zenoh_python(given: str | None) -> str | None:
    """An interpreter that imports `zenoh`, or None."""
    for candidate in (given, os.environ.get("ZENOH_PYTHON"), sys.executable):
        if not candidate:
            continue
        probe = subprocess.run([candidate, "-c", "import zenoh"], capture_output=True, timeout=30)
        if probe.returncode == 0:
            return candidate
    return None


def raw_run(team: Any, python: str, protocol: str, updates: int, idle: float) -> dict[str, Any]:
    """The baseline: raw Zenoh puts from r1's namespace to r2's, on the same radio."""
    endpoint = f"{protocol}/10.77.0.2:7450"
    args = [str(updates), str(idle), str(RAW_PAYLOAD)]
    ns = team.nets.names
    sub = subprocess.Popen(
        ["ip", "netns", "exec", ns[1], python, "-c", RAW_SCRIPT, "sub", endpoint, *args],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, start_new_session=True,
    )
    pub: subprocess.Popen[str] | None = None
    try:
        assert sub.stdout is not None and sub.stdin is not None
        if sub.stdout.readline().strip() != "ready":
            return {"ok": False, "why": "the raw Zenoh subscriber did not start"}
        pub = subprocess.Popen(
            ["ip", "netns", "exec", ns[0], python, "-c", RAW_SCRIPT, "pub", endpoint, *args],
            stdout=subprocess.PIPE, text=True, start_new_session=True,
        )
        result = raw_phases(team, pub, updates + idle + 120)
        sub.stdin.write("count\n")
        sub.stdin.flush()
        result["received"] = int(sub.stdout.readline().split()[-1])
        return result
    finally:
        for p in (pub, sub):
            stop(p)


def raw_phases(team: Any, pub: subprocess.Popen[str], limit: float) -> dict[str, Any]:
    """Reads the publisher's `begin`/`end` lines and the radio's counters at each."""
    assert pub.stdout is not None
    result: dict[str, Any] = {"ok": True}
    began: dict[str, tuple[float, dict[str, int]]] = {}
    deadline = time.time() + limit
    for line in pub.stdout:
        words = line.split()
        if words[:1] == ["begin"]:
            began[words[1]] = (time.time(), directed(team.radio))
        elif words[:1] == ["end"]:
            t0, c0 = began[words[1]]
            n = int(words[2])
            result[f"{words[1]}_per_s" if not n else words[1]] = cost(c0, directed(team.radio), n or time.time() - t0)
        if time.time() > deadline:
            break
    return result


def stop(proc: subprocess.Popen[str] | None) -> None:
    """Stops one process we started, by its pid."""
    if proc is None or proc.poll() is not None:
        return
    proc.terminate()
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(timeout=5)


def summary(result: dict[str, Any]) -> str:
    """A few readable lines from one bytes run."""
    lines = []
    for who in ("slate", "zenoh"):
        r = result.get(who) or {}
        if not r.get("ok"):
            lines.append(f"{who}: {r.get('why', 'not run')}")
            continue
        for phase in ("20hz", "200hz"):
            c = r.get(phase)
            if c:
                lines.append(
                    f"{who} {phase}: {c['bytes']:.1f} B/update ({c['fwd_bytes']:.1f} forward, "
                    f"{c['back_bytes']:.1f} back), {c['frames']:.2f} frames/update"
                )
        idle = r.get("idle_per_s")
        if idle:
            lines.append(
                f"{who} idle: {idle['bytes']:.1f} B/s per link ({idle['fwd_bytes']:.1f} + "
                f"{idle['back_bytes']:.1f}), {idle['frames']:.2f} frames/s"
            )
    return "\n".join(lines)


def as_json(result: dict[str, Any]) -> str:
    return json.dumps(result)


HERE = Path(__file__).resolve().parent
