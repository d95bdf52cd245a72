"""`slate plan send` across a lossy radio: does the command print every acknowledgement
the destination produced, and exit 0?

    sudo python3 scripts/reallink/harness.py plansend --loss 0.3 --runs 10

Two robots: `rl/r1/nav` (robot r1) and `rl/r2/nav` (robot r2, owner of `gsr`). Once they
have met, every radio link loses `loss` of its frames. Then, `runs` times, a plan that
fires three times (100 ms apart) and terminates is sent from robot r1 (`slate plan send
--format json`, connected to `rl/r1/nav` over r1's loopback; its observer is a module
of robot r1, so the plan crosses the team link) to `rl/r2/nav`. A run holds when the
command exits 0 and printed `initiated`, each `triggered` (`fired N`) and `terminated`
that the destination's log shows for that plan (`plan NAME initiated|fired (N)|
terminated` lines of `slate_node::monitor`).
"""

from __future__ import annotations

import json
import re
import subprocess
import time
from pathlib import Path
from typing import Any

TEAM = "rl"
WORLD = f"""// The plan-send run's world: a counter the destination owns.
class Vehicle {{ count: int = 0; }}
object gsr : Vehicle context self owner "{TEAM}/r2/nav";
"""
# The destination's own plan: writes the counter once, so that r1's board shows the
# two have met.
START = """plan start { action { set gsr.count = 0; } }
"""
FIRES = 3
LOG_STEP = re.compile(r"slate_node::monitor: plan (\S+) (initiated|terminated|fired \((\d+)\))")
ANSI = re.compile(r"\x1b\[[0-9;]*m")


def plan_text(i: int) -> str:
    """Plan `probe_i`: fires FIRES times, 100 ms apart, then terminates."""
    return f"""plan probe_{i} {{
    termination: gsr.count >= {FIRES * i};
    every 100ms;
    action {{ set gsr.count = gsr.count + 1; }}
}}
"""


def destination_steps(log: Path, plan: str) -> list[str]:
    """What the destination's log shows of `plan`: `initiated`, `fired N`, `terminated`."""
    steps = []
    for line in log.read_text(errors="replace").splitlines():
        m = LOG_STEP.search(ANSI.sub("", line))
        if m and m.group(1) == plan:
            steps.append(f"fired {m.group(3)}" if m.group(3) else m.group(2))
    return steps


def printed_steps(stdout: str) -> list[str]:
    """What the command printed: `initiated`, `fired N` (a `triggered` line), ..."""
    steps = []
    for line in stdout.splitlines():
        try:
            ack = json.loads(line)
        except ValueError:
            continue
        steps.append(ack["detail"] if ack.get("step") in ("triggered", "failed") else ack.get("step", ""))
    return steps


def send_once(team: Any, slate: str, i: int, timeout: float) -> dict[str, Any]:
    """Sends plan `probe_i` from robot r1 to rl/r2/nav; compares what was printed with
    what the destination logged."""
    path = team.workdir / f"probe_{i}.slate"
    path.write_text(plan_text(i))
    cmd = ["ip", "netns", "exec", team.nets.names[0], slate, "--format", "json", "plan", "send", str(path)]
    cmd += ["--to", f"{TEAM}/r2/nav", "--connect", f"{team.mods[0].protocol}/10.77.0.1:{team.mods[0].port}"]
    cmd += ["--timeout", str(timeout)]
    started = time.time()
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout + 30)
    time.sleep(0.5)  # the destination's last log line
    produced = destination_steps(team.mods[1].log, f"probe_{i}")
    printed = printed_steps(done.stdout)
    missing = [s for s in produced if s not in printed]
    return {
        "plan": f"probe_{i}",
        "exit": done.returncode,
        "seconds": round(time.time() - started, 1),
        "printed": printed,
        "destination": produced,
        "missing": missing,
        "stderr": done.stderr.strip()[-500:],
        "ok": done.returncode == 0 and not missing and "terminated" in produced,
    }
