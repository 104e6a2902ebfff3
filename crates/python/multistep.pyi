"""multistep: exact step-edge timing for stepper motors.

Units throughout: steps are microsteps, times seconds (s), speeds steps/s, accelerations
steps/s², jerk steps/s³, snap steps/s⁴, edges and periods clock ticks at ``clock`` Hz.
"""

from __future__ import annotations

import os
from fractions import Fraction
from typing import Any, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, TypedDict, Union, final

import numpy as np
import numpy.typing as npt

__version__: str
#: Seed 000's clock, the default of every ``clock`` argument: 50 MHz.
DEFAULT_CLOCK_HZ: float
#: Motor names of the simulator's library ("57mm", "42mm", "20mm").
MOTORS: List[str]
#: Most edges one array holds (10⁸, 800 MB of uint64): ``Plan.edges``, ``Plan.periods``,
#: a chunk and ``track`` give no more and raise ``ValueError`` before making any beyond it;
#: longer moves stream through ``Plan.chunks``.
MAX_EDGES: int
#: Most trace rows one ``simulate(trace=True)`` returns (10⁷: eight float64 columns,
#: 640 MB); a longer trace raises ``ValueError`` before the run.
MAX_TRACE_ROWS: int
#: How long a ``Board`` call waits for the board's reply unless told otherwise: 10 s.
DEFAULT_TIMEOUT: float
#: Velocity-curve families: trapezoid, parabolic, exponential, sine, scurve, scurve4.
PROFILES: List[str]
#: A move's numeric keywords (times, speeds, limits, shape fractions), the same for
#: ``plan``, ``simulate`` and ``Board``'s moves: vmax, amax, jmax, smax, accel_time, …
MOVE_PARAMS: List[str]

class MultistepError(Exception):
    """Base class of every error multistep raises itself."""

class PlanError(MultistepError, ValueError):
    """A move that is malformed or cannot be done; the message is the command line's."""

class SimulationError(MultistepError, ValueError):
    """A bad motor, driver setting or simulation input."""

class BoardError(MultistepError):
    """A board session failed (fault while waiting, timeout, a word that is not one word)."""

class ProtocolError(BoardError):
    """The board answered ``error:<code> <message>``."""

    #: The protocol's stable error number (3 syntax, 4 unknown axis, 5 soft limits,
    #: 6 busy, 7 cannot plan, 8 unknown name, 9 setting, 11 e-stop, 14 too fast, …).
    code: int
    #: The board's message after the code.
    message: str

class BoardConnectionError(BoardError, ConnectionError):
    """The connection to the board failed or was closed."""

class BoardTimeoutError(BoardError, TimeoutError):
    """The board did not answer within the Board's ``timeout``, or the axes were not idle
    within ``wait``'s."""

# Typing only (not names of the module at run time): a segment, the summary dict and the
# trace dict.

#: One constant-acceleration segment (v0, T, n): start speed (steps/s), time (s), steps.
Segment = Tuple[float, float, int]

class PlanSummary(TypedDict):
    """The fields of ``multistep plan --format json`` (a plain dict at run time)."""

    mode: str
    steps: int
    clock_hz: float  # Hz
    duration_s: float  # s
    last_edge_tick: int  # ticks
    peak_speed_steps_per_s: float
    peak_accel_steps_per_s2: float
    min_period_ticks: int
    max_period_ticks: int
    #: edges settled in double-double because f64 could not decide the nearest tick
    settled_edges: int

def plan(
    *,
    steps: Optional[int] = None,
    vmax: Optional[float] = None,
    amax: Optional[float] = None,
    profile: Optional[str] = None,
    jmax: Optional[float] = None,
    smax: Optional[float] = None,
    accel_time: Optional[float] = None,
    cruise_time: Optional[float] = None,
    decel_time: Optional[float] = None,
    start_speed: Optional[float] = None,
    end_speed: Optional[float] = None,
    rho: Optional[float] = None,
    phi: Optional[float] = None,
    psi: Optional[float] = None,
    segments: Optional[Sequence[Segment]] = None,
    clock: float = 50e6,
) -> Plan:
    """Plans one move, exactly as ``multistep plan`` does.

    Three modes (give the keywords of one):

    - phase mode: ``steps`` with ``accel_time``, ``cruise_time``, ``decel_time`` (s);
    - limits mode: ``steps`` with ``vmax`` (steps/s), ``amax`` (steps/s²), and ``jmax``
      (steps/s³) for ``scurve``, ``jmax`` and ``smax`` (steps/s⁴) for ``scurve4``;
    - segment mode: ``segments=[(v0, T, n), …]`` and nothing else.

    ``profile`` is the family (default ``"trapezoid"``); ``start_speed``/``end_speed``
    (steps/s, default 0); ``rho`` the exponential time constant as a fraction of the phase
    time (0.25), ``phi`` the S-curve jerk fraction and ``psi`` the 4th-order snap fraction,
    both in (0, 0.5] (0.5); ``clock`` the tick rate (Hz).

    Raises ``PlanError`` (a ``ValueError``) with the command line's message for a move that
    cannot be planned, ``TypeError`` for a value of the wrong type or an unknown keyword.
    """

@final
class Plan:
    """A planned move. Nothing is generated until an attribute asks for it."""

    @property
    def edges(self) -> npt.NDArray[np.uint64]:
        """Edge tick of every step, ``floor(clock·t_i + ½)`` (uint64, read-only, cached).
        A move of more than ``MAX_EDGES`` steps raises ``ValueError``: use ``chunks``."""
    @property
    def periods(self) -> npt.NDArray[np.uint64]:
        """Ticks between consecutive edges; the first is the first edge (uint64, read-only).
        A move of more than ``MAX_EDGES`` steps raises ``ValueError``: use ``chunks``."""
    def chunks(self, size: int = 1 << 20, periods: bool = False) -> Chunks:
        """Edges (or periods) in arrays of at most ``size`` (1 to ``MAX_EDGES``); memory
        stays at one chunk."""
    @property
    def summary(self) -> PlanSummary:
        """The fields of ``multistep plan --format json`` (runs the whole move once)."""
    @property
    def duration_s(self) -> float:
        """Duration T of the move (s): the last step happens at T."""
    @property
    def steps(self) -> int:
        """Number of steps (edges)."""
    @property
    def clock_hz(self) -> float:
        """The clock edges are counted in (Hz)."""
    @property
    def mode(self) -> str:
        """Mode and family: ``"trapezoid (phases)"``, ``"scurve (limits)"``, ``"segments (3)"``."""
    @property
    def last_edge_tick(self) -> int:
        """Tick of the last edge, ``round(clock·T)``."""
    def velocity(self, t: float) -> float:
        """Commanded speed at time ``t`` (s), in steps/s; 0 outside the move."""
    def position(self, t: float) -> float:
        """Commanded position at time ``t`` (s), in steps."""
    def __len__(self) -> int: ...

@final
class Chunks(Iterator[npt.NDArray[np.uint64]]):
    """Iterator over a plan's edges or periods in uint64 arrays."""

    @property
    def remaining(self) -> int:
        """Edges not yet returned."""
    def __iter__(self) -> Chunks: ...
    def __next__(self) -> npt.NDArray[np.uint64]: ...

class SimTrace(TypedDict):
    """Trace columns, one sample every ``trace_interval`` (a plain dict at run time)."""

    t_s: npt.NDArray[np.float64]  # s
    commanded_deg: npt.NDArray[np.float64]  # °
    actual_deg: npt.NDArray[np.float64]  # °
    commanded_speed_deg_s: npt.NDArray[np.float64]  # °/s
    actual_speed_deg_s: npt.NDArray[np.float64]  # °/s
    error_deg: npt.NDArray[np.float64]  # °
    ia_a: npt.NDArray[np.float64]  # A
    ib_a: npt.NDArray[np.float64]  # A

def simulate(
    motor: Union[str, os.PathLike[str]],
    *,
    profile: Optional[str] = None,
    steps: Optional[int] = None,
    accel_time: Optional[float] = None,
    cruise_time: Optional[float] = None,
    decel_time: Optional[float] = None,
    start_speed: Optional[float] = None,
    end_speed: Optional[float] = None,
    rho: Optional[float] = None,
    phi: Optional[float] = None,
    psi: Optional[float] = None,
    segments: Optional[Sequence[Segment]] = None,
    vmax: Optional[float] = None,
    amax: Optional[float] = None,
    jmax: Optional[float] = None,
    smax: Optional[float] = None,
    clock: float = 50e6,
    reverse: bool = False,
    microsteps: Optional[int] = None,
    supply: Optional[float] = None,
    mode: str = "rl",
    load_inertia: Optional[float] = None,
    load_torque: Optional[float] = None,
    damping_ratio: Optional[float] = None,
    dt: float = 1e-6,
    trace: bool = False,
    trace_interval: float = 1e-5,
) -> Dict[str, Any]:
    """Simulates one move on a motor and driver, as ``multistep simulate`` does.

    ``motor`` is a library name (``MOTORS``) or a TOML motor file. The move keywords are
    those of ``plan``. ``microsteps`` per full step, ``supply`` (V), ``mode`` ``"rl"`` (PI
    current loop, voltage clamped to the supply) or ``"ideal"``, ``load_inertia`` (kg·m²),
    ``load_torque`` (N·m), ``damping_ratio`` ζ, ``dt`` the RK4 step (s); unset ones come
    from the motor file.

    Returns the fields of ``simulate --format json``: steps, microsteps, mode, lost_steps,
    lost, first_loss_s (s or None), peak/min/max/final following error (°),
    peak_following_error_steps, move_time_s, simulated_s, dt_s (s), damping_ratio,
    natural_frequency_hz, peak_speed_deg_s, energy; with ``trace=True`` also ``"trace"``,
    a dict of numpy arrays sampled every ``trace_interval`` (s) (see ``SimTrace``), at
    most ``MAX_TRACE_ROWS`` rows (a longer trace raises ``ValueError`` before the run).
    Ctrl-C ends a long simulation.
    """

#: A tracking rate in steps/s: a str read exactly (``"46.4228"``, ``"15041/324"``), an
#: int, an exact ``Fraction`` or a float (its exact binary value).
Rate = Union[str, int, Fraction, float]

def track(
    rate: Rate,
    duration: float,
    *,
    amax: Optional[float] = None,
    start_speed: float = 0.0,
    jmax: Optional[float] = None,
    clock: float = 50e6,
    integer: bool = False,
) -> npt.NDArray[np.uint64]:
    """The edges of open-ended motion, exactly as ``multistep plan --track`` prints them.

    A ramp from ``start_speed`` to ``rate`` within ``amax`` (steps/s², needed unless the
    start speed is the rate; an S-curve with ``jmax``), then a cruise at exactly ``rate``:
    every edge (ticks at ``clock`` Hz) up to ``duration`` s. ``integer=True`` runs the
    integer tracker (trapezoid and S-curve ramps), which gives the same edges.

    Raises ``PlanError`` (a ``ValueError``) with the command line's message for a rate or
    limit it refuses, ``ValueError`` before making any edge when the run could give more
    than ``MAX_EDGES`` (the ramp's steps within ``duration``, then ``rate`` steps/s for the
    rest), ``TypeError`` for a value of the wrong type.
    """

@final
class Board:
    """A session with one controller board (``multistep serve`` or real hardware).

    Distances and positions are microsteps (int) or user units as a str (``"12.5u"``).
    Move keywords (``move``, ``moveto``, ``group``, ``goto``, ``preset``): ``preset``,
    ``profile``, ``vmax`` (steps/s), ``amax`` (steps/s²), ``jmax`` (steps/s³), ``smax``
    (steps/s⁴), ``accel_time``, ``cruise_time``, ``decel_time`` (s), ``start_speed``,
    ``end_speed`` (steps/s), ``rho``, ``phi``, ``psi``; unset ones come from the preset,
    then the axis settings. A refusal raises ``ProtocolError`` with its ``code``.

    Every call waits at most ``timeout`` s for the board's reply, then raises
    ``BoardTimeoutError``; the reply still owed is read past by the next call. Calls
    release the GIL and let Ctrl-C in within 50 ms.
    """

    def __new__(cls, endpoint: str, timeout: float = 10.0) -> Board:
        """Connects to ``"tcp://HOST:PORT"`` or ``"serial:DEVICE"`` (115200 8N1) within
        ``timeout`` s (0.001 to 3600; it also bounds each call's wait for a reply)."""
    @property
    def endpoint(self) -> str: ...
    @property
    def timeout(self) -> float:
        """Longest wait for the reply to one call (s, 0.001 to 3600; default 10)."""
    @timeout.setter
    def timeout(self, value: float) -> None: ...
    def move(self, axis: str, distance: Union[int, str], **opts: Any) -> List[str]:
        """Relative move; returns the board's data lines (``"X target=…"``)."""
    def moveto(self, axis: str, position: Union[int, str], **opts: Any) -> List[str]:
        """Absolute move (periodic axes take the shortest way)."""
    def group(
        self,
        targets: Mapping[str, Union[int, str]],
        *,
        absolute: bool = False,
        sync: bool = False,
        **opts: Any,
    ) -> List[str]:
        """Moves axes of this board from the same tick; ``sync``: same finish tick too."""
    def home(self, axis: str) -> None:
        """Starts homing ``axis`` on its Hall sensor; ``wait`` for it."""
    def stop(self, axis: Optional[str] = None) -> None:
        """Controlled stop of ``axis`` (every axis without one)."""
    def estop(self) -> None:
        """Emergency stop: every axis halts; motion is refused until ``reset``."""
    def reset(self) -> None:
        """Clears an emergency stop and faults."""
    def wait(self, *axes: str, timeout: float = 600.0) -> None:
        """Waits until the axes (every axis without any) are idle; ``timeout`` in s (≥ 0,
        ``inf`` for none). Raises ``BoardError`` on a fault, ``BoardTimeoutError`` when the
        axes are not idle in time."""
    def status(self, *axes: str) -> List[Dict[str, Any]]:
        """``status json``: axis, position (microsteps), units, state, homed, trusted,
        target, speed (steps/s), sensor, drift, move_start/move_end (ticks), fault, …"""
    def get(self, axis: str, key: Optional[str] = None) -> Union[str, Dict[str, str]]:
        """One setting as a str, or all of them as a dict."""
    def set(self, axis: str, key: str, value: Any) -> None:
        """Changes one setting (stored); ``None`` clears an optional one."""
    def save(self, name: str, *axes: str) -> List[str]:
        """Stores the current positions of ``axes`` (all without any) under ``name``."""
    def goto(self, name: str, **opts: Any) -> List[str]:
        """Group move to a named position."""
    def positions(self) -> List[str]:
        """The named positions (``"NAME X=… Y=…"``)."""
    def forget(self, name: str) -> None:
        """Deletes a named position."""
    def preset(self, name: str, **opts: Any) -> None:
        """Stores a speed preset from move keywords."""
    def presets(self) -> List[str]:
        """The presets (``"NAME vmax=… …"``)."""
    def info(self) -> Dict[str, str]:
        """Board facts: board, version, axes, clock_hz, time_scale, tick, estop."""
    def version(self) -> str:
        """The board's version line."""
    def sim_slip(self, axis: str, steps: int) -> None:
        """Simulation only: the mechanics lose ``steps`` steps the count does not see."""
    def track(
        self, axis: str, rate: Rate, *, amax: Optional[float] = None, lease: Optional[float] = None
    ) -> List[str]:
        """Ramps ``axis`` to ``rate`` (steps/s; a str may be ``"0.5u"`` in user units/s or
        a stored rate's name; negative runs backwards) and runs at exactly that rate until
        ``stop`` or a new ``track`` (0 stops). ``amax`` (steps/s², > 0 and finite) for the
        ramps, ``lease`` (s, > 0 and at most 60) stops the axis unless the command comes
        again."""
    def rate(self, name: str, rate: Rate) -> None:
        """Stores the named rate ``name`` on the board, for ``track(axis, name)``."""
    def rates(self) -> List[str]:
        """The named rates (``"NAME RATE"``)."""
    def release(self, axis: str) -> None:
        """Releases the driver of idle ``axis`` (it may then be turned by hand)."""
    def energize(self, axis: str) -> None:
        """Energizes the driver of ``axis``."""
    def raw(self, line: str) -> List[str]:
        """Sends one raw protocol line; returns its data lines."""
    def close(self) -> None:
        """Closes the connection."""
    def __enter__(self) -> Board: ...
    def __exit__(self, *exc: object) -> bool: ...
