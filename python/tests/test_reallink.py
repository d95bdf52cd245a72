"""The real-link harness's short set (scripts/reallink/harness.py): real `slate node`
processes in network namespaces joined by the emulated radio. Needs root, `ip netns` and
TAP devices, and a built `slate` binary; skipped otherwise, with the reason. The long set
is run on demand (docs/real-links.md)."""

from __future__ import annotations

import argparse
import socket
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "scripts" / "reallink"))

import harness  # noqa: E402
from netns import unavailable  # noqa: E402
from radio import Impairment, Radio  # noqa: E402


@pytest.fixture(scope="module")
def slate_bin() -> str:
    reason = unavailable()
    if reason:
        pytest.skip(reason)
    try:
        return harness.find_slate(None)
    except SystemExit as e:
        pytest.skip(str(e))


def test_a_10_s_partition_heals_with_no_healthy_module_marked_dead(slate_bin: str) -> None:
    # As long as Zenoh's lease: its links to the cut robot close as the partition heals.
    result = harness.run(harness.Scenario("partition-10s", partition=10.0), slate_bin)
    assert result["started"], result
    assert result["converged_s"] is not None, result
    assert result["false_marks"] == [], result
    # The radio cut r3's links, and counted every frame it carried or dropped.
    assert all(c["dropped_cut"] > 0 for link, c in result["frames"].items() if "r3" in link)
    for link, c in result["frames"].items():
        dropped = c["dropped_cut"] + c["dropped_loss"] + c["dropped_queue"]
        assert c["delivered_frames"] == c["offered_frames"] - dropped + c["duplicated"], link


def test_at_30_percent_loss_the_team_converges_and_no_mate_is_marked_dead(slate_bin: str) -> None:
    # Mates share a loopback the radio's loss never touches. Modules of other robots can
    # still be marked dead at this loss, over TCP (docs/real-links.md, "What does not
    # hold yet"): not asserted here.
    scn = harness.Scenario("loss-0.3", Impairment(loss=0.3), hold=10.0)
    result = harness.run(scn, slate_bin)
    assert result["started"], result
    assert result["converged_s"] is not None, result
    robot = {m.address: m.robot for m in harness.team_modules()}
    mates = [m for m in result["false_marks"] if robot[m["board"]] == robot[m["peer"]]]
    assert mates == [], result


def test_plan_send_at_30_percent_loss_prints_every_acknowledgement_the_destination_produced(
    slate_bin: str,
) -> None:
    # Three plans across the lossy team link (`harness.py plansend` runs ten).
    args = argparse.Namespace(protocol="tcp", topology="mesh", loss=0.3, runs=3, timeout=60.0, keep=False)
    results = harness.plansend_run(args, slate_bin)
    assert len(results) == 3, results
    for r in results:
        assert r["exit"] == 0, r
        assert r["missing"] == [], r
        assert "terminated" in r["destination"], r


def frame(src: int, dst: int, size: int = 100) -> bytes:
    """An Ethernet frame from MAC ..:src to MAC ..:dst (unicast), `size` bytes long."""
    return bytes([2, 0, 0, 0, 0, dst, 2, 0, 0, 0, 0, src]) + bytes(size - 12)


# Socket pairs whose one end a radio under test holds by file number only.
KEPT_OPEN: list[tuple[socket.socket, socket.socket]] = []


def radio_between_sockets(imp: Impairment) -> tuple[Radio, list[socket.socket]]:
    """A two-port radio whose ports are datagram socket pairs (no root, no TAP)."""
    pairs = [socket.socketpair(socket.AF_UNIX, socket.SOCK_DGRAM) for _ in range(2)]
    for ours, _ in pairs:
        ours.setblocking(False)
    radio = Radio([ours.fileno() for ours, _ in pairs], seed=7)
    KEPT_OPEN.extend(pairs)  # the radio's ends, open as long as the test run
    radio.set_impairment(imp)
    radio.start()
    return radio, [theirs for _, theirs in pairs]


def received(sock: socket.socket, wanted: int) -> int:
    """Frames read from `sock` until `wanted` arrived or none came for 1 s."""
    sock.settimeout(1.0)
    n = 0
    try:
        while n < wanted:
            sock.recv(4096)
            n += 1
    except TimeoutError:
        pass
    return n


def test_the_radio_drops_duplicates_and_counts_frames_with_their_headers() -> None:
    radio, ends = radio_between_sockets(Impairment(loss=0.5, duplicate=0.5))
    try:
        ends[1].send(frame(1, 0))  # teaches the radio where MAC 1 is
        for _ in range(200):
            ends[0].send(frame(0, 1))
        got = received(ends[1], 400)  # all delivered once none came for 1 s
    finally:
        radio.stop()
    c = radio.counters()[(0, 1)]
    assert c["offered_frames"] == 200 and c["offered_bytes"] == 200 * 100
    assert 0 < c["dropped_loss"] < 200 and 0 < c["duplicated"] < 200
    assert got == c["delivered_frames"] == 200 - c["dropped_loss"] + c["duplicated"]


def test_a_cut_link_carries_nothing_until_healed() -> None:
    radio, ends = radio_between_sockets(Impairment())
    try:
        ends[1].send(frame(1, 0))
        radio.cut([0], [1])
        ends[0].send(frame(0, 1))
        assert received(ends[1], 1) == 0
        radio.cut([0], [1], cut=False)
        ends[0].send(frame(0, 1))
        assert received(ends[1], 1) == 1
    finally:
        radio.stop()
    assert radio.counters()[(0, 1)]["dropped_cut"] == 1
