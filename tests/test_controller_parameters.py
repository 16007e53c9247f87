"""Parameter bounds (bad input gets the manual's warning 12): float parameters out of any sensible range,
the payload of register 36, and saved settings that a register would have refused."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import pytest
from helpers import bits, call, joints7, ready

from xarm_emu.controller.core.config import ConfigStore
from xarm_emu.controller.core.interface import PARAMETER_LIMIT
from xarm_emu.controller.core.settings import Settings
from xarm_emu.controller.emulator import Emulator
from xarm_emu.model.robots import MODELS
from xarm_emu.protocol import reports
from xarm_emu.protocol.layouts import Layout, LayoutError, fp32
from xarm_emu.protocol.registers import REGISTERS, Flag


def float_layout(code: int) -> Layout | None:
    """The first request layout of a register (each option of a multi-form one) with an fp32 field."""
    request = REGISTERS[code].request
    for layout in getattr(request, "options", None) or (request,):
        if any(f.kind == "fp32" for f in layout.fields):
            return layout
    return None


FLOAT_REGISTERS = sorted(
    code for code, reg in REGISTERS.items()
    if float_layout(code) is not None and not reg.flags & Flag.ANY_FLOAT and code not in (10, 39, 40))


def warning(emu: Emulator) -> int:
    return int(call(emu, 15)[1]["warning"])


@pytest.mark.parametrize("code", FLOAT_REGISTERS)
@pytest.mark.parametrize("value", [2.0 * PARAMETER_LIMIT, -3.0e38, math.nan, math.inf])
def test_out_of_range_float_is_warning_12_on_every_register(code: int, value: float) -> None:
    emu = Emulator(6)
    emu.controller.strict = True
    ready(emu)
    before = emu.controller.settings.to_dict()
    reg = REGISTERS[code]
    layout = float_layout(code)
    assert layout is not None
    raw = b"".join(
        struct.pack("<" + "f" * f.count, *([value] * f.count)) if f.kind == "fp32" else bytes(f.size)
        for f in layout.fields)
    state, reply = emu.handle(code, raw)
    assert bits(state)[1], code
    assert warning(emu) == 12
    assert reg.reply.accepts(len(reply))
    assert emu.controller.settings.to_dict() == before  # nothing was taken over
    assert emu.controller.executor.cmdnum == 0


def test_register_45_still_answers_for_any_float() -> None:
    emu = Emulator(6)
    state, reply = call(emu, 45, joints=joints7(math.nan))
    assert reply["limited"] == 1 and not bits(state)[1]
    assert call(emu, 45, joints=joints7(3.0e38))[1]["limited"] == 1


def test_manual_payload_example_is_taken_and_changes_the_torques() -> None:
    emu = Emulator(6)
    ready(emu)
    unloaded = call(emu, 55)[1]["torques"]
    state, _ = call(emu, 36, mass=1.0, center=(400.0, 0.0, 200.0))  # manual 2.1.4 example
    assert not bits(state)[1]
    assert emu.controller.settings.tcp_load == [1.0, 400.0, 0.0, 200.0]
    loaded = call(emu, 55)[1]["torques"]
    # at zero joints the 1 kg at x = 400 mm pulls J2 by about 9.81 N * (0.4 + reach) more
    assert abs(loaded[1] - unloaded[1]) > 3.0
    assert all(math.isfinite(t) for t in loaded)


@pytest.mark.parametrize("dof", sorted(MODELS))
def test_payload_above_the_rated_payload_is_refused(dof: int) -> None:
    emu = Emulator(dof)
    rated = MODELS[dof].rated_payload
    assert not bits(call(emu, 36, mass=rated, center=(0.0, 0.0, 50.0))[0])[1]
    state, _ = call(emu, 36, mass=rated + 0.5, center=(0.0, 0.0, 50.0))
    assert bits(state)[1] and warning(emu) == 12
    assert emu.controller.settings.tcp_load == [rated, 0.0, 0.0, 50.0]


@pytest.mark.parametrize("mass, center", [(-0.1, (0.0, 0.0, 0.0)), (1.0, (0.0, 1500.0, 0.0)),
                                          (1.0, (0.0, 0.0, -1001.0))])
def test_negative_mass_or_far_centre_of_mass_is_refused(mass: float, center: tuple[float, ...]) -> None:
    emu = Emulator(6)
    state, _ = call(emu, 36, mass=mass, center=center)
    assert bits(state)[1] and warning(emu) == 12
    assert emu.controller.settings.tcp_load == [0.0, 0.0, 0.0, 0.0]


def test_huge_payload_then_torque_query_cannot_break_the_reply() -> None:
    """The sequence a fuzzer found: a 5.6e14 kg payload, then register 55."""
    emu = Emulator(6)
    emu.controller.strict = True
    state, _ = emu.handle(36, bytes.fromhex("00000058 00004c6a 00000000 00000000"))
    assert bits(state)[1]
    state, reply = call(emu, 55)
    assert all(math.isfinite(t) and abs(t) < 1e3 for t in reply["torques"])


def test_saved_settings_a_register_would_refuse_keep_their_defaults(tmp_path: Path) -> None:
    emu = Emulator(6, config_dir=tmp_path)
    call(emu, 37, sensitivity=4)
    call(emu, 40)
    store = ConfigStore(tmp_path, emu.controller.robot_sn)
    data = store.load()
    assert data is not None
    data.update(tcp_load=[5.6e14, 0.0, 0.0, 0.0], tcp_offset=[0.0, 0.0, "x", 0.0, 0.0, 0.0],
                world_offset=[1.0, 2.0], boundary_on="yes", teach_sensitivity=9, joint_jerk=0.0,
                gravity_direction=[0.0, 0.0, 0.0], boundary=[0, 100, 0, -100, 100, -100])
    data["collision_sensitivity"] = 4.0  # an integral float is taken, as the int it stands for
    store.save(data)
    again = Emulator(6, config_dir=tmp_path)
    s, defaults = again.controller.settings, Settings.for_model(again.model)
    assert s.collision_sensitivity == 4  # the valid value is kept
    for name in ("tcp_load", "tcp_offset", "world_offset", "boundary_on", "teach_sensitivity", "joint_jerk",
                 "gravity_direction", "boundary"):
        assert getattr(s, name) == getattr(defaults, name), name
    assert type(s.collision_sensitivity) is int
    reports.encode_normal(again.snapshot())
    reports.encode_rich(again.snapshot())
    assert all(math.isfinite(t) for t in call(again, 55)[1]["torques"])


def test_float_too_large_for_fp32_is_a_layout_error() -> None:
    layout = Layout((fp32("x"),))
    with pytest.raises(LayoutError, match="'x'"):
        layout.encode(x=1e39)
    assert layout.encode(x=3.0e38) == struct.pack("<f", 3.0e38)


@pytest.mark.parametrize("code, key, name", [(31, "jerk", "tcp_jerk"), (32, "maxacc", "tcp_maxacc"),
                                             (33, "jerk", "joint_jerk"), (34, "maxacc", "joint_maxacc")])
def test_zero_jerk_or_acceleration_limit_is_refused_and_motion_still_plans(code: int, key: str,
                                                                           name: str) -> None:
    """Table 1.2 starts at 0, but a zero limit leaves nothing to plan: warning 12 (a fuzzer found a
    zero joint jerk followed by a home move)."""
    emu = Emulator(6)
    emu.controller.strict = True
    ready(emu)
    before = getattr(emu.controller.settings, name)
    state, _ = call(emu, code, **{key: 0.0})
    assert bits(state)[1] and warning(emu) == 12
    assert getattr(emu.controller.settings, name) == before
    call(emu, 17)
    call(emu, 23, joints=joints7(0.3), speed=1.0, acc=5.0, mvtime=0.0)
    call(emu, 21, pose=(300.0, 0.0, 200.0, math.pi, 0.0, 0.0), speed=200.0, acc=2000.0, mvtime=0.0)
    emu.advance(4.0)
    assert emu.controller.error_code == 0 and emu.controller.state == 2
