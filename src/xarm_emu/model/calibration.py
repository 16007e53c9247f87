"""A calibration: the emulator's estimated constants replaced by values measured on one arm.

What the manual and the SDK fix (layouts, codes, limits, kinematics, link inertials) is never part of
a calibration. Only the constants the project itself had to assume, and says so where they live, can be
overridden:

- ``torque_constants``: N.m per A of motor current, per joint (``model.inertials`` assumes them by joint
  size); current = torque / constant, as the reports' currents (manual 2.1.6) show them;
- ``torque_offsets`` (N.m), ``viscous_friction`` (N.m s/rad) and ``coulomb_friction`` (N.m): added to
  the joint torques of the dynamic model, ``offset + viscous * qd + coulomb * sign(qd)`` (the emulator's
  defaults are zero: no friction);
- ``thermal_time_constants`` (s), ``thermal_rise_per_amp2`` (C/A^2) and ``thermal_idle_rise`` (C): the
  first-order thermal model of the joints (``controller.core.thermal``);
- ``collision_thresholds`` (N.m): the external joint torque that collision sensitivity 1..5 (register
  37) detects as a collision (error C31), five values, one per level (``controller.core.safety``).

A field left ``None`` keeps the emulator's own value. A calibration is frozen and hashable; applying it
(``robots.with_calibration``) gives a new ``RobotModel``, as models never change. ``uncertainties``
holds the standard deviation of each fitted value (same names), for the reader of a calibration file.

Files are TOML (``xarm-emu calibrate -o cal.toml``, ``serve --calibration cal.toml``)::

    format = 1
    model = "6"
    torque_constants = [5.28, 5.28, 3.74, 1.32, 1.32, 1.32]
    [uncertainty]
    torque_constants = [0.001, ...]
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..tomlfile import check_keys, load_toml

#: Version of the calibration file format.
FORMAT = 1

#: The overridable constants, in file order.
CONSTANTS = ("torque_constants", "torque_offsets", "viscous_friction", "coulomb_friction",
             "thermal_time_constants", "thermal_rise_per_amp2", "thermal_idle_rise", "collision_thresholds")
_POSITIVE = frozenset({"torque_constants", "thermal_time_constants", "collision_thresholds"})
#: Collision sensitivity levels 1..5 (register 37; level 0 switches detection off).
COLLISION_LEVELS = 5


class CalibrationError(ValueError):
    """A calibration file or value that cannot be used; the message says which and why."""


PerJoint = tuple[float, ...] | None


@dataclass(frozen=True)
class Calibration:
    """Measured replacements of the emulator's estimated constants (module docstring)."""

    torque_constants: PerJoint = None
    torque_offsets: PerJoint = None
    viscous_friction: PerJoint = None
    coulomb_friction: PerJoint = None
    thermal_time_constants: PerJoint = None
    thermal_rise_per_amp2: PerJoint = None
    thermal_idle_rise: PerJoint = None
    #: One value per collision sensitivity level 1..5, not per joint.
    collision_thresholds: PerJoint = None
    #: The model key the calibration was measured on ("" for any arm with as many joints).
    model: str = ""
    #: Standard deviations of the fitted values, as ``(name, values)`` pairs.
    uncertainties: tuple[tuple[str, tuple[float, ...]], ...] = ()

    def values(self) -> dict[str, tuple[float, ...]]:
        """The constants this calibration sets, by name."""
        return {name: v for name in CONSTANTS if (v := getattr(self, name)) is not None}

    def check(self, dof: int) -> None:
        """``CalibrationError`` unless every set constant has ``dof`` finite values (positive where a
        constant divides or is a time)."""
        for name, vals in self.values().items():
            if name == "collision_thresholds":
                if len(vals) != COLLISION_LEVELS:
                    raise CalibrationError(f"{name} has {len(vals)} values, one per collision sensitivity "
                                           f"level 1..{COLLISION_LEVELS} is needed")
            elif len(vals) != dof:
                raise CalibrationError(f"{name} has {len(vals)} values, the arm has {dof} joints")
            for v in vals:
                bad = (name in _POSITIVE and v <= 0.0) or (v < 0.0 and "friction" in name)
                if bad or not math.isfinite(v):
                    raise CalibrationError(f"{name}: {v!r} is not a usable value")

    @property
    def empty(self) -> bool:
        """True when nothing is overridden."""
        return not self.values()


def _floats(name: str, value: Any) -> tuple[float, ...]:
    if not isinstance(value, list) or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                              for v in value):
        raise CalibrationError(f"{name} must be a list of numbers")
    return tuple(float(v) for v in value)


#: The top-level keys of a calibration file: its format, the arm, where it came from, the constants and
#: their ``[uncertainty]`` table.
KEYS = ("format", "model", "source", "uncertainty", *CONSTANTS)


def from_dict(data: dict[str, Any]) -> Calibration:
    """A calibration from the tables of its TOML file."""
    fmt = data.get("format", FORMAT)
    if fmt != FORMAT:
        raise CalibrationError(f"calibration format {fmt!r} is not supported (this version reads {FORMAT})")
    check_keys(data, KEYS, error=CalibrationError)
    model = data.get("model", "")
    if not isinstance(model, str):
        raise CalibrationError("model must be a string such as \"6\" or \"lite6\"")
    kw: dict[str, Any] = {name: _floats(name, data[name]) for name in CONSTANTS if name in data}
    unc = data.get("uncertainty", {})
    if not isinstance(unc, dict):
        raise CalibrationError("[uncertainty] must be a table")
    kw["uncertainties"] = tuple((k, _floats(f"uncertainty.{k}", v)) for k, v in unc.items() if k in CONSTANTS)
    return Calibration(model=model, **kw)


def load(path: Path | str) -> Calibration:
    """Read a calibration file; ``CalibrationError`` with a one-line reason naming the file on any
    problem (the TOML files' one format, xarm_emu.tomlfile)."""
    return load_toml(path, "calibration file", from_dict, CalibrationError)


def _list(vals: tuple[float, ...]) -> str:
    return "[" + ", ".join(repr(float(v)) for v in vals) + "]"


def dumps(calibration: Calibration, comment: str = "") -> str:
    """The TOML text of a calibration file (read back by :func:`load`)."""
    lines = [f"# {line}" for line in comment.splitlines()]
    lines.append(f"format = {FORMAT}")
    if calibration.model:
        lines.append(f"model = \"{calibration.model}\"")
    lines += [f"{name} = {_list(v)}" for name, v in calibration.values().items()]
    if calibration.uncertainties:
        lines.append("")
        lines.append("[uncertainty]  # one standard deviation of each fitted value")
        lines += [f"{name} = {_list(v)}" for name, v in calibration.uncertainties]
    return "\n".join(lines) + "\n"


def save(calibration: Calibration, path: Path | str, comment: str = "") -> None:
    """Write a calibration file atomically (a temporary file renamed over the target)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    try:
        tmp.write_text(dumps(calibration, comment), encoding="utf-8")
        tmp.replace(path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise CalibrationError(f"cannot write {path}: {exc.strerror or exc}") from None


__all__ = ["COLLISION_LEVELS", "CONSTANTS", "FORMAT", "Calibration", "CalibrationError", "dumps", "from_dict",
           "load", "save"]
