"""Joint temperatures for the rich report (manual 2.1.6, bytes 246-252, "Joint Celsius", u8 per joint).

A first-order thermal model per joint, an assumption (UFACTORY publishes no thermal data): each joint
tends to ``ambient + idle_rise + rise_per_amp2 * I^2`` with time constant ``time_constant``, where ``I`` is
the motor current (A) of that joint. Heating is Joule heating (proportional to I^2); ``idle_rise`` is the
drive electronics' own warming while the box is on. Parameters by joint size (``model.inertials``): a
large joint holding 1.6 A settles near 38 C after about an hour, a wrist joint near 33 C; a joint at 5 A
continuous heads towards 80-100 C, the range where a real controller would raise an over-temperature
error. The exact exponential update keeps the model stable for any step ``dt``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ...model.inertials import joint_sizes
from ...model.robots import RobotModel
from .controller_state import holds

#: Ambient temperature (C); the manual's operating range is 0-50 C.
AMBIENT_C = 25.0
#: The box advances the thermal model every this many control periods (1 s; its time constants are
#: minutes).
THERMAL_EVERY = 250


@dataclass(frozen=True)
class JointThermal:
    """Thermal parameters of one joint size."""

    time_constant: float  # s
    rise_per_amp2: float  # C per A^2 at steady state
    idle_rise: float  # C at steady state with no current


#: Assumed parameters per joint size ("L" shoulder, "M" elbow, "S" wrist).
THERMAL_BY_SIZE: dict[str, JointThermal] = {
    "L": JointThermal(time_constant=900.0, rise_per_amp2=2.5, idle_rise=6.0),
    "M": JointThermal(time_constant=720.0, rise_per_amp2=3.0, idle_rise=5.0),
    "S": JointThermal(time_constant=480.0, rise_per_amp2=6.0, idle_rise=4.0),
}


@dataclass(slots=True)
class ThermalState:
    """The joints' temperatures (C), the thermal model's only changing values."""

    _temps: np.ndarray = field(default_factory=lambda: np.zeros(0))


@holds(ThermalState)
class ThermalModel:
    """Temperatures of ``dof`` joints, advanced by :meth:`step`. Starts at ambient (cold start)."""

    def __init__(self, dof: int, ambient: float = AMBIENT_C, initial: Sequence[float] | None = None,
                 sizes: Sequence[str] | None = None, params: Sequence[JointThermal] | None = None) -> None:
        if params is None:
            params = [THERMAL_BY_SIZE[s] for s in (joint_sizes(dof) if sizes is None else sizes)]
        self.data = ThermalState()
        self.dof = dof
        self.ambient = float(ambient)
        self._tau = np.array([p.time_constant for p in params])
        self._k = np.array([p.rise_per_amp2 for p in params])
        self._idle = np.array([p.idle_rise for p in params])
        self._temps = (np.full(dof, self.ambient) if initial is None
                       else np.asarray(initial, dtype=float).reshape(dof).copy())

    @classmethod
    def for_model(cls, model: RobotModel) -> ThermalModel:
        """The thermal model of ``model``'s joints: the parameters of their sizes, or a calibrated
        model's measured ones (``RobotModel.calibration``)."""
        return cls(model.dof, params=thermal_params(model))

    @property
    def temperatures(self) -> np.ndarray:
        """Current joint temperatures (C), a copy."""
        return self._temps.copy()

    def steady_state(self, currents: Sequence[float] | np.ndarray) -> np.ndarray:
        """Temperatures the joints settle at under constant ``currents`` (A)."""
        i = np.asarray(currents, dtype=float).reshape(-1)[: self.dof]
        return self.ambient + self._idle + self._k * i * i

    def step(self, dt: float, currents: Sequence[float] | np.ndarray) -> np.ndarray:
        """Advance by ``dt`` seconds with joint ``currents`` (A, sign ignored); returns the temperatures."""
        if dt < 0 or not math.isfinite(dt):
            raise ValueError(f"dt must be finite and >= 0, got {dt!r}")
        target = self.steady_state(currents)
        decay = np.exp(-dt / self._tau)
        self._temps = target + (self._temps - target) * decay
        return self._temps.copy()

    def celsius_u8(self) -> list[int]:
        """Temperatures as the report's whole degrees, clamped to 0..127: the rich report carries
        them as signed bytes (as the SDK reads them), so a hotter joint shows 127, never a wrap."""
        return [int(min(127, max(0, round(t)))) for t in self._temps]


def thermal_params(model: RobotModel) -> list[JointThermal]:
    """Thermal parameters per joint of ``model``: by joint size, each replaced where the model's
    calibration sets it."""
    params = [THERMAL_BY_SIZE[s] for s in joint_sizes(model)]
    cal = model.calibration
    if cal is None:
        return params
    tau, rise, idle = cal.thermal_time_constants, cal.thermal_rise_per_amp2, cal.thermal_idle_rise
    return [JointThermal(time_constant=p.time_constant if tau is None else tau[i],
                         rise_per_amp2=p.rise_per_amp2 if rise is None else rise[i],
                         idle_rise=p.idle_rise if idle is None else idle[i]) for i, p in enumerate(params)]
