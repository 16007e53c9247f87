"""The UFACTORY six-axis force/torque sensor between the flange and the tool (registers 150 and
200-212, the rich report's external and raw force fields; the error codes C50-C53 of chapter 3).

What it measures, every control period while it is attached and switched on (register 201):

- the gravity of what hangs below its gauge (the tool and the payload; see :func:`load_below`) in the
  sensor frame as the arm moves, and the inertial force of that load during motion (its centre of
  mass's acceleration, from the joint motion of the period);
- :func:`external_wrench`: every wrench from outside acting at the TCP (held or ramped wrenches
  from the admin channel, the CLI or a fault schedule, and the contact scene of
  :mod:`..scene.contact`);
- a slow drift and white noise, as on a real sensor (switchable off: ``Emulator(ft_noise=False)``
  or :func:`set_noise`).

Noise and drift are pure functions of the sensor's seed and the clock: the white noise of control
period ``n`` (the controller's period count) is drawn from a generator keyed by the seed and the block
of :data:`NOISE_BLOCK` periods ``n`` falls in (:func:`white_noise`), and the drift is a closed-form
function of the time since the noise was switched on (:func:`drift`). So a reading never depends on
how many periods were stepped before it, and the sensor is idle (:func:`idle_until`) while the arm
rests and no force or admittance application is set: the stepped clock jumps over such periods
(up to the end of a played wrench) and the reading of the period that runs comes out bit for bit as
if every period had run.

Frames and signs. The sensor frame has the flange's axes; its origin is the sensor's tool face,
:data:`SENSOR_HEIGHT` mm along flange +z (the SDK's ``set_ft_sensor_load_offset`` adds the same
32 mm when it turns an identified centre of mass into a TCP load). A reading is the wrench that the
load and the world exert on that face: a 1 kg load hanging below a flange that points down reads
Fz = +9.81 N; a table pushing the tool up reads a negative Fz. Torques are about the sensor origin,
except in :func:`control_wrench`, whose torques are about the TCP point (register 35's offset).

Assumptions (the vendor publishes no inner geometry): the gauge sits at the tool face, so the
sensor's own housing (:data:`SENSOR_MASS` at :data:`SENSOR_COM`, the values the SDK uses for the
sensor) hangs above it and loads the joints but not the reading; the factory zero is exact; noise
is :data:`NOISE_FORCE` / :data:`NOISE_TORQUE` (1 sigma) and the drift a sum of slow sinusoids
(periods :data:`DRIFT_PERIODS`) with seeded amplitudes and phases that starts from zero, grows about
like a random walk of :data:`DRIFT_RATE` per square root of a second over the first minutes and stays
within :data:`DRIFT_LIMIT` times that rate. The seed is in the controller's state, so a run is
repeatable and a checkpoint restores it.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from ...model import dynamics as dyn
from ...model import kinematics as kin
from ...protocol.regmap import RegisterMap
from ..core.controller_protocol import Controller
from ..core.device import NO_REGISTERS
from ..core.ft_config import ft_config
from ..core.interface import NOT_IDLE, ControllerView
from ..scene import contact

#: Sensor thickness, flange to tool face (mm): the offset the SDK adds to an identified centroid.
SENSOR_HEIGHT = 32.0
#: The sensor's own mass (kg) and centre of mass (mm, flange frame), as the SDK's
#: ``set_ft_sensor_load_offset(..., association_setting_tcp_load=True)`` assumes them.
SENSOR_MASS = 0.270
SENSOR_COM = (-17.0, 9.0, 11.8)
#: Register 212's sensor type, id and sampling rate (Hz) of an attached sensor (emulator's choice).
SENSOR_TYPE = 1
SENSOR_ID = 1
SENSOR_RATE_HZ = 1000
#: White noise of one reading (1 sigma): N and N m.
NOISE_FORCE = 0.03
NOISE_TORQUE = 0.002
#: Drift: about a random walk of N/sqrt(s) and N m/sqrt(s), bounded to DRIFT_LIMIT times that.
DRIFT_RATE = (0.01, 0.0005)
DRIFT_LIMIT = 20.0
#: Periods (s) of the drift's sinusoids; the one of period P has an amplitude of about
#: DRIFT_RATE * sqrt(P / 2 pi), the size a random walk reaches in P / 2 pi seconds.
DRIFT_PERIODS = (15.0, 60.0, 240.0, 960.0)
#: The noise's default seed, and the number of control periods whose noise one keyed draw gives.
NOISE_SEED = 0x0F75
NOISE_BLOCK = 250
#: Keys (after the seed) of the generators of the drift and of the identification's samples, apart
#: from the per-block keys of the white noise (which are >= 0).
_DRIFT_KEY = -1
_IDEN_KEY = -2
#: get_ft_sensor_error reads servo register ERROR_ADDRESS of axis 8; NO_SENSOR_ERROR means "fine".
ERROR_ADDRESS = 0x0010
NO_SENSOR_ERROR = 27
#: Control box errors of the sensor (chapter 3): read failure, set-mode, set-zero, overload.
C_FT_READ, C_FT_MODE, C_FT_ZERO, C_FT_OVERLOAD = 50, 51, 52, 53
#: Poses (J5, J6 offsets, rad) the load identification reads the sensor at.
IDEN_POSES: tuple[tuple[float, float], ...] = (
    (0.0, 0.0), (0.6, 0.0), (-0.6, 0.0), (0.0, 1.2), (0.6, 1.2), (-0.6, -1.2), (0.3, 2.4), (-0.3, -2.4))
#: Readings averaged per identification pose.
IDEN_SAMPLES = 25


@dataclass
class AppliedWrench:
    """A wrench played from outside (:func:`apply_wrench`): N and N m about the TCP point."""

    wrench: tuple[float, ...]
    frame: str  # "tool" (sensor axes) or "base"
    start: float  # controller time it was applied, s
    ramp_s: float = 0.0
    until: float | None = None  # controller time it ends, s

    def value(self, now: float) -> np.ndarray:
        """The wrench at controller time ``now`` (zero once it has ended)."""
        if self.until is not None and now >= self.until - 1e-9:
            return np.zeros(6)
        k = 1.0 if self.ramp_s <= 0 else min(1.0, max(0.0, (now - self.start) / self.ramp_s))
        return np.asarray(self.wrench, dtype=float) * k


@dataclass(slots=True)
class FtSensorState:
    """Everything of the sensor that changes: switches, external wrenches, drift, readings."""

    attached: bool = False
    enabled: bool = False
    noise: bool = True
    #: Sensor error as get_ft_sensor_error reads it (0: none).
    error: int = 0
    #: The physical load below the gauge when declared from outside: (kg, centre of mass mm in the
    #: flange frame); ``None``: register 36's TCP load is the truth (see :func:`load_below`).
    payload: tuple[float, tuple[float, float, float]] | None = None
    wrenches: list[AppliedWrench] = field(default_factory=list)
    #: The seed of the noise and the drift (:func:`white_noise`, :func:`drift`).
    seed: int = NOISE_SEED
    #: Controller time the noise was last switched on: the drift starts from zero there.
    noise_since: float = 0.0
    #: The raw reading of the last control period (sensor frame, about its origin).
    raw: np.ndarray = field(default_factory=lambda: np.zeros(6))
    #: Centre-of-mass positions (m, base frame) of the last two periods, for the load's acceleration.
    com_history: list[np.ndarray] = field(default_factory=list)


def state_of(ctl: Controller) -> FtSensorState:
    """The sensor state of ``ctl`` (in its :class:`~..core.controller_state.ControllerState`),
    created on first use."""
    st = ctl.data.ft_sensor
    if not isinstance(st, FtSensorState):
        st = FtSensorState()
        ctl.data.ft_sensor = st
    return st


def attach(ctl: Controller, *, noise: bool = True) -> None:
    """Mount the sensor (``Emulator(ft_sensor=True)``); it starts switched off, as after power-on."""
    st = state_of(ctl)
    st.attached, st.noise = True, bool(noise)


def attached(ctl: Controller) -> bool:
    """A sensor is mounted between flange and tool."""
    return state_of(ctl).attached


def enabled(ctl: Controller) -> bool:
    """The sensor is mounted and register 201 switched it on (a box whose firmware lacks register 201
    cannot have the sensor: protocol/firmware.py's ``PARTS``)."""
    st = state_of(ctl)
    return st.attached and st.enabled


def set_noise(ctl: Controller, on: bool) -> None:
    """Switch the sensor's noise and drift on or off (off: deterministic readings)."""
    st = state_of(ctl)
    if on and not st.noise:
        st.noise_since = float(ctl.data.time)
    st.noise = bool(on)


def error_register(ctl: Controller) -> int:
    """What servo register 0x0010 of axis 8 holds: the sensor's error, or 27 when there is none."""
    err = state_of(ctl).error
    return err if err else NO_SENSOR_ERROR


def inject_error(ctl: Controller, code: int) -> None:
    """The sensor reports error ``code`` (1..255; 0 clears it), as get_ft_sensor_error reads it.
    While the sensor is switched on the box also raises C50 (F/T sensor read failure)."""
    if not 0 <= int(code) <= 255 or int(code) == NO_SENSOR_ERROR:
        raise ValueError(f"F/T sensor error code {code} out of range 0..255 (27 means no error)")
    st = state_of(ctl)
    if not st.attached:
        raise ValueError("no F/T sensor is attached (Emulator(ft_sensor=True), serve --ft-sensor)")
    st.error = int(code)
    if code and st.enabled:
        ctl.raise_error(C_FT_READ)


class FtSensorComponent:
    """The controller component that steps the sensor each control period, and the sensor as a device
    (:class:`~..core.device.Device`): its registers are the controller's (handlers/ft_sensor.py's
    bindings, 150 and 200-212), its state the controller's part :func:`state_of`."""

    REGISTER_MAP: ClassVar[RegisterMap] = NO_REGISTERS

    def __init__(self, ctl: Controller) -> None:
        self.ctl = ctl

    @property
    def data(self) -> FtSensorState:
        return state_of(self.ctl)

    def step(self, dt: float, ctl: ControllerView) -> None:
        step(self.ctl, dt)

    def idle_until(self, ctl: ControllerView) -> float:
        """Idle as :func:`idle_until` says (:func:`~..core.interface.idle_until`)."""
        return idle_until(self.ctl)

    @property
    def error(self) -> int:
        return state_of(self.ctl).error

    def inject_error(self, code: int) -> None:
        inject_error(self.ctl, code)

    def clear_error(self) -> None:
        state_of(self.ctl).error = 0

    def status_fields(self) -> dict[str, Any]:
        return status(self.ctl)


def status(ctl: Controller) -> dict[str, Any]:
    """The sensor as the admin ``status`` shows it: switched on, its error, the compensated, raw and
    external readings (N, N m)."""
    return {"enabled": enabled(ctl), "error": state_of(ctl).error,
            "reading": [round(float(x), 4) for x in reading(ctl)],
            "raw": [round(float(x), 4) for x in raw_reading(ctl)],
            "external": [round(float(x), 4) for x in external_wrench(ctl)]}


#: The key of the saved configuration (register 40) that holds the sensor's load and zero.
CONFIG_KEY = "ft_sensor"


def config_of(ctl: Controller) -> dict[str, Any] | None:
    """What register 40 saves of the sensor: register 205's load and the zero (205/206); None
    while they are all zero."""
    cfg = ft_config(ctl)
    if cfg.mass == 0 and not any(cfg.centroid) and not any(cfg.offsets):
        return None
    return {"mass": cfg.mass, "centroid": list(cfg.centroid), "offsets": list(cfg.offsets)}


def load_config(ctl: Controller, data: Any) -> None:
    """Apply a saved load and zero; anything of the wrong shape or not finite is ignored."""
    if not isinstance(data, dict):
        return
    try:
        mass = float(data["mass"])
        centroid = tuple(float(x) for x in data["centroid"])
        offsets = tuple(float(x) for x in data["offsets"])
    except (KeyError, TypeError, ValueError):
        return
    values = (mass, *centroid, *offsets)
    if len(centroid) != 3 or len(offsets) != 6 or not all(math.isfinite(x) for x in values):
        return
    cfg = ft_config(ctl)
    cfg.mass, cfg.centroid, cfg.offsets = mass, centroid, offsets


# -- geometry ---------------------------------------------------------------------------------
def _gravity(ctl: Controller) -> np.ndarray:
    try:
        return dyn.gravity_from_direction(ctl.settings.gravity_direction)
    except ValueError:
        return np.array(dyn.DEFAULT_GRAVITY)


def cross(a: Any, b: Any) -> np.ndarray:
    """a x b of two 3-vectors (numpy's ``cross`` costs twenty times more on 3-vectors)."""
    a0, a1, a2 = float(a[0]), float(a[1]), float(a[2])
    b0, b1, b2 = float(b[0]), float(b[1]), float(b[2])
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


#: The last sensor pose computed per robot model object (it depends on the model and the joints
#: only): ``id(model)`` -> (the model, the joints' bytes, the pose). Keyed by the object, checked by
#: identity, never by the model's name: two models of one name may differ in geometry.
_POSE_CACHE: dict[int, tuple[Any, bytes, tuple[np.ndarray, np.ndarray]]] = {}


def _sensor_pose(ctl: Controller, q: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (sensor axes in the base frame) and origin (mm, base frame) of the sensor frame; the
    present joints' pose is computed once per joint vector (a period asks for it several times)."""
    if q is None:
        key = np.asarray(ctl.data.q, dtype=float).tobytes()
        model = ctl.model
        hit = _POSE_CACHE.get(id(model))
        if hit is not None and hit[0] is model and hit[1] == key:
            return hit[2]
        pose = _sensor_pose(ctl, ctl.data.q)
        _POSE_CACHE[id(model)] = (model, key, pose)
        return pose
    T = kin.fk(ctl.model, q)
    R = T[:3, :3]
    return R, T[:3, 3] + R[:, 2] * SENSOR_HEIGHT


def tcp_in_sensor(ctl: Controller) -> np.ndarray:
    """The TCP point (mm) in the sensor frame: register 35's offset less the sensor's height."""
    off = ctl.settings.tcp_offset
    return np.array([off[0], off[1], off[2] - SENSOR_HEIGHT], dtype=float)


def load_below(ctl: Controller) -> tuple[float, np.ndarray]:
    """The load below the gauge: mass (kg) and centre of mass (mm, sensor frame).

    A payload declared from outside (:func:`set_payload`) is the truth. Otherwise register 36's TCP
    load is; with the sensor mounted it includes the sensor (as the SDK sets it after an
    identification), whose share is taken out."""
    st = state_of(ctl)
    if st.payload is not None:
        m, com = st.payload
        c = np.asarray(com, dtype=float)
    else:
        load = ctl.settings.tcp_load
        m, c = float(load[0]), np.asarray(load[1:4], dtype=float)
        if st.attached:
            rest = m - SENSOR_MASS
            if rest <= 1e-6:
                return 0.0, np.zeros(3)
            c = (m * c - SENSOR_MASS * np.asarray(SENSOR_COM)) / rest
            m = rest
    return float(m), c - np.array([0.0, 0.0, SENSOR_HEIGHT])


def set_payload(ctl: Controller, mass: float, com: Sequence[float]) -> None:
    """Declare the physical payload below the sensor (kg, centre of mass mm in the flange frame)."""
    c = tuple(float(x) for x in com)
    if len(c) != 3 or not all(math.isfinite(x) for x in (mass, *c)) or mass < 0:
        raise ValueError(f"payload: a mass >= 0 kg and three finite mm, not {mass!r}, {com!r}")
    state_of(ctl).payload = (float(mass), (c[0], c[1], c[2]))


def physical_tcp_load(ctl: Controller) -> tuple[float, np.ndarray]:
    """Everything on the flange, as the joints feel it: mass (kg) and centre of mass (mm, flange
    frame): the load below the gauge plus the sensor when it is mounted."""
    m, c = load_below(ctl)
    c = c + np.array([0.0, 0.0, SENSOR_HEIGHT])
    if attached(ctl):
        total = m + SENSOR_MASS
        c = (m * c + SENSOR_MASS * np.asarray(SENSOR_COM)) / total
        m = total
    return m, c


def _load_wrench(R: np.ndarray, g: np.ndarray, m: float, com_mm: np.ndarray,
                 acc: np.ndarray | None = None) -> np.ndarray:
    """Wrench of a point load (kg, mm in the sensor frame) on the sensor, sensor frame."""
    a = g if acc is None else g - acc
    f = R.T @ (m * a)
    return np.concatenate([f, cross(com_mm / 1000.0, f)])


def _shift(w: np.ndarray, r_mm: np.ndarray) -> np.ndarray:
    """A wrench about a point at ``r_mm`` moved to the origin: torques gain r x F."""
    return np.concatenate([w[:3], w[3:] + cross(r_mm / 1000.0, w[:3])])


# -- external wrenches -------------------------------------------------------------------------
def apply_wrench(ctl: Controller, wrench: Sequence[float], frame: str = "tool", ramp_s: float = 0.0,
                 duration_s: float | None = None) -> None:
    """Act on the TCP with ``wrench`` (Fx, Fy, Fz N, Tx, Ty, Tz N m about the TCP point) in the tool
    (sensor axes) or base frame, reached linearly over ``ramp_s`` and held for ``duration_s`` (or
    until :func:`clear_wrench`). Wrenches add up. Raises ValueError on non-finite values."""
    w = tuple(float(x) for x in wrench)
    if len(w) != 6:
        raise ValueError(f"a wrench has six values (Fx Fy Fz Tx Ty Tz), not {len(w)}")
    if not all(math.isfinite(x) for x in w):
        raise ValueError(f"wrench values must be finite numbers, got {w}")
    if frame not in ("tool", "base"):
        raise ValueError(f"frame must be 'tool' or 'base', not {frame!r}")
    if not math.isfinite(ramp_s) or ramp_s < 0:
        raise ValueError(f"ramp must be a finite time >= 0 s, not {ramp_s!r}")
    if duration_s is not None and (not math.isfinite(duration_s) or duration_s <= 0):
        raise ValueError(f"duration must be a finite time > 0 s, not {duration_s!r}")
    now = float(ctl.data.time)
    until = None if duration_s is None else now + float(duration_s)
    state_of(ctl).wrenches.append(AppliedWrench(w, frame, now, float(ramp_s), until))


def clear_wrench(ctl: Controller) -> None:
    """Remove every wrench played with :func:`apply_wrench`."""
    state_of(ctl).wrenches.clear()


def external_wrench(ctl: Controller) -> np.ndarray:
    """The sum of every external wrench on the TCP (applied wrenches and the contact scene): base
    frame, N and N m about the TCP point, shape (6,)."""
    st = state_of(ctl)
    now = float(ctl.data.time)
    R, _ = _sensor_pose(ctl)
    total = np.zeros(6)
    for w in st.wrenches:
        v = w.value(now)
        if w.frame == "tool":
            v = np.concatenate([R @ v[:3], R @ v[3:]])
        total += v
    total += contact.scene_wrench(ctl)
    return total


# -- the measurement ---------------------------------------------------------------------------
def _measure(ctl: Controller, q: np.ndarray | None = None, acc: np.ndarray | None = None,
             external: np.ndarray | None = None) -> np.ndarray:
    """The noiseless reading at joints ``q`` (default: the present ones), sensor frame."""
    R, _ = _sensor_pose(ctl, q)
    m, com = load_below(ctl)
    w = _load_wrench(R, _gravity(ctl), m, com, acc)
    ext = external_wrench(ctl) if external is None else external
    ext_s = np.concatenate([R.T @ ext[:3], R.T @ ext[3:]])
    return w + _shift(ext_s, tcp_in_sensor(ctl))


def _load_acceleration(ctl: Controller, st: FtSensorState) -> np.ndarray:
    """The acceleration (m/s^2, base frame) of the load's centre of mass over the last periods."""
    p = _load_point(ctl)
    hist = st.com_history
    hist.append(p)
    if len(hist) > 3:
        del hist[0]
    if len(hist) < 3:
        return np.zeros(3)
    dt = float(ctl.period)
    return (hist[2] - 2.0 * hist[1] + hist[0]) / (dt * dt)


_SIGMA = np.array([NOISE_FORCE] * 3 + [NOISE_TORQUE] * 3)
_WALK = np.array([DRIFT_RATE[0]] * 3 + [DRIFT_RATE[1]] * 3)
#: The drift's sinusoids per seed: amplitudes, angular frequencies and phases, each (6, K), and the
#: per-axis sum of amplitude times sine of phase (the value at 0, taken off).
_DRIFTS: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = {}
_DRIFT_LO, _DRIFT_HI = -DRIFT_LIMIT * _WALK, DRIFT_LIMIT * _WALK


def _keyed(seed: int, *key: int) -> np.random.Generator:
    """A generator that depends on ``seed`` and ``key`` only (numpy's SeedSequence of both)."""
    return np.random.default_rng(np.random.SeedSequence([seed & 0xFFFFFFFF, *(k & 0xFFFFFFFF for k in key)]))


def white_noise(seed: int, period: int) -> np.ndarray:
    """The white noise (N, N m; 1 sigma :data:`NOISE_FORCE` / :data:`NOISE_TORQUE`) of control period
    ``period``: a pure function of the seed and the period, whatever was drawn before. The periods
    of one block of :data:`NOISE_BLOCK` share one keyed draw."""
    block, row = divmod(int(period), NOISE_BLOCK)
    return _normals(int(seed), block)[row] * _SIGMA


@functools.lru_cache(maxsize=8)
def _normals(seed: int, block: int) -> np.ndarray:
    """The standard normal draws of one block of periods (read-only: the memo shares them)."""
    normals = _keyed(seed, block).standard_normal((NOISE_BLOCK, 6))
    normals.flags.writeable = False
    return normals


def _drift_terms(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    terms = _DRIFTS.get(seed)
    if terms is None:
        g = _keyed(seed, _DRIFT_KEY)
        periods = np.array(DRIFT_PERIODS)
        k = len(periods)
        amp = _WALK[:, None] * np.sqrt(periods / (2.0 * math.pi))[None, :] * g.uniform(0.5, 1.5, (6, k))
        omega = np.broadcast_to(2.0 * math.pi / periods, (6, k)) * g.uniform(0.8, 1.25, (6, k))
        phase = g.uniform(0.0, 2.0 * math.pi, (6, k))
        terms = _DRIFTS[seed] = (amp, omega, phase, (amp * np.sin(phase)).sum(axis=1))
    return terms


def drift(seed: int, t: float) -> np.ndarray:
    """The drift (N, N m) ``t`` seconds after the noise was switched on: zero at 0, a sum of slow
    sinusoids (:data:`DRIFT_PERIODS`) with seeded amplitudes, frequencies and phases, bounded to
    :data:`DRIFT_LIMIT` times :data:`DRIFT_RATE`."""
    amp, omega, phase, at_zero = _drift_terms(int(seed))
    value = (amp * np.sin(omega * t + phase)).sum(axis=1) - at_zero
    return np.minimum(np.maximum(value, _DRIFT_LO), _DRIFT_HI)


def _noise(ctl: Controller, st: FtSensorState) -> np.ndarray:
    """Noise and drift of the present control period (zeros with the noise off)."""
    if not st.noise:
        return np.zeros(6)
    d = ctl.data
    return drift(st.seed, float(d.time) - st.noise_since) + white_noise(st.seed, int(d.steps))


def _load_point(ctl: Controller) -> np.ndarray:
    """The load's centre of mass (m, base frame) at the present joints."""
    R, origin = _sensor_pose(ctl)
    _, com = load_below(ctl)
    return (origin + R @ com) / 1000.0


def idle_until(ctl: Controller) -> float:
    """Controller time up to which the sensor is idle (:func:`~..core.interface.idle_until`): while no
    application reads it every period (``ctl.ft_sensor_in_use()``: admittance or force control,
    register 202) and, switched on, the load's centre of mass has stood still over the last periods
    (its acceleration is zero), up to the end of the first played wrench that ends (:func:`step`
    removes it then). With the arm at rest the reading is a function of the clock alone:
    the noise and the drift (pure functions of the period and the time) and the played wrenches (a
    ramp is one of the time), which the period that runs in full computes afresh."""
    st = state_of(ctl)
    horizon = math.inf
    for w in st.wrenches:
        if w.until is not None:
            horizon = min(horizon, w.until - 1e-9)
    if ctl.ft_sensor_in_use():
        return NOT_IDLE
    hist = st.com_history
    if not enabled(ctl):
        return NOT_IDLE if hist else horizon
    if len(hist) < 3:
        return NOT_IDLE
    p = _load_point(ctl)
    return horizon if all(np.array_equal(h, p) for h in hist) else NOT_IDLE


def step(ctl: Controller, dt: float) -> None:
    """One control period of the sensor: a new raw reading when it is mounted and switched on."""
    st = state_of(ctl)
    now = float(ctl.data.time)
    if st.wrenches:
        st.wrenches = [w for w in st.wrenches if w.until is None or now < w.until - 1e-9]
    if not enabled(ctl):
        st.com_history.clear()
        return
    acc = _load_acceleration(ctl, st)
    st.raw = _measure(ctl, acc=acc) + _noise(ctl, st)


def compensation(ctl: Controller) -> np.ndarray:
    """What the box takes off the raw reading: register 205's offsets (or 206's zero) and the gravity
    of register 205's load at the present pose (sensor frame)."""
    cfg = ft_config(ctl)
    out = np.asarray(cfg.offsets, dtype=float).copy()
    if cfg.mass > 0:
        R, _ = _sensor_pose(ctl)
        out += _load_wrench(R, _gravity(ctl), cfg.mass, np.asarray(cfg.centroid, dtype=float) * 1000.0)
    return out


def raw_reading(ctl: Controller) -> np.ndarray:
    """Register 200 ``[01]`` and the report's raw field: zeros unless mounted and switched on."""
    return state_of(ctl).raw.copy() if enabled(ctl) else np.zeros(6)


def reading(ctl: Controller) -> np.ndarray:
    """Registers 150/200 and the report's external field: the raw reading after the zero and the
    load compensation of registers 205/206 (sensor frame, torques about the sensor origin)."""
    if not enabled(ctl):
        return np.zeros(6)
    return state_of(ctl).raw - compensation(ctl)


def control_wrench(ctl: Controller) -> np.ndarray:
    """What force and admittance control act on: :func:`reading` with its torques moved to the TCP
    point, sensor (tool) frame, shape (6,). With an exact calibration and no noise it equals
    :func:`external_wrench` rotated into the sensor frame."""
    return _shift(reading(ctl), -tcp_in_sensor(ctl))


def set_zero(ctl: Controller) -> None:
    """Register 206: the present reading becomes the zero (stored as register 205's offsets)."""
    cfg = ft_config(ctl)
    cfg.offsets = tuple(float(x) for x in (np.asarray(cfg.offsets) + reading(ctl)))


def iden_poses(ctl: Controller, q0: np.ndarray) -> list[np.ndarray]:
    """The joints the load identification reads at: :data:`IDEN_POSES` (J5, J6 offsets) around
    ``q0`` (on a five-axis arm J4 turns for both)."""
    out = []
    for d5, d6 in IDEN_POSES:
        q = np.array(q0, dtype=float)
        if ctl.model.dof >= 6:
            q[4] += d5
            q[5] += d6
        else:
            q[3] += d5 + d6 * 0.5
        out.append(q)
    return out


def iden_reading(ctl: Controller, index: int, q: np.ndarray | None = None) -> np.ndarray:
    """Register 204 ``[00]``'s reading at joints ``q`` (the present ones by default; pose ``index``
    of the sequence): the
    mean of :data:`IDEN_SAMPLES` sensor samples, with the sensor's noise and drift."""
    st = state_of(ctl)
    noise = np.zeros((IDEN_SAMPLES, 6))
    if st.noise:  # keyed by the period the reading is taken in and the pose
        gen = _keyed(st.seed, _IDEN_KEY, int(ctl.data.steps), index)
        noise = gen.standard_normal(noise.shape) * _SIGMA
        noise += drift(st.seed, float(ctl.data.time) - st.noise_since)
    q = np.asarray(ctl.data.q if q is None else q, dtype=float)
    ext = external_wrench(ctl)
    return np.asarray(np.mean([_measure(ctl, q, external=ext) + n for n in noise], axis=0))


def solve_ft_load(ctl: Controller, samples: list[tuple[np.ndarray, np.ndarray]]) -> tuple[float, ...]:
    """Mass (kg), centre of mass (m, sensor frame) and the six offsets from sensor readings taken
    at several wrist orientations, ``samples`` = [(joints, wrench)]: least squares over gravity's
    direction in the sensor frame."""
    g = _gravity(ctl)
    rows_f, rhs_f, rows_t, rhs_t, forces = [], [], [], [], []
    for q, w in samples:
        R, _ = _sensor_pose(ctl, q)
        gs = R.T @ g
        rows_f.append(np.hstack([gs[:, None], np.eye(3)]))
        rhs_f.append(w[:3])
        forces.append((gs, w))
    sol_f = np.linalg.lstsq(np.vstack(rows_f), np.concatenate(rhs_f), rcond=None)[0]
    m, bias_f = float(sol_f[0]), sol_f[1:4]
    for gs, w in forces:
        f = m * gs
        # torque = c x f + b  ->  -[f]x c + b
        skew = np.array([[0.0, f[2], -f[1]], [-f[2], 0.0, f[0]], [f[1], -f[0], 0.0]])
        rows_t.append(np.hstack([skew, np.eye(3)]))
        rhs_t.append(w[3:])
    sol_t = np.linalg.lstsq(np.vstack(rows_t), np.concatenate(rhs_t), rcond=None)[0]
    c = sol_t[:3] if m > 1e-3 else np.zeros(3)
    return (m, *(float(x) for x in c), *(float(x) for x in bias_f), *(float(x) for x in sol_t[3:]))


def identify(ctl: Controller) -> tuple[float, ...]:
    """Register 204 ``[00]`` at once, without moving (:func:`solve_ft_load` over readings computed
    at the sequence's poses): the instant form, for tests and tools; the register runs the moving
    sequence of :mod:`..applications.identification`."""
    q0 = np.asarray(ctl.data.q, dtype=float)
    samples = []
    for i, q in enumerate(iden_poses(ctl, q0)):
        samples.append((q, iden_reading(ctl, i, q)))
    return solve_ft_load(ctl, samples)


def iden_torques(ctl: Controller, q: np.ndarray | None = None) -> np.ndarray:
    """Register 204 ``[01]``'s reading at joints ``q`` (the present ones by default): the static
    joint torques the load adds (the emulator's dynamic model: with the load less without it)."""
    model = ctl.model
    g = _gravity(ctl)
    m_true, c_arr = physical_tcp_load(ctl)
    q = np.asarray(ctl.data.q if q is None else q, dtype=float)
    return np.asarray(dyn.gravity_torques(model, q, g, m_true, tuple(float(x) for x in c_arr))
                      - dyn.gravity_torques(model, q, g))


def solve_tcp_load(ctl: Controller,
                   samples: list[tuple[np.ndarray, np.ndarray]]) -> tuple[float, float, float, float]:
    """The flange load (kg, centre of mass mm in the flange frame) from the load's joint torques
    at several wrist poses, ``samples`` = [(joints, torques)]: least squares on the static torques."""
    model = ctl.model
    g = _gravity(ctl)
    rows, rhs = [], []
    for q, tau in samples:
        # The load's torques are linear in (m, m*cx, m*cy, m*cz): one column per unit basis load.
        base = dyn.gravity_torques(model, q, g)
        cols = [dyn.gravity_torques(model, q, g, 1.0, (0.0, 0.0, 0.0)) - base]
        for axis in range(3):
            e = [0.0, 0.0, 0.0]
            e[axis] = 1000.0  # 1 kg at 1 m: the torque per unit of m*c (kg m)
            cols.append(dyn.gravity_torques(model, q, g, 1.0, e) - base - cols[0])
        rows.append(np.column_stack(cols))
        rhs.append(tau)
    sol = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)[0]
    m = float(sol[0])
    if m < 1e-3:
        return (max(m, 0.0), 0.0, 0.0, 0.0)
    c = sol[1:4] / m * 1000.0
    return (m, float(c[0]), float(c[1]), float(c[2]))


def identify_tcp_load(ctl: Controller) -> tuple[float, float, float, float]:
    """Register 204 ``[01]`` at once, without moving (:func:`solve_tcp_load` over the torques at
    the sequence's poses)."""
    q0 = np.asarray(ctl.data.q, dtype=float)
    samples = [(q, iden_torques(ctl, q)) for q in iden_poses(ctl, q0)]
    return solve_tcp_load(ctl, samples)

