#!/usr/bin/env python3
"""The real-link harness: real `slate node` processes in network namespaces, joined by an
emulated radio, and checks of what every board holds and which modules it marks dead.

    sudo python3 scripts/reallink/harness.py short            # the CI set (about 1 min)
    sudo python3 scripts/reallink/harness.py long             # the issue's set (hours)
    sudo python3 scripts/reallink/harness.py partition --seconds 10 --runs 5
    sudo python3 scripts/reallink/harness.py loss --loss 0.3 --seconds 30 --runs 5

A team of three robots, one namespace each, 10.77.0.(i+1) on the radio: r1 runs
`rl/r1/nav` and `rl/r1/writer` (a node whose plan increments `gsr.count` every 200 ms),
r2 and r3 run `rl/rN/nav`. Every node loads the same world, exports everything, uses
slate's default timeouts (team link: heartbeat 1 s, timeout 20 s) and a node's Zenoh
defaults (a UDP link beside each TCP one for the team link's reports, a 60 s lease), and
listens on its robot's radio address; each connects to every other
(`--topology chain`: to the one before it only). Boards are read from each node's
dashboard JSON (`/api/snapshot`, polled from inside its namespace); liveliness marks are
the nodes' own `peer ADDR down` / `peer ADDR up` lines (one per change of a `Module`
object's `alive` on that board).

What a run reports (one JSON object per run, then a summary):
- `converged_s`: seconds from the heal (or the end of the impairment) until every board
  holds a `gsr.count` at least the writer's own value at that moment; null if not within
  the convergence window (15 s).
- `false_marks`: `alive = false` marks on a board for a module whose links to that board
  were never cut (same robot, or robots the partition left together), with their lengths.
- `frames`: frames and bytes each directed radio link carried, Ethernet headers included.

Exit codes: 0 all runs held, 1 a run failed a check, 77 skipped (not root, no netns or
TAP; the reason on stderr), 2 bad usage. Bounded: each run has a deadline; every process
started is stopped by its pid and every namespace deleted, also on Ctrl-C.

Python (not Rust) because the orchestration is processes, namespaces and JSON, and the
radio needs nothing faster at these rates; the pytest wrapper is python/tests/test_reallink.py.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable

sys.path.insert(0, str(Path(__file__).resolve().parent))

from netns import Namespaces, sweep_leftovers, thread_in, unavailable  # noqa: E402
from radio import Impairment, Radio  # noqa: E402
import plansend  # noqa: E402
import wirebytes  # noqa: E402

SKIP = 77
ROOT = Path(__file__).resolve().parents[2]
TEAM = "rl"
PORT = 7447
DASHBOARD = 18080
WORLD = f"""// The real-link harness's world: one counter, written by rl/r1/writer.
class Vehicle {{ count: int = 0; }}
object gsr : Vehicle context self owner "{TEAM}/r1/writer";
"""
WRITER = """// Increments gsr.count every 200 ms (5 updates per second).
plan write_count {
    every 200ms;
    action { set gsr.count = gsr.count + 1; }
}
"""
FILES = {"world.slate": WORLD, "writer.slate": WRITER}
# The nodes' log filter; $REALLINK_LOG adds to it (like `zenoh=debug` to see Zenoh's
# sessions open and close). The `peer ... up|down` lines must stay at info.
NODE_LOG = ",".join(filter(None, ["warn,slate_node=info", os.environ.get("REALLINK_LOG")]))
LOG_LINE = re.compile(r"^(\S+Z)\s+\w+\s+slate_node::monitor: peer (\S+) (up|down)\s*$")
ANSI = re.compile(r"\x1b\[[0-9;]*m")


def find_slate(given: str | None) -> str:
    """The `slate` binary: given, $SLATE_BIN, the newest of the target dirs', or PATH."""
    if given:
        return given
    if os.environ.get("SLATE_BIN"):
        return os.environ["SLATE_BIN"]
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    built = [target / p / "slate" for p in ("debug", "release")]
    built = [b for b in built if b.exists()]
    if built:
        return str(max(built, key=lambda b: b.stat().st_mtime))
    found = shutil.which("slate")
    if found:
        return found
    raise SystemExit("reallink: no slate binary: build it (cargo build -p slate-cli) or give --slate")


@dataclass
class Module:
    """One `slate node` of the team."""

    address: str
    robot: int
    port: int
    dashboard: int
    writer: bool = False
    protocol: str = "tcp"  # of its endpoint: tcp or udp
    zenoh_config: str | None = None  # a Zenoh config file for the node (`zenoh_config`)
    export: str = "Thing"  # the classes it exports to the team link
    extra: str = ""  # TOML appended to the node's config (like an `[ici]` table)
    proc: subprocess.Popen[bytes] | None = None
    log: Path | None = None


def team_modules() -> list[Module]:
    return [
        Module(f"{TEAM}/r1/nav", 0, PORT, DASHBOARD),
        Module(f"{TEAM}/r1/writer", 0, PORT + 1, DASHBOARD + 1, writer=True),
        Module(f"{TEAM}/r2/nav", 1, PORT, DASHBOARD),
        Module(f"{TEAM}/r3/nav", 2, PORT, DASHBOARD),
    ]


def endpoint(m: Module) -> str:
    return f"{m.protocol}/{Namespaces.address(m.robot)}:{m.port}"


def node_config(m: Module, peers: list[Module]) -> str:
    """The TOML config of module `m`, connecting to `peers`."""
    files = ["world.slate", "writer.slate"] if m.writer else ["world.slate"]
    return "\n".join(
        [
            f'address = "{m.address}"',
            f"files = {json.dumps(files)}",
            f"export = [{json.dumps(m.export)}]",
            f'dashboard = "127.0.0.1:{m.dashboard}"',
            f"zenoh_config = {json.dumps(m.zenoh_config)}" if m.zenoh_config else "",
            "[zenoh]",
            f'listen = ["{endpoint(m)}"]',
            f"connect = {json.dumps([endpoint(p) for p in peers])}",
            m.extra,
            "",
        ]
    )


def connections(mods: list[Module], topology: str) -> dict[str, list[Module]]:
    """Whom each module connects to: every other (mesh), or the one before it (chain)."""
    if topology == "chain":
        return {m.address: mods[i - 1 : i] if i else [] for i, m in enumerate(mods)}
    return {m.address: [p for p in mods if p is not m] for m in mods}


class Boards:
    """Polls every node's dashboard snapshot from inside its namespace, every 200 ms, and
    keeps the latest `gsr.count` each board holds."""

    def __init__(self, ns_names: list[str], mods: list[Module]) -> None:
        self.counts: dict[str, int | None] = {m.address: None for m in mods}
        self.stopping = threading.Event()
        self.threads = [
            thread_in(ns, self._poller([m for m in mods if m.robot == r]), f"boards-{r}")
            for r, ns in enumerate(ns_names)
        ]
        for t in self.threads:
            t.start()

    def _poller(self, mods: list[Module]) -> Callable[[], None]:
        """The body of one robot's polling thread."""
        return lambda: self._poll(mods)

    def _poll(self, mods: list[Module]) -> None:
        while not self.stopping.wait(0.2):
            for m in mods:
                self.counts[m.address] = read_count(m.dashboard)

    def stop(self) -> None:
        self.stopping.set()
        for t in self.threads:
            t.join(timeout=3)


def read_count(port: int) -> int | None:
    """`gsr.count` on the board whose dashboard listens on 127.0.0.1:`port` (this
    thread's namespace), or None when it cannot be read or was never written."""
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/snapshot", timeout=1) as r:
            snap = json.load(r)
    except (OSError, ValueError):
        return None
    for obj in snap.get("objects") or []:
        if obj.get("name") == "gsr":
            for a in obj.get("attrs") or []:
                if a.get("name") == "count" and a.get("age") is not None:
                    return int(float(a.get("value")))
    return None


def liveliness_marks(mod: Module) -> list[tuple[str, bool, float]]:
    """(peer, alive, unix time) for each `peer ... up|down` line of the node's log."""
    marks = []
    text = mod.log.read_text(errors="replace") if mod.log and mod.log.exists() else ""
    for line in text.splitlines():
        m = LOG_LINE.match(ANSI.sub("", line))
        if m:
            t = datetime.fromisoformat(m.group(1).replace("Z", "+00:00")).timestamp()
            marks.append((m.group(2), m.group(3) == "up", t))
    return marks


def dead_spells(marks: list[tuple[str, bool, float]], end: float) -> list[tuple[str, float, float]]:
    """(peer, start, length) of each spell a peer was marked dead (a down to the next up)."""
    down: dict[str, float] = {}
    spells = []
    for peer, alive, t in marks:
        if not alive and peer not in down:
            down[peer] = t
        elif alive and peer in down:
            start = down.pop(peer)
            spells.append((peer, start, t - start))
    spells += [(p, s, end - s) for p, s in down.items()]
    return spells


@dataclass
class Scenario:
    """One run: impairment for all links, an optional partition of robot `cut` from the
    others (after `settle` seconds, for `partition` seconds), then `window` seconds for the
    boards to converge and `linger` seconds more to watch liveliness."""

    name: str
    impairment: Impairment = field(default_factory=Impairment)
    partition: float = 0.0
    cut: int = 2
    settle: float = 3.0
    hold: float = 0.0  # seconds under the impairment when there is no partition
    window: float = 15.0
    linger: float = 3.0
    topology: str = "mesh"
    extra: str = ""  # TOML appended to every node's config (--node-toml)
    protocol: str = "tcp"


class Team:
    """The namespaces, the radio and the node processes of one run; `close` stops every
    process by pid and deletes every namespace."""

    def __init__(
        self,
        slate: str,
        scn: Scenario,
        workdir: Path,
        mods: list[Module] | None = None,
        files: dict[str, str] | None = None,
    ) -> None:
        """`mods` (default: the team of three robots) and the .slate `files` they load
        (default: the counter's world and the writer's plan)."""
        self.slate, self.workdir = slate, workdir
        self.mods = mods if mods is not None else team_modules()
        for m in self.mods:
            m.extra = m.extra or scn.extra
        for m in self.mods:
            m.protocol = scn.protocol
        self.boards: Boards | None = None
        self.nets = Namespaces(1 + max(m.robot for m in self.mods))
        self.radio = Radio(self.nets.fds)
        try:
            self.radio.start()
            self._write_files(connections(self.mods, scn.topology), files or FILES)
        except BaseException:
            self.close()
            raise

    def _write_files(self, peers: dict[str, list[Module]], files: dict[str, str]) -> None:
        for name, text in files.items():
            (self.workdir / name).write_text(text)
        for m in self.mods:
            name = m.address.replace("/", "_")
            (self.workdir / f"{name}.toml").write_text(node_config(m, peers[m.address]))
            m.log = self.workdir / f"{name}.log"

    def start(self) -> None:
        for m in self.mods:
            self.start_module(m)
        self.boards = Boards(self.nets.names, self.mods)

    def start_module(self, m: Module) -> None:
        """Starts module `m`'s `slate node` in its robot's namespace."""
        cfg = self.workdir / f"{m.address.replace('/', '_')}.toml"
        cmd = ["ip", "netns", "exec", self.nets.names[m.robot], self.slate, "node"]
        assert m.log is not None, "_write_files names every module's log"
        with open(m.log, "wb") as log:
            m.proc = subprocess.Popen(
                [*cmd, "--config", str(cfg), "--log", NODE_LOG],
                stdout=subprocess.DEVNULL,
                stderr=log,
                start_new_session=True,
            )

    def counts(self) -> dict[str, int | None]:
        return dict(self.boards.counts) if self.boards else {}

    def writer_count(self) -> int | None:
        return self.counts().get(f"{TEAM}/r1/writer")

    def close(self) -> None:
        if self.boards:
            self.boards.stop()
        for m in self.mods:
            stop_process(m.proc)
        self.radio.stop()
        self.nets.close()


def stop_process(proc: subprocess.Popen[bytes] | None, grace: float = 3.0) -> None:
    """SIGTERM, then SIGKILL after `grace` seconds, to this process (by its pid) only."""
    if proc is None or proc.poll() is not None:
        return
    proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(timeout=grace)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(timeout=grace)


def wait_converged(team: Team, target: int, deadline: float) -> float | None:
    """Waits until every board holds gsr.count >= target; the time it did, or None."""
    while time.time() < deadline:
        counts = team.counts()
        if all(c is not None and c >= target for c in counts.values()):
            return time.time()
        time.sleep(0.1)
    return None


def never_cut(scn: Scenario, a: int, b: int) -> bool:
    """Were robots a and b never separated by the scenario's partition?"""
    return a == b or not scn.partition or scn.cut not in (a, b)


def run(scn: Scenario, slate: str, keep: bool = False) -> dict[str, Any]:
    """Runs one scenario; returns what it measured (see the module's doc)."""
    workdir = Path(tempfile.mkdtemp(prefix="slate-reallink-"))
    team = Team(slate, scn, workdir)
    result: dict[str, Any] = {"scenario": scn.name, "workdir": str(workdir)}
    try:
        team.start()
        start_ok = wait_converged(team, 1, time.time() + 30)
        result["started"] = start_ok is not None
        if start_ok is None:
            return finish(result, team, scn, time.time())
        time.sleep(scn.settle)
        team.radio.set_impairment(scn.impairment)
        result["converged_s"] = impair_then_converge(team, scn, result)
        time.sleep(scn.linger)
        return finish(result, team, scn, time.time())
    finally:
        team.close()
        result["frames"] = {f"r{a + 1}->r{b + 1}": c for (a, b), c in team.radio.counters().items()}
        if not keep and result.get("ok"):
            shutil.rmtree(workdir, ignore_errors=True)


def impair_then_converge(team: Team, scn: Scenario, result: dict[str, Any]) -> float | None:
    """The partition (or the hold under impairment), then the convergence wait."""
    others = [r for r in range(3) if r != scn.cut]
    if scn.partition:
        result["cut_at"] = utc(time.time())
        team.radio.cut([scn.cut], others)
        time.sleep(scn.partition)
        team.radio.cut([scn.cut], others, cut=False)
        result["healed_at"] = utc(time.time())
    else:
        time.sleep(scn.hold)
    healed = time.time()
    target = team.writer_count() or 0
    result["writer_at_heal"] = target
    done = wait_converged(team, target, healed + scn.window)
    result["counts_at_end"] = team.counts()
    return None if done is None else round(done - healed, 2)


def utc(t: float) -> str:
    """A Unix time as the nodes' logs write it, to line the two up."""
    return datetime.fromtimestamp(t, timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


def finish(result: dict[str, Any], team: Team, scn: Scenario, end: float) -> dict[str, Any]:
    """Collects the liveliness marks and decides whether the run held."""
    robot = {m.address: m.robot for m in team.mods}
    false = []
    for m in team.mods:
        marks = [mark for mark in liveliness_marks(m) if mark[2] <= end]
        for peer, start, length in dead_spells(marks, end):
            if peer in robot and never_cut(scn, m.robot, robot[peer]):
                false.append({"board": m.address, "peer": peer, "seconds": round(length, 2)})
    result["false_marks"] = false
    result["exited"] = {m.address: m.proc.poll() for m in team.mods if m.proc and m.proc.poll() is not None}
    result["ok"] = bool(result.get("started")) and result.get("converged_s") is not None and not false
    return result


def bytes_run(args: argparse.Namespace, slate: str) -> dict[str, Any]:
    """The `bytes` command: slate's cost per update and idle on one team link, then the
    raw Zenoh baseline on the same radio (wirebytes.py)."""
    mods = [
        Module(f"{TEAM}/r1/writer", 0, PORT, DASHBOARD, writer=True),
        Module(f"{TEAM}/r2/nav", 1, PORT, DASHBOARD),
    ]
    for m in mods:
        m.zenoh_config = str(Path(args.zenoh_config).resolve()) if args.zenoh_config else None
        m.extra = args.node_toml or ""
        m.export = "Vehicle"  # not the plans' own objects: one attribute's updates only
    world = WORLD + (args.world_extra or "")
    files = {"world.slate": world, "writer.slate": wirebytes.writer_plans(args.updates)}
    workdir = Path(tempfile.mkdtemp(prefix="slate-reallink-"))
    scn = Scenario("bytes", protocol=args.protocol, topology=args.topology)
    team = Team(slate, scn, workdir, mods, files)
    result: dict[str, Any] = {"scenario": f"bytes-{args.protocol}", "workdir": str(workdir)}
    try:
        result["slate"] = wirebytes.slate_run(team, args.updates, args.idle)
        if team.boards:
            team.boards.stop()
        for m in team.mods:
            stop_process(m.proc)
        python = wirebytes.zenoh_python(args.zenoh_python)
        if python is None:
            result["zenoh"] = {"ok": False, "why": "skipped: no Python that imports zenoh (--zenoh-python)"}
        elif not args.no_baseline:
            result["zenoh"] = wirebytes.raw_run(team, python, args.protocol, args.updates, args.idle)
    finally:
        team.close()
    result["ok"] = bool(result["slate"].get("ok"))
    if not args.keep and result["ok"]:
        shutil.rmtree(workdir, ignore_errors=True)
    return result


def plansend_run(args: argparse.Namespace, slate: str) -> list[dict[str, Any]]:
    """The `plansend` command: `args.runs` plans sent across the lossy radio
    (plansend.py); one result per plan."""
    mods = [Module(f"{TEAM}/r1/nav", 0, PORT, DASHBOARD), Module(f"{TEAM}/r2/nav", 1, PORT, DASHBOARD, writer=True)]
    workdir = Path(tempfile.mkdtemp(prefix="slate-reallink-"))
    scn = Scenario("plansend", protocol=args.protocol, topology=args.topology)
    files = {"world.slate": plansend.WORLD, "writer.slate": plansend.START}
    team = Team(slate, scn, workdir, mods, files)
    results: list[dict[str, Any]] = []
    try:
        team.start()
        if not met(team, time.time() + 30):
            return [{"ok": False, "why": "the two nodes did not meet", "workdir": str(workdir)}]
        team.radio.set_impairment(Impairment(loss=args.loss))
        for i in range(1, args.runs + 1):
            results.append(plansend.send_once(team, slate, i, args.timeout))
            print(json.dumps(results[-1]), flush=True)
    finally:
        team.close()
        if not args.keep and results and all(r["ok"] for r in results):
            shutil.rmtree(workdir, ignore_errors=True)
    return results


def met(team: Team, deadline: float) -> bool:
    """Waits until r1's board holds gsr.count, which only r2's node writes."""
    while time.time() < deadline:
        if team.counts().get(f"{TEAM}/r1/nav") is not None:
            return True
        time.sleep(0.2)
    return False


def scenarios(args: argparse.Namespace) -> list[Scenario]:
    """The scenarios a command line asks for."""
    loss = Impairment(loss=args.loss) if args.loss else Impairment()
    how = {"topology": args.topology, "protocol": args.protocol, "extra": args.node_toml or ""}
    suffix = "-udp" if args.protocol == "udp" else ""
    if args.command == "partition":
        name = f"partition-{args.seconds:g}s" + ("-chain" if args.topology == "chain" else "")
        return [Scenario(name + suffix, loss, partition=args.seconds, **how)]
    if args.command == "loss":
        return [Scenario(f"loss-{args.loss:g}{suffix}", loss, hold=args.seconds, **how)]
    if args.command == "short":
        return [
            Scenario("partition-10s", partition=10.0),
            Scenario("loss-0.3", Impairment(loss=0.3), hold=10.0),
        ]
    return [
        Scenario("partition-3s", partition=3.0),
        Scenario("partition-10s", partition=10.0),
        Scenario("partition-30s", partition=30.0),
        Scenario("partition-10s-chain", partition=10.0, topology="chain"),
        Scenario("loss-0.3", Impairment(loss=0.3), hold=30.0),
        Scenario("radio-9600", Impairment(rate_bps=9600, delay=0.1, jitter=0.05), hold=20.0),
    ]


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("command", choices=["short", "long", "partition", "loss", "bytes", "plansend"], help="which scenarios")
    p.add_argument("--runs", type=int, default=None, help="runs of each scenario (short: 1, long: 20, else 5)")
    p.add_argument("--seconds", type=float, default=10.0, help="partition length, or time under loss")
    p.add_argument("--loss", type=float, default=0.0, help="loss probability on every link (0..1)")
    p.add_argument("--topology", choices=["mesh", "chain"], default="mesh")
    p.add_argument("--protocol", choices=["tcp", "udp"], default="tcp", help="the nodes' Zenoh links")
    p.add_argument("--slate", help="the slate binary (default: $SLATE_BIN, else target/{debug,release}/slate)")
    p.add_argument("--keep", action="store_true", help="keep every run's configs and node logs")
    p.add_argument("--updates", type=int, default=300, help="bytes: updates at 20 Hz (ten times as many at 200 Hz)")
    p.add_argument("--idle", type=float, default=20.0, help="bytes: seconds of idle measured")
    p.add_argument("--zenoh-config", help="bytes: a Zenoh config file every node is given (zenoh_config)")
    p.add_argument("--node-toml", help="TOML appended to every node's config, like '[ici]\\nteam_heartbeat = \"3s\"'")
    p.add_argument("--zenoh-python", help="bytes: a Python that imports zenoh, for the baseline (default: $ZENOH_PYTHON)")
    p.add_argument("--world-extra", help="bytes: slate text added to the world file, like 'link team { ... }'")
    p.add_argument("--timeout", type=float, default=60.0, help="plansend: the command's --timeout, seconds")
    p.add_argument("--no-baseline", action="store_true", help="bytes: measure slate only")
    args = p.parse_args(argv)
    if args.runs is None:
        args.runs = {"short": 1, "long": 20, "bytes": 1, "plansend": 10}.get(args.command, 5)
    return args


def main(argv: list[str]) -> int:
    args = parse_args(argv)
    reason = unavailable()
    if reason:
        print(f"reallink: skipped: {reason}", file=sys.stderr)
        return SKIP
    sweep_leftovers()
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    slate = find_slate(args.slate)
    if args.command == "bytes":
        out = [bytes_run(args, slate) for _ in range(args.runs)]
        for r in out:
            print(json.dumps(r), flush=True)
            print(wirebytes.summary(r), file=sys.stderr)
        return 0 if all(r["ok"] for r in out) else 1
    if args.command == "plansend":
        sent = plansend_run(args, slate)
        held = sum(1 for r in sent if r["ok"])
        print(f"plansend at {args.loss:g} loss: {held}/{len(sent)} printed every acknowledgement and exited 0", file=sys.stderr)
        return 0 if sent and held == len(sent) else 1
    results = []
    for scn in scenarios(args):
        for _ in range(args.runs):
            results.append(run(scn, slate, args.keep))
            print(json.dumps(results[-1]), flush=True)
    print(summary(results), file=sys.stderr)
    return 0 if all(r["ok"] for r in results) else 1


def summary(results: list[dict[str, Any]]) -> str:
    """One line per scenario: runs converged, false marks, slowest convergence."""
    lines = []
    for name in dict.fromkeys(r["scenario"] for r in results):
        rs = [r for r in results if r["scenario"] == name]
        conv = [r["converged_s"] for r in rs if r.get("converged_s") is not None]
        marks = sum(len(r["false_marks"]) for r in rs)
        worst = f"{max(conv):.1f} s" if conv else "-"
        lines.append(
            f"{name}: converged {len(conv)}/{len(rs)} (slowest {worst}), "
            f"false dead marks {marks} in {sum(1 for r in rs if r['false_marks'])}/{len(rs)} runs"
        )
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
