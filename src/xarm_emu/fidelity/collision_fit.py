"""The collision thresholds fitted to the collisions of a recording (``xarm-emu calibrate``).

A box detects a collision (error C31, manual 3.2.1) when the external torque on a joint reaches the
threshold of the collision sensitivity (register 37, levels 1..5). The external torque is what the
recorded joint torques (real-time report) carry beyond the dynamic model's on the same path and the
fitted offsets and friction: the residual, the largest over the joints. The normal and rich reports
show the error code and the sensitivity five times a second, so a detection is known to lie between
the last frame without C31 and the first with it.

Each detection bounds its level's threshold from above (the residual reached it somewhere in that
window: the window's largest residual); every moment the detection was armed at that level without
tripping (no error in the frames on both sides) bounds it from below (the largest residual then). The
threshold is the middle of the tightest bounds, with the standard deviation of a value spread evenly
between them, ``(upper - lower) / sqrt(12)``. A level with no recorded detection keeps the emulator's
value. The residuals are only as good as the torque model: on a real arm, the friction and the
current-to-torque fit limit them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: The error code of a detected collision (manual 3.2.1).
C_COLLISION = 31
#: Motion state "stopped" (manual 2.1.3, register 13): the real-time frame shows a detection with it.
STOPPED = 4
#: A detection whose window shows less external torque than this (N m) was not a collision the torques
#: show (an error raised some other way): it bounds nothing.
MIN_DETECTION = 1.0


@dataclass
class ThresholdFit:
    """Fitted thresholds by level (1..5), their standard deviations, the bounds and what was left."""

    values: dict[int, float] = field(default_factory=dict)
    sd: dict[int, float] = field(default_factory=dict)
    bounds: dict[int, tuple[float, float]] = field(default_factory=dict)
    detections: int = 0
    notes: list[str] = field(default_factory=list)


def fit_thresholds(sample_t: np.ndarray, residual: np.ndarray, status_t: np.ndarray,
                   status_error: np.ndarray, status_level: np.ndarray,
                   sample_state: np.ndarray | None = None) -> ThresholdFit:
    """Thresholds from the residual external torque (N m, the largest over the joints) at controller
    times ``sample_t`` and the status frames (controller times, error codes, sensitivity levels), all
    in time order (module docstring). With the real-time frames' motion states ``sample_state``, a
    detection's window ends at the first frame that shows the arm stopped."""
    out = ThresholdFit()
    order = np.argsort(status_t, kind="stable")
    st, err, lvl = status_t[order], status_error[order], status_level[order]
    upper: dict[int, float] = {}
    lower: dict[int, float] = {}
    for n in range(1, len(st)):
        if err[n] == C_COLLISION and err[n - 1] != C_COLLISION:
            level = int(lvl[n - 1])
            inside = (sample_t > st[n - 1]) & (sample_t <= st[n])
            if sample_state is not None:
                stop = np.nonzero(inside & (sample_state == STOPPED))[0]
                if len(stop):
                    inside &= np.arange(len(sample_t)) <= stop[0]
            if not level or not inside.any():
                continue
            peak = float(residual[inside].max())
            if peak < MIN_DETECTION:
                out.notes.append(f"a C31 at {st[n]:.3f} s shows no external torque in the recorded torques "
                                 f"(at most {peak:.3g} N.m): it bounds no threshold")
                continue
            out.detections += 1
            upper[level] = min(upper.get(level, math.inf), peak)
        elif err[n] == 0 and err[n - 1] == 0 and lvl[n] == lvl[n - 1] and lvl[n]:
            armed = (sample_t > st[n - 1]) & (sample_t <= st[n])
            if armed.any():
                level = int(lvl[n])
                lower[level] = max(lower.get(level, 0.0), float(residual[armed].max()))
    for level, hi in sorted(upper.items()):
        lo = lower.get(level, 0.0)
        if hi < lo:
            out.notes.append(f"collision sensitivity {level}: a detection at {hi:.3g} N.m below a torque "
                             f"of {lo:.3g} N.m that was not detected (the torque model is off); the lower "
                             "is kept")
            hi = lo
        out.values[level] = 0.5 * (lo + hi)
        out.sd[level] = (hi - lo) / math.sqrt(12.0)
        out.bounds[level] = (lo, hi)
    return out
