"""The admin table (server/admin.py): every command of the wire protocol has one row, every argument
a row declares is checked before anything changes, and a fault schedule accepts exactly those."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from xarm_emu.controller.devices.linear_track import TRACK_ERRORS
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol import codes
from xarm_emu.protocol.admin import COMMANDS
from xarm_emu.server.admin import SCHEDULABLE, TABLE, AdminError, arguments, prepare
from xarm_emu.server.faults import FaultScheduleError, parse_schedule


class Target:
    """Just what an admin request needs of a server (lockstep, so that ``step`` is allowed)."""

    stepped = True
    reply_delay = 0.0

    def __init__(self, emulator: Emulator) -> None:
        self.emulator, self.checkpoints = emulator, {"kept": emulator.checkpoint()}

    def advance(self, seconds: float) -> int:
        return 0

    def pause_reports(self, seconds: float) -> None: ...

    def reports_paused(self) -> bool:
        return False

    def set_reply_delay(self, seconds: float) -> None: ...

    def clear_delays(self) -> None: ...

    def drop_clients(self) -> int:
        return 0


#: A request each command accepts on an xArm 6 with a linear track and an F/T sensor (the physics
#: world's commands need objects and MuJoCo: tested in test_physics_scene.py).
VALID: dict[str, dict[str, Any]] = {
    "estop": {}, "error": {"code": "C31"}, "warning": {"code": 11},
    "servo-error": {"joint": 2, "code": "S23"}, "gripper-error": {"code": min(codes.GRIPPER_ERRORS)},
    "track-error": {"code": min(TRACK_ERRORS)}, "end-module-lost": {}, "collision": {"joint": 1, "torque": 5},
    "report-pause": {"seconds": "50ms"}, "reply-delay": {"seconds": 0.01}, "drop-clients": {}, "clear": {},
    "set-input": {"kind": "cgpio", "index": 0, "value": 1}, "status": {}, "step": {"seconds": 0.004},
    "ft-error": {"code": 1}, "ft-noise": {"on": True}, "payload": {"mass": 0.5, "com": [0, 0, 10]},
    "scene": {"scene": {"plane": []}}, "checkpoint-save": {"name": "a"},
    "checkpoint-restore": {"name": "kept"}, "checkpoint-list": {},
}
WRENCH = {"kind": "ft", "wrench": [0, 0, 1, 0, 0, 0], "frame": "base", "ramp": 0.1, "for": 1.0}


@pytest.fixture
def target(tmp_path: Path) -> Target:
    return Target(Emulator(6, config_dir=tmp_path, firmware="2.7.103", linear_track=700, ft_sensor=True))


def test_every_command_has_one_row_in_the_wire_order() -> None:
    assert tuple(TABLE) == COMMANDS


def requests() -> list[tuple[str, dict[str, Any]]]:
    return [*VALID.items(), ("set-input", WRENCH)]


@pytest.mark.parametrize("cmd, args", requests(), ids=[f"{c}-{a.get('kind', '')}" for c, a in requests()])
def test_every_declared_argument_is_checked_before_anything_changes(target: Target, cmd: str,
                                                                     args: dict[str, Any]) -> None:
    assert callable(prepare(target, {"cmd": cmd, **args}))  # the valid request is accepted
    before = (target.emulator.snapshot(), dict(target.checkpoints))
    for name in args:
        if name == "kind":
            continue  # another kind is another form of set-input
        with pytest.raises(AdminError) as info:
            prepare(target, {"cmd": cmd, **args, name: {"not": "valid"}})
        assert "\n" not in str(info.value) and str(info.value)
    assert (target.emulator.snapshot(), dict(target.checkpoints)) == before


def test_a_schedule_takes_the_declared_arguments_and_no_other() -> None:
    for cmd in sorted(SCHEDULABLE):
        entry = {"at": 1.0, "do": cmd, **dict.fromkeys(arguments(cmd), 0)}
        assert parse_schedule({"fault": [entry]}) == [entry]
        refusal = f"fault 1 \\({cmd}\\): unknown key 'colour'; known: at, "
        with pytest.raises(FaultScheduleError, match=refusal):
            parse_schedule({"fault": [{**entry, "colour": 1}]})
    assert arguments("set-input") == ("kind", "wrench", "frame", "ramp", "for", "index", "value")


def test_the_inspire_hand_takes_an_error_byte_not_the_xarm_grippers_codes(tmp_path: Path) -> None:
    """The RH56 hand has no table of named codes: gripper-error takes an error byte 1..255, which its
    fingers then report (not the xArm gripper's section 3.3 table, which names other faults)."""
    target = Target(Emulator(6, config_dir=tmp_path, gripper="inspire-rh56"))
    device = target.emulator.gripper.device
    assert prepare(target, {"cmd": "gripper-error", "code": 3})() == "injected gripper G3 error byte"
    assert device.error == 3 and device.data.errors == [3] * 6
    for bad in (0, 256):
        with pytest.raises(AdminError, match="an error byte of the inspire-rh56 hand is 1..255"):
            prepare(target, {"cmd": "gripper-error", "code": bad})
    with pytest.raises(AdminError, match="is not an error code of the xarm gripper"):
        prepare(Target(Emulator(6, config_dir=tmp_path)), {"cmd": "gripper-error", "code": 3})
