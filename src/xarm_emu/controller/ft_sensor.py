"""The UFACTORY six-axis force/torque sensor between the flange and the tool (registers 150 and
200-212, the rich report's external and raw force fields; the error codes C50-C53 of chapter 3).

What it measures, every control period while it is attached and switched on (register 201):

- the gravity of what hangs below its gauge (the tool and the payload; see :func:`load_below`) in the
  sensor frame as the arm moves, and the inertial force of that load during motion (its centre of
  mass's acceleration, from the joint motion of the period);
- :func:`external_wrench`: every wrench from outside acting at the TCP (held or ramped wrenches
  from the admin channel, the CLI or a fault schedule, and the contact scene of
  :mod:`.contact`);
- a slow drift and white noise, as on a real sensor (switchable off: ``Emulator(ft_noise=False)``
  or :func:`set_noise`).

Frames and signs. The sensor frame has the flange's axes; its origin is the sensor's tool face,
:data:`SENSOR_HEIGHT` mm along flange +z (the SDK's ``set_ft_sensor_load_offset`` adds the same
32 mm when it turns an identified centre of mass into a TCP load). A reading is the wrench that the
load and the world exert on that face: a 1 kg load hanging below a flange that points down reads
Fz = +9.81 N; a table pushing the tool up reads a negative Fz. Torques are about the sensor origin,
except in :func:`control_wrench`, whose torques are about the TCP point (register 35's offset).

Assumptions (the vendor publishes no inner geometry): the gauge sits at the tool face, so the
sensor's own housing (:data:`SENSOR_MASS` at :data:`SENSOR_COM`, the values the SDK uses for the
sensor) hangs above it and loads the joints but not the reading; the factory zero is exact; noise
is :data:`NOISE_FORCE` / :data:`NOISE_TORQUE` (1 sigma) and the drift a bounded random walk of
:data:`DRIFT_RATE` per square root of a second. The random numbers come from a seeded generator in
the controller's state, so a run is repeatable and a checkpoint restores them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..model import dynamics as dyn
from ..model import kinematics as kin

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
#: Drift: random walk N/sqrt(s) and N m/sqrt(s), bounded to DRIFT_LIMIT times that.
DRIFT_RATE = (0.01, 0.0005)
DRIFT_LIMIT = 20.0
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


@dataclass
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
    drift: np.ndarray = field(default_factory=lambda: np.zeros(6))
    rng: np.random.Generator = field(default_factory=lambda: np.random.default_rng(0x0F75))
    #: The raw reading of the last control period (sensor frame, about its origin).
    raw: np.ndarray = field(default_factory=lambda: np.zeros(6))
    #: Centre-of-mass positions (m, base frame) of the last two periods, for the load's acceleration.
    com_history: list[np.ndarray] = field(default_factory=list)


def state_of(ctl: Any) -> FtSensorState:
    """The sensor state of ``ctl`` (in its :class:`~.state.ControllerState`), created on first use."""
    st = getattr(ctl.data, "ft_sensor", None)
    if not isinstance(st, FtSensorState):
        st = FtSensorState()
        ctl.data.ft_sensor = st
    return st


def attach(ctl: Any, *, noise: bool = True) -> None:
    """Mount the sensor (``Emulator(ft_sensor=True)``); it starts switched off, as after power-on."""
    st = state_of(ctl)
    st.attached, st.noise = True, bool(noise)


def attached(ctl: Any) -> bool:
    """A sensor is mounted between flange and tool."""
    return state_of(ctl).attached


def enabled(ctl: Any) -> bool:
    """The sensor is mounted and register 201 switched it on. A box of a firmware without register
    201 (below 1.8.3, where the SDK reads the sensor through register 150 alone) has no switch:
    a mounted sensor always reads there."""
    st = state_of(ctl)
    return st.attached and (st.enabled or 201 not in ctl.registers)


def set_noise(ctl: Any, on: bool) -> None:
    """Switch the sensor's noise and drift on or off (off: deterministic readings)."""
    st = state_of(ctl)
    st.noise = bool(on)
    if not on:
        st.drift = np.zeros(6)


def error_register(ctl: Any) -> int:
    """What servo register 0x0010 of axis 8 holds: the sensor's error, or 27 when there is none."""
    err = state_of(ctl).error
    return err if err else NO_SENSOR_ERROR


def inject_error(ctl: Any, code: int) -> None:
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
    """The controller component that steps the sensor each control period."""

    def __init__(self, ctl: Any) -> None:
        self.ctl = ctl

    def handlers(self) -> dict[int, Any]:
        return {}

    def step(self, dt: float, view: Any) -> None:
        step(self.ctl, dt)


# -- geometry ---------------------------------------------------------------------------------
def _gravity(ctl: Any) -> np.ndarray:
    try:
        return dyn.gravity_from_direction(ctl.settings.gravity_direction)
    except ValueError:
        return np.array(dyn.DEFAULT_GRAVITY)


def _sensor_pose(ctl: Any, q: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (sensor axes in the base frame) and origin (mm, base frame) of the sensor frame."""
    T = kin.fk(ctl.model, ctl.data.q if q is None else q)
    R = T[:3, :3]
    return R, T[:3, 3] + R[:, 2] * SENSOR_HEIGHT


def tcp_in_sensor(ctl: Any) -> np.ndarray:
    """The TCP point (mm) in the sensor frame: register 35's offset less the sensor's height."""
    off = ctl.settings.tcp_offset
    return np.array([off[0], off[1], off[2] - SENSOR_HEIGHT], dtype=float)


def load_below(ctl: Any) -> tuple[float, np.ndarray]:
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


def set_payload(ctl: Any, mass: float, com: Sequence[float]) -> None:
    """Declare the physical payload below the sensor (kg, centre of mass mm in the flange frame)."""
    c = tuple(float(x) for x in com)
    if len(c) != 3 or not all(math.isfinite(x) for x in (mass, *c)) or mass < 0:
        raise ValueError(f"payload: a mass >= 0 kg and three finite mm, not {mass!r}, {com!r}")
    state_of(ctl).payload = (float(mass), (c[0], c[1], c[2]))


def physical_tcp_load(ctl: Any) -> tuple[float, np.ndarray]:
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
    return np.concatenate([f, np.cross(com_mm / 1000.0, f)])


def _shift(w: np.ndarray, r_mm: np.ndarray) -> np.ndarray:
    """A wrench about a point at ``r_mm`` moved to the origin: torques gain r x F."""
    return np.concatenate([w[:3], w[3:] + np.cross(r_mm / 1000.0, w[:3])])


# -- external wrenches -------------------------------------------------------------------------
def apply_wrench(ctl: Any, wrench: Sequence[float], frame: str = "tool", ramp_s: float = 0.0,
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


def clear_wrench(ctl: Any) -> None:
    """Remove every wrench played with :func:`apply_wrench`."""
    state_of(ctl).wrenches.clear()


def external_wrench(ctl: Any) -> np.ndarray:
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
    from . import contact

    total += contact.scene_wrench(ctl)
    return total


# -- the measurement ---------------------------------------------------------------------------
def _measure(ctl: Any, q: np.ndarray | None = None, acc: np.ndarray | None = None,
             external: np.ndarray | None = None) -> np.ndarray:
    """The noiseless reading at joints ``q`` (default: the present ones), sensor frame."""
    R, _ = _sensor_pose(ctl, q)
    m, com = load_below(ctl)
    w = _load_wrench(R, _gravity(ctl), m, com, acc)
    ext = external_wrench(ctl) if external is None else external
    ext_s = np.concatenate([R.T @ ext[:3], R.T @ ext[3:]])
    return w + _shift(ext_s, tcp_in_sensor(ctl))


def _load_acceleration(ctl: Any, st: FtSensorState) -> np.ndarray:
    """The acceleration (m/s^2, base frame) of the load's centre of mass over the last periods."""
    R, origin = _sensor_pose(ctl)
    _, com = load_below(ctl)
    p = (origin + R @ com) / 1000.0
    hist = st.com_history
    hist.append(p)
    if len(hist) > 3:
        del hist[0]
    if len(hist) < 3:
        return np.zeros(3)
    dt = float(ctl.period)
    return (hist[2] - 2.0 * hist[1] + hist[0]) / (dt * dt)


def _noise(st: FtSensorState, dt: float) -> np.ndarray:
    if not st.noise:
        return np.zeros(6)
    sig = np.array([NOISE_FORCE] * 3 + [NOISE_TORQUE] * 3)
    walk = np.array([DRIFT_RATE[0]] * 3 + [DRIFT_RATE[1]] * 3)
    st.drift = np.clip(st.drift + st.rng.normal(0.0, 1.0, 6) * walk * math.sqrt(dt),
                       -DRIFT_LIMIT * walk, DRIFT_LIMIT * walk)
    return st.drift + st.rng.normal(0.0, 1.0, 6) * sig


def step(ctl: Any, dt: float) -> None:
    """One control period of the sensor: a new raw reading when it is mounted and switched on."""
    st = state_of(ctl)
    now = float(ctl.data.time)
    if st.wrenches:
        st.wrenches = [w for w in st.wrenches if w.until is None or now < w.until - 1e-9]
    if not enabled(ctl):
        st.com_history.clear()
        return
    acc = _load_acceleration(ctl, st)
    st.raw = _measure(ctl, acc=acc) + _noise(st, dt)


def compensation(ctl: Any) -> np.ndarray:
    """What the box takes off the raw reading: register 205's offsets (or 206's zero) and the gravity
    of register 205's load at the present pose (sensor frame)."""
    from .handlers.ft_sensor import ft_config

    cfg = ft_config(ctl)
    out = np.asarray(cfg.offsets, dtype=float).copy()
    if cfg.mass > 0:
        R, _ = _sensor_pose(ctl)
        out += _load_wrench(R, _gravity(ctl), cfg.mass, np.asarray(cfg.centroid, dtype=float) * 1000.0)
    return out


def raw_reading(ctl: Any) -> np.ndarray:
    """Register 200 ``[01]`` and the report's raw field: zeros unless mounted and switched on."""
    return state_of(ctl).raw.copy() if enabled(ctl) else np.zeros(6)


def reading(ctl: Any) -> np.ndarray:
    """Registers 150/200 and the report's external field: the raw reading after the zero and the
    load compensation of registers 205/206 (sensor frame, torques about the sensor origin)."""
    if not enabled(ctl):
        return np.zeros(6)
    return state_of(ctl).raw - compensation(ctl)


def control_wrench(ctl: Any) -> np.ndarray:
    """What force and admittance control act on: :func:`reading` with its torques moved to the TCP
    point, sensor (tool) frame, shape (6,). With an exact calibration and no noise it equals
    :func:`external_wrench` rotated into the sensor frame."""
    return _shift(reading(ctl), -tcp_in_sensor(ctl))


def set_zero(ctl: Any) -> None:
    """Register 206: the present reading becomes the zero (stored as register 205's offsets)."""
    from .handlers.ft_sensor import ft_config

    cfg = ft_config(ctl)
    cfg.offsets = tuple(float(x) for x in (np.asarray(cfg.offsets) + reading(ctl)))


def identify(ctl: Any) -> tuple[float, ...]:
    """Register 204 ``[00]``: mass (kg), centre of mass (m, sensor frame) and the six offsets from
    the sensor's own readings at :data:`IDEN_POSES` around the present joints (least squares over
    gravity's direction, as the real identification turns the wrist). The emulator reads those
    poses without moving the arm; the external wrench present at the start stays as it is."""
    st = state_of(ctl)
    g = _gravity(ctl)
    ext = external_wrench(ctl)
    q0 = np.asarray(ctl.data.q, dtype=float)
    rows_f, rhs_f, rows_t, rhs_t, forces = [], [], [], [], []
    for d5, d6 in IDEN_POSES:
        q = q0.copy()
        if ctl.model.dof >= 6:
            q[4] += d5
            q[5] += d6
        else:
            q[3] += d5 + d6 * 0.5
        w = np.mean([_measure(ctl, q, external=ext) + _noise(st, ctl.period) for _ in range(IDEN_SAMPLES)],
                    axis=0)
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


def identify_tcp_load(ctl: Any) -> tuple[float, float, float, float]:
    """Register 204 ``[01]``: the flange load (kg, centre of mass mm in the flange frame) from the
    joint torques of the emulator's dynamic model at several wrist poses, less the arm's own
    torques (least squares on the static torques; no sensor needed)."""
    model = ctl.model
    g = _gravity(ctl)
    m_true, c_arr = physical_tcp_load(ctl)
    c_true = tuple(float(x) for x in c_arr)
    q0 = np.asarray(ctl.data.q, dtype=float)
    rows, rhs = [], []
    for d5, d6 in IDEN_POSES:
        q = q0.copy()
        if model.dof >= 6:
            q[4] += d5
            q[5] += d6
        else:
            q[3] += d5 + d6 * 0.5
        tau = dyn.gravity_torques(model, q, g, m_true, c_true) - dyn.gravity_torques(model, q, g)
        # The load's torques are linear in (m, m*cx, m*cy, m*cz): one column per unit basis load.
        cols = [dyn.gravity_torques(model, q, g, 1.0, (0.0, 0.0, 0.0)) - dyn.gravity_torques(model, q, g)]
        for axis in range(3):
            e = [0.0, 0.0, 0.0]
            e[axis] = 1000.0  # 1 kg at 1 m: the torque per unit of m*c (kg m)
            cols.append(dyn.gravity_torques(model, q, g, 1.0, e) - dyn.gravity_torques(model, q, g) - cols[0])
        rows.append(np.column_stack(cols))
        rhs.append(tau)
    sol = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)[0]
    m = float(sol[0])
    if m < 1e-3:
        return (max(m, 0.0), 0.0, 0.0, 0.0)
    c = sol[1:4] / m * 1000.0
    return (m, float(c[0]), float(c[1]), float(c[2]))

