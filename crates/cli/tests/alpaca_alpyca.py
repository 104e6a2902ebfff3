"""alpyca, the ASCOM Initiative's Python client, drives a running `multistep serve --alpaca`.

Run by crates/cli/tests/alpaca.rs:
    python3 alpaca_alpyca.py ALPACA_HOST:PORT DISCOVERY_PORT LINE_PROTOCOL_HOST:PORT TOKEN

Checks discovery, the management API, Focuser move and halt, Rotator MoveAbsolute across
the wrap, FilterWheel change by slot and the error numbers of bad values; positions are
compared with the line protocol's `status` for the same axis. Exits non-zero on the first
failed check.
"""

import json
import socket
import sys
import time

import ifaddr
import alpaca.discovery as discovery
from alpaca import management
from alpaca.exceptions import (
    InvalidOperationException,
    InvalidValueException,
    NotConnectedException,
    NotImplementedException,
)
from alpaca.filterwheel import FilterWheel
from alpaca.focuser import Focuser
from alpaca.rotator import Rotator

addr, discovery_port, tcp, token = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
# The server wants the token: alpyca carries it as HTTP Basic credentials in the address.
server = f"alpyca:{token}@{addr}"
host, port = tcp.rsplit(":", 1)
line = socket.create_connection((host, int(port)), timeout=10)
replies = line.makefile("r")


def protocol(cmd):
    """One line-protocol command; the reply's lines (the protocol ends a reply with 'ok')."""
    line.sendall((cmd + "\n").encode())
    out = []
    while True:
        r = replies.readline().strip()
        if r == "ok":
            return out
        if r.startswith("error"):
            raise AssertionError(f"{cmd}: {r}")
        out.append(r)


def status(axis):
    """`status AXIS` as a dict: pos, units, state, ..."""
    (reply,) = protocol(f"status {axis}")
    return dict(kv.split("=", 1) for kv in reply.split()[1:])


def expect(exc, f, what):
    try:
        f()
    except exc as e:
        print(f"  {what}: {type(e).__name__} 0x{e.number:X} {e.message}")
        return
    raise AssertionError(f"{what}: no {exc.__name__}")


def wait(dev, what, limit=60.0):
    t0 = time.monotonic()
    while dev.IsMoving:
        assert time.monotonic() - t0 < limit, f"{what} still moving"
        time.sleep(0.02)


# --- discovery: alpyca broadcasts on every IPv4 adapter; keep it to loopback so that no
# datagram leaves this machine, and send to the server's discovery port.
all_adapters = ifaddr.get_adapters
discovery.ifaddr.get_adapters = lambda *a, **k: [
    ad for ad in all_adapters(*a, **k)
    if any(ip.is_IPv4 and ip.ip.startswith("127.") for ip in ad.ips)
]
discovery.port = discovery_port
found = discovery.search_ipv4(numquery=1, timeout=1)
print("discovery:", found)
assert addr in found, found

# --- management API
try:
    management.apiversions(addr)
    refused = None
except Exception as e:
    refused = e
assert refused is not None, "served without the token"
print("without the token:", type(refused).__name__, str(refused)[:60])
assert management.apiversions(server) == [1]
print("description:", management.description(server))
devices = management.configureddevices(server)
print("configured devices:", [(d["DeviceType"], d["DeviceNumber"], d["DeviceName"]) for d in devices])
assert [(d["DeviceType"], d["DeviceNumber"]) for d in devices] == [
    ("Focuser", 0), ("Rotator", 0), ("FilterWheel", 0)], devices

# --- Focuser
f = Focuser(server, 0)
expect(NotConnectedException, lambda: f.Position, "Position before connecting")
f.Connected = True
assert f.Connected
print(f"focuser: {f.Name!r} MaxStep={f.MaxStep} MaxIncrement={f.MaxIncrement} StepSize={f.StepSize}")
assert (f.Absolute, f.MaxStep, f.MaxIncrement, f.StepSize) == (True, 20000, 20000, 10.0)
assert (f.TempCompAvailable, f.TempComp) == (False, False)
expect(NotImplementedException, lambda: setattr(f, "TempComp", True), "TempComp = True")
expect(InvalidValueException, lambda: f.Move(20001), "Move(20001)")
expect(InvalidValueException, lambda: f.Move(-5), "Move(-5)")
f.Move(5000)
wait(f, "focuser")
assert f.Position == 5000 == int(status("F")["pos"]), (f.Position, status("F"))
# A long move: read alpyca, the line protocol, alpyca again; the move is monotone, so
# the protocol's position lies between the two reads.
f.Move(20000)
expect(InvalidOperationException, lambda: f.Move(100), "Move while moving")
for _ in range(5):
    a = f.Position
    s = int(status("F")["pos"])
    b = f.Position
    assert a <= s <= b, (a, s, b)
while f.Position == 5000:
    time.sleep(0.005)
f.Halt()
wait(f, "focuser halt")
p = f.Position
assert 5000 < p < 20000 and p == int(status("F")["pos"]), (p, status("F"))
print(f"focuser halted at {p} (line protocol: pos={status('F')['pos']})")
protocol("home F")
expect(InvalidOperationException, lambda: f.Move(100), "Move while homing")
protocol("estop")
expect(InvalidOperationException, lambda: f.Move(100), "Move during e-stop")
protocol("reset")

# --- Rotator: 350° → 10° takes the short way, up through 360°
r = Rotator(server, 0)
r.Connect()
assert r.Connected and not r.Connecting and r.CanReverse
expect(InvalidValueException, lambda: r.MoveAbsolute(360.0), "MoveAbsolute(360)")
expect(InvalidValueException, lambda: r.MoveMechanical(-1.0), "MoveMechanical(-1)")
r.MoveAbsolute(350.0)
wait(r, "rotator")
assert r.Position == 350.0 == float(status("R")["units"]), (r.Position, status("R"))
r.MoveAbsolute(10.0)
seen = []
while r.IsMoving:
    seen.append(r.Position)
    time.sleep(0.01)
assert all(x >= 349.999 or x <= 10.001 for x in seen), seen
assert r.Position == 10.0 == r.MechanicalPosition == float(status("R")["units"]), r.Position
# The DIR line of the move was high (counting up) and it ended on 10°: it went +20°, the
# short way, since a move never turns half a period or more.
(js,) = protocol("status json R")
assert json.loads(js)[0]["dir_level"] is True, js
print(f"rotator 350 -> 10: counted up (dir_level=1), {len(seen)} readings on the way, "
      f"all in [350, 360) or [0, 10]; Position={r.Position}")
r.Sync(100.0)
assert (r.Position, r.MechanicalPosition) == (100.0, 10.0)
r.Move(-20.0)
wait(r, "rotator")
assert (r.Position, r.MechanicalPosition, r.TargetPosition) == (80.0, 350.0, 80.0)
assert float(status("R")["units"]) == 350.0

# --- FilterWheel: slots are named positions
w = FilterWheel(server, 0)
w.Connected = True
print("filter wheel:", w.Names, w.FocusOffsets, "Position", w.Position)
assert w.Names == ["Ha", "CaK", "Hb"] and w.FocusOffsets == [12, -7, 0]
expect(InvalidValueException, lambda: setattr(w, "Position", 3), "Position = 3")
w.Position = 1
during = w.Position
if status("W")["state"] == "moving":   # still moving after the read: it was read mid-move
    assert during == -1, during
t0 = time.monotonic()
while w.Position == -1:
    assert time.monotonic() - t0 < 60
    time.sleep(0.02)
assert w.Position == 1 and int(status("W")["pos"]) == 2000
print(f"filter wheel: Position -1 while moving, then {w.Position} (line protocol: pos={status('W')['pos']})")

print("alpyca: all checks passed")
