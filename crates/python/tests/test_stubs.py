"""multistep.pyi matches the module: mypy's stubtest compares every name and signature."""

import pathlib
import subprocess
import sys

import pytest


def test_stubs_match_the_runtime():
    pytest.importorskip("mypy")
    allow = pathlib.Path(__file__).with_name("stubtest-allowlist.txt")
    r = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "multistep", "--allowlist", str(allow)],
        capture_output=True, text=True, timeout=600,
    )
    assert r.returncode == 0, r.stdout + r.stderr
