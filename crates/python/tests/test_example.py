"""examples/python/plan_and_run.py runs end to end on a `multistep serve` board."""

import subprocess
import sys

from conftest import REPO


def test_example_plans_plots_and_runs(serve, tmp_path):
    script = REPO / "examples" / "python" / "plan_and_run.py"
    r = subprocess.run(
        [sys.executable, str(script), serve.endpoint],
        cwd=tmp_path, capture_output=True, text=True, timeout=300,
    )
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert "scurve4 (limits): 20000 steps" in out
    assert "X target=20000" in out
    assert "refused with code 4" in out
    # with matplotlib it writes the plot, without it says so
    assert ("wrote velocity.png" in out) == (tmp_path / "velocity.png").exists()
    assert "wrote velocity.png" in out or "matplotlib is not installed" in out
    took = [l for l in out.splitlines() if l.startswith("X at 20000")]
    assert took, out
    ticks, planned = took[0].split("took ")[1].split(" ticks (plan: ")
    assert int(ticks) == int(planned.rstrip(")"))
