"""A Board session against a real `multistep serve` process on 127.0.0.1."""

import pytest

import multistep


def test_move_wait_status_and_the_edges_of_plan(serve):
    with multistep.Board(serve.endpoint) as b:
        assert b.version().startswith("multistep-controller")
        info = b.info()
        assert float(info["clock_hz"]) == multistep.DEFAULT_CLOCK_HZ
        assert b.move("X", 3200) == ["X target=3200"]
        b.wait("X", timeout=120)
        (st,) = b.status("X")
        assert st["axis"] == "X" and st["position"] == 3200 and st["state"] == "idle"
        # the board timed the move with the same edges as plan (axis vmax/amax: limits mode)
        p = multistep.plan(steps=3200, vmax=float(b.get("X", "vmax")), amax=float(b.get("X", "amax")))
        assert st["move_end"] - st["move_start"] == p.last_edge_tick
        # phase mode, relative back to 0
        assert b.move("X", -3200, accel_time=0.5, cruise_time=0.5, decel_time=0.5) == ["X target=0"]
        b.wait()
        assert [s["position"] for s in b.status()] == [0, 0, 0, 0]


def test_every_protocol_word(serve):
    b = multistep.Board(serve.endpoint)
    assert b.get("X", "profile") == "trapezoid"
    settings = b.get("X")
    assert settings["vmax"] == b.get("X", "vmax") and "amax" in settings
    b.set("X", "steps_per_unit", 100)
    assert b.moveto("X", "12.5u") == ["X target=1250"]
    b.wait("X", timeout=120)
    lines = b.group({"X": 100, "Y": -100}, sync=True, profile="scurve", jmax=1e6)
    assert sorted(lines) == ["X target=1350", "Y target=-100"]
    b.wait("X", "Y", timeout=120)
    st = {s["axis"]: s for s in b.status("X", "Y")}
    assert st["X"]["move_end"] == st["Y"]["move_end"]
    assert b.save("park", "X", "Y") == ["park X=1350 Y=-100"]
    assert any(l.startswith("park ") for l in b.positions())
    b.group({"X": 0, "Y": 0}, absolute=True)
    b.wait(timeout=120)
    b.goto("park")
    b.wait(timeout=120)
    assert [s["position"] for s in b.status("X", "Y")] == [1350, -100]
    b.forget("park")
    assert not any(l.startswith("park ") for l in b.positions())
    b.preset("gentle", vmax=1000.0, amax=4000.0)
    assert any(l.startswith("gentle ") for l in b.presets())
    b.move("Y", 100, preset="gentle")
    b.wait("Y", timeout=120)
    b.home("Z")
    b.wait("Z", timeout=120)
    (z,) = b.status("Z")
    assert z["homed"] is True and z["trusted"] is True
    assert any("move AXIS" in l for l in b.raw("help"))
    b.close()
    with pytest.raises(multistep.BoardConnectionError):
        b.status()


def code_of(f, *a, **kw):
    with pytest.raises(multistep.ProtocolError) as e:
        f(*a, **kw)
    assert isinstance(e.value, multistep.MultistepError)
    assert str(e.value) == f"error:{e.value.code} {e.value.message}"
    return e.value.code


def test_refusals_carry_their_codes(serve):
    b = multistep.Board(serve.endpoint)
    assert code_of(b.raw, "frobnicate") == 3
    assert code_of(b.move, "Q", 10) == 4
    b.set("X", "soft_max", 1000)
    assert code_of(b.moveto, "X", 5000) == 5
    b.move("Y", 400000)
    assert code_of(b.move, "Y", 10) == 6
    b.stop("Y")
    b.wait("Y", timeout=120)
    assert code_of(b.move, "X", 10, accel_time=-1.0) == 7
    assert code_of(b.move, "X", 10, preset="nope") == 8
    assert code_of(b.set, "X", "bogus", 1) == 9
    assert code_of(b.move, "Z", 40000, vmax=1e5) == 14
    b.estop()
    assert code_of(b.move, "X", 10) == 11
    b.reset()
    b.move("X", 10)
    b.wait("X", timeout=120)
    # the connection stays usable after every refusal
    assert b.status("X")[0]["position"] == 10


def test_client_side_errors(serve):
    b = multistep.Board(serve.endpoint)
    with pytest.raises(multistep.BoardError, match="not one protocol word"):
        b.set("X", "profile", "a b")
    with pytest.raises(multistep.BoardError, match="not one protocol word"):
        b.move("X a", 10)
    with pytest.raises(TypeError):
        b.move("X", 1.5)
    with pytest.raises(TypeError):
        b.move("X", 10, velocity=3)
    with pytest.raises(ValueError):
        b.move("X", "ten")
    for bad in (float("nan"), -1.0):
        with pytest.raises(ValueError):
            b.wait("X", timeout=bad)
    b.wait("X", timeout=float("inf"))
    b.wait("X", timeout=1e300)
    b.move("Y", 400000)
    with pytest.raises(multistep.BoardError, match="timed out"):
        b.wait("Y", timeout=0.05)
    b.stop()
    b.wait(timeout=120)
    assert b.status("X")[0]["position"] == 0


def test_two_sessions_see_one_board(serve):
    a = multistep.Board(serve.endpoint)
    c = multistep.Board(serve.endpoint)
    a.move("A", 500)
    c.wait("A", timeout=120)
    assert c.status("A")[0]["position"] == 500
    assert repr(a) == f"Board('{serve.endpoint}')"


class PtyLink:
    """Two pseudo-terminals joined back to back (what a null-modem cable is to two serial
    ports): the board opens one by name, the Board client the other."""

    def __init__(self):
        import os
        import threading
        import tty

        self.os = os
        self.pairs = [os.openpty(), os.openpty()]
        for _, slave in self.pairs:
            tty.setraw(slave)
        self.names = [os.ttyname(s) for _, s in self.pairs]
        self.running = True
        self.thread = threading.Thread(target=self._relay, daemon=True)
        self.thread.start()

    def _relay(self):
        import select

        (a, _), (b, _) = self.pairs
        other = {a: b, b: a}
        while self.running:
            ready, _, _ = select.select([a, b], [], [], 0.05)
            for fd in ready:
                try:
                    data = self.os.read(fd, 4096)
                except OSError:
                    continue
                self.os.write(other[fd], data)

    def close(self):
        self.running = False
        self.thread.join(timeout=5)
        for m, s in self.pairs:
            self.os.close(m)
            self.os.close(s)


def wait_until_open(pid, device, timeout=30.0):
    """Waits until process `pid` has `device` open (the board opens its serial line on a
    thread of its own, after it prints its address)."""
    import os
    import time

    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        fds = f"/proc/{pid}/fd"
        for fd in os.listdir(fds):
            try:
                if os.readlink(f"{fds}/{fd}") == device:
                    return
            except OSError:
                pass
        time.sleep(0.02)
    raise AssertionError(f"the board did not open {device}")


def test_serial_session(cli, tmp_path):
    from conftest import Serve

    link = PtyLink()
    board_side, host_side = link.names
    s = Serve(cli.exe, tmp_path / "board", "--time-scale", "20", "--serial", board_side)
    try:
        wait_until_open(s.proc.pid, board_side)
        b = multistep.Board(f"serial:{host_side}")
        assert b.version().startswith("multistep-controller")
        assert b.move("X", 800) == ["X target=800"]
        b.wait("X", timeout=120)
        assert b.status("X")[0]["position"] == 800
        assert code_of(b.move, "Q", 1) == 4
        b.close()
    finally:
        s.stop()
        link.close()


def test_random_bad_arguments_never_break_the_session(serve):
    import math
    import random

    r = random.Random(7)
    b = multistep.Board(serve.endpoint)
    values = [None, 0, -1, 2**63, 2**64, 1.5, math.nan, math.inf, "", " ", "X", "Q", "a b",
              "#", "12.5u", "nanu", "x" * 5000, b"X", [], {}, {"X": 1}, {"X": "1e400u"},
              {"X": None}, True, object(), 10**400, -(10**400)]
    methods = ["move", "moveto", "group", "home", "stop", "status", "get", "set", "save",
               "goto", "forget", "preset", "sim_slip", "raw", "track", "rate"]
    keys = ["preset", "profile", "vmax", "amax", "accel_time", "phi", "lease", "bogus"]
    ok = (TypeError, ValueError, multistep.MultistepError)
    for _ in range(400):
        name = r.choice(methods)
        args = [r.choice(values) for _ in range(r.randint(0, 3))]
        kw = {k: r.choice(values) for k in r.sample(keys, r.randint(0, 2))}
        try:
            getattr(b, name)(*args, **kw)
        except ok:
            pass
    # still one working session
    b.estop()
    b.reset()
    assert b.version().startswith("multistep-controller")
    assert len(b.status()) == 4
