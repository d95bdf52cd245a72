"""`slate node --foxglove`, seen by a Foxglove client written in Python: the `websockets`
package speaks the WebSocket protocol and `protobuf` decodes the scene with the schema the
server advertises, as Foxglove's own app does. Nothing of slate's is used on the client's
side: a `slate node` process serves, a `slate.Node` in this process writes through it."""

from __future__ import annotations

import base64
import json
import os
import socket
import subprocess
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from websockets.sync.client import ClientConnection, connect
from websockets.typing import Subprotocol

import slate

from .conftest import free_endpoint
from .test_demo_recording import find_slate

# The subprotocol offered: the first version, whose advertisements carry their schemas.
SUBPROTOCOL = Subprotocol("foxglove.sdk.v1")
MESSAGE_DATA = 1  # the binary opcode of a message on a subscription

WORLD = """
class Vehicle {
    position: vec<2> [m] = [0.0, 0.0];
    speed: real [m/s] in 0 .. 10 = 0.0;
    mode: string = "auto";
}
"""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


class Server:
    """A `slate node` process, t/r1/nav, serving Foxglove; stopped by its pid."""

    def __init__(self, directory: Path, slate_bin: str) -> None:
        self.endpoint = free_endpoint()
        self.foxglove = f"127.0.0.1:{free_port()}"
        (directory / "world.slate").write_text(WORLD + 'object gsr : Vehicle context self { mode = "survey"; }\n')
        config = directory / "nav.toml"
        config.write_text(
            'address = "t/r1/nav"\nfiles = ["world.slate"]\nexport = ["Thing"]\n'
            f'foxglove = "{self.foxglove}"\n[zenoh]\nlisten = ["{self.endpoint}"]\n'
        )
        self.log = directory / "nav.log"
        self.process = subprocess.Popen(
            [slate_bin, "node", "--config", str(config), "--format", "json"],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=self.log.open("w"),
            text=True,
        )
        assert self.process.stdout is not None
        ready = json.loads(self.process.stdout.readline() or "{}")
        assert ready.get("event") == "ready", (ready, self.log.read_text())

    def stop(self) -> None:
        self.process.terminate()
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()


@pytest.fixture
def server(tmp_path: Path) -> Iterator[Server]:
    slate_bin = find_slate()
    if slate_bin is None or not os.access(slate_bin, os.X_OK):
        pytest.skip("no slate binary: cargo build -p slate-cli (or set SLATE_BIN)")
    s = Server(tmp_path, slate_bin)
    try:
        yield s
    finally:
        s.stop()


class Client:
    """A Foxglove client: the channels advertised so far, and the messages received."""

    def __init__(self, ws: ClientConnection) -> None:
        self.ws = ws
        assert ws.subprotocol == SUBPROTOCOL
        self.channels: dict[str, dict[str, Any]] = {}
        self.ops: list[dict[str, Any]] = []

    def next(self, deadline: float) -> str | bytes | None:
        try:
            return self.ws.recv(timeout=max(0.0, deadline - time.monotonic()))
        except TimeoutError:
            return None

    def until(self, found: Callable[[], bool], seconds: float = 10.0) -> bool:
        """Reads messages until `found()` holds (text ones are kept), within `seconds`."""
        deadline = time.monotonic() + seconds
        while not found():
            if time.monotonic() > deadline:
                return False
            message = self.next(deadline)
            if isinstance(message, str):
                op = json.loads(message)
                self.ops.append(op)
                if op["op"] == "advertise":
                    self.channels.update({c["topic"]: c for c in op["channels"]})
        return True

    def subscribe(self, subscription: int, topic: str) -> None:
        channel = self.channels[topic]["id"]
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": subscription, "channelId": channel}]}))

    def payloads(self, subscription: int, wanted: Callable[[bytes], bool], seconds: float = 10.0) -> bytes | None:
        """The first payload on `subscription` that `wanted` accepts, within `seconds`."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            message = self.next(deadline)
            if not isinstance(message, bytes) or len(message) < 13 or message[0] != MESSAGE_DATA:
                continue
            # opcode, subscription id (u32 LE), log time (u64 LE), payload
            if int.from_bytes(message[1:5], "little") == subscription and wanted(message[13:]):
                return message[13:]
        return None



def protobuf_class(channel: dict[str, Any]) -> Any:
    """The message class of a protobuf channel, built from the schema it advertises (a
    base64 FileDescriptorSet), as a Foxglove client builds it."""
    assert channel["encoding"] == "protobuf" and channel["schemaEncoding"] == "protobuf", channel
    files = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
    pool = descriptor_pool.DescriptorPool()
    for f in files.file:
        pool.Add(f)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))


def only_packet(payload: bytes) -> dict[str, Any]:
    """The packet of a class channel's message: a list of packets, here of one."""
    packets = json.loads(payload)["packets"]
    assert len(packets) == 1, packets
    return dict(packets[0])


def json_packet(attr: str, value: object) -> Callable[[bytes], bool]:
    def wanted(payload: bytes) -> bool:
        packet = only_packet(payload)
        return bool(packet.get("attr") == attr and packet["values"].get(attr) == value)

    return wanted


def test_a_python_foxglove_client_gets_the_channels_schemas_and_the_writes_of_a_peer(server: Server) -> None:
    address = f"ws://{server.foxglove}/"
    with connect(address, subprotocols=[SUBPROTOCOL], open_timeout=10) as ws:
        client = Client(ws)
        assert client.until(lambda: any(op["op"] == "serverInfo" for op in client.ops)), client.ops
        info = next(op for op in client.ops if op["op"] == "serverInfo")
        assert "t/r1/nav" in info["name"], info
        assert client.until(lambda: {"/slate/class/Vehicle", "/slate/scene"} <= client.channels.keys()), client.channels

        vehicle = client.channels["/slate/class/Vehicle"]
        assert (vehicle["encoding"], vehicle["schemaName"], vehicle["schemaEncoding"]) == ("json", "Vehicle", "jsonschema")
        packet_schema = json.loads(vehicle["schema"])["properties"]["packets"]["items"]
        values = packet_schema["properties"]["values"]["properties"]
        assert values["speed"]["type"] == ["number", "null"], values
        assert values["mode"]["type"] == ["string", "null"], values
        assert values["position"]["maxItems"] == 2, values
        assert client.channels["/slate/scene"]["schemaName"] == "foxglove.SceneUpdate"
        scene_update = protobuf_class(client.channels["/slate/scene"])

        # On subscribing, the latest values come at once.
        client.subscribe(1, "/slate/class/Vehicle")
        first = client.payloads(1, json_packet("mode", "survey"))
        assert first is not None, "gsr.mode's latest packet on subscribe"
        assert only_packet(first)["object"] == "gsr"

        # A module of another robot writes through the node: the client gets its packets.
        board = slate.Board(address="t/r2/loco")
        board.load(WORLD)
        with slate.Node("t/r2/loco", board, connect=[server.endpoint], export=["Thing"]):
            deadline = time.monotonic() + 10
            while "gsr" not in board and time.monotonic() < deadline:
                time.sleep(0.02)
            assert "gsr" in board, "the writer never heard of gsr"
            board.write("gsr", "mode", "manual")
            written = client.payloads(1, json_packet("mode", "manual"))
            assert written is not None, f"no packet of gsr.mode = manual\n{server.log.read_text()}"
            packet = only_packet(written)
            assert (packet["object"], packet["source"]) == ("gsr", "t/r2/loco"), packet

            # The scene: its protobuf messages decode with the advertised schema.
            client.subscribe(2, "/slate/scene")
            board.write("gsr", "position", [1.5, 2.5])

            def places_gsr(payload: bytes) -> bool:
                update = scene_update.FromString(payload)
                return any(
                    e.id == "gsr"
                    and e.frame_id == "slate"
                    and [(c.pose.position.x, c.pose.position.y) for c in e.cubes] == [(1.5, 2.5)]
                    for e in update.entities
                )

            assert client.payloads(2, places_gsr) is not None, "no SceneUpdate placing gsr at (1.5, 2.5)"
