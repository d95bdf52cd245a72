"""`slate demo --record`: the console's recording read by an independent MCAP reader (the
`mcap` package from PyPI, not slate's), checked against the demo's own counters and
outcome. Needs a built `slate` binary (cargo build -p slate-cli); skipped otherwise."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

ROOT = Path(__file__).resolve().parents[2]
# The channels every demo recording holds: what the console's board sees of a mission.
FIXED = {
    "/slate/classes": "slate.ClassDef",
    "/slate/objects": "slate.ObjectEvent",
    "/slate/plans": "slate.PlanEvent",
    "/slate/circuits": "slate.CircuitStep",
    "/slate/liveliness": "slate.Liveliness",
    "/slate/links": "slate.LinkStats",
    "/slate/recorder": "slate.RecorderStats",
}


def find_slate() -> str | None:
    """The `slate` binary: $SLATE_BIN, the newest of the target dir's, or PATH."""
    if os.environ.get("SLATE_BIN"):
        return os.environ["SLATE_BIN"]
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    built = [b for b in (target / p / "slate" for p in ("debug", "release")) if b.exists()]
    if built:
        return str(max(built, key=lambda b: b.stat().st_mtime))
    return shutil.which("slate")


@dataclass
class Read:
    """A recording as the `mcap` package reads it."""

    schemas: dict[str, tuple[str, str, dict[str, Any]]] = field(default_factory=dict)
    encodings: set[str] = field(default_factory=set)
    counts: Counter[str] = field(default_factory=Counter)
    # A class channel's message is a list of packets (`{"packets": [...]}`): each of them.
    messages: dict[str, list[dict[str, Any]]] = field(default_factory=dict)


@dataclass
class Recorded:
    summary: dict[str, Any]
    read: Read


def read_mcap(path: Path) -> Read:
    read = Read()
    with path.open("rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            assert schema is not None, channel.topic
            topic = channel.topic
            read.schemas[topic] = (schema.name, schema.encoding, json.loads(schema.data))
            read.encodings.add(channel.message_encoding)
            read.counts[topic] += 1
            data = json.loads(message.data)
            if topic.startswith("/slate/class/"):
                assert len(data["packets"]) >= 1, data
                read.messages.setdefault(topic, []).extend(data["packets"])
            else:
                read.messages.setdefault(topic, []).append(data)
    return read


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Recorded:
    slate_bin = find_slate()
    if slate_bin is None:
        pytest.skip("no slate binary: build it (cargo build -p slate-cli) or set SLATE_BIN")
    path = tmp_path_factory.mktemp("demo") / "demo.mcap"
    done = subprocess.run(
        [slate_bin, "demo", "--record", str(path), "--quiet", "--format", "json"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    return Recorded(json.loads(done.stdout), read_mcap(path))


def attrs_of(classes: list[dict[str, Any]], name: str) -> set[str]:
    """The attributes class `name` declares or inherits, by its recorded definitions."""
    by_name = {c["name"]: c for c in classes}
    attrs: set[str] = set()
    while name in by_name:
        attrs |= {a["name"] for a in by_name[name]["attrs"]}
        name = by_name[name]["parent"]
    return attrs


def last_values(read: Read, cls: str, attr: str) -> dict[str, Any]:
    """The last recorded value of `attr` of each object of `cls`."""
    return {
        m["object"]: m["values"][attr]
        for m in read.messages.get(f"/slate/class/{cls}", [])
        if m["attr"] == attr
    }


def test_the_message_counts_per_channel_are_the_demos_own(recorded: Recorded) -> None:
    facts = recorded.summary["recording"]
    assert facts["failed"] is None and facts["dropped"] == 0, facts
    assert dict(recorded.read.counts) == facts["by_topic"]
    assert sum(recorded.read.counts.values()) == facts["messages"]
    assert recorded.read.encodings == {"json"}


def test_every_channel_has_its_schema_and_a_class_channel_types_its_attributes(
    recorded: Recorded,
) -> None:
    read = recorded.read
    for topic, name in FIXED.items():
        assert read.schemas[topic][:2] == (name, "jsonschema"), topic
    classes = read.messages["/slate/classes"]
    class_topics = [t for t in read.schemas if t.startswith("/slate/class/")]
    assert {t.removeprefix("/slate/class/") for t in class_topics} >= {
        "Mission",
        "Robot",
        "Target",
        "Waypoint",
        "Module",
        "Plan",
    }
    for topic in class_topics:
        cls = topic.removeprefix("/slate/class/")
        name, encoding, schema = read.schemas[topic]
        assert (name, encoding) == (cls, "jsonschema")
        packet = schema["properties"]["packets"]["items"]
        assert set(packet["properties"]["values"]["properties"]) == attrs_of(classes, cls)
        for m in read.messages[topic]:
            assert set(m["values"]) == {m["attr"]} <= attrs_of(classes, cls), m


def test_the_recorded_outcome_is_the_one_the_demo_reported(recorded: Recorded) -> None:
    summary, read = recorded.summary, recorded.read
    assert last_values(read, "Mission", "phase") == {"mission": summary["mission_phase"]}
    found_by = {t["name"]: t["found_by"] for t in summary["targets"]}
    assert last_values(read, "Target", "found_by") == {
        t: by for t, by in found_by.items() if by
    }
    alive: dict[str, bool] = {}
    for m in read.messages["/slate/liveliness"]:
        alive[m["module"]] = m["alive"]
    dead = {module for module, up in alive.items() if not up}
    robot = summary["fault"]["robot"]
    assert dead == {f"team/{robot}/{r}" for r in ("exec", "nav", "prox", "vision", "loco")}
