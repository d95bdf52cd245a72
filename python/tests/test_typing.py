"""The stubs match the native module, and typed code using slate type-checks."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

PYTHON_DIR = Path(__file__).resolve().parent.parent
EXAMPLES = PYTHON_DIR.parent / "examples" / "python"
# The real-link harness, which tests/test_reallink.py imports (and so type-checks too).
REALLINK = PYTHON_DIR.parent / "scripts" / "reallink"


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, *args],
        cwd=PYTHON_DIR,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "MYPYPATH": str(REALLINK)},
    )


def test_stubtest_finds_the_stubs_exact() -> None:
    done = run("-m", "mypy.stubtest", "slate._slate")
    assert done.returncode == 0, done.stdout + done.stderr


def test_package_examples_and_tests_type_check_strictly() -> None:
    done = run(
        "-m",
        "mypy",
        "--strict",
        "--no-incremental",
        "slate",
        str(EXAMPLES),
        "bench",
        "tests",
    )
    assert done.returncode == 0, done.stdout + done.stderr
