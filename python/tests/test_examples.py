"""Every example runs end to end."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parent.parent.parent / "examples" / "python"


def run_example(name: str) -> str:
    done = subprocess.run(
        [sys.executable, str(EXAMPLES / name)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stderr == ""
    return done.stdout


def test_sensor_example_grows_accuracy_and_takes_fixes() -> None:
    out = run_example("sensor.py")
    assert "nav: 120 steps of 0.1 s at 2.0 m/s" in out
    assert "nav: 3 landmark fixes, 3 reports to the executive" in out
    assert "nav: plan ask_for_fix fired 3 times" in out
    assert "nav: function_failed" not in out


def test_effector_example_reacts_to_commanded_speeds() -> None:
    out = run_example("effector.py")
    assert "loco: commanded 7.0 m/s -> driving at 3.0 m/s" in out
    assert "loco: obstacle at 4.0 m -> driving at 0.0 m/s" in out
    assert "ValueError: cannot drive backwards at -1.0 m/s" in out
    assert "loco: 5 commands executed, motor current now 0.0 A" in out


def test_planner_example_prints_every_acknowledgement_over_zenoh() -> None:
    out = run_example("planner.py")
    steps = [line for line in out.splitlines() if line.startswith("planner: slow_down ")]
    assert steps == [
        "planner: slow_down received",
        "planner: slow_down accepted",
        "planner: slow_down initiated",
        "planner: slow_down triggered (fired 1)",
        "planner: slow_down terminated",
    ], out
    assert "planner: gsr is slow at 2.0 m/s (written by team/r1/loco)" in out
    assert "loco: plan slow_down terminated, fired 1 time(s)" in out
