"""Bounded results and argument ranges: no call fills memory until the process is killed,
and every out-of-range argument is a ValueError that says the range."""

import subprocess
import sys
import textwrap
import time

import pytest

import multistep
from conftest import interrupt

HUGE = 10**400  # an int beyond a float's range


def test_the_limits_are_module_constants():
    assert multistep.MAX_EDGES == 100_000_000
    assert multistep.MAX_TRACE_ROWS == 10_000_000


# the child reports its peak resident memory before and after the call
RSS = textwrap.dedent(
    r"""
    import resource, sys, time
    import multistep
    rss = lambda: resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    before = rss()
    t = time.monotonic()
    try:
        exec(sys.argv[1])
        print("no error")
    except ValueError as e:
        print("ValueError", type(e).__name__, e)
    print("seconds", time.monotonic() - t)
    print("grew_kib", rss() - before)
    """
)


@pytest.mark.parametrize(
    "call",
    [
        "multistep.track('4000', 1e9, amax=1e4)",
        "multistep.track('4000', 1e9, amax=1e4, integer=True)",
        "multistep.track('1000', 1e10, start_speed=1000.0)",
        "multistep.track(10**6, 101, amax=1e7)",
        "multistep.plan(steps=2**40, accel_time=1e6, cruise_time=1e6, decel_time=1e6).edges",
        "multistep.plan(steps=10**8 + 1, accel_time=10.0, cruise_time=10.0, decel_time=10.0).periods",
        "multistep.plan(steps=10**10, accel_time=1e3, cruise_time=1e3, decel_time=1e3).chunks(10**10)",
        "multistep.simulate('42mm', steps=1000, accel_time=10.0, cruise_time=80.0, decel_time=10.0,"
        " trace=True, trace_interval=1e-6)",
    ],
)
def test_too_many_edges_are_refused_before_any_is_made(call):
    r = subprocess.run(
        [sys.executable, "-c", RSS, call], capture_output=True, text=True, timeout=10
    )
    assert r.returncode == 0, r.stderr[-2000:]
    out = dict(l.split(" ", 1) for l in r.stdout.strip().splitlines())
    assert out.get("ValueError", "").split(" ", 1)[0] == "ValueError", r.stdout
    assert any(w in out["ValueError"] for w in ("MAX_EDGES", "MAX_TRACE_ROWS", "from 1 to"))
    assert float(out["seconds"]) < 2.0
    assert int(out["grew_kib"]) < 64 * 1024


def test_runs_within_the_limit_still_give_every_edge():
    # a ramp of 0.1 s (50 steps), then 2.4 s at 1000 steps/s
    assert len(multistep.track("1000", 2.5, amax=1e4)) == 2450
    # a ramp of 10⁴ s to 10⁶ steps/s cut after its first second: only what that second
    # holds is counted against the limit
    assert len(multistep.track(10**6, 1, amax=100.0)) == 50
    assert len(multistep.track(10**6, 1, amax=1.0)) == 0


def plan():
    return multistep.plan(steps=10, accel_time=0.1)


def board_track(b, **kw):
    return b.track("X", 100, **kw)


# (what, call, words the message must have); `b` is a Board on a server that never answers
OUT_OF_RANGE = [
    ("chunks size -1", lambda b: plan().chunks(-1), "from 1 to 100000000"),
    ("chunks size 0", lambda b: plan().chunks(0), "from 1 to 100000000"),
    ("chunks size 2**70", lambda b: plan().chunks(2**70), "from 1 to 100000000"),
    ("chunks size MAX+1", lambda b: plan().chunks(10**8 + 1), "from 1 to 100000000"),
    ("velocity t", lambda b: plan().velocity(HUGE), "within ±"),
    ("position t", lambda b: plan().position(-HUGE), "within ±"),
    ("plan accel_time", lambda b: multistep.plan(steps=10, accel_time=HUGE), "within ±"),
    ("plan steps -1", lambda b: multistep.plan(steps=-1, accel_time=0.1), "from 0 to"),
    ("plan segment steps", lambda b: multistep.plan(segments=[(0.0, 0.1, -1)]), "from 0 to"),
    ("track duration", lambda b: multistep.track("10", HUGE, amax=1.0), "within ±"),
    ("track amax", lambda b: multistep.track("10", 1, amax=HUGE), "within ±"),
    ("simulate microsteps -1", lambda b: multistep.simulate("42mm", steps=10, accel_time=0.1,
                                                            microsteps=-1), "from 0 to 4294967295"),
    ("simulate microsteps 2**40", lambda b: multistep.simulate("42mm", steps=10, accel_time=0.1,
                                                               microsteps=2**40), "from 0 to 4294967295"),
    ("simulate dt", lambda b: multistep.simulate("42mm", steps=10, accel_time=0.1, dt=HUGE),
     "within ±"),
    ("Board timeout 0", lambda b: multistep.Board(b.endpoint, timeout=0), "from 0.001 to 3600"),
    ("Board timeout -1", lambda b: multistep.Board(b.endpoint, timeout=-1), "from 0.001 to 3600"),
    ("Board timeout huge", lambda b: multistep.Board(b.endpoint, timeout=HUGE), "within ±"),
    ("Board timeout nan", lambda b: multistep.Board(b.endpoint, timeout=float("nan")),
     "from 0.001 to 3600"),
    ("Board timeout 1e4", lambda b: multistep.Board(b.endpoint, timeout=1e4),
     "from 0.001 to 3600"),
    ("Board.timeout =", lambda b: setattr(b, "timeout", 0.0), "from 0.001 to 3600"),
    ("wait timeout -1", lambda b: b.wait("X", timeout=-1.0), "≥ 0"),
    ("wait timeout huge", lambda b: b.wait("X", timeout=HUGE), "within ±"),
    ("track amax -1", lambda b: board_track(b, amax=-1.0), "> 0"),
    ("track amax huge", lambda b: board_track(b, amax=HUGE), "within ±"),
    ("track amax inf", lambda b: board_track(b, amax=float("inf")), "> 0"),
    ("track lease -1", lambda b: board_track(b, lease=-1), "at most 60"),
    ("track lease 61", lambda b: board_track(b, lease=61), "at most 60"),
    ("track lease huge", lambda b: board_track(b, lease=HUGE), "within ±"),
    ("move distance 2**64", lambda b: b.move("X", 2**64), "2^63 − 1"),
    ("sim_slip steps -2**70", lambda b: b.sim_slip("X", -(2**70)), "2^63 − 1"),
]


@pytest.mark.parametrize("call,words", [c[1:] for c in OUT_OF_RANGE],
                         ids=[c[0] for c in OUT_OF_RANGE])
def test_out_of_range_arguments_raise_value_error_with_the_range(silent_board, call, words):
    t = time.monotonic()
    with pytest.raises(ValueError) as e:
        call(silent_board)
    assert words in str(e.value)
    # refused before anything is sent (the server never answers)
    assert time.monotonic() - t < 1.0


# a child that starts a long computation and is sent SIGINT half a second later
LONG = textwrap.dedent(
    r"""
    import sys, time
    import multistep
    print("started", flush=True)
    try:
        exec(sys.argv[1])
        print("finished", flush=True)
    except KeyboardInterrupt:
        print("interrupted", time.monotonic(), flush=True)
        raise
    """
)


@pytest.mark.parametrize(
    "call",
    [
        "multistep.plan(profile='exponential', steps=10**8, accel_time=100.0, cruise_time=100.0,"
        " decel_time=100.0).edges",
        "next(multistep.plan(profile='sine', steps=10**8, accel_time=100.0, cruise_time=100.0,"
        " decel_time=100.0).chunks(10**8, periods=True))",
        "multistep.track(10**6, 99.9, amax=1e7)",
        "multistep.plan(steps=10**11, accel_time=1e4, cruise_time=1e2, decel_time=1e4).summary",
        "multistep.simulate('42mm', steps=10000, accel_time=10.0, cruise_time=80.0,"
        " decel_time=10.0)",
    ],
    ids=["edges", "a chunk", "track", "summary", "simulate"],
)
def test_ctrl_c_ends_a_long_computation(call):
    lines, err, sent = interrupt(LONG, call, ready="started", timeout=20.0)
    if lines[0] == "finished":
        pytest.skip("the call finished within half a second (a fast build)")
    assert lines[0].startswith("interrupted"), (lines, err)
    assert float(lines[0].split()[1]) - sent < 1.0
    assert "KeyboardInterrupt" in err
