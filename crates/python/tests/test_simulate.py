"""`multistep.simulate` against `multistep simulate --format json` (and its --trace CSV)."""

import json

import numpy as np
import pytest

import multistep
from moves import flags

MOVE = {"steps": 3200, "accel_time": 0.05, "cruise_time": 0.05, "decel_time": 0.05}


@pytest.mark.parametrize(
    "motor,kw,extra",
    [
        ("42mm", MOVE, {}),
        (
            "57mm",
            {"profile": "scurve", "steps": 6400, "vmax": 40000.0, "amax": 2e6, "jmax": 1e9},
            {"microsteps": 8, "supply": 12.0, "load_torque": 0.2, "reverse": True},
        ),
        ("20mm", {"profile": "sine", **MOVE}, {"mode": "ideal", "damping_ratio": 0.3}),
    ],
)
def test_result_equals_the_cli_json(cli, motor, kw, extra):
    r = multistep.simulate(motor, **kw, **extra)
    args = []
    for k, v in extra.items():
        if v is True:
            args.append(f"--{k.replace('_', '-')}")
        else:
            args.append(f"--{k.replace('_', '-')}={v}")
    j = json.loads(cli("simulate", "--motor", motor, *flags(kw), *args, "--format", "json").stdout)
    assert r == j
    assert r["steps"] == kw["steps"]


def test_lost_steps_are_reported():
    # far too fast for the small motor: it stalls
    r = multistep.simulate("20mm", steps=3200, accel_time=0.005, cruise_time=0.01, decel_time=0.005)
    assert r["lost"] and r["lost_steps"] != 0 and r["first_loss_s"] is not None


def test_trace_arrays_equal_the_cli_trace(cli, tmp_path):
    r = multistep.simulate("42mm", **MOVE, trace=True)
    tr = r.pop("trace")
    csv = tmp_path / "trace.csv"
    cli("simulate", "--motor", "42mm", *flags(MOVE), "--trace", csv)
    ref = np.loadtxt(csv, delimiter=",", skiprows=1)
    cols = ["t_s", "commanded_deg", "actual_deg", "commanded_speed_deg_s",
            "actual_speed_deg_s", "error_deg", "ia_a", "ib_a"]
    assert sorted(tr) == sorted(cols)
    for i, c in enumerate(cols):
        a = tr[c]
        assert a.dtype == np.float64 and len(a) == len(ref)
        # the CSV is printed with 3 to 7 decimals
        np.testing.assert_allclose(a, ref[:, i], atol=1e-3, rtol=0)
    # 3200 microsteps of a 1.8° motor at 16 microsteps: 360°
    assert tr["commanded_deg"][-1] == pytest.approx(360.0)
    assert np.all(np.diff(tr["t_s"]) > 0)


def test_motor_file_path(tmp_path):
    import pathlib

    src = pathlib.Path(__file__).resolve().parents[2] / "sim" / "motors" / "42mm.toml"
    f = tmp_path / "mine.toml"
    f.write_text(src.read_text())
    by_name = multistep.simulate("42mm", **MOVE)
    by_path = multistep.simulate(f, **MOVE)
    assert by_path == by_name
    assert multistep.simulate(str(f), **MOVE) == by_name
