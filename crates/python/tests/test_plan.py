"""`multistep.plan` against the `multistep plan` command line: the same edges, periods,
summary and error messages for random moves of every family and mode."""

import json
import resource

import numpy as np
import pytest

import multistep
from moves import all_moves, flags

MOVES = list(all_moves())


def cli_csv(cli, kw):
    r = cli("plan", *flags(kw), "--format", "csv")
    rows = np.array(r.stdout.replace(",", "\n").split()[3:], dtype=np.uint64).reshape(-1, 3)
    return rows


@pytest.mark.parametrize("name,kw", MOVES, ids=[m[0] for m in MOVES])
def test_edges_periods_and_summary_equal_the_cli(cli, name, kw):
    r = cli("plan", *flags(kw), "--format", "json", check=False)
    if r.returncode != 0:
        # an infeasible random move: the binding refuses it with the CLI's message
        with pytest.raises(multistep.PlanError) as e:
            multistep.plan(**kw)
        assert r.returncode == 2
        assert r.stderr.strip() == f"error: {e.value}"
        return
    p = multistep.plan(**kw)
    assert p.summary == json.loads(r.stdout)
    rows = cli_csv(cli, kw)
    assert p.edges.dtype == np.uint64 and p.periods.dtype == np.uint64
    assert len(p) == p.steps == len(rows)
    np.testing.assert_array_equal(rows[:, 0], np.arange(1, p.steps + 1, dtype=np.uint64))
    np.testing.assert_array_equal(p.edges, rows[:, 1])
    np.testing.assert_array_equal(p.periods, rows[:, 2])
    assert p.edges[-1] == p.last_edge_tick == p.summary["last_edge_tick"]
    assert p.duration_s == p.summary["duration_s"]
    assert p.mode == p.summary["mode"]


@pytest.mark.parametrize("size", [1, 7, 1000, 1 << 20])
def test_chunks_are_the_edges_in_order(size):
    p = multistep.plan(profile="scurve", steps=5003, accel_time=0.05, cruise_time=0.02, decel_time=0.04)
    parts = list(p.chunks(size))
    assert all(len(c) == size for c in parts[:-1]) and 0 < len(parts[-1]) <= size
    np.testing.assert_array_equal(np.concatenate(parts), p.edges)
    np.testing.assert_array_equal(np.concatenate(list(p.chunks(size, periods=True))), p.periods)


def test_arrays_are_read_only_and_cached():
    p = multistep.plan(steps=2400, accel_time=0.02, cruise_time=0.01, decel_time=0.02)
    e = p.edges
    assert not e.flags.writeable
    with pytest.raises(ValueError):
        e[0] = 1
    assert p.edges is e
    # seed 000's run: vm = 80 000 steps/s is 625 ticks a step in the cruise
    assert (p.periods[1000:1300] == 625).all()
    assert p.edges[-1] == 2_500_000
    s = p.summary
    s["steps"] = -1
    assert p.summary["steps"] == 2400


def test_velocity_and_position_follow_the_profile():
    p = multistep.plan(steps=2400, accel_time=0.02, cruise_time=0.01, decel_time=0.02)
    assert p.velocity(0.025) == pytest.approx(80_000)
    assert p.position(p.duration_s) == 2400
    assert p.position(-1) == 0 and p.velocity(1.0) == 0


def rss_kib():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise RuntimeError("no VmRSS")


def test_huge_move_streams_in_constant_memory():
    # 2·10^8 steps: 1.6 GB as one array; through chunks of 2^20 edges, one chunk at a time
    steps = 200_000_000
    p = multistep.plan(steps=steps, accel_time=100.0, cruise_time=800.0, decel_time=100.0)
    base = rss_kib()
    peak = base
    count = 0
    last = 0
    total_periods = 0
    for k, chunk in enumerate(p.chunks(1 << 20)):
        assert chunk[0] >= last
        last = int(chunk[-1])
        count += len(chunk)
        if k % 16 == 0:
            peak = max(peak, rss_kib())
    peak = max(peak, rss_kib())
    assert count == steps
    assert last == p.last_edge_tick == round(1000.0 * 50e6)
    # a few chunks at most (8 MiB each), never the 1.6 GB the whole move would take
    assert peak - base < 64 * 1024, f"RSS grew by {(peak - base) / 1024:.0f} MiB"
    # the first chunk of periods sums to its last edge
    first = next(iter(p.chunks(1 << 16, periods=True)))
    total_periods = int(first.sum())
    assert total_periods == int(next(iter(p.chunks(1 << 16)))[-1])
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss < 1_000_000  # KiB: < 1 GB
