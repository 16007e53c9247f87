"""The F/T sensor's applications (registers that come with the sensor's own): register 202 sets
admittance (1) or force control (2) or neither (0), 203 reads it back, 207-211 set their parameters
(the SDK's ``set_ft_sensor_mode``, ``get_ft_sensor_mode``, ``set_ft_sensor_admittance_parameters`` and
``set_ft_sensor_force_parameters``); the control laws are in controller/applications/force_control.py.

Parameters outside the vendor's ranges (those the SDK checks unless ``params_limit=False``) are
parameter abnormal, warning 12 (manual 3.2.2), and change nothing. An application needs the sensor
attached and switched on (register 201); otherwise the box answers that the command could not be
carried out (reply bit 0x08, the SDK's code 10) and the application stays off.
"""

from __future__ import annotations

from typing import Any

from ..applications import force_control as fc
from ..core.controller_protocol import Controller
from ..core.ft_config import ft_config
from ..core.interface import Binding, CommandFailed, ParameterError, Values
from ..devices import ft_sensor as sensor


def _floats(values: Any) -> tuple[float, ...]:
    return tuple(float(x) for x in values)


def _coord_axes(v: Values) -> tuple[int, tuple[int, ...]]:
    coord, axes = int(v["coord"]), tuple(int(x) for x in v["c_axis"])
    if coord not in (fc.FRAME_BASE, fc.FRAME_TOOL) or any(a not in (0, 1) for a in axes):
        raise ParameterError(f"frame {coord} (0 base, 1 tool) and axes {axes} (0/1 each)")
    return coord, axes


def _mkb(v: Values) -> tuple[tuple[float, ...], ...]:
    M, K, B = _floats(v["M"]), _floats(v["K"]), _floats(v["B"])
    problem = fc.mkb_problem(M, K, B)
    if problem:
        raise ParameterError(problem)
    return M, K, B


def set_mode(ctl: Controller, v: Values) -> None:
    """Register 202: the application, 0 none, 1 admittance, 2 force control."""
    app = int(v["app"])
    if app not in fc.APPS:
        raise ParameterError(f"application {app} (0-2)")
    if app != fc.APP_OFF and not sensor.attached(ctl):
        raise CommandFailed("no F/T sensor attached")
    if app != fc.APP_OFF and not sensor.enabled(ctl):
        raise CommandFailed("the F/T sensor is off (register 201)")
    fc.set_app(ctl, app)


def get_mode(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 203: the application set by 202."""
    return {"app": fc.control_of(ctl).app}


def admittance_config(ctl: Controller, v: Values) -> None:
    """Register 207: admittance frame, compliant axes and M, K, B."""
    coord, axes = _coord_axes(v)
    M, K, B = _mkb(v)
    cfg = ft_config(ctl)
    cfg.imp_coord, cfg.imp_c_axis, cfg.M, cfg.K, cfg.B = coord, axes, M, K, B


def force_pid(ctl: Controller, v: Values) -> None:
    """Register 208: force-control PID and the speed cap ``xe_limit``."""
    pid = {k: _floats(v[k]) for k in ("kp", "ki", "kd", "xe_limit")}
    problem = fc.pid_problem(pid["kp"], pid["ki"], pid["kd"], pid["xe_limit"])
    if problem:
        raise ParameterError(problem)
    ft_config(ctl).pid = pid


def force_config(ctl: Controller, v: Values) -> None:
    """Register 209: force-control frame, axes, reference and limits (stored; the SDK's example
    calls them reserved)."""
    coord, axes = _coord_axes(v)
    f_ref, limits = _floats(v["f_ref"]), _floats(v["limits"])
    problem = fc.f_ref_problem(f_ref)
    if problem:
        raise ParameterError(problem)
    cfg = ft_config(ctl)
    cfg.fc_coord, cfg.fc_c_axis, cfg.f_ref, cfg.limits = coord, axes, f_ref, limits


def admittance_mkb(ctl: Controller, v: Values) -> None:
    """Register 210: admittance M, K, B."""
    cfg = ft_config(ctl)
    cfg.M, cfg.K, cfg.B = _mkb(v)


def admittance_frame(ctl: Controller, v: Values) -> None:
    """Register 211: admittance frame and compliant axes."""
    cfg = ft_config(ctl)
    cfg.imp_coord, cfg.imp_c_axis = _coord_axes(v)


#: The registers of this module, bound (:class:`~xarm_emu.controller.core.interface.Binding`).
BINDINGS: tuple[Binding, ...] = (
    Binding(202, set_mode),
    Binding(203, get_mode),
    Binding(207, admittance_config),
    Binding(208, force_pid),
    Binding(209, force_config),
    Binding(210, admittance_mkb),
    Binding(211, admittance_frame),
)


def create_state(ctl: Controller) -> None:
    """Create the application's state at construction, so that a checkpoint always holds it."""
    fc.control_of(ctl)
