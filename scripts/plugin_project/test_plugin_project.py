"""A user's test file in a scratch project outside the xarm-emu checkout, where only the installed
package provides the pytest plugin (``scripts/plugin-check`` copies it there and runs it once per
firmware profile). Each test runs on every profile the command line gives."""

from __future__ import annotations

import asyncio

import pytest


def test_the_sdk_moves_the_arm(xarm_sdk, xarm_settings):
    """The official SDK's start sequence and a joint move with ``wait=True``, read back."""
    major, minor, patch = (int(x) for x in xarm_settings["firmware"].split("."))
    assert tuple(xarm_sdk.version_number) == (major, minor, patch)
    assert xarm_sdk.motion_enable(True) == 0
    assert xarm_sdk.set_mode(0) == 0
    assert xarm_sdk.set_state(0) == 0
    assert xarm_sdk.set_servo_angle(angle=[10, 0, 0, 0, 0, 0], speed=50, wait=True) == 0
    code, angles = xarm_sdk.get_servo_angle()
    assert code == 0 and angles[0] == pytest.approx(10, abs=0.01)


def test_the_async_client_reads_the_version(xarm_async_client, xarm_settings):
    async def version():
        async with xarm_async_client() as client:
            return await client.get_version()

    assert asyncio.run(version()).endswith("v" + xarm_settings["firmware"])


@pytest.mark.xarm(model="lite6", speed=5.0, vacuum=True)
def test_the_marker_sets_the_box(xarm_emulator, xarm_settings):
    assert xarm_emulator.emulator.model.name == "Lite6"
    assert xarm_emulator.server.config.speed == 5.0
    assert str(xarm_emulator.emulator.firmware) == xarm_settings["firmware"]
