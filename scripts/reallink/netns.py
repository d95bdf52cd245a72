"""Network namespaces for the real-link harness: one per robot, each with one TAP device
whose other end the radio (radio.py) holds, and a way to run code and processes in them.

Names carry a prefix and this process's pid (`slrl<pid>r<i>`), so parallel runs never
clash, and a later run removes the leftovers of a run whose process is gone.
"""

from __future__ import annotations

import ctypes
import os
import re
import shutil
import subprocess
import threading
from collections.abc import Callable

from radio import open_tap

PREFIX = "slrl"
CLONE_NEWNET = 0x40000000
_LIBC = ctypes.CDLL(None, use_errno=True)


def ip(*args: str, check: bool = True) -> subprocess.CompletedProcess[str]:
    """Runs `ip ARGS`, raising with ip's own message when it fails and `check` is set."""
    done = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=10)
    if check and done.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)}: {done.stderr.strip()}")
    return done


def unavailable() -> str | None:
    """Why the harness cannot run here (not root, no `ip`, no TAP, no netns), or None."""
    if os.geteuid() != 0:
        return "the real-link harness needs root (network namespaces and TAP devices)"
    if shutil.which("ip") is None:
        return "the real-link harness needs `ip` (iproute2)"
    if not os.path.exists("/dev/net/tun"):
        return "the real-link harness needs /dev/net/tun (TAP devices)"
    probe = f"{PREFIX}{os.getpid()}probe"
    if ip("netns", "add", probe, check=False).returncode != 0:
        return "cannot create network namespaces (`ip netns add` failed)"
    ip("netns", "del", probe, check=False)
    return None


def sweep_leftovers() -> list[str]:
    """Deletes the namespaces of earlier runs whose process is gone; returns their names."""
    removed = []
    for line in ip("netns", "list", check=False).stdout.splitlines():
        name = line.split()[0] if line.split() else ""
        m = re.fullmatch(rf"{PREFIX}(\d+)(?:r\d+|probe)", name)
        if m and not os.path.exists(f"/proc/{m.group(1)}"):
            ip("netns", "del", name, check=False)
            removed.append(name)
    return removed


class Namespaces:
    """`count` robot namespaces on subnet 10.77.0.0/24 (robot i at 10.77.0.(i+1)), each
    with loopback up and one TAP device. `close` deletes them all; it is safe to call
    twice and after a failed `__init__` step."""

    def __init__(self, count: int) -> None:
        self.names: list[str] = []
        self.fds: list[int] = []
        pid = os.getpid()
        try:
            for i in range(count):
                self._add(f"{PREFIX}{pid}r{i}", f"{PREFIX}{pid}t{i}", i)
        except BaseException:
            self.close()
            raise

    @staticmethod
    def address(robot: int) -> str:
        return f"10.77.0.{robot + 1}"

    def _add(self, ns: str, tap: str, robot: int) -> None:
        ip("netns", "add", ns)
        self.names.append(ns)
        self.fds.append(open_tap(tap))
        ip("link", "set", tap, "netns", ns)
        # No IPv6: its address autoconfiguration and multicast reports would cross the
        # radio and be counted as the team's bytes.
        sysctl = ["ip", "netns", "exec", ns, "sysctl", "-qw", "net.ipv6.conf.all.disable_ipv6=1"]
        subprocess.run(sysctl, capture_output=True, timeout=10, check=False)
        ip("-n", ns, "link", "set", "lo", "up")
        ip("-n", ns, "addr", "add", f"{self.address(robot)}/24", "dev", tap)
        ip("-n", ns, "link", "set", tap, "up")

    def close(self) -> None:
        for fd in self.fds:
            try:
                os.close(fd)
            except OSError:
                pass
        self.fds = []
        for ns in self.names:
            ip("netns", "del", ns, check=False)
        self.names = []


def enter(ns: str) -> None:
    """Moves the calling thread (only it) into network namespace `ns`."""
    fd = os.open(f"/var/run/netns/{ns}", os.O_RDONLY)
    try:
        if _LIBC.setns(fd, CLONE_NEWNET) != 0:
            raise OSError(ctypes.get_errno(), f"setns {ns}")
    finally:
        os.close(fd)


def thread_in(ns: str, target: Callable[[], None], name: str) -> threading.Thread:
    """A daemon thread that runs `target` inside namespace `ns` (its sockets live there)."""

    def run() -> None:
        enter(ns)
        target()

    return threading.Thread(target=run, name=name, daemon=True)
