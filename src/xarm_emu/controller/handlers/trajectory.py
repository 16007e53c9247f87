"""Trajectory registers (61-65, 230): recording, saving, loading, playback and its speed check.
The mechanism is :mod:`xarm_emu.controller.applications.trajectory`."""

from __future__ import annotations

from typing import Any

from ..applications import trajectory as traj
from ..core.controller_protocol import Controller
from ..core.interface import Binding, CommandWarning, NotReady, ParameterError, Values
from ..core.state_machine import STATE_SLEEP


def set_record(ctl: Controller, v: Values) -> None:
    """Register 61: ``[1]`` starts recording the joints, ``[0]`` stops."""
    on = int(v["on"])
    if on not in (0, 1):
        raise ParameterError("record switch is 0 or 1")
    traj.set_recording(ctl, bool(on))
    return None


def _name(v: Values) -> str:
    name = str(v["filename"])
    if not name:
        raise ParameterError("empty trajectory name")
    return name


def save(ctl: Controller, v: Values) -> None:
    """Register 62: save the recording (register 65 then reads 5, or 6 when it failed)."""
    traj.save(ctl, _name(v))
    return None


def load(ctl: Controller, v: Values) -> None:
    """Register 63: load a saved trajectory (register 65 then reads 2, or 3 when it failed)."""
    traj.load(ctl, _name(v))
    return None


def play(ctl: Controller, v: Values) -> None:
    """Register 64: play the loaded trajectory ``times`` times (-1 forever) at a factor 1, 2 or 4.
    Only from position mode at rest; mode 11 during playback."""
    times = int(v["times"])
    factor = int(v.get("speed", 1)) if ctl.firmware.play_traj_speed else 1
    if times == 0 or times < -1 or factor not in traj.SPEED_FACTORS:
        raise ParameterError("times is -1 or >= 1, the speed factor 1, 2 or 4")
    st = traj.store_of(ctl)
    if st.loaded is None:
        raise CommandWarning(message="no trajectory loaded")
    if (ctl.error_code or not ctl.ready or ctl.mode != 0 or ctl.motion_state != STATE_SLEEP
            or ctl.executor.active):
        raise NotReady()
    try:
        traj.start_playback(ctl, times, factor)
    except traj.TrajectoryError as exc:
        raise ParameterError(str(exc)) from exc
    return None


def rw_status(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 65: status of the last save or load."""
    return {"status": traj.store_of(ctl).status}


def speeding(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 230: whether the loaded trajectory played at ``rate`` exceeds the joint speed
    limit: (result 0 within / 1 above, joint 1-based, peak speed rad/s)."""
    rate = int(v["rate"])
    if rate not in traj.SPEED_FACTORS:
        raise ParameterError("rate is 1, 2 or 4")
    joint, speed = traj.peak_speed(ctl, rate)
    over = speed > ctl.model.max_joint_speed
    return {"result": 1 if over else 0, "servo_id": joint if over else 0, "speed": speed}


#: The registers of this module, bound (:class:`~xarm_emu.controller.core.interface.Binding`).
BINDINGS: tuple[Binding, ...] = (
    Binding(61, set_record),
    Binding(62, save),
    Binding(63, load),
    Binding(64, play),
    Binding(65, rw_status),
    Binding(230, speeding),
)
