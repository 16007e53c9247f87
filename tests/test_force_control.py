"""Admittance and force control on the F/T sensor (registers 202, 203, 207-211) in an in-process
box with the sensor mounted (noise off) and the stepped clock: the TCP's motion under a played
external wrench against the mass-spring-damper law, force control pressing on a table plane, the
frames, the state sequence the SDK's examples follow, and refusals."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from xarm_emu.controller.applications import force_control as fc
from xarm_emu.controller.core.interface import PERIOD, WARN_PARAMETER
from xarm_emu.controller.emulator import Emulator
from xarm_emu.controller.scene.contact import Plane, Scene
from xarm_emu.protocol.firmware import profile_for
from xarm_emu.protocol.frame import STATE_FAILED, STATE_WARNING
from xarm_emu.protocol.registers import registers_for

FW = "2.7.103"
TABLE = registers_for(profile_for(FW))
#: A pose with the tool pointing down, clear of singularities and joint limits (rad).
START = (0.0, -0.5, -0.9, 0.0, 1.4, 0.0)
M_LIN, M_ROT = 1.0, 0.005


def call(emu: Emulator, code: int, **values: Any) -> tuple[int, dict[str, Any]]:
    reg = TABLE[code]
    state, reply = emu.handle(code, reg.request.encode(values))
    return state, (reg.reply.decode(reply) if reply or reg.reply.fields else {})


def ok(emu: Emulator, code: int, **values: Any) -> dict[str, Any]:
    state, reply = call(emu, code, **values)
    assert not state & 0x6F, (code, hex(state), emu.controller.warning_code)
    return reply


def box(sensor: bool = True) -> Emulator:
    emu = Emulator(6, firmware=FW, ft_sensor=sensor, ft_noise=False)
    for code, values in ((11, {"joint": 8, "enable": 1}), (19, {"mode": 0}), (12, {"state": 0})):
        call(emu, code, **values)
    call(emu, 23, joints=START + (0.0,), speed=2.0, acc=20.0, mvtime=0.0)
    emu.advance(3.0)
    assert emu.controller.state == 2
    return emu


def start_admittance(emu: Emulator, coord: int, K: float, B: float,
                     axes: tuple[int, ...] = (0, 0, 1, 0, 0, 0)) -> None:
    ok(emu, 207, coord=coord, c_axis=axes, M=[M_LIN] * 3 + [M_ROT] * 3, K=[K] * 3 + [0.0] * 3,
       B=[B] * 3 + [1.0] * 3)
    ok(emu, 201, on=1)
    ok(emu, 202, app=fc.APP_ADMITTANCE)
    assert emu.controller.state == 5  # like a mode change: it starts after the state is set to 0
    ok(emu, 12, state=0)


def tcp(emu: Emulator) -> np.ndarray:
    return np.asarray(emu.controller.tcp_pose(), dtype=float)


def test_constant_force_along_tool_z_moves_as_the_mass_damper_law() -> None:
    emu = box()
    start_admittance(emu, fc.FRAME_TOOL, K=0.0, B=40.0)
    emu.advance(0.2)
    p0 = tcp(emu)
    assert np.allclose(p0, tcp(emu)) and emu.controller.state == 2  # no force: at rest
    axis = emu.controller.tcp_matrix()[:3, 2].copy()  # tool z in the base frame
    emu.apply_wrench([0, 0, 10.0, 0, 0, 0], frame="tool")
    path = []
    for _ in range(150):
        emu.step()
        path.append(float(np.dot(tcp(emu)[:3] - p0[:3], axis)) / 1000.0)  # m along tool z
    tau, v_end = M_LIN / 40.0, 10.0 / 40.0
    # A period acts on the reading the sensor took at the end of the one before: the law starts
    # one period after the wrench, so path[n] (n + 1 periods after it) is the law at n periods.
    for n in (5, 10, 25, 50, 75, 100, 148):
        t = n * PERIOD
        v = (path[n + 1] - path[n - 1]) / (2 * PERIOD)
        a = (path[n + 1] - 2 * path[n] + path[n - 1]) / PERIOD ** 2
        assert path[n] == pytest.approx(v_end * (t - tau * (1 - math.exp(-t / tau))), rel=0.02), n
        assert v == pytest.approx(v_end * (1 - math.exp(-t / tau)), rel=0.02), n
        if n <= 75:  # later the acceleration is below the positions' rounding
            assert a == pytest.approx(10.0 / M_LIN * math.exp(-t / tau), rel=0.02), n
    assert emu.controller.state == 1  # moving
    lateral = tcp(emu)[:3] - p0[:3]
    assert np.linalg.norm(lateral - np.dot(lateral, axis) * axis) < 1e-6  # only along tool z
    assert np.allclose(tcp(emu)[3:], p0[3:], atol=1e-7)  # orientation held
    emu.clear_wrench()
    emu.advance(0.5)
    here = tcp(emu)
    emu.advance(0.5)
    assert np.linalg.norm(tcp(emu)[:3] - here[:3]) < 1e-6  # the damping brought it to rest
    assert emu.controller.state == 2


def test_with_stiffness_it_settles_at_force_over_stiffness_in_the_base_frame() -> None:
    emu = box()
    start_admittance(emu, fc.FRAME_BASE, K=1000.0, B=0.0, axes=(1, 0, 0, 0, 0, 0))
    emu.step()
    p0 = tcp(emu)
    emu.apply_wrench([10.0, 0, 0, 0, 0, 0], frame="base")
    emu.advance(2.0)
    d = tcp(emu)[:3] - p0[:3]
    assert d[0] == pytest.approx(10.0, abs=0.1)  # 10 N / 1000 N/m = 10 mm
    assert abs(d[1]) < 1e-6 and abs(d[2]) < 1e-6
    emu.clear_wrench()
    emu.advance(2.0)
    assert np.linalg.norm(tcp(emu)[:3] - p0[:3]) < 0.1  # the spring brings it back


def test_axes_not_compliant_do_not_yield() -> None:
    emu = box()
    start_admittance(emu, fc.FRAME_TOOL, K=0.0, B=40.0, axes=(0, 0, 1, 0, 0, 0))
    emu.step()
    p0 = tcp(emu)
    emu.apply_wrench([10.0, -10.0, 0, 0.2, 0.2, 0.2], frame="tool")
    emu.advance(0.5)
    assert np.allclose(tcp(emu), p0, atol=1e-6)


def pressing_box(f_ref: float, kp: float, ki: float, kd: float) -> tuple[Emulator, float]:
    emu = box()
    table_z = float(tcp(emu)[2]) - 5.0  # the table 5 mm below the TCP
    emu.set_scene(Scene((Plane("table", (0.0, 0.0, table_z), (0.0, 0.0, 1.0), stiffness=10.0),)))
    ok(emu, 208, kp=[kp] * 6, ki=[ki] * 6, kd=[kd] * 6, xe_limit=[200.0] * 3 + [0.35] * 3)
    ok(emu, 209, coord=fc.FRAME_TOOL, c_axis=(0, 0, 1, 0, 0, 0), f_ref=[0, 0, f_ref, 0, 0, 0], limits=[0] * 6)
    ok(emu, 201, on=1)
    ok(emu, 206)
    ok(emu, 202, app=fc.APP_FORCE)
    ok(emu, 12, state=0)
    return emu, table_z


def test_force_control_presses_on_the_table_with_the_reference_force() -> None:
    emu, table_z = pressing_box(20.0, 0.005, 0.00005, 0.05)  # the gains of the SDK's example 8003
    emu.advance(4.0)
    _, reply = call(emu, 200)
    assert -reply["forces"][2] == pytest.approx(20.0, abs=0.5)  # the table pushes back with 20 N
    depth = table_z - float(tcp(emu)[2])
    assert depth == pytest.approx(2.0, abs=0.05)  # the spring's share: 20 N at 10 N/mm


def test_proportional_force_control_never_passes_the_spring_share() -> None:
    emu, table_z = pressing_box(20.0, 0.005, 0.0, 0.0)
    deepest = -math.inf
    for _ in range(750):
        emu.step()
        deepest = max(deepest, table_z - float(tcp(emu)[2]))
    assert deepest <= 2.0 + 0.02
    assert deepest == pytest.approx(2.0, abs=0.02)
    assert -float(call(emu, 200)[1]["forces"][2]) == pytest.approx(20.0, abs=0.5)


def test_application_reads_back_and_needs_the_sensor_switched_on() -> None:
    emu = box()
    state, _ = call(emu, 202, app=1)
    assert state & STATE_FAILED and not state & STATE_WARNING  # switched off: cannot be carried out
    assert ok(emu, 203) == {"app": 0}
    ok(emu, 201, on=1)
    ok(emu, 202, app=2)
    assert ok(emu, 203) == {"app": 2}
    ok(emu, 202, app=0)
    assert ok(emu, 203) == {"app": 0}
    bare = box(sensor=False)
    state, _ = call(bare, 202, app=1)
    assert state & STATE_FAILED
    assert ok(bare, 203) == {"app": 0}
    assert bare.controller.state == 2  # nothing changed


def test_switching_the_sensor_off_ends_the_application() -> None:
    emu = box()
    start_admittance(emu, fc.FRAME_TOOL, K=0.0, B=40.0)
    emu.apply_wrench([0, 0, 10.0, 0, 0, 0])
    emu.advance(0.1)
    ok(emu, 201, on=0)
    emu.advance(0.02)
    here = tcp(emu)
    emu.advance(0.2)
    assert np.allclose(tcp(emu), here)
    assert ok(emu, 203) == {"app": 0}


@pytest.mark.parametrize("code, values", [
    (207, {"coord": 1, "c_axis": (0, 0, 1, 0, 0, 0), "M": [0.01] * 3 + [0.001] * 3, "K": [0.0] * 6,
           "B": [0.0] * 6}),
    (210, {"M": [0.06] * 3 + [0.001] * 3, "K": [0.0] * 5 + [20.5], "B": [0.0] * 6}),
    (210, {"M": [0.06] * 3 + [0.001] * 3, "K": [0.0] * 6, "B": [-1.0] + [0.0] * 5}),
    (208, {"kp": [0.06] * 6, "ki": [0.0] * 6, "kd": [0.0] * 6, "xe_limit": [100.0] * 6}),
    (208, {"kp": [0.0] * 6, "ki": [0.0] * 6, "kd": [0.0] * 6, "xe_limit": [250.0] * 6}),
    (209, {"coord": 1, "c_axis": (0, 0, 1, 0, 0, 0), "f_ref": [0, 0, 201.0, 0, 0, 0], "limits": [0] * 6}),
    (211, {"coord": 2, "c_axis": (0, 0, 1, 0, 0, 0)}),
    (211, {"coord": 0, "c_axis": (0, 0, 2, 0, 0, 0)}),
])
def test_parameters_outside_the_vendor_ranges_get_warning_12_and_change_nothing(
        code: int, values: dict[str, Any]) -> None:
    emu = box()
    before = ok(emu, 212)
    state, _ = call(emu, code, **values)
    assert state & STATE_WARNING and emu.controller.warning_code == WARN_PARAMETER
    assert call(emu, 212)[1] == before


def test_pushed_out_of_reach_it_stops_at_the_edge_and_comes_back() -> None:
    emu = box()
    start_admittance(emu, fc.FRAME_BASE, K=0.0, B=20.0, axes=(1, 0, 0, 0, 0, 0))
    emu.apply_wrench([20.0, 0, 0, 0, 0, 0], frame="base")  # 1 m/s outward: past the reach in 1 s
    emu.advance(2.0)
    edge = tcp(emu)
    emu.advance(0.2)
    assert np.allclose(tcp(emu), edge)  # stopped where the joints could follow no further
    assert emu.controller.error_code == 0 and emu.controller.state == 2
    assert ok(emu, 203) == {"app": 1}
    ctl = emu.controller
    assert float(np.max(np.abs(ctl.qd))) < 1e-9
    emu.clear_wrench()
    emu.apply_wrench([-20.0, 0, 0, 0, 0, 0], frame="base")
    emu.advance(0.5)
    assert tcp(emu)[0] < edge[0] - 50.0  # pulled back, it follows again


def test_joint_speeds_stay_within_the_limit_under_a_large_torque() -> None:
    emu = box()
    ok(emu, 207, coord=fc.FRAME_TOOL, c_axis=(0, 0, 0, 0, 0, 1), M=[M_LIN] * 3 + [0.0001] * 3,
       K=[0.0] * 6, B=[40.0] * 3 + [0.01] * 3)
    ok(emu, 201, on=1)
    ok(emu, 202, app=fc.APP_ADMITTANCE)
    ok(emu, 12, state=0)
    emu.apply_wrench([0, 0, 0, 0, 0, 4.0])  # 400 rad/s asked of the tool's roll
    fastest = 0.0
    for _ in range(100):
        emu.step()
        fastest = max(fastest, float(np.max(np.abs(emu.controller.qd))))
    assert fastest <= emu.controller.model.max_joint_speed * 1.001
    assert fastest > 0.9 * emu.controller.model.max_joint_speed  # it turns as fast as it may


def test_a_queued_move_runs_during_admittance_and_the_law_starts_again_after_it() -> None:
    emu = box()
    start_admittance(emu, fc.FRAME_BASE, K=1000.0, B=0.0, axes=(0, 0, 1, 0, 0, 0))
    emu.step()
    target = tcp(emu) + np.array([0.0, 30.0, 0, 0, 0, 0])
    ok(emu, 21, pose=tuple(target), speed=100.0, acc=1000.0, mvtime=0.0)
    emu.advance(1.5)
    assert tcp(emu)[:3] == pytest.approx(target[:3], abs=1e-3)
    p0 = tcp(emu)
    emu.apply_wrench([0, 0, 5.0, 0, 0, 0], frame="base")
    emu.advance(2.0)
    assert tcp(emu)[2] - p0[2] == pytest.approx(5.0, abs=0.1)  # from where the move left it


def test_the_tool_frame_follows_the_tcp_offset_rotation() -> None:
    emu = box()
    ok(emu, 35, pose=(0.0, 0.0, 50.0, 0.0, 0.0, math.pi / 2))  # tool x = flange y, tool y = -flange x
    emu.advance(0.1)
    ok(emu, 12, state=0)
    start_admittance(emu, fc.FRAME_TOOL, K=0.0, B=40.0, axes=(0, 1, 0, 0, 0, 0))  # tool y only
    emu.step()
    p0 = tcp(emu)
    flange_x = emu.controller.tcp_matrix()[:3, 1].copy() * -1.0  # -tool y, in the base frame
    emu.apply_wrench([10.0, 0, 0, 0, 0, 0], frame="tool")  # along the sensor's (flange's) x
    emu.advance(0.3)
    d = tcp(emu)[:3] - p0[:3]
    assert float(np.dot(d, flange_x)) > 30.0  # it yields along flange x, which is tool -y
    assert np.linalg.norm(d - np.dot(d, flange_x) * flange_x) < 1e-6


def test_a_checkpoint_holds_the_application_mid_motion() -> None:
    emu = box()
    start_admittance(emu, fc.FRAME_TOOL, K=300.0, B=40.0)
    emu.apply_wrench([0, 0, 10.0, 0, 0, 0])
    emu.advance(0.1)
    cp = emu.checkpoint()
    emu.advance(0.3)
    later = tcp(emu)
    emu.restore(cp)
    assert ok(emu, 203) == {"app": 1}
    emu.advance(0.3)
    assert tcp(emu) == pytest.approx(later, abs=1e-9)
