"""Servo-mode target tracking (mode 1; registers 29 servoj, 30 and 93 servo
Cartesian; manual 2.1.3.2 and register 19).

In servo mode every command replaces the target. A joint follows a new target
at once when it can reach it within one control period at the joint speed
limit (so targets streamed at 250 Hz are followed with no lag); otherwise it
heads for it at no more than the speed limit,
changing speed by at most ``amax * dt`` per period and braking so as to arrive
without overshoot. Jerk is not limited in servo mode (the manual says speed
and acceleration of servoj are not planned: rich report bytes 257-284 note).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .joint import Limit


class ServoTracker:
    """Joint position/velocity tracking a target that may change every period.

    ``q``, ``qd`` and ``qdd`` hold the state after the last :meth:`step`.
    """

    def __init__(self, q: Sequence[float] | np.ndarray, vmax: Limit, amax: Limit,
                 qd: Sequence[float] | np.ndarray | None = None) -> None:
        self.q = np.array(q, dtype=float)
        dof = len(self.q)
        self.qd = np.zeros(dof) if qd is None else np.array(qd, dtype=float)
        self.qdd = np.zeros(dof)
        self.target = self.q.copy()
        self._new = False  # a target arrived since the last step
        self.set_limits(vmax, amax)

    def set_limits(self, vmax: Limit, amax: Limit) -> None:
        dof = len(self.q)
        self.vmax = np.broadcast_to(np.asarray(vmax, dtype=float), (dof,)).copy()
        self.amax = np.broadcast_to(np.asarray(amax, dtype=float), (dof,)).copy()
        if np.any(~np.isfinite(self.vmax)) or np.any(self.vmax <= 0) or np.any(~np.isfinite(self.amax)) \
                or np.any(self.amax <= 0):
            raise ValueError("servo limits must be positive and finite")

    def set_target(self, target: Sequence[float] | np.ndarray) -> None:
        t = np.array(target, dtype=float)
        if t.shape != self.q.shape or not np.all(np.isfinite(t)):
            raise ValueError("servo target must be finite, one value per joint")
        self.target = t
        self._new = True

    @property
    def at_target(self) -> bool:
        return bool(np.array_equal(self.q, self.target) and not self.qd.any())

    def step(self, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance one control period of ``dt`` seconds toward the target; returns ``(q, qd, qdd)``."""
        err = self.target - self.q
        # A new target within one period's reach is taken at once; so is a target already reached.
        direct = (np.abs(err) <= self.vmax * dt) if self._new else (err == 0.0)
        self._new = False
        # Joints that cannot reach: speed toward the target, capped by the braking speed and vmax.
        brake = np.sqrt(2.0 * self.amax * np.abs(err))
        v_des = np.sign(err) * np.minimum(self.vmax, brake)
        dv = self.amax * dt
        v = np.clip(v_des, self.qd - dv, self.qd + dv)
        q_new = self.q + v * dt
        overshoot = (q_new - self.target) * np.sign(err) > 0.0
        q_new = np.where(direct | overshoot, self.target, q_new)
        qd_new = (q_new - self.q) / dt
        self.qdd = (qd_new - self.qd) / dt
        self.q, self.qd = q_new, qd_new
        return self.q, self.qd, self.qdd
