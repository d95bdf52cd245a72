"""The emulated radio: a user-space Ethernet switch between TAP devices.

Each robot's network namespace holds one TAP device; this process holds the other end
(the file descriptor) of every one of them. A frame read from robot i's TAP is switched
(learning the source MAC address; unknown and group destinations are flooded) to the
TAP of each robot j it is for, through the directed link i -> j, which applies, in order:
a cut (partition), loss, a rate limit with a bounded queue (the frame waits until the
link has sent what was queued before it, and is dropped when that wait would exceed the
queue), delay with jitter, reordering and duplication. Every frame and byte is counted
on each directed link, Ethernet header included (no preamble, no frame check sequence),
so the counters are what a radio carries.

A user-space forwarder (not `tc netem`) because the kernels this project is tested on
have no `sch_netem`; it also sees and counts every frame exactly, both directions.
"""

from __future__ import annotations

import fcntl
import heapq
import os
import random
import select
import struct
import threading
import time
from dataclasses import dataclass, field

TUNSETIFF = 0x400454CA
IFF_TAP = 0x0002
IFF_NO_PI = 0x1000
# Largest frame read: the TAP's MTU (1500) plus the Ethernet header, with room to spare.
MAX_FRAME = 2048


@dataclass
class Impairment:
    """What a directed link does to the frames it carries (all off by default)."""

    loss: float = 0.0  # probability a frame is dropped (0..1)
    delay: float = 0.0  # seconds added to every frame
    jitter: float = 0.0  # a uniform +- this many seconds on top of delay
    rate_bps: float = 0.0  # bits per second (0: unlimited)
    queue_s: float = 1.0  # longest wait in the rate limiter's queue, seconds
    duplicate: float = 0.0  # probability a frame is sent twice
    reorder: float = 0.0  # probability a frame is held back by reorder_gap
    reorder_gap: float = 0.010  # seconds a reordered frame is held back


@dataclass
class Counters:
    """Frames and bytes of one directed link, headers included."""

    offered_frames: int = 0
    offered_bytes: int = 0
    delivered_frames: int = 0
    delivered_bytes: int = 0
    dropped_cut: int = 0
    dropped_loss: int = 0
    dropped_queue: int = 0
    duplicated: int = 0

    def as_dict(self) -> dict[str, int]:
        return dict(self.__dict__)


@dataclass
class Link:
    """A directed link i -> j: its impairment, whether it is cut, its counters."""

    impairment: Impairment = field(default_factory=Impairment)
    cut: bool = False
    busy_until: float = 0.0  # when the rate limiter has sent what is queued
    counters: Counters = field(default_factory=Counters)


def open_tap(name: str) -> int:
    """Creates TAP device `name` (in this process's namespace) and returns its fd."""
    fd = os.open("/dev/net/tun", os.O_RDWR | os.O_NONBLOCK)
    try:
        fcntl.ioctl(fd, TUNSETIFF, struct.pack("16sH", name.encode(), IFF_TAP | IFF_NO_PI))
    except OSError:
        os.close(fd)
        raise
    return fd


class Radio:
    """Switches frames between TAP fds through impaired directed links, on one thread.

    Thread safety: `set_impairment`, `cut` and `counters` take the lock the forwarding
    loop holds while it handles a frame, so a scenario can change the radio mid-run.
    """

    def __init__(self, fds: list[int], seed: int | None = None) -> None:
        self.fds = fds
        self.links = {(i, j): Link() for i in range(len(fds)) for j in range(len(fds)) if i != j}
        self.macs: dict[bytes, int] = {}
        self.queue: list[tuple[float, int, tuple[int, int], bytes]] = []
        self.serial = 0
        self.rng = random.Random(seed)
        self.lock = threading.Lock()
        self.stopping = threading.Event()
        self.thread = threading.Thread(target=self._run, name="radio", daemon=True)
        # REALLINK_FRAMES=PATH logs every delivered frame (time, link, length, its first
        # 160 bytes in hex): what an idle link carries, for instance.
        log = os.environ.get("REALLINK_FRAMES")
        self.frame_log = open(log, "w", buffering=1) if log else None  # noqa: SIM115

    def start(self) -> None:
        self.thread.start()

    def stop(self) -> None:
        self.stopping.set()
        self.thread.join(timeout=5)

    def set_impairment(self, imp: Impairment, pairs: list[tuple[int, int]] | None = None) -> None:
        """Applies `imp` to the directed links `pairs` (all links when None)."""
        with self.lock:
            for key in pairs if pairs is not None else list(self.links):
                self.links[key].impairment = imp

    def cut(self, robots_a: list[int], robots_b: list[int], cut: bool = True) -> None:
        """Cuts (or heals) every link between a robot of `robots_a` and one of `robots_b`,
        both directions."""
        with self.lock:
            for a in robots_a:
                for b in robots_b:
                    if a != b:
                        self.links[(a, b)].cut = cut
                        self.links[(b, a)].cut = cut

    def counters(self) -> dict[tuple[int, int], dict[str, int]]:
        with self.lock:
            return {k: link.counters.as_dict() for k, link in self.links.items()}

    def _run(self) -> None:
        while not self.stopping.is_set():
            timeout = self._until_next_delivery()
            try:
                ready, _, _ = select.select(self.fds, [], [], timeout)
            except (OSError, ValueError):
                return
            for fd in ready:
                self._read_all(fd)
            self._deliver_due()

    def _until_next_delivery(self) -> float:
        with self.lock:
            if not self.queue:
                return 0.05
            return max(0.0, min(0.05, self.queue[0][0] - time.monotonic()))

    def _read_all(self, fd: int) -> None:
        src = self.fds.index(fd)
        for _ in range(64):
            try:
                frame = os.read(fd, MAX_FRAME)
            except (BlockingIOError, OSError):
                return
            if not frame:
                return
            with self.lock:
                self._switch(src, frame)

    def _switch(self, src: int, frame: bytes) -> None:
        """Learns the source MAC, then offers the frame to each link it is for."""
        if len(frame) < 14:
            return
        dst_mac, src_mac = frame[0:6], frame[6:12]
        self.macs[src_mac] = src
        group = dst_mac[0] & 1 == 1
        known = self.macs.get(dst_mac)
        if not group and known is not None and known != src:
            targets = [known]
        else:
            targets = [j for j in range(len(self.fds)) if j != src]
        for dst in targets:
            self._offer((src, dst), frame)

    def _offer(self, pair: tuple[int, int], frame: bytes) -> None:
        """Applies the link's cut, loss, rate limit, delay, reorder and duplication."""
        link = self.links[pair]
        c, imp, now = link.counters, link.impairment, time.monotonic()
        c.offered_frames += 1
        c.offered_bytes += len(frame)
        if link.cut:
            c.dropped_cut += 1
            return
        if imp.loss and self.rng.random() < imp.loss:
            c.dropped_loss += 1
            return
        sent = self._transmit(link, len(frame), now)
        if sent is None:
            c.dropped_queue += 1
            return
        copies = 2 if imp.duplicate and self.rng.random() < imp.duplicate else 1
        c.duplicated += copies - 1
        for _ in range(copies):
            self._schedule(sent + self._latency(imp), pair, frame)

    def _transmit(self, link: Link, size: int, now: float) -> float | None:
        """When the frame has left the rate limiter, or None when the queue is full."""
        rate = link.impairment.rate_bps
        if not rate:
            return now
        start = max(now, link.busy_until)
        if start - now > link.impairment.queue_s:
            return None
        link.busy_until = start + size * 8 / rate
        return link.busy_until

    def _latency(self, imp: Impairment) -> float:
        jitter = self.rng.uniform(-imp.jitter, imp.jitter) if imp.jitter else 0.0
        held = imp.reorder_gap if imp.reorder and self.rng.random() < imp.reorder else 0.0
        return max(0.0, imp.delay + jitter) + held

    def _schedule(self, at: float, pair: tuple[int, int], frame: bytes) -> None:
        self.serial += 1
        heapq.heappush(self.queue, (at, self.serial, pair, frame))

    def _deliver_due(self) -> None:
        while True:
            with self.lock:
                if not self.queue or self.queue[0][0] > time.monotonic():
                    return
                _, _, pair, frame = heapq.heappop(self.queue)
                c = self.links[pair].counters
                c.delivered_frames += 1
                c.delivered_bytes += len(frame)
            if self.frame_log is not None:
                self.frame_log.write(f"{time.monotonic():.3f} {pair[0]}>{pair[1]} {len(frame)} {frame[:160].hex()}\n")
            try:
                os.write(self.fds[pair[1]], frame)
            except OSError:
                pass  # the namespace is going away, or the TAP's queue is full
