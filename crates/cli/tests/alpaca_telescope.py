"""alpyca drives the Telescope of a running `multistep serve --alpaca` and checks it
against ITelescopeV4 as docs/ALPACA.md writes it down.

Run by crates/cli/tests/alpaca_telescope.rs:
    python3 alpaca_telescope.py first|restart ALPACA_HOST:PORT LINE_PROTOCOL_HOST:PORT TOKEN

`first` checks every member and ends parked, printing where it points; `restart` (a new
serve on the same data, given that line's numbers) checks the mount is still parked,
points there (the sync offsets were kept) and reads the host's clock again, and unparks. Every check is counted; the run prints
"telescope: N checks, F failures" and exits non-zero when F > 0.
"""

import json
import math
import socket
import sys
import time
from datetime import datetime, timezone

from alpaca.exceptions import (
    InvalidOperationException,
    InvalidValueException,
    NotConnectedException,
    NotImplementedException,
    ParkedException,
    ValueNotSetException,
)
from alpaca.telescope import (
    AlignmentModes,
    DriveRates,
    EquatorialCoordinateType,
    GuideDirections,
    PierSide,
    Telescope,
    TelescopeAxes,
)

mode, addr, tcp, token = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
host, port = tcp.rsplit(":", 1)
line = socket.create_connection((host, int(port)), timeout=10)
replies = line.makefile("r")

# The mount of alpaca_telescope.rs's board config.
LAT, LON, ELEV = 52.0, 4.5, 12.0
SPR = 360_000  # microsteps per turn of both axes
SIDEREAL = 15.041067  # arcsec/s
STEPS_PER_ARCSEC = SPR / 1_296_000
DEADLINE = 120.0

checks = 0
failures = []


def check(ok, what):
    global checks
    checks += 1
    if not ok:
        failures.append(what)
        print(f"  FAIL {what}")


def expect(exc, f, what, says=""):
    try:
        f()
    except exc as e:
        check(says in e.message, f"{what}: says '{says}'")
        print(f"  {what}: {type(e).__name__} 0x{e.number:X} {e.message}")
        return
    except Exception as e:  # noqa: BLE001 - any other outcome is a failed check
        check(False, f"{what}: {type(e).__name__} {e}")
        return
    check(False, f"{what}: no {exc.__name__}")


def protocol(cmd):
    line.sendall((cmd + "\n").encode())
    out = []
    while True:
        r = replies.readline().strip()
        if r == "ok":
            return out
        if r.startswith("error"):
            raise AssertionError(f"{cmd}: {r}")
        out.append(r)


def axis(name):
    (reply,) = protocol(f"status json {name}")
    return json.loads(reply)[0]


def poll(cond, what):
    """Waits for cond() with a generous deadline; a check either way."""
    t0 = time.monotonic()
    while not cond():
        if time.monotonic() - t0 > DEADLINE:
            check(False, f"{what} (not within {DEADLINE} s)")
            return False
        time.sleep(0.02)
    check(True, what)
    return True


def lst_hours():
    """IAU 1982 GMST (Meeus eq. 12.4) plus the east longitude."""
    jd = time.time() / 86400.0 + 2440587.5
    d = jd - 2451545.0
    t = d / 36525.0
    th = 280.46061837 + 360.98564736629 * d + 0.000387933 * t * t - t**3 / 38710000.0
    return ((th + LON) % 360.0) / 15.0


def hours_apart(a, b):
    return abs((a - b + 12.0) % 24.0 - 12.0)


def sky_target(ha_deg, dec):
    return ((lst_hours() - ha_deg / 15.0) % 24.0, dec)


def slew_and_wait(t, ha_deg, dec, what):
    ra, dec = sky_target(ha_deg, dec)
    t.SlewToCoordinatesAsync(ra, dec)
    check(t.Slewing, f"{what}: Slewing right after SlewToCoordinatesAsync")
    poll(lambda: not t.Slewing, f"{what}: the slew ends")
    # One step is 3.6"; the catch-up move and a tick of tracking leave well under 30".
    check(hours_apart(t.RightAscension, ra) * 15 * 3600 < 30,
          f"{what}: RightAscension {t.RightAscension} ~ {ra}")
    check(abs(t.Declination - dec) * 3600 < 30, f"{what}: Declination {t.Declination} ~ {dec}")
    return ra, dec


def speed(name, want, tol, what):
    tol = max(tol, 1e-6 * abs(want))
    poll(lambda: abs(axis(name)["speed"] - want) <= tol,
         f"{what}: {name} at {want:.4f} steps/s")


def first(t):
    expect(NotConnectedException, lambda: t.Tracking, "unconnected: Tracking")
    t.Connected = True
    check(t.Connected, "Connected")
    check(t.InterfaceVersion == 4, "InterfaceVersion 4")
    check(t.Name == "Mount", "Name")
    check("Telescope" in t.Description, "Description")
    check(t.DriverVersion != "", "DriverVersion")
    check(t.SupportedActions == [], "SupportedActions empty")
    # Capabilities as docs/ALPACA.md lists them.
    for name, want in [
        ("CanFindHome", True), ("CanPark", True), ("CanPulseGuide", True),
        ("CanSetDeclinationRate", True), ("CanSetGuideRates", True), ("CanSetPark", True),
        ("CanSetPierSide", True), ("CanSetRightAscensionRate", True),
        ("CanSetTracking", True), ("CanSlew", False), ("CanSlewAltAz", True),
        ("CanSlewAltAzAsync", True), ("CanSlewAsync", True), ("CanSync", True),
        ("CanSyncAltAz", True), ("CanUnpark", True), ("DoesRefraction", False),
    ]:
        check(getattr(t, name) == want, f"{name} is {want}")
    check(t.AlignmentMode == AlignmentModes.algGermanPolar, "AlignmentMode German polar")
    check(t.EquatorialSystem == EquatorialCoordinateType.equTopocentric,
          "EquatorialSystem topocentric")
    for name in ["ApertureArea", "ApertureDiameter", "FocalLength"]:
        expect(NotImplementedException, lambda n=name: getattr(t, n), name)
    expect(NotImplementedException, lambda: setattr(t, "DoesRefraction", True),
           "DoesRefraction = True")
    # alpyca refuses the synchronous slews itself; sent raw, the server answers 0x400.
    for method, args in [
        ("slewtocoordinates", {"RightAscension": 1.0, "Declination": 10.0}),
        ("slewtotarget", {}),
    ]:
        expect(NotImplementedException, lambda m=method, a=args: t._put(m, **a), method)

    # Site and time.
    check((t.SiteLatitude, t.SiteLongitude, t.SiteElevation) == (LAT, LON, ELEV), "site")
    expect(InvalidValueException, lambda: setattr(t, "SiteLatitude", 91.0), "SiteLatitude 91")
    expect(InvalidValueException, lambda: setattr(t, "SiteLongitude", -181.0),
           "SiteLongitude -181")
    t.SiteElevation = 20.0
    check(t.SiteElevation == 20.0, "SiteElevation set")
    t.SiteElevation = ELEV
    utc = t.UTCDate
    check(abs((utc - datetime.now(timezone.utc)).total_seconds()) < 5, f"UTCDate {utc}")
    check(hours_apart(t.SiderealTime, lst_hours()) < 1e-4,
          f"SiderealTime {t.SiderealTime} is the IAU LST {lst_hours()}")

    # Rates.
    check(list(t.TrackingRates) == [0, 1, 2, 3], f"TrackingRates {list(t.TrackingRates)}")
    check(t.TrackingRate == DriveRates.driveSidereal, "TrackingRate sidereal at start")
    t.TrackingRate = DriveRates.driveKing
    check(t.TrackingRate == DriveRates.driveKing, "TrackingRate King")
    expect(InvalidValueException, lambda: t._put("trackingrate", TrackingRate=7), "TrackingRate 7")
    t.TrackingRate = DriveRates.driveSidereal
    half = 0.5 * SIDEREAL / 3600
    check(abs(t.GuideRateRightAscension - half) < 1e-12, "GuideRateRightAscension default")
    check(abs(t.GuideRateDeclination - half) < 1e-12, "GuideRateDeclination default")
    expect(InvalidValueException, lambda: setattr(t, "GuideRateDeclination", 0.01),
           "GuideRateDeclination above sidereal")
    expect(InvalidValueException, lambda: setattr(t, "GuideRateRightAscension", 0.0),
           "GuideRateRightAscension 0")
    check(t.SlewSettleTime == 0, "SlewSettleTime 0")
    t.SlewSettleTime = 2
    check(t.SlewSettleTime == 2, "SlewSettleTime set")
    expect(InvalidValueException, lambda: setattr(t, "SlewSettleTime", -1), "SlewSettleTime -1")
    t.SlewSettleTime = 0

    # At start both axes are at count 0: the home pose, looking at the pole.
    check(abs(t.Declination - 90.0) < 1e-9, "the home pose looks at the pole")
    check(abs(t.Altitude - LAT) < 1e-6 and min(t.Azimuth, 360 - t.Azimuth) < 1e-6,
          "the pole is at the latitude's altitude, due north")
    expect(ValueNotSetException, lambda: t.TargetRightAscension, "TargetRightAscension unset")
    expect(ValueNotSetException, lambda: t.TargetDeclination, "TargetDeclination unset")
    expect(ValueNotSetException, lambda: t.SlewToTargetAsync(), "SlewToTargetAsync unset")

    # Altitude and azimuth, with tracking off (so the point stays put).
    alt_az(t)

    # Tracking.
    check(not t.Tracking, "Tracking off at start")
    expect(InvalidOperationException, lambda: t.SlewToCoordinatesAsync(1.0, 10.0),
           "a slew with tracking off")
    expect(InvalidOperationException, lambda: t.SyncToCoordinates(1.0, 10.0),
           "a sync with tracking off")
    t.Tracking = True
    check(t.Tracking, "Tracking on")
    sid = SIDEREAL * STEPS_PER_ARCSEC
    speed("ha", sid, 1e-6, "sidereal tracking")
    check(axis("ha")["state"] == "tracking", "the polar axis tracks")

    # Slews, both sides of the pier.
    ra, dec = sky_target(30.0, 20.0)
    check(t.DestinationSideOfPier(ra, dec) == PierSide.pierEast, "DestinationSideOfPier east")
    ra_w, dec_w = sky_target(-30.0, 20.0)
    check(t.DestinationSideOfPier(ra_w, dec_w) == PierSide.pierWest,
          "DestinationSideOfPier west")
    ra, dec = slew_and_wait(t, 30.0, 20.0, "slew west of the meridian")
    check(t.SideOfPier == PierSide.pierEast, "SideOfPier east after it")
    check(abs(t.TargetRightAscension - ra) < 1e-12 and t.TargetDeclination == dec,
          "Target* are the slew's")
    alt = math.degrees(math.asin(
        math.sin(math.radians(LAT)) * math.sin(math.radians(dec))
        + math.cos(math.radians(LAT)) * math.cos(math.radians(dec)) * math.cos(math.radians(30.0))))
    check(abs(t.Altitude - alt) < 0.02, f"Altitude {t.Altitude} ~ {alt}")
    check(180.0 < t.Azimuth < 270.0, f"Azimuth {t.Azimuth} is south-west")
    speed("ha", sid, 1e-6, "tracking resumes after the slew")
    p0 = axis("ha")["position"]
    r0 = t.RightAscension
    poll(lambda: axis("ha")["position"] >= p0 + 20, "the polar axis tracks on")
    check(hours_apart(t.RightAscension, r0) * 54000 < 8, "RightAscension holds while tracking")
    slew_and_wait(t, -30.0, 20.0, "slew east of the meridian")
    check(t.SideOfPier == PierSide.pierWest, "SideOfPier west after it")
    t.TargetRightAscension, t.TargetDeclination = sky_target(-20.0, 45.0)
    t.SlewToTargetAsync()
    poll(lambda: not t.Slewing, "SlewToTargetAsync ends")
    check(abs(t.Declination - 45.0) * 3600 < 30, "SlewToTargetAsync reaches its Dec")

    # Refusals.
    expect(InvalidValueException, lambda: t.SlewToCoordinatesAsync(24.0, 0.0), "RA 24")
    expect(InvalidValueException, lambda: t.SlewToCoordinatesAsync(1.0, 90.5), "Dec 90.5")
    expect(InvalidValueException, lambda: setattr(t, "TargetDeclination", -91.0),
           "TargetDeclination -91")
    expect(InvalidValueException, lambda: t.SlewToCoordinatesAsync(*sky_target(20.0, -60.0)),
           "a slew below the horizon", "horizon")
    expect(InvalidValueException, lambda: t.SlewToCoordinatesAsync(*sky_target(175.0, 80.0)),
           "a slew beyond ha_limit", "ha_limit")
    check(not t.Slewing, "a refused slew does not move")

    # Sync.
    ra, dec = t.RightAscension, t.Declination
    t.SyncToCoordinates((ra + 0.01) % 24, dec - 0.1)
    check(hours_apart(t.RightAscension, ra + 0.01) * 54000 < 8
          and abs(t.Declination - (dec - 0.1)) * 3600 < 8, "SyncToCoordinates")
    t.TargetRightAscension, t.TargetDeclination = ra, dec
    t.SyncToTarget()
    check(hours_apart(t.RightAscension, ra) * 54000 < 8
          and abs(t.Declination - dec) * 3600 < 8, "SyncToTarget")

    # Rate offsets: RightAscensionRate in RA seconds per sidereal second, DeclinationRate ″/s.
    t.RightAscensionRate = 0.1
    check(t.RightAscensionRate == 0.1, "RightAscensionRate set")
    speed("ha", (SIDEREAL - 0.1 * 15 / 0.9972695663) * STEPS_PER_ARCSEC, 1e-6,
          "RightAscensionRate slows the polar axis")
    t.RightAscensionRate = 0.0
    t.DeclinationRate = 10.0
    check(t.DeclinationRate == 10.0, "DeclinationRate set")
    # Pier west: the dec axis turns with declination.
    speed("dec", 10.0 * STEPS_PER_ARCSEC, 1e-6, "DeclinationRate turns the dec axis")
    expect(InvalidValueException, lambda: setattr(t, "DeclinationRate", 20.0),
           "DeclinationRate beyond sidereal")
    t.DeclinationRate = 0.0
    poll(lambda: axis("dec")["state"] == "idle", "the dec axis rests again")

    # Pulse guiding at the sidereal rate; 5 s pulses leave a loaded machine time to see them.
    t.GuideRateRightAscension = SIDEREAL / 3600
    t.GuideRateDeclination = SIDEREAL / 3600
    check(abs(t.GuideRateRightAscension - SIDEREAL / 3600) < 1e-12, "GuideRateRightAscension set")
    t.PulseGuide(GuideDirections.guideWest, 5000)
    check(t.IsPulseGuiding, "IsPulseGuiding during a west pulse")
    speed("ha", 2 * sid, 1e-6, "a west pulse doubles the polar rate")
    poll(lambda: not t.IsPulseGuiding, "the west pulse ends")
    speed("ha", sid, 1e-6, "sidereal again after it")
    t.PulseGuide(GuideDirections.guideEast, 5000)
    speed("ha", 0.0, 1e-6, "an east pulse holds the polar axis")
    poll(lambda: not t.IsPulseGuiding, "the east pulse ends")
    speed("ha", sid, 1e-6, "sidereal after the east pulse")
    t.PulseGuide(GuideDirections.guideNorth, 5000)
    speed("dec", sid, 1e-6, "a north pulse turns the dec axis (pier west: with Dec)")
    poll(lambda: not t.IsPulseGuiding, "the north pulse ends")
    poll(lambda: axis("dec")["state"] == "idle", "the dec axis rests after the pulse")
    expect(InvalidValueException, lambda: t._put("pulseguide", Direction=7, Duration=100),
           "PulseGuide direction 7")
    expect(InvalidValueException, lambda: t.PulseGuide(GuideDirections.guideSouth, -1),
           "PulseGuide -1 ms")

    # MoveAxis.
    check(t.CanMoveAxis(TelescopeAxes.axisPrimary) and t.CanMoveAxis(TelescopeAxes.axisSecondary)
          and not t.CanMoveAxis(TelescopeAxes.axisTertiary), "CanMoveAxis 0, 1, not 2")
    rates = t.AxisRates(TelescopeAxes.axisPrimary)
    check(len(rates) == 1 and rates[0].Minimum == 0.0 and abs(rates[0].Maximum - 40.0) < 1e-9,
          "AxisRates(primary) 0 to 40 deg/s")
    check(t.AxisRates(TelescopeAxes.axisTertiary) == [], "AxisRates(tertiary) empty")
    expect(InvalidValueException, lambda: t.MoveAxis(TelescopeAxes.axisPrimary, 41.0),
           "MoveAxis beyond AxisRates")
    expect(InvalidValueException, lambda: t.MoveAxis(TelescopeAxes.axisTertiary, 1.0),
           "MoveAxis tertiary")
    t.MoveAxis(TelescopeAxes.axisSecondary, -2.0)
    check(t.Slewing, "Slewing during MoveAxis")
    speed("dec", -2.0 * 3600 * STEPS_PER_ARCSEC, 1e-6, "MoveAxis(secondary, -2)")
    t.MoveAxis(TelescopeAxes.axisSecondary, 0.0)
    check(not t.Slewing, "MoveAxis 0 ends it")
    poll(lambda: axis("dec")["state"] == "idle", "the dec axis stops after MoveAxis")
    check(t.Tracking and axis("ha")["state"] == "tracking", "tracking went on throughout")

    # AbortSlew.
    t.SlewToCoordinatesAsync(*sky_target(40.0, 60.0))
    t.AbortSlew()
    poll(lambda: not t.Slewing, "AbortSlew ends the slew")
    check(t.Tracking, "tracking stays on after AbortSlew")
    speed("ha", sid, 1e-6, "tracking resumes after AbortSlew")

    # FindHome: Hall homing of both axes.
    t.FindHome()
    poll(lambda: not t.Slewing, "FindHome ends")
    check(t.AtHome, "AtHome after FindHome")
    check(not t.Tracking, "FindHome turns tracking off")
    check(axis("ha")["homed"] and axis("dec")["homed"], "both axes homed")

    # SetPark with the axes at rest, then Park from elsewhere.
    t.Tracking = True
    slew_and_wait(t, 20.0, 50.0, "slew to the park pose")
    t.Tracking = False
    poll(lambda: axis("ha")["state"] == "idle", "the axes rest before SetPark")
    t.SetPark()
    park = (axis("ha")["position"], axis("dec")["position"])
    t.Tracking = True
    slew_and_wait(t, -40.0, 10.0, "slew away from it")
    check(not t.AtHome, "AtHome false away from home")
    t.Park()
    poll(lambda: not t.Slewing, "Park ends")
    check(t.AtPark, "AtPark after Park")
    check(not t.Tracking, "Park turns tracking off")
    check((axis("ha")["position"], axis("dec")["position"]) == park, "at the set park position")
    parked_refusals(t)
    state = {d["Name"]: d["Value"] for d in t.DeviceState}
    check(state.get("AtPark") is True and "RightAscension" in state and "Tracking" in state,
          f"DeviceState {sorted(state)}")
    t.Park()
    check(t.AtPark, "Park when parked is no error")
    utc_date(t)
    return park


def alt_az(t):
    for alt, az, what, says in [
        (91.0, 100.0, "SlewToAltAzAsync altitude 91", "altitude"),
        (45.0, 360.0, "SlewToAltAzAsync azimuth 360", "azimuth"),
        (-5.0, 250.0, "SlewToAltAzAsync below the horizon", "horizon"),
    ]:
        expect(InvalidValueException, lambda a=alt, z=az: t.SlewToAltAzAsync(z, a), what, says)
    # West of the meridian, 40 degrees up: pier east.
    t.SlewToAltAzAsync(200.0, 40.0)
    check(t.Slewing, "Slewing right after SlewToAltAzAsync")
    poll(lambda: not t.Slewing, "the alt-az slew ends")
    # One step is 3.6"; Az spreads by 1/cos(Alt).
    check(abs(t.Altitude - 40.0) * 3600 < 8, f"Altitude {t.Altitude} ~ 40")
    check(abs(t.Azimuth - 200.0) * 3600 < 12, f"Azimuth {t.Azimuth} ~ 200")
    check(t.SideOfPier == PierSide.pierEast, "SideOfPier east after the alt-az slew")
    check(not t.Tracking, "tracking stays off")
    # Synchronous (alpyca refuses to send it; sent raw): it returns once there.
    t._put("slewtoaltaz", tmo=DEADLINE, Azimuth=150.0, Altitude=30.0)
    check(not t.Slewing, "SlewToAltAz returns once the slew ends")
    check(abs(t.Altitude - 30.0) * 3600 < 8 and abs(t.Azimuth - 150.0) * 3600 < 12,
          f"SlewToAltAz reaches 30/150: {t.Altitude} {t.Azimuth}")
    check(t.SideOfPier == PierSide.pierWest, "SideOfPier west east of the meridian")
    # A pier flip: already west is no move; east would put the polar axis past ha_limit.
    t.SideOfPier = PierSide.pierWest
    check(not t.Slewing, "SideOfPier set to the side it is on moves nothing")
    expect(InvalidValueException, lambda: setattr(t, "SideOfPier", PierSide.pierEast),
           "a pier flip beyond ha_limit", "ha_limit")
    expect(InvalidValueException, lambda: t._put("sideofpier", SideOfPier=2), "SideOfPier 2")
    # Sync 0.5 degrees higher: the axes stay, the reading moves (and is kept: see restart).
    ha_pos = axis("ha")["position"]
    t.SyncToAltAz(150.0, 30.5)
    check(abs(t.Altitude - 30.5) < 1e-6 and abs(t.Azimuth - 150.0) < 1e-6,
          f"SyncToAltAz: {t.Altitude} {t.Azimuth}")
    check(axis("ha")["position"] == ha_pos, "SyncToAltAz moves nothing")
    expect(InvalidValueException, lambda: t.SyncToAltAz(10.0, -91.0), "SyncToAltAz altitude -91")
    t.Tracking = True
    expect(InvalidOperationException, lambda: t.SlewToAltAzAsync(150.0, 30.0),
           "SlewToAltAzAsync while tracking")
    expect(InvalidOperationException, lambda: t.SyncToAltAz(150.0, 30.0),
           "SyncToAltAz while tracking")
    t.Tracking = False
    poll(lambda: axis("ha")["state"] == "idle", "the polar axis rests")


def utc_date(t):
    """UTCDate set: the mount's clock runs an hour ahead, and its sidereal time with it."""
    ahead = datetime.fromtimestamp(time.time() + 3600.0, timezone.utc)
    t.UTCDate = ahead
    check(abs((t.UTCDate - ahead).total_seconds()) < 5, f"UTCDate set to {ahead}: {t.UTCDate}")
    check(hours_apart(t.SiderealTime, lst_hours() + 1.0027379) < 1e-3,
          f"SiderealTime {t.SiderealTime} an hour (sidereal) ahead of {lst_hours()}")
    t.UTCDate = "2026-06-01T12:00:00.5Z"
    check(t.UTCDate == datetime(2026, 6, 1, 12, 0, 0, 500000, timezone.utc)
          or abs((t.UTCDate - datetime(2026, 6, 1, 12, 0, 0, 500000, timezone.utc))
                 .total_seconds()) < 5, f"UTCDate as text: {t.UTCDate}")
    for bad in ["2026-06-01 12:00:00Z", "2026-06-01T12:00:00", "2026-02-30T00:00:00Z"]:
        expect(InvalidValueException, lambda b=bad: setattr(t, "UTCDate", b), f"UTCDate {bad}")
    t.UTCDate = ahead


def parked_refusals(t):
    expect(ParkedException, lambda: setattr(t, "Tracking", True), "Tracking on while parked")
    expect(ParkedException, lambda: t.SlewToCoordinatesAsync(1.0, 10.0), "a slew while parked")
    expect(ParkedException, lambda: t.PulseGuide(GuideDirections.guideNorth, 100),
           "PulseGuide while parked")
    expect(ParkedException, lambda: t.MoveAxis(TelescopeAxes.axisPrimary, 1.0),
           "MoveAxis while parked")
    expect(ParkedException, lambda: t.FindHome(), "FindHome while parked")


def pointing(t):
    """Declination and hour angle (degrees) by the mount's own clock."""
    return t.Declination, ((t.SiderealTime - t.RightAscension + 12.0) % 24.0 - 12.0) * 15.0


def restart(t, dec0, ha0):
    t.Connected = True
    check(t.AtPark, "still parked after the restart")
    check(not t.Tracking, "not tracking after the restart")
    dec, ha = pointing(t)
    check(abs(dec - dec0) < 1e-6 and abs(ha - ha0) * 3600 < 1,
          f"the sync offsets are kept: Dec {dec} HA {ha} (before: {dec0} {ha0})")
    utc = t.UTCDate
    check(abs((utc - datetime.now(timezone.utc)).total_seconds()) < 5,
          f"UTCDate is the host's again: {utc}")
    parked_refusals(t)
    t.Unpark()
    check(not t.AtPark, "Unpark")
    t.Tracking = True
    check(t.Tracking, "tracking after Unpark")
    t.Tracking = False


t = Telescope(f"alpyca:{token}@{addr}", 0)
if mode == "first":
    park = first(t)
    print(f"park position {park[0]} {park[1]}")
    dec0, ha0 = pointing(t)
    print(f"pointing {dec0!r} {ha0!r}")
else:
    restart(t, float(sys.argv[5]), float(sys.argv[6]))
t.Connected = False
print(f"telescope: {checks} checks, {len(failures)} failures")
for f in failures:
    print(f"  failed: {f}")
sys.exit(1 if failures else 0)
