"""The firmware a box claims (``serve --firmware``, the fleet key, ``running_emulator(firmware=...)``):
register 1's version string and the register table follow it; 1.6.0 is the manual's box."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from xarm_emu.controller.base import WARN_UNKNOWN_COMMAND
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol import registers as regs
from xarm_emu.protocol.firmware import SUPPORTED_VERSIONS, profile_for
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
    assert [str(a.firmware) for a in fleet.arms] == ["2.0.102", "1.6.0"]
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
