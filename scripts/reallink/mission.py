#!/usr/bin/env python3
"""The demo's mission on real links: `slate demo --network processes` with every robot's
modules in a network namespace of their own, on their own LAN (the namespace's
addresses), and the team link through the emulated radio shaped as the demo's simulator
shapes it: 60 ms +- 40 ms, 5 % loss, 9600 bit/s per directed link.

    sudo python3 scripts/reallink/mission.py                 # seed 7, one run
    sudo python3 scripts/reallink/mission.py --seed 3 --runs 3
    sudo python3 scripts/reallink/mission.py --loss 0 --rate 0   # the radio unshaped
    sudo python3 scripts/reallink/mission.py --speakers modules  # every module speaks

Robots speak by default (`slate demo --speakers robots`: one gateway per robot on the
team link, docs/team-protocol.md): with every module speaking, each module's Zenoh
session has a TCP connection to every module of every other robot, and 9600 bit/s
cannot carry them (docs/deploy.md).

Namespace 0 holds the `slate demo` process itself (the world, served as a module, and the
referee's observers; docs/demo.md "As processes"): its links to every robot are clean, so
only the team's own traffic crosses the shaped radio. Namespace 1 holds the console
(robot `base`), namespaces 2.. the robots r1, r2, ... Each robot's five modules talk to
each other inside their namespace (their LAN) and to other robots over the radio.

Each run prints one JSON object: the demo's summary (its `--format json`), the radio's
counters summed over the team's links (`team_radio`: frames and bytes offered, delivered
and dropped, Ethernet headers included), the impairment and the wall time. Exit codes: 0
every run completed the mission with no duplicated investigation and the fault detected,
1 otherwise, 77 skipped (not root, no netns or TAP), 2 bad usage. Bounded: every run has
a deadline; the demo is stopped by its pid (its module processes leave when their input
closes) and every namespace deleted, also on Ctrl-C.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from harness import find_slate, stop_process  # noqa: E402
from netns import Namespaces, sweep_leftovers, unavailable  # noqa: E402
from radio import Impairment, Radio  # noqa: E402

SKIP = 77
# The world and the referee, then the console, then the robots.
WORLD, BASE, FIRST_ROBOT = 0, 1, 2


def team_pairs(count: int) -> list[tuple[int, int]]:
    """Every directed link between two members of the team (console and robots)."""
    members = range(BASE, count)
    return [(a, b) for a in members for b in members if a != b]


def placement(nets: Namespaces, robots: int) -> list[str]:
    """`slate demo`'s arguments placing the world, the console and every robot."""
    args = ["--world-address", nets.address(WORLD)]
    names = ["base"] + [f"r{i + 1}" for i in range(robots)]
    for k, name in enumerate(names):
        ns = BASE + k
        args += ["--place", f"{name}={nets.names[ns]}@{nets.address(ns)}"]
    return args


def radio_totals(radio: Radio, pairs: list[tuple[int, int]]) -> dict[str, int]:
    """The radio's counters summed over `pairs`."""
    totals: dict[str, int] = {}
    for pair, counters in radio.counters().items():
        if pair in pairs:
            for key, value in counters.items():
                totals[key] = totals.get(key, 0) + value
    return totals


def run(args: argparse.Namespace, slate: str, workdir: Path) -> dict[str, Any]:
    """One mission: namespaces, the shaped radio, the demo; its summary and counters."""
    nets = Namespaces(FIRST_ROBOT + args.robots)
    radio = Radio(nets.fds, seed=args.seed)
    pairs = team_pairs(len(nets.names))
    shaped = Impairment(
        loss=args.loss, delay=0.060, jitter=0.040, rate_bps=args.rate, queue_s=args.queue
    )
    radio.set_impairment(shaped, pairs)
    demo = [slate, "demo", "--network", "processes", "--format", "json"]
    demo += ["--seed", str(args.seed), "--robots", str(args.robots), "--speakers", args.speakers]
    cmd = ["ip", "netns", "exec", nets.names[WORLD], *demo, *placement(nets, args.robots)]
    log = workdir / f"demo-seed{args.seed}.log"
    started = time.monotonic()
    proc: subprocess.Popen[bytes] | None = None
    try:
        radio.start()
        with open(log, "wb") as err:
            proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=err)
            out, _ = proc.communicate(timeout=args.deadline)
        summary = json.loads(out) if out.strip() else None
    except subprocess.TimeoutExpired:
        summary = None
    finally:
        if proc is not None:
            # The demo stops its module processes on SIGTERM: give it time.
            stop_process(proc, grace=10)
        radio.stop()
        nets.close()
    return {
        "seed": args.seed,
        "speakers": args.speakers,
        "impairment": shaped.__dict__,
        "wall_s": round(time.monotonic() - started, 1),
        "summary": summary,
        "team_radio": radio_totals(radio, pairs),
        "log": str(log),
    }


def held(result: dict[str, Any]) -> bool:
    """Mission complete, no duplicated investigation, the fault detected."""
    s = result["summary"]
    return bool(
        s
        and s["mission_complete"]
        and s["duplicate_investigations"] == 0
        and s["detection_seconds"] is not None
    )


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seed", type=int, default=7, help="the demo's seed (default 7); runs use seed, seed+1, ...")
    p.add_argument("--runs", type=int, default=1, help="runs, one seed each (default 1)")
    p.add_argument("--robots", type=int, default=3, help="robots (default 3)")
    p.add_argument(
        "--speakers",
        choices=["robots", "modules"],
        default="robots",
        help="who speaks on the team link: one gateway per robot (default) or every module",
    )
    p.add_argument("--loss", type=float, default=0.05, help="loss per frame on the team's links (default 0.05)")
    p.add_argument("--rate", type=float, default=9600, help="bit/s per directed team link (default 9600; 0: unlimited)")
    p.add_argument("--queue", type=float, default=5.0, help="longest wait in a link's queue, s (default 5)")
    p.add_argument("--deadline", type=float, default=600, help="seconds a run may take (default 600)")
    p.add_argument("--slate", help="the slate binary (default: as harness.py finds it)")
    p.add_argument("--keep", action="store_true", help="keep the logs' folder")
    return p.parse_args(argv)


def main(argv: list[str]) -> int:
    args = parse_args(argv)
    why = unavailable()
    if why:
        print(f"mission: skipped: {why}", file=sys.stderr)
        return SKIP
    sweep_leftovers()
    slate = find_slate(args.slate)
    workdir = Path(tempfile.mkdtemp(prefix="slate-mission-"))
    first, results = args.seed, []
    for k in range(args.runs):
        args.seed = first + k
        result = run(args, slate, workdir)
        print(json.dumps(result), flush=True)
        results.append(result)
    ok = all(held(r) for r in results)
    print(f"mission: {sum(held(r) for r in results)} of {len(results)} runs held; logs in {workdir}", file=sys.stderr)
    if ok and not args.keep:
        for f in workdir.iterdir():
            f.unlink()
        workdir.rmdir()
    return 0 if ok else 1


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except KeyboardInterrupt:
        sys.exit(130)
