"""The one rule for the parts of a box (protocol/firmware.py ``PARTS``, ``check_parts``): a part the
chosen firmware cannot drive is refused the same way for every part, by ``serve`` (one line, exit 2,
before any port opens), by a fleet file and by the in-process ``Emulator``. The SDK documents its linear
motor calls from firmware 1.8.0 and every F/T call from 1.8.3; the UFACTORY 850 ships with 2.1.0 and
the xArm 7T with 2.4.0. The grippers on the tool RS-485 (register 124 of the manual) and on the tool
IO every firmware drives."""

from __future__ import annotations

import pytest
from helpers import run_cli

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.firmware import FirmwareRefusal
from xarm_emu.server.fleet import FleetError, parse_fleet

#: (serve options, the part as refused, the firmware it needs, the firmware asked for)
REFUSED = [
    (["--linear-track"], "linear track", "1.8.0", "1.6.0"),
    (["--ft-sensor"], "F/T sensor", "1.8.3", "1.6.0"),
    (["--model", "850"], "850 arm", "2.1.0", "2.0.102"),
    (["--model", "7t"], "xArm7T arm", "2.4.0", "2.0.102"),
]


@pytest.mark.parametrize("options, part, need, asked", REFUSED)
def test_serve_refuses_every_part_in_the_same_words(options: list[str], part: str, need: str,
                                                   asked: str) -> None:
    code, out = run_cli("serve", "--firmware", asked, *options, "--port", "0")
    assert code == 2 and "Traceback" not in out
    assert out.strip() == f"--firmware: the {part} needs firmware {need} or later, not {asked}"


FT_REFUSED = r"the F/T sensor needs firmware 1\.8\.3 or later, not 1\.6\.0$"


def test_the_emulator_and_a_fleet_refuse_with_the_same_line() -> None:
    with pytest.raises(FirmwareRefusal, match="^" + FT_REFUSED):
        Emulator(6, ft_sensor=True)
    with pytest.raises(FirmwareRefusal, match=r"^the linear track needs firmware 1\.8\.0 or later, not"):
        Emulator(6, linear_track=700)
    emu = Emulator(6)
    with pytest.raises(FirmwareRefusal, match="F/T sensor needs firmware 1.8.3"):
        emu.attach_ft_sensor()  # mounted later: the same rule
    assert not emu.has_ft_sensor
    with pytest.raises(FleetError, match="^arm 1: " + FT_REFUSED):
        parse_fleet({"arm": [{"ft_sensor": True, "firmware": "1.6.0", "port": 0}]})


@pytest.mark.parametrize("firmware", ["1.11.100", "2.7.103"])
def test_a_firmware_that_drives_them_takes_every_part(firmware: str) -> None:
    emu = Emulator(6, firmware=firmware, ft_sensor=True, linear_track=700)
    assert emu.has_ft_sensor and emu.linear_track is not None
    assert 200 in emu.controller.registers and 150 in emu.controller.registers


@pytest.mark.parametrize("gripper", ["xarm", "robotiq-2f85", "robotiq-2f140", "bio", "bio-g1",
                                     "inspire-rh56"])
def test_every_firmware_drives_the_grippers(gripper: str) -> None:
    from xarm_emu.cli.serve import checked_arm

    profile, _ = checked_arm("6", "1.6.0", None, None, gripper, False)
    assert str(profile) == "1.6.0"
    assert Emulator(6, firmware="1.6.0", gripper=gripper).gripper_kind == gripper
    assert Emulator("lite6", firmware="1.6.0").lite6_gripper is not None
    assert Emulator(6, firmware="1.6.0", vacuum=True).vacuum is not None
