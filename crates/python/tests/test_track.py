"""multistep.track against `multistep plan --track` (every edge), and the board client's
tracking words against a real `multistep serve` board."""

from fractions import Fraction

import numpy as np
import pytest

import multistep


def cli_track(cli, rate, duration, *flags):
    r = cli("plan", "--track", rate, "--duration", duration, *flags, "--format", "csv")
    rows = r.stdout.strip().splitlines()
    assert rows[0] == "step,edge_tick,period_ticks"
    return np.array([int(l.split(",")[1]) for l in rows[1:]], dtype=np.uint64)


CASES = [
    # sidereal rate from rest, its exact fraction
    ("15041/324", 30, dict(amax=200.0)),
    # a fast decimal rate from a start speed
    ("31999.9", 0.5, dict(amax=64000.0, start_speed=1000.0)),
    # an S-curve ramp down to a slow rate
    ("46.4228", 3, dict(amax=500.0, jmax=5000.0, start_speed=300.0)),
    # no ramp: already at the rate, another clock
    ("2500", 0.2, dict(start_speed=2500.0, clock=1e6)),
]


def cli_flags(kw):
    out = []
    for k, v in kw.items():
        out += ["--" + k.replace("_", "-"), v]
    return out


@pytest.mark.parametrize("rate,duration,kw", CASES)
def test_edges_equal_plan_track(cli, rate, duration, kw):
    want = cli_track(cli, rate, duration, *cli_flags(kw))
    assert len(want) > 10
    got = multistep.track(rate, duration, **kw)
    assert got.dtype == np.uint64
    np.testing.assert_array_equal(got, want)
    # the same rate as an exact fraction, and through the integer tracker (S-curves too)
    num, _, den = rate.partition("/")
    frac = Fraction(num) / Fraction(den or 1)
    np.testing.assert_array_equal(multistep.track(frac, duration, **kw), want)
    np.testing.assert_array_equal(multistep.track(rate, duration, integer=True, **kw), want)


def test_float_and_int_rates_are_their_exact_values(cli):
    # a float is its binary value: the command line given that value as a fraction agrees
    x = 31999.9
    f = Fraction(x)
    assert f.denominator & (f.denominator - 1) == 0 and f != Fraction("31999.9")
    a = multistep.track(x, 0.1, amax=1e5)
    np.testing.assert_array_equal(a, multistep.track(f, 0.1, amax=1e5))
    np.testing.assert_array_equal(
        a, cli_track(cli, f"{f.numerator}/{f.denominator}", 0.1, "--amax", 1e5)
    )
    np.testing.assert_array_equal(
        multistep.track(100, 1, amax=1e3), cli_track(cli, "100", 1, "--amax", 1e3)
    )


def test_refusals_are_the_cli_messages(cli):
    with pytest.raises(multistep.PlanError, match="needs amax"):
        multistep.track("10", 1)
    r = cli("plan", "--track", "abc", "--duration", "1", "--amax", "10", check=False)
    with pytest.raises(multistep.PlanError) as e:
        multistep.track("abc", 1, amax=10.0)
    assert str(e.value) in r.stderr
    with pytest.raises(multistep.PlanError, match="shorter than two clock ticks"):
        multistep.track("600000", 1, amax=1e6, clock=1e6)
    with pytest.raises(multistep.PlanError, match="duration"):
        multistep.track("10", 0, amax=10.0)
    with pytest.raises(multistep.PlanError):
        multistep.track(Fraction(-1, 3), 1, amax=10.0)
    with pytest.raises(TypeError):
        multistep.track(True, 1, amax=10.0)
    with pytest.raises(TypeError):
        multistep.track([1], 1, amax=10.0)


def test_board_tracks_changes_rate_stops_and_releases(serve):
    with multistep.Board(serve.endpoint) as b:
        b.rate("sidereal", Fraction(15041, 324))
        assert any(l.startswith("sidereal ") and "15041/324" in l for l in b.rates())
        b.track("X", "sidereal", amax=2000.0)
        (st,) = b.status("X")
        assert st["state"] == "tracking"
        # another rate, backwards: through a controlled stop and on the other way
        b.track("X", Fraction(-1000, 3))
        (st,) = b.status("X")
        assert st["state"] in ("tracking", "moving")
        b.track("X", 0)
        b.wait("X", timeout=120)
        (st,) = b.status("X")
        assert st["state"] == "idle"
        b.release("X")
        (st,) = b.status("X")
        assert st["enabled"] is False
        b.energize("X")
        (st,) = b.status("X")
        assert st["enabled"] is True
        with pytest.raises(multistep.ProtocolError):
            b.track("X", "no_such_rate")
