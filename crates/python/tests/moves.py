"""Random moves of every family and mode, as keyword dicts for `multistep.plan` and as
the equivalent `multistep plan` flags."""

import random

FAMILIES = ["trapezoid", "parabolic", "exponential", "sine", "scurve", "scurve4"]
LIMIT_FAMILIES = ["trapezoid", "scurve", "scurve4"]
CLOCKS = [50e6, 50e6, 1e6, 12e6, 100e6]


def phase_move(family, seed):
    r = random.Random(f"phase-{family}-{seed}")
    kw = {"profile": family, "steps": r.randint(1, 20000)}
    times = [r.choice([0.0, r.uniform(1e-3, 0.3)]) for _ in range(3)]
    if sum(times) == 0:
        times[1] = r.uniform(1e-3, 0.3)
    kw["accel_time"], kw["cruise_time"], kw["decel_time"] = times
    if r.random() < 0.4:
        kw["start_speed"] = r.uniform(0, 2e4)
    if r.random() < 0.4:
        kw["end_speed"] = r.uniform(0, 2e4)
    if family == "exponential" and r.random() < 0.7:
        kw["rho"] = r.uniform(0.05, 1.0)
    if family in ("scurve", "scurve4") and r.random() < 0.7:
        kw["phi"] = r.uniform(0.05, 0.5)
    if family == "scurve4" and r.random() < 0.7:
        kw["psi"] = r.uniform(0.05, 0.5)
    kw["clock"] = r.choice(CLOCKS)
    return kw


def limits_move(family, seed):
    r = random.Random(f"limits-{family}-{seed}")
    kw = {
        "profile": family,
        "steps": r.randint(1, 20000),
        "vmax": r.uniform(1e3, 1e5),
        "amax": 10 ** r.uniform(4, 7),
    }
    if family in ("scurve", "scurve4"):
        kw["jmax"] = 10 ** r.uniform(6, 9)
    if family == "scurve4":
        kw["smax"] = 10 ** r.uniform(8, 12)
    if r.random() < 0.3:
        kw["start_speed"] = r.uniform(0, kw["vmax"])
    if r.random() < 0.3:
        kw["end_speed"] = r.uniform(0, kw["vmax"])
    kw["clock"] = r.choice(CLOCKS)
    return kw


def segment_move(seed):
    r = random.Random(f"segments-{seed}")
    segs = []
    for _ in range(r.randint(1, 5)):
        t = r.uniform(1e-3, 0.1)
        v0 = r.uniform(0, 2e4)
        # n ≥ v0·T/2 keeps the end speed 2n/T − v0 ≥ 0 (most of the time)
        n = r.randint(int(v0 * t / 2) + 1, int(v0 * t / 2) + 3000)
        segs.append((v0, t, n))
    return {"segments": segs, "clock": r.choice(CLOCKS)}


def all_moves():
    for fam in FAMILIES:
        for seed in range(8):
            yield f"phase-{fam}-{seed}", phase_move(fam, seed)
    for fam in LIMIT_FAMILIES:
        for seed in range(8):
            yield f"limits-{fam}-{seed}", limits_move(fam, seed)
    for seed in range(12):
        yield f"segments-{seed}", segment_move(seed)


def flags(kw):
    """The `multistep plan` flags of a keyword move."""
    out = []
    for k, v in kw.items():
        if k == "segments":
            for v0, t, n in v:
                out.append(f"--segment={v0!r}:{t!r}:{n}")
        else:
            out.append(f"--{k.replace('_', '-')}={v!r}" if isinstance(v, float) else f"--{k.replace('_', '-')}={v}")
    return out
