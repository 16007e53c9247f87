"""The six-axis force/torque sensor registers (150, 200-212).

With no sensor mounted the box answers as one without it: readings are zeros, the configuration
registers store what they are sent and register 212 reads it back, and what needs the sensor itself
(switching it on, zeroing, identifying its load) is refused with warning 12 (parameter abnormal,
manual 3.2.2). With the sensor mounted (``Emulator(ft_sensor=True)``, :mod:`..devices.ft_sensor`) it must
also be switched on (register 201) before it reads, zeroes or identifies, as on the real box.
Register 204 with type 1 (``iden_tcp_load``) needs no sensor: it identifies the flange load from
the joint torques on every arm. The reply lengths are the ones the SDK reads.
"""

from __future__ import annotations

from typing import Any

from ..applications import force_control, identification
from ..core.controller_protocol import Controller
from ..core.ft_config import ZEROS6, ft_config
from ..core.interface import Binding, ParameterError, Values
from ..devices import ft_sensor as ft

NO_SENSOR = "no F/T sensor attached"
NOT_ENABLED = "the F/T sensor is not switched on (register 201)"


def _floats(values: Any) -> tuple[float, ...]:
    return tuple(float(x) for x in values)


def _require_enabled(ctl: Controller) -> None:
    if not ft.attached(ctl):
        raise ParameterError(NO_SENSOR)
    if not ft.enabled(ctl):
        raise ParameterError(NOT_ENABLED)


def get_data(ctl: Controller, v: Values) -> dict[str, Any]:
    """Registers 150/200: forces (N) and torques (N m) in the sensor frame, compensated by registers
    205/206, or raw with ``[01]``; zeros with no sensor or while it is switched off."""
    raw = int(v.get("raw", 0))
    if raw not in (0, 1):
        raise ParameterError(f"raw {raw} (0/1)")
    if not ft.enabled(ctl):
        return {"forces": ZEROS6}
    return {"forces": _floats(ft.raw_reading(ctl) if raw else ft.reading(ctl))}


def enable(ctl: Controller, v: Values) -> None:
    """Register 201: switch the sensor on or off; switching on needs a sensor (switching off is
    accepted on any box)."""
    on = int(v["on"])
    if on not in (0, 1):
        raise ParameterError(f"switch {on} (0/1)")
    if on and not ft.attached(ctl):
        raise ParameterError(NO_SENSOR)
    if ft.attached(ctl):
        st = ft.state_of(ctl)
        st.enabled = bool(on)
        if on:
            ft.step(ctl, ctl.period)  # the first reading is there at once


def identify_load(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 204: type 1 identifies the flange load from the joint torques (4 fp32: kg, mm),
    on any arm; type 0 the load below the F/T sensor from its readings (10 fp32: kg, centre of
    mass in m, six offsets), which needs the sensor switched on. Either turns the wrist through
    the identification sequence (:mod:`..applications.identification`): the arm must be able to move, and the
    reply (which the server holds until the sequence ends) carries the result."""
    kind = int(v["iden_type"])
    if kind not in (0, 1):
        raise ParameterError("identification type 0/1")
    if kind == 1:
        mass = v.get("mass")
        if mass is not None and not float(mass) >= 0:
            raise ParameterError(f"estimated mass {mass}")
    else:
        _require_enabled(ctl)
    ctl.require_motion_allowed()
    identification.start(ctl, kind, ft)
    return identification.reply(ctl)


def set_load_offset(ctl: Controller, v: Values) -> None:
    """Register 205: the load (kg, centre of mass in m) and the six offsets, stored."""
    cfg = ft_config(ctl)
    cfg.mass, cfg.centroid, cfg.offsets = float(v["mass"]), _floats(v["center"]), _floats(v["offsets"])


def set_zero(ctl: Controller, v: Values) -> None:
    """Register 206: the present reading becomes the zero; needs the sensor switched on."""
    _require_enabled(ctl)
    ft.set_zero(ctl)


def get_config(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 212: the 280-byte configuration: application status (register 202's application:
    0 none, 1 admittance, 2 force control), started (the sensor switched on), sensor type, id and
    rate (zeros with no sensor), then what 205/206 and 207-211 stored."""
    cfg = ft_config(ctl)
    on = ft.attached(ctl)
    return {"app_status": force_control.control_of(ctl).app, "started": int(ft.enabled(ctl)),
            "type": ft.SENSOR_TYPE if on else 0,
            "id": ft.SENSOR_ID if on else 0, "freq": ft.SENSOR_RATE_HZ if on else 0, "mass": cfg.mass,
            "dir_bias": 0.0, "centroid": cfg.centroid, "zero": cfg.offsets,
            "imp_coord": cfg.imp_coord, "imp_c_axis": cfg.imp_c_axis, "M": cfg.M, "K": cfg.K, "B": cfg.B,
            "fc_coord": cfg.fc_coord, "fc_c_axis": cfg.fc_c_axis, "f_ref": cfg.f_ref, "limits": cfg.limits,
            **cfg.pid}


#: The registers of this module, bound (:class:`~xarm_emu.controller.core.interface.Binding`).
BINDINGS: tuple[Binding, ...] = (
    Binding(150, get_data),
    Binding(200, get_data),
    Binding(201, enable),
    Binding(204, identify_load),
    Binding(205, set_load_offset),
    Binding(206, set_zero),
    Binding(212, get_config),
)
