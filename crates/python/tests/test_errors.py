"""Every error class: bad moves raise PlanError (a ValueError) with the message the
command line prints, wrong types TypeError, and no input brings the interpreter down."""

import math
import subprocess
import sys
import textwrap

import pytest

import multistep
from moves import flags

# moves every planner error comes from, with the flags the CLI is given for them
BAD_MOVES = [
    {"steps": 0, "accel_time": 0.1},
    {"accel_time": 0.1},
    {"steps": 100},
    {"profile": "banana", "steps": 10, "accel_time": 0.1},
    {"steps": 10, "accel_time": 0.1, "vmax": 100.0, "amax": 100.0},
    {"profile": "scurve", "steps": 10, "accel_time": 0.1, "phi": 0.7},
    {"profile": "scurve4", "steps": 10, "accel_time": 0.1, "psi": 0.0},
    {"profile": "exponential", "steps": 10, "accel_time": 0.1, "rho": -1.0},
    {"steps": 10, "accel_time": -0.1},
    {"steps": 10, "accel_time": math.nan},
    {"steps": 10, "accel_time": math.inf},
    {"steps": 10, "accel_time": 0.0, "cruise_time": 0.0, "decel_time": 0.0},
    {"steps": 10, "accel_time": 0.1, "start_speed": 1e6},
    {"steps": 10, "accel_time": 0.1, "clock": 0.0},
    {"steps": 10_000_000, "accel_time": 1e9, "clock": 1e9},
    {"steps": 1 << 49, "accel_time": 1.0},
    {"segments": [(1000.0, 0.1, 1)]},
    {"segments": [(0.0, 0.1, 1)] * 65},
    {"segments": [(0.0, -0.1, 1)]},
    {"segments": [(0.0, 0.1, 0)]},
    {"segments": [(0.0, 0.1, 10)], "steps": 10},
    {"profile": "sine", "steps": 10, "vmax": 100.0, "amax": 100.0},
    {"profile": "scurve", "steps": 10, "vmax": 100.0, "amax": 100.0},
    {"profile": "scurve4", "steps": 10, "vmax": 100.0, "amax": 100.0, "jmax": 1e3},
    {"steps": 10, "vmax": 100.0},
    {"steps": 10, "vmax": 100.0, "amax": 100.0, "start_speed": 200.0},
    {"steps": 10, "vmax": 1000.0, "amax": 100.0, "start_speed": 900.0},
    {"steps": 10, "vmax": -1.0, "amax": 100.0},
]


@pytest.mark.parametrize("kw", BAD_MOVES, ids=[str(i) for i in range(len(BAD_MOVES))])
def test_plan_errors_carry_the_cli_message(cli, kw):
    r = cli("plan", *flags(kw), "--format", "json", check=False)
    assert r.returncode == 2, r.stdout
    with pytest.raises(multistep.PlanError) as e:
        multistep.plan(**kw)
    assert isinstance(e.value, ValueError) and isinstance(e.value, multistep.MultistepError)
    assert r.stderr.strip() == f"error: {e.value}"


TYPE_ERRORS = [
    {"steps": "10", "accel_time": 0.1},
    {"steps": 10.0, "accel_time": 0.1},
    {"steps": True, "accel_time": 0.1},
    {"steps": 10, "accel_time": "0.1"},
    {"steps": 10, "accel_time": [0.1]},
    {"steps": 10, "accel_time": 0.1, "profile": 3},
    {"segments": "0:0.1:10"},
    {"segments": 5},
    {"segments": [5]},
    {"segments": [(0.0, 0.1, 10.5)]},
    {"steps": 10, "accel_time": 0.1, "acel_time": 0.1},
    {"steps": 10, "accel_time": 0.1, "clock": "fast"},
]


@pytest.mark.parametrize("kw", TYPE_ERRORS, ids=[str(i) for i in range(len(TYPE_ERRORS))])
def test_wrong_types_raise_type_error(kw):
    with pytest.raises(TypeError):
        multistep.plan(**kw)


@pytest.mark.parametrize(
    "kw",
    [
        {"steps": -1, "accel_time": 0.1},
        {"steps": 1 << 70, "accel_time": 0.1},
        {"segments": [(0.0, 0.1)]},
        {"segments": [(0.0, 0.1, -3)]},
    ],
)
def test_out_of_range_values_raise_value_error(kw):
    with pytest.raises(ValueError):
        multistep.plan(**kw)


def test_positional_arguments_are_refused():
    with pytest.raises(TypeError):
        multistep.plan(100, 0.1)


def test_chunk_size_out_of_range_is_a_value_error():
    for size in (0, -1):
        with pytest.raises(ValueError, match="from 1 to"):
            multistep.plan(steps=10, accel_time=0.1).chunks(size)
    with pytest.raises(TypeError):
        multistep.plan(steps=10, accel_time=0.1).chunks(1.5)


def test_simulation_errors(cli):
    with pytest.raises(multistep.SimulationError) as e:
        multistep.simulate("99mm", steps=100, accel_time=0.1)
    assert isinstance(e.value, ValueError)
    r = cli("simulate", "--motor", "99mm", "--steps", "100", "--accel-time", "0.1", check=False)
    assert r.stderr.strip() == f"error: {e.value}"
    with pytest.raises(multistep.SimulationError, match="unstable"):
        multistep.simulate("42mm", steps=100, accel_time=0.1, dt=1e-2)
    with pytest.raises(multistep.SimulationError):
        multistep.simulate("42mm", steps=100, accel_time=0.1, supply=-24.0)
    with pytest.raises(ValueError, match="driver mode"):
        multistep.simulate("42mm", steps=100, accel_time=0.1, mode="magic")
    with pytest.raises(multistep.PlanError):
        multistep.simulate("42mm", steps=0, accel_time=0.1)
    with pytest.raises(TypeError):
        multistep.simulate(42, steps=100, accel_time=0.1)
    with pytest.raises(TypeError):
        multistep.simulate("42mm", steps=100, accel_time=0.1, reverse="yes")
    with pytest.raises(ValueError):
        multistep.simulate("42mm", steps=100, accel_time=0.1, microsteps=1 << 40)


def test_board_endpoint_and_connection_errors():
    with pytest.raises(ValueError, match="neither tcp://HOST:PORT nor serial:DEVICE"):
        multistep.Board("http://127.0.0.1:7878")
    # port 1 on loopback: nothing listens there
    with pytest.raises(multistep.BoardConnectionError) as e:
        multistep.Board("tcp://127.0.0.1:1")
    assert isinstance(e.value, ConnectionError) and isinstance(e.value, multistep.BoardError)
    with pytest.raises(multistep.BoardError):
        multistep.Board("serial:/dev/nonexistent-multistep-tty")


def test_exception_hierarchy():
    assert issubclass(multistep.MultistepError, Exception)
    for c in (multistep.PlanError, multistep.SimulationError, multistep.BoardError):
        assert issubclass(c, multistep.MultistepError)
    assert issubclass(multistep.ProtocolError, multistep.BoardError)
    assert multistep.PlanError.__module__ == "multistep"


FUZZ = textwrap.dedent(
    r"""
    import itertools, math, random, sys
    import multistep

    r = random.Random(21)
    values = [None, 0, 1, -1, 2**64, 2**48 + 1, 10**400, 0.0, -0.0, 1e-300, 1e300,
              math.nan, math.inf, -math.inf, "", "x", "trapezoid", b"1", [], [1], (1, 2, 3),
              [(0.0, 0.1, 10)], [(math.nan, 0.1, 10)], [(0.0, 1e-300, 2**48)], {}, object(),
              True, 3 + 4j, float("1e-320")]
    keys = ["profile", "steps", "accel_time", "cruise_time", "decel_time", "start_speed",
            "end_speed", "rho", "phi", "psi", "segments", "vmax", "amax", "jmax", "smax",
            "clock"]
    ok = (TypeError, ValueError, MemoryError, multistep.MultistepError)
    tried = 0
    for _ in range(3000):
        kw = {k: r.choice(values) for k in r.sample(keys, r.randint(1, 6))}
        tried += 1
        try:
            p = multistep.plan(**kw)
            if p.steps <= 200_000:
                p.edges; p.periods; p.summary
            next(iter(p.chunks(r.randint(1, 64))))
            p.velocity(r.choice([0.0, 1.0, math.nan, math.inf])); repr(p)
        except ok:
            pass
    for _ in range(150):
        kw = {k: r.choice(values) for k in r.sample(keys + ["microsteps", "supply", "mode",
              "dt", "load_torque", "load_inertia", "damping_ratio", "trace"], r.randint(1, 5))}
        kw.setdefault("steps", r.choice([1, 50]))
        kw.setdefault("accel_time", 0.01)
        try:
            multistep.simulate(r.choice(["42mm", "20mm", "nope", ""]), **kw)
        except ok:
            pass
    for ep in ["", "tcp://", "tcp://:", "tcp://127.0.0.1:99999", "tcp://[::1", "serial:",
               "serial:/dev/null", "x" * 10000, "tcp://127.0.0.1:0"]:
        try:
            multistep.Board(ep)
        except ok:
            pass
    print("survived", tried)
    """
)


def test_interpreter_survives_random_bad_input():
    r = subprocess.run([sys.executable, "-c", FUZZ], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "survived 3000" in r.stdout
    assert "panicked" not in r.stderr and "PanicException" not in r.stderr
