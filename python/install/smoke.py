"""What `pip install ./python` must give: the installed package (not the source tree)
runs a board, and two nodes exchange a packet over Zenoh on 127.0.0.1. Run by
python/install/check.sh in a fresh virtualenv; exits non-zero, saying why, otherwise."""

from __future__ import annotations

import os
import socket
import sys
import time

import slate

WORLD = "class Vehicle { speed: real [m/s] in 0 .. 10 = 0.0; }\n"
LIMIT_S = 20.0


def eventually(condition, seconds: float = LIMIT_S) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.02)
    return condition()


def free_endpoint() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{s.getsockname()[1]}"


def check_installed() -> None:
    here = os.path.dirname(os.path.abspath(__file__))
    source = os.path.abspath(os.path.join(here, ".."))
    where = os.path.abspath(slate.__file__)
    assert not where.startswith(source + os.sep), f"imported from the source tree: {where}"
    print(f"slate imported from {where}")


def check_board() -> None:
    b = slate.Board(clock="manual")
    b.load(WORLD + "object gsr : Vehicle;")
    b.write("gsr", "speed", 2.5, accuracy=0.1, confidence=0.9)
    p = b.read("gsr", "speed")
    assert p.value == 2.5, p
    print(f"board: gsr.speed = {p.value}")


def check_two_nodes() -> None:
    endpoint = free_endpoint()
    nav_board = slate.Board(address="t/r1/nav")
    nav_board.load(WORLD + "object gsr : Vehicle context self;")
    loco_board = slate.Board(address="t/r2/loco")
    loco_board.load(WORLD)
    nav = slate.Node("t/r1/nav", nav_board, listen=[endpoint], export=["Thing"])
    loco = slate.Node("t/r2/loco", loco_board, connect=[endpoint], export=["Thing"])
    try:
        assert eventually(lambda: "gsr" in loco.board), "t/r2/loco never saw gsr"
        nav.board.write("gsr", "speed", 4.0)
        assert eventually(lambda: loco.board.read("gsr", "speed").value == 4.0), "no report"
        print(f"two nodes: t/r2/loco reads gsr.speed = 4.0 from {loco.board.read('gsr', 'speed').source}")
    finally:
        loco.close()
        nav.close()


def main() -> int:
    check_installed()
    check_board()
    check_two_nodes()
    return 0


if __name__ == "__main__":
    sys.exit(main())
