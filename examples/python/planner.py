"""A planner sends a plan to the locomotion module of a robot over Zenoh, and prints every
acknowledgement of its virtual circuit as it arrives (the paper's plan downloading).

Both modules run in this one process, each with its own Zenoh session on 127.0.0.1:
team/r1/loco holds the vehicle and listens; team/base/planner connects to it. The plan
slows the vehicle down once its speed goes over 2 m/s, and terminates once it has. The
locomotion module "senses" a speed of 3 m/s after the plan is initiated; the planner
sees the result on its own board, through the reports that the robot exports.

Run it:  .venv/bin/python examples/python/planner.py
"""

from __future__ import annotations

import socket
import time
from collections.abc import Callable

import slate

WORLD = """
class Vehicle {
    speed: real [m/s] in 0 .. 10 = 0.0;
    mode: string = "auto";
}
object gsr : Vehicle context self;
"""

PLAN = """
plan slow_down {
    initiation: gsr.mode == "auto";
    trigger: gsr.speed > 2.0;
    termination: gsr.mode == "slow";
    action { set gsr.speed = 2.0, gsr.mode = "slow"; }
}
"""


def free_endpoint() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{s.getsockname()[1]}"


def wait_for(condition: Callable[[], bool], seconds: float = 10.0) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.02)
    return False


def main() -> int:
    endpoint = free_endpoint()
    board = slate.Board(address="team/r1/loco")
    board.load(WORLD)
    # A module takes plans from its own robot and the team's operators by default: loco
    # names the base's planner too (docs/security.md, "Authority over plans").
    with slate.Node("team/r1/loco", board, listen=[endpoint], export=["Vehicle"],
                    plans_from=["robot", "operators", "team/base/planner"]) as loco, \
            slate.Node("team/base/planner", connect=[endpoint]) as planner:
        if not wait_for(lambda: "team/r1/loco" in planner.peers()):
            print("planner: team/r1/loco never came up")
            return 1
        print(f"planner: sees {', '.join(planner.peers())} through {endpoint}")
        handle = planner.send_plan(PLAN, to="team/r1/loco")
        print(f"planner: sent plan {handle.name} to {handle.to} on circuit {handle.circuit}")
        for ack in handle.acks:
            detail = f" ({ack.detail})" if ack.detail else ""
            print(f"planner: {handle.name} {ack.step}{detail}")
            if ack.step == "initiated":
                loco.board.write("gsr", "speed", 3.0, accuracy=0.1)
                print("loco: speed 3.0 m/s sensed")
        mine = planner.board
        wait_for(lambda: "gsr" in mine and mine.read("gsr", "mode").value == "slow")
        speed = mine.read("gsr", "speed")
        mode = mine.read("gsr", "mode").value
        print(f"planner: gsr is {mode} at {speed.value} m/s (written by {speed.source})")
        plan = loco.board.plan("slow_down")
        print(f"loco: plan {plan.name} {plan.state}, fired {plan.fired} time(s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
