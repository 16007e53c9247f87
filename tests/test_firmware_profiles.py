"""The firmware a box claims (``serve --firmware``, the fleet key, ``running_emulator(firmware=...)``):
register 1's version string and the register table follow it; 1.6.0 is the manual's box."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from xarm_emu.controller.core.interface import WARN_UNKNOWN_COMMAND
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol import registers as regs
from xarm_emu.protocol.firmware import SERVE_VERSION, SUPPORTED_VERSIONS, profile_for
from xarm_emu.server.fleet import FleetError, load_fleet
from xarm_emu.testing import running_emulator


def _version(emu: Emulator) -> str:
    return emu.handle(1, b"")[1].rstrip(b"\0").decode()


@pytest.mark.parametrize("version", SUPPORTED_VERSIONS)
def test_register_1_claims_the_profile_version(version: str) -> None:
    assert _version(Emulator(6, firmware=version)).endswith(f",v{version}")


def test_manual_box_answers_exactly_the_manual_table() -> None:
    emu = Emulator(6)
    assert _version(emu) == "6,6,XI1300,AC1300,v1.6.0"
    assert emu.controller.registers == regs.REGISTERS
    # A register the SDK sends only to later firmware (83, relative move) is unknown here.
    state, reply = emu.handle(83, bytes(30))
    assert reply == b"" and state & 0x20
    assert emu.handle(15, b"")[1][1] == WARN_UNKNOWN_COMMAND


def test_later_profile_has_the_later_table() -> None:
    emu = Emulator(6, firmware="2.7.103")
    assert 83 in emu.controller.registers and 254 in emu.controller.registers
    assert emu.controller.registers == regs.registers_for(profile_for("2.7.103"))


def test_unsupported_version_is_refused() -> None:
    with pytest.raises(ValueError, match="not supported"):
        Emulator(6, firmware="3.0.0")


def test_running_emulator_takes_the_firmware() -> None:
    with running_emulator(firmware="2.4.101") as st:
        assert _version(st.emulator).endswith(",v2.4.101")


def test_fleet_key_firmware(tmp_path: Path) -> None:
    f = tmp_path / "fleet.toml"
    f.write_text('[[arm]]\nfirmware = "2.0.102"\n[[arm]]\nhost = "127.0.0.2"\n')
    fleet = load_fleet(f)
    assert [str(a.firmware) for a in fleet.arms] == ["2.0.102", SERVE_VERSION]  # serve's default
    f.write_text('[[arm]]\nfirmware = 2\n')
    with pytest.raises(FleetError, match="firmware is a version string"):
        load_fleet(f)
    f.write_text('[[arm]]\nfirmware = "9.9.9"\n')
    with pytest.raises(FleetError, match="not supported"):
        load_fleet(f)


def test_cli_refuses_a_bad_firmware_in_one_line() -> None:
    out = subprocess.run([sys.executable, "-m", "xarm_emu.cli", "serve", "--firmware", "banana"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 2
    assert "--firmware" in out.stderr and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("name, firmware, version", [
    ("lite6", "1.6.0", "6,9,LI1006,DL1000,v1.6.0"),
    ("850", "2.4.101", "6,12,FX1202,AC1300,v2.4.101"),
    ("7t", "2.7.103", "7,13,CS1300,AC1300,v2.7.103"),
])
def test_other_arms_identify_themselves(name: str, firmware: str, version: str) -> None:
    """Register 1 of Lite 6, 850 and 7T: axis, robot type, their serial-number prefixes."""
    assert _version(Emulator(name, firmware=firmware)) == version


@pytest.mark.parametrize("name, too_old", [("850", "2.0.102"), ("7t", "2.0.102")])
def test_an_arm_refuses_a_firmware_older_than_it_ships_with(name: str, too_old: str) -> None:
    with pytest.raises(ValueError, match=f"the {Emulator(name, firmware='2.7.103').model.name} arm needs "
                                         "firmware 2.[14].0 or later, not 2.0.102"):
        Emulator(name, firmware=too_old)


def test_cli_refuses_an_unknown_model_in_one_line() -> None:
    out = subprocess.run([sys.executable, "-m", "xarm_emu.cli", "serve", "--model", "9"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and "lite6" in out.stderr and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1
