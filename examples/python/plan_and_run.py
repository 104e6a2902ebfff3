"""Plan a move, plot its velocity from the exact periods, and run it on a board.

    multistep serve --data /tmp/board &        # prints: board board listening on tcp://127.0.0.1:7878
    python examples/python/plan_and_run.py tcp://127.0.0.1:7878

The plot (velocity.png) needs matplotlib; without it the script skips the plot.
"""

import sys

import numpy as np

import multistep

endpoint = sys.argv[1] if len(sys.argv) > 1 else "tcp://127.0.0.1:7878"

# A 4th-order S-curve in limits mode: 20 000 microsteps under the axis's limits.
move = dict(profile="scurve4", vmax=4000.0, amax=20000.0, jmax=2e5, smax=5e6)
plan = multistep.plan(steps=20000, **move)
s = plan.summary
print(f"{plan.mode}: {plan.steps} steps in {plan.duration_s:.4f} s, "
      f"peak {s['peak_speed_steps_per_s']:.1f} steps/s, periods "
      f"{s['min_period_ticks']}..{s['max_period_ticks']} ticks")

# Velocity from the periods: one step per period, at the midpoint between its edges.
clock = plan.clock_hz
edges = plan.edges.astype(np.float64)
periods = plan.periods.astype(np.float64)
t_mid = (edges - periods / 2) / clock
speed = clock / periods  # steps/s

try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("matplotlib is not installed: no plot")
else:
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(t_mid, speed, lw=0.8, label="from the edge periods")
    t = np.linspace(0, plan.duration_s, 2000)
    ax.plot(t, [plan.velocity(x) for x in t], "--", lw=0.8, label="profile v(t)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("speed (steps/s)")
    ax.set_title(plan.mode)
    ax.legend()
    fig.savefig("velocity.png", dpi=120)
    print("wrote velocity.png")

# The same move on the board; its edges there are these edges, shifted to its start tick.
with multistep.Board(endpoint) as board:
    start = board.status("X")[0]["position"]
    print(board.move("X", plan.steps, **move)[0])
    board.wait("X", timeout=60)
    (x,) = board.status("X")
    assert x["position"] == start + plan.steps
    ticks = x["move_end"] - x["move_start"]
    print(f"X at {x['position']}, the move took {ticks} ticks (plan: {plan.last_edge_tick})")
    try:
        board.move("W", 100)  # the default board has axes X, Y, Z and A
    except multistep.ProtocolError as e:
        print(f"refused with code {e.code}: {e.message}")
