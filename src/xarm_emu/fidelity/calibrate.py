"""``xarm-emu calibrate session.xrec -o cal.toml``: the emulator's estimated constants fitted to a recording.

The recording is replayed into the emulator with its own constants (:mod:`.compare`), which gives, at
the controller time of every recorded real-time frame, the joint torques of the dynamic model on the
same path. Then, per joint, by linear least squares:

- the torque constant (N.m/A): the recorded torques against the recorded motor currents,
  ``torque = constant * current``;
- the torque offset, viscous and Coulomb friction: the recorded torques less the model's,
  ``offset + viscous * speed + coulomb * sign(speed)``; the friction terms only for a joint that moved
  both ways over enough samples (else they cannot be told from the offset and are left out);
- the thermal constants (time constant, idle rise, rise per A^2) where the rich report's temperatures
  changed during the recording, by nonlinear least squares on the emulator's thermal model
  (:mod:`.thermal_fit`); a session of minutes at room temperature leaves them as they are.

Each value comes with its standard deviation, ``sqrt(s^2 (A^T A)^-1)`` of the fit, ``s^2`` the residual
variance. The collision thresholds (the external torque each collision sensitivity detects) are fitted
where the recording holds a detected collision (:mod:`.collision_fit`), between bounds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..controller.core import safety
from ..controller.core.interface import PERIOD
from ..controller.core.thermal import AMBIENT_C, thermal_params
from ..controller.emulator import THERMAL_EVERY
from ..model.calibration import Calibration
from ..model.inertials import torque_constants
from ..model.robots import get_model
from . import collision_fit, thermal_fit
from .compare import Comparison, compare

#: Samples a joint needs in each direction of motion before friction is fitted for it.
MIN_MOVING = 10
#: Joints (rad, about half a degree) a recorded frame may be from the replayed one for its torques to
#: be fitted: more than a real arm's tracking error, less than an arm that stopped on an error while
#: the replay goes on shows within a few periods.
SAME_PATH = 0.01
#: Joint speed (rad/s) above which a sample counts as moving for the friction fit.
MOVING = 1e-3
#: A joint's torque constant is fitted only from frames whose torque reaches this (N.m), when there
#: are at least ``MIN_EXCITED`` of them and the fit knows it to ``MAX_RELATIVE_SD`` of its value
#: (current noise against too little torque leaves it wider); else the emulator's is kept.
EXCITED_TORQUE, MIN_EXCITED, MAX_RELATIVE_SD = 0.05, 10, 0.02
#: The relative resolution of a ratio of two of the report's float32 values (torque over current):
#: the least a torque constant's standard deviation can be (rounding that repeats with the values
#: does not average out).
FLOAT32_RATIO = 2.0 ** -22


@dataclass
class Fit:
    """A fitted calibration and what could not be fitted, and why."""

    calibration: Calibration
    notes: list[str] = field(default_factory=list)
    samples: int = 0
    #: The constants kept at the emulator's values (``name[joint or level]``): the recording did not
    #: excite them; the file gives them the uncertainty ``inf``.
    kept: list[str] = field(default_factory=list)


def _lstsq(a: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares solution of ``a x = y`` and the standard deviation of each value."""
    x, _, rank, _ = np.linalg.lstsq(a, y, rcond=None)
    dof = max(1, len(y) - a.shape[1])
    resid = y - a @ x
    s2 = float(resid @ resid) / dof
    try:
        cov = s2 * np.linalg.inv(a.T @ a)
        sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    except np.linalg.LinAlgError:
        sd = np.full(a.shape[1], math.inf)
    return x, sd


def fit(comparison: Comparison) -> Fit:
    """The constants of :mod:`xarm_emu.model.calibration` fitted to a comparison run with the
    emulator's own constants (module docstring)."""
    rec, rep = comparison.recorded, comparison.replayed
    if len(rec) < 10:
        raise ValueError("the recording has too few real-time report frames to fit anything")
    # where the arm was where the replay is (after an error the box stops and the replay, which never
    # sees it, goes on)
    use = np.flatnonzero(np.abs(rep.joints - rec.joints[:len(rep)]).max(axis=1) < SAME_PATH)
    if len(use) < 3:
        raise ValueError("the recorded arm never followed the replayed path: nothing to fit")
    tau, cur = rec.torques[use], rec.currents[use]
    model_tau, qd = rep.torques[use], rep.speeds[use]
    dof = tau.shape[1]
    defaults = torque_constants(get_model(comparison.model))
    kt, kt_sd = defaults.astype(float).copy(), np.full(dof, math.inf)
    off, off_sd = np.zeros(dof), np.zeros(dof)
    visc, visc_sd = np.zeros(dof), np.full(dof, math.inf)
    coul, coul_sd = np.zeros(dof), np.full(dof, math.inf)
    notes: list[str] = []
    kept: list[str] = []
    friction_any = False
    for j in range(dof):
        excited = np.abs(tau[:, j]) >= EXCITED_TORQUE
        if excited.sum() >= MIN_EXCITED:
            x, sd = _lstsq(cur[excited, j:j + 1], tau[excited, j])
            sd[0] = max(sd[0], abs(x[0]) * FLOAT32_RATIO)
            if x[0] > 0 and sd[0] <= MAX_RELATIVE_SD * x[0]:
                kt[j], kt_sd[j] = x[0], sd[0]
            else:
                kept.append(f"torque_constants[{j + 1}]")
                notes.append(f"joint {j + 1}: torque constant not fitted (the fit knows it only to "
                             f"{sd[0]:.3g} of {x[0]:.4g} N.m/A); the emulator's {defaults[j]:.4g} is kept")
        else:
            kept.append(f"torque_constants[{j + 1}]")
            notes.append(f"joint {j + 1}: torque constant not fitted (its torque reached {EXCITED_TORQUE:g} "
                         f"N.m in {int(excited.sum())} frames, fewer than {MIN_EXCITED}); the emulator's "
                         f"{defaults[j]:.4g} N.m/A is kept")
        y = tau[:, j] - model_tau[:, j]
        v = qd[:, j]
        both = (v > MOVING).sum() >= MIN_MOVING and (v < -MOVING).sum() >= MIN_MOVING
        if both:
            friction_any = True
            a = np.column_stack([np.ones_like(v), v, np.sign(v)])
            x, sd = _lstsq(a, y)
            off[j], visc[j], coul[j] = x
            off_sd[j], visc_sd[j], coul_sd[j] = sd
        else:
            x, sd = _lstsq(np.ones((len(y), 1)), y)
            off[j], off_sd[j] = x[0], sd[0]
            notes.append(f"joint {j + 1}: friction not fitted (it did not move both ways over "
                         f"{MIN_MOVING} frames each)")
    values: dict[str, tuple[float, ...]] = {"torque_constants": tuple(kt.tolist()),
                                            "torque_offsets": tuple(off.tolist())}
    unc = [("torque_constants", tuple(kt_sd.tolist())), ("torque_offsets", tuple(off_sd.tolist()))]
    _thermal(comparison, values, unc, notes)
    _collisions(comparison, use, np.column_stack([off, visc, coul]), values, unc, notes)
    if friction_any:
        values["viscous_friction"] = tuple(max(0.0, x) for x in visc.tolist())
        values["coulomb_friction"] = tuple(max(0.0, x) for x in coul.tolist())
        unc += [("viscous_friction", tuple(visc_sd.tolist())), ("coulomb_friction", tuple(coul_sd.tolist()))]
    kept += [f"{name}[{j + 1}]" for name, sds in unc if name not in ("torque_constants",)
             for j, sd in enumerate(sds) if not math.isfinite(sd)]
    cal = Calibration(model=comparison.model, uncertainties=tuple(unc), **values)  # type: ignore[arg-type]
    return Fit(cal, notes, len(rec), kept)


def _collisions(comparison: Comparison, use: np.ndarray, friction: np.ndarray,
                values: dict[str, tuple[float, ...]], unc: list[tuple[str, tuple[float, ...]]],
                notes: list[str]) -> None:
    """Add the collision thresholds of the levels at which a collision was detected
    (:mod:`.collision_fit`); the other levels keep the emulator's, with an infinite uncertainty."""
    session = comparison.session
    status = session.status if session is not None else []
    if session is None or not any(f.error == collision_fit.C_COLLISION for f in status):
        notes.append("collision thresholds not fitted: no collision (C31) was recorded")
        return
    rec, rep = comparison.recorded, comparison.replayed
    t, tau, speeds = rec.t, rec.torques, rec.speeds
    # the model's torques between the frames they were taken at, plus the fitted offsets and friction
    t_use = t[use]
    model = np.column_stack([np.interp(t, t_use, rep.torques[use, j])
                             for j in range(tau.shape[1])])
    model += friction[:, 0] + friction[:, 1] * speeds + friction[:, 2] * np.sign(speeds)
    residual = np.abs(tau - model).max(axis=1)
    st = session.controller_times([f.t for f in status])
    res = collision_fit.fit_thresholds(t, residual, st, np.array([f.error for f in status]),
                                       np.array([f.sensitivity for f in status]),
                                       rec.state)
    notes.extend(res.notes)
    if not res.values:
        notes.append("collision thresholds not fitted: no detection with frames before it at a known level")
        return
    defaults = safety.COLLISION_THRESHOLDS
    vals = tuple(res.values.get(level, defaults[level]) for level in sorted(defaults))
    sds = tuple(res.sd.get(level, math.inf) for level in sorted(defaults))
    for level in sorted(defaults):
        if level in res.bounds:
            lo, hi = res.bounds[level]
            notes.append(f"collision sensitivity {level}: threshold between {lo:.4g} and {hi:.4g} N.m")
        else:
            notes.append(f"collision sensitivity {level}: no detection recorded, the emulator's threshold "
                         "is kept")
    values["collision_thresholds"] = vals
    unc.append(("collision_thresholds", sds))


THERMAL_NAMES = ("thermal_time_constants", "thermal_idle_rise", "thermal_rise_per_amp2")


def _thermal(comparison: Comparison, values: dict[str, tuple[float, ...]],
             unc: list[tuple[str, tuple[float, ...]]], notes: list[str]) -> None:
    """Add the thermal constants of the joints whose temperatures changed (:mod:`.thermal_fit`); a
    joint not fitted keeps the emulator's values, written with an infinite uncertainty."""
    session = comparison.session
    rich = [f for f in session.status if f.temperatures is not None] if session is not None else []
    if session is None or len(rich) < 8 or not comparison.recorded:
        notes.append("thermal constants not fitted: the recording has no rich report (port 30002) "
                     "with joint temperatures")
        return
    dt = THERMAL_EVERY * PERIOD
    defaults = thermal_params(get_model(comparison.model))
    dof = len(defaults)
    obs_t = session.controller_times([f.t for f in rich])
    temps = np.array([list(f.temperatures or ())[:dof] for f in rich], dtype=float)
    cur_t, cur = comparison.recorded.t, np.abs(comparison.recorded.currents)
    i2, idx, keep = thermal_fit.step_inputs(obs_t, cur_t, cur, dt)
    idx, temps = idx[keep], temps[keep]
    _, first = np.unique(idx, return_index=True)  # one observation per step: they repeat between steps
    idx, temps = idx[first], temps[first]
    fitted = [thermal_fit.fit_joint(idx, temps[:, j], i2[:, j], AMBIENT_C, dt, defaults[j].rise_per_amp2)
              for j in range(dof)]
    if not any(fitted):
        notes.append(f"thermal constants not fitted: no joint's temperature changed by "
                     f"{thermal_fit.MIN_CHANGE:g} C or more over the recording (a long session from a "
                     "cold start shows them)")
        return
    inf = math.inf
    tau = [f.time_constant if f else d.time_constant for f, d in zip(fitted, defaults, strict=True)]
    idle = [f.idle_rise if f else d.idle_rise for f, d in zip(fitted, defaults, strict=True)]
    rise = [f.rise_per_amp2 if f else d.rise_per_amp2 for f, d in zip(fitted, defaults, strict=True)]
    sd = [f.sd if f else (inf, inf, inf) for f in fitted]
    for j, f in enumerate(fitted):
        if f is None:
            notes.append(f"joint {j + 1}: thermal constants not fitted (its temperature changed by less "
                         f"than {thermal_fit.MIN_CHANGE:g} C); the emulator's are kept")
        elif not f.fitted_rise:
            notes.append(f"joint {j + 1}: thermal rise per A^2 not fitted (its current hardly varied); "
                         "the emulator's is kept")
    values["thermal_time_constants"] = tuple(tau)
    values["thermal_idle_rise"] = tuple(idle)
    values["thermal_rise_per_amp2"] = tuple(max(0.0, r) for r in rise)
    unc += [("thermal_time_constants", tuple(s[0] for s in sd)),
            ("thermal_idle_rise", tuple(s[1] for s in sd)),
            ("thermal_rise_per_amp2", tuple(inf if math.isnan(s[2]) else s[2] for s in sd))]


def calibrate(path: Path) -> Fit:
    """Fit a calibration to the recording at ``path`` (module docstring)."""
    return fit(compare(path))
