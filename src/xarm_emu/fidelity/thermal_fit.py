"""The joints' thermal constants fitted to the temperatures of a recording (``xarm-emu calibrate``).

The model is the emulator's (:mod:`xarm_emu.controller.core.thermal`): each joint tends to
``ambient + idle_rise + rise_per_amp2 * I^2`` with ``time_constant``, advanced once a second of
controller time with the motor current of that instant (the real-time report's currents, manual
2.1.6). The rich report (port 30002) carries the temperatures as whole degrees, five times a second.

Per joint, four values are fitted by nonlinear least squares (Gauss-Newton with a damping term, the
Jacobian by finite differences) to the recorded temperatures: the time constant, the idle rise, the
rise per A^2 and the temperature when the recording began (the arm need not start cold). The model is
simulated on the same one-second steps, so the fit is exact for the emulator and off by at most one
second of lag for an arm that warms continuously. The rounding to whole degrees is the fit's noise
(standard deviation about 0.29 C).

A joint is fitted only when its temperature changed by :data:`MIN_CHANGE` degrees or more; the rise
per A^2 only when the squared current varied enough to move the temperature by :data:`MIN_CURRENT_EFFECT`
degrees (else it keeps the emulator's value, and the idle rise takes up the small rest). Each value
comes with its standard deviation, ``sqrt(s^2 (J^T J)^-1)``, which treats the readings' rounding as
independent: for a slowly warming joint, whose consecutive readings share their rounding, it is
optimistic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Degrees a joint's temperature must change over the recording before it is fitted.
MIN_CHANGE = 3.0
#: Degrees by which the varying current must move a joint's temperature before its rise per A^2 is fitted.
MIN_CURRENT_EFFECT = 2.0
#: Observations this close (s) to a thermal step are left out: the frame's controller time is read
#: from the real-time frames around it and may fall on either side of the step.
STEP_GUARD = 0.02


@dataclass(frozen=True)
class JointFit:
    """A joint's fitted constants and their standard deviations (``nan`` where not fitted)."""

    time_constant: float
    idle_rise: float
    rise_per_amp2: float
    sd: tuple[float, float, float]
    fitted_rise: bool


def _simulate(p: np.ndarray, i2: np.ndarray, ambient: float, dt: float, k_fixed: float | None) -> np.ndarray:
    """Temperatures before the first step and after each step of ``dt`` with squared currents ``i2``;
    ``p`` = (log time constant, idle rise, rise per A^2 or unused, initial temperature)."""
    a = math.exp(-dt / math.exp(p[0]))
    k = p[2] if k_fixed is None else k_fixed
    targets = ambient + p[1] + k * i2
    out = np.empty(len(i2) + 1)
    x = out[0] = p[3]
    for n, target in enumerate(targets):
        x = target + (x - target) * a
        out[n + 1] = x
    return out


def fit_joint(obs_idx: np.ndarray, obs: np.ndarray, i2: np.ndarray, ambient: float, dt: float,
              k_default: float) -> JointFit | None:
    """Fit one joint (module docstring); ``obs`` observed at step index ``obs_idx`` (the number of
    steps taken before it), ``i2`` the squared current of each step. None when it cannot be fitted.
    The rise per A^2 is kept at ``k_default`` unless the current's effect is seen: the fitted rise
    times the squared current's range reaches :data:`MIN_CURRENT_EFFECT` and the rise is known to a
    quarter of its value."""
    if len(obs) < 8 or float(obs.max() - obs.min()) < MIN_CHANGE:
        return None
    spread = float(i2.max() - i2.min())
    if max(k_default, _rough_rise(obs_idx, obs, i2, dt)) * spread >= MIN_CURRENT_EFFECT:
        f = _fit(obs_idx, obs, i2, ambient, dt, k_default, True)
        if f.rise_per_amp2 * spread >= MIN_CURRENT_EFFECT and f.sd[2] < 0.25 * abs(f.rise_per_amp2):
            return f
    return _fit(obs_idx, obs, i2, ambient, dt, k_default, False)


def _fit(obs_idx: np.ndarray, obs: np.ndarray, i2: np.ndarray, ambient: float, dt: float,
         k_default: float, fit_rise: bool, iterations: int = 60) -> JointFit:
    k_fixed = None if fit_rise else k_default
    # A start: a time constant of a tenth of the recording, idle rise to the last value seen.
    span = max(dt, len(i2) * dt)
    p = np.array([math.log(max(dt, span / 10)), float(obs[-1]) - ambient, k_default if fit_rise else 0.0,
                  float(obs[0])])
    free = [0, 1, 3] + ([2] if fit_rise else [])

    def resid(q: np.ndarray) -> np.ndarray:
        return obs - _simulate(q, i2, ambient, dt, k_fixed)[obs_idx]

    r = resid(p)
    cost = float(r @ r)
    lam = 1e-3
    jac = np.zeros((len(obs), len(free)))
    for _ in range(iterations):
        for c, n in enumerate(free):
            h = 1e-6 * max(1.0, abs(p[n]))
            q = p.copy()
            q[n] += h
            jac[:, c] = (resid(q) - r) / -h
        jtj, jtr = jac.T @ jac, jac.T @ r
        improved = False
        for _ in range(12):
            try:
                step = np.linalg.solve(jtj + lam * np.diag(np.diag(jtj) + 1e-12), jtr)
            except np.linalg.LinAlgError:
                break
            q = p.copy()
            q[free] += step
            q[0] = min(max(q[0], math.log(dt / 20)), math.log(1e6))
            rq = resid(q)
            cq = float(rq @ rq)
            if cq < cost:
                p, r, cost, improved = q, rq, cq, True
                lam = max(lam / 10, 1e-9)
                break
            lam *= 10
        if not improved or float(np.abs(step).max()) < 1e-9:
            break
    dof = max(1, len(obs) - len(free))
    s2 = cost / dof
    try:
        cov = s2 * np.linalg.inv(jac.T @ jac)
        sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    except np.linalg.LinAlgError:
        sd = np.full(len(free), math.inf)
    by = dict(zip(free, sd.tolist(), strict=True))
    tau = math.exp(p[0])
    return JointFit(tau, float(p[1]), float(p[2]) if fit_rise else k_default,
                    (tau * by[0], by[1], by.get(2, math.nan)), fit_rise)


def _rough_rise(obs_idx: np.ndarray, obs: np.ndarray, i2: np.ndarray, dt: float) -> float:
    """A rough rise per A^2 from one-step differences (equation error), to judge whether the current's
    effect can be seen at all; 0 when the regression says nothing."""
    steps = np.diff(obs_idx)
    use = np.nonzero(steps == 1)[0] if (steps == 1).any() else np.zeros(0, dtype=int)
    if len(use) < 6:
        return 0.0
    dx = obs[use + 1] - obs[use]
    a = np.column_stack([np.ones(len(use)), i2[obs_idx[use]], obs[use]])
    x = np.linalg.lstsq(a, dx, rcond=None)[0]
    b = -x[2]
    return float(x[1] / b) if 0 < b < 1 else 0.0


def step_inputs(obs_times: np.ndarray, current_times: np.ndarray, currents: np.ndarray,
                dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The thermal steps (whole multiples of ``dt`` of controller time) over the observations, the
    squared currents at each (the current sample nearest in time) and, per kept observation, the
    number of steps before it; returns (squared currents per step and joint, observation step index,
    mask of the observations kept)."""
    first = math.floor(obs_times[0] / dt) + 1
    last = math.floor(obs_times[-1] / dt)
    grid = np.arange(first, last + 1) * dt
    near = np.clip(np.searchsorted(current_times, grid), 1, max(1, len(current_times) - 1))
    left = near - 1
    pick = np.where(np.abs(current_times[np.minimum(near, len(current_times) - 1)] - grid)
                    < np.abs(current_times[left] - grid), np.minimum(near, len(current_times) - 1), left)
    i2 = currents[pick] ** 2
    phase = obs_times / dt - np.round(obs_times / dt)
    keep = np.abs(phase) * dt > STEP_GUARD
    idx = np.floor(obs_times / dt).astype(int) - first + 1
    return i2, idx, keep
