"""Motion through the controller (manual 2.1.3): end points, paths and timing, sampled every control
period with the stepped clock."""

from __future__ import annotations

import math

import numpy as np
import pytest
import ruckig
from helpers import bits, call, joints7, ready

from xarm_emu.controller.core.interface import PERIOD
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol import reports

ROLL = math.pi


@pytest.fixture
def emu() -> Emulator:
    e = Emulator(6)
    ready(e)
    return e


def run_until_idle(emu: Emulator, limit: float = 30.0) -> list[np.ndarray]:
    """Step until the buffer is empty and the arm rests; returns the TCP pose at every period."""
    poses = []
    t = 0.0
    while t < limit:
        emu.step()
        t += PERIOD
        poses.append(emu.controller.tcp_pose())
        if emu.controller.executor.cmdnum == 0 and emu.controller.state == 2:
            break
    else:
        raise AssertionError("motion did not finish")
    return poses


def line(emu: Emulator, x: float, y: float, z: float, speed: float = 200.0, acc: float = 2000.0,
         radius: float | None = None) -> dict:
    pose = (x, y, z, ROLL, 0.0, 0.0)
    if radius is None:
        return call(emu, 21, pose=pose, speed=speed, acc=acc, mvtime=0.0)[1]
    return call(emu, 22, pose=pose, speed=speed, acc=acc, mvtime=0.0, radius=radius)[1]


def dist_to_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    ab = b - a
    u = float(np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + u * ab)))


def test_joint_move_ends_on_target_with_ideal_jerk_limited_duration(emu: Emulator) -> None:
    target = np.array([0.8, -0.3, -0.5, 0.4, 0.6, -0.2])
    speed, acc = 0.8, 6.0
    call(emu, 23, joints=joints7(*target), speed=speed, acc=acc, mvtime=0.0)
    steps = 0
    while emu.controller.executor.cmdnum:
        emu.step()
        steps += 1
    np.testing.assert_allclose(emu.controller.q, target.astype(np.float32), atol=1e-7)
    # Ideal time-optimal jerk-limited profile with the same limits (ruckig, independent call).
    otg = ruckig.Ruckig(6)
    inp = ruckig.InputParameter(6)
    inp.current_position = [0.0] * 6
    inp.target_position = [float(np.float32(x)) for x in target]
    inp.max_velocity = [float(np.float32(speed))] * 6
    inp.max_acceleration = [float(np.float32(acc))] * 6
    inp.max_jerk = [emu.controller.settings.joint_jerk] * 6
    traj = ruckig.Trajectory(6)
    otg.calculate(inp, traj)
    assert steps * PERIOD == pytest.approx(traj.duration, rel=0.05)


def test_linear_move_stays_on_the_straight_line(emu: Emulator) -> None:
    start = emu.controller.tcp_pose()
    reply = line(emu, 350.0, 120.0, 250.0)
    assert reply["cmdnum"] == 1
    poses = run_until_idle(emu)
    a, b = start[:3], np.array([350.0, 120.0, 250.0])
    worst = max(dist_to_segment(p[:3], a, b) for p in poses)
    assert worst < 1e-3
    end = emu.controller.tcp_pose()
    np.testing.assert_allclose(end[:3], b, atol=0.01)
    assert abs(abs(end[3]) - math.pi) < 1e-5 and abs(end[4]) < 1e-5 and abs(end[5]) < 1e-5


def test_linear_move_speed_is_the_commanded_linear_speed(emu: Emulator) -> None:
    line(emu, 207.0, 0.0, 412.0, speed=100.0, acc=5000.0)  # 300 mm straight up
    poses = run_until_idle(emu)
    z = np.array([p[2] for p in poses])
    v = np.diff(z) / PERIOD
    assert v.max() == pytest.approx(100.0, rel=0.01)
    assert np.all(v <= 100.0 * 1.001)


def test_blended_corner_never_stops_and_stays_within_radius(emu: Emulator) -> None:
    radius = 30.0
    line(emu, 300.0, 0.0, 112.0, radius=radius)
    line(emu, 300.0, 150.0, 112.0)
    assert emu.controller.executor.cmdnum == 2
    poses = run_until_idle(emu)
    pts = np.array([p[:3] for p in poses])
    speeds = np.linalg.norm(np.diff(pts, axis=0), axis=1) / PERIOD
    corner = np.array([300.0, 0.0, 112.0])
    near = np.linalg.norm(pts[1:] - corner, axis=1) < 2 * radius
    assert near.any()
    assert speeds[near].min() > 50.0  # does not stop at the corner
    closest = np.linalg.norm(pts - corner, axis=1).min()
    assert closest > 1.0  # the corner itself is cut
    for p in pts:  # every point is on a line or within the blend radius of the corner
        d_line = min(dist_to_segment(p, np.array([207.0, 0.0, 112.0]), corner),
                     dist_to_segment(p, corner, np.array([300.0, 150.0, 112.0])))
        assert d_line < 1e-3 or np.linalg.norm(p - corner) <= radius + 1e-6
    np.testing.assert_allclose(pts[-1], [300.0, 150.0, 112.0], atol=0.01)


def test_circle_points_lie_on_circle_and_cover_the_percentage(emu: Emulator) -> None:
    # Start at (300, 0, 200): move there first.
    line(emu, 300.0, 0.0, 200.0)
    run_until_idle(emu)
    p1 = (350.0, 50.0, 200.0, ROLL, 0.0, 0.0)
    p2 = (400.0, 0.0, 200.0, ROLL, 0.0, 0.0)
    state, reply = call(emu, 27, pose1=p1, pose2=p2, speed=100.0, acc=2000.0, mvtime=0.0, percent=50.0)
    assert state == 0 and reply["cmdnum"] == 1
    poses = run_until_idle(emu)
    centre = np.array([350.0, 0.0, 200.0])
    pts = np.array([p[:3] for p in poses])
    r = np.linalg.norm(pts - centre, axis=1)
    assert np.max(np.abs(r - 50.0)) < 0.1
    np.testing.assert_allclose(pts[:, 2], 200.0, atol=0.1)
    np.testing.assert_allclose(pts[-1], [400.0, 0.0, 200.0], atol=0.01)  # half the circle


def test_collinear_circle_is_error_c32(emu: Emulator) -> None:
    p1 = (250.0, 0.0, 112.0, ROLL, 0.0, 0.0)
    p2 = (300.0, 0.0, 112.0, ROLL, 0.0, 0.0)
    call(emu, 27, pose1=p1, pose2=p2, speed=100.0, acc=2000.0, mvtime=0.0, percent=50.0)
    emu.step()
    assert call(emu, 15)[1]["error"] == 32


def test_unreachable_line_target_is_kinematic_error(emu: Emulator) -> None:
    line(emu, 2000.0, 0.0, 112.0)
    emu.step()
    assert call(emu, 15)[1]["error"] == 21
    assert call(emu, 14)[1]["cmdnum"] == 0


def test_go_home_returns_to_zero(emu: Emulator) -> None:
    call(emu, 23, joints=joints7(0.5, 0.2, -0.4, 0.1, 0.3, 0.2), speed=1.0, acc=10.0, mvtime=0.0)
    state, reply = call(emu, 25, speed=1.0, acc=10.0, mvtime=0.0)
    assert reply["cmdnum"] == 2
    run_until_idle(emu)
    np.testing.assert_allclose(emu.controller.q, 0.0, atol=1e-9)


def test_dwell_pauses_the_queue(emu: Emulator) -> None:
    call(emu, 26, seconds=0.5)
    call(emu, 23, joints=joints7(0.1), speed=1.0, acc=10.0, mvtime=0.0)
    emu.advance(0.48)
    assert emu.controller.q[0] == 0.0
    emu.advance(1.0)
    assert emu.controller.q[0] == pytest.approx(0.1, abs=1e-7)


def test_tool_frame_line_moves_along_tool_z(emu: Emulator) -> None:
    # At the zero pose the tool z axis points down: +50 mm along tool z lowers the TCP by 50 mm.
    call(emu, 28, pose=(0.0, 0.0, 50.0, 0.0, 0.0, 0.0), speed=100.0, acc=2000.0, mvtime=0.0)
    run_until_idle(emu)
    np.testing.assert_allclose(emu.controller.tcp_pose()[:3], [207.0, 0.0, 62.0], atol=0.01)


def test_axis_angle_relative_line(emu: Emulator) -> None:
    call(emu, 92, pose=(10.0, 20.0, 30.0, 0.0, 0.0, 0.0), speed=100.0, acc=2000.0, mvtime=0.0,
         coord=0, relative=1)
    run_until_idle(emu)
    np.testing.assert_allclose(emu.controller.tcp_pose()[:3], [217.0, 20.0, 142.0], atol=0.01)


def test_reports_carry_moving_state_and_speeds(emu: Emulator) -> None:
    line(emu, 207.0, 0.0, 312.0, speed=100.0)
    emu.advance(1.0)
    snap = emu.snapshot()
    frame = reports.encode_rich(snap)
    back = reports.decode_rich(frame)
    assert back.state == 1 and back.cmdnum == 1
    assert back.tcp_speed == pytest.approx(100.0, rel=0.02)
    assert any(abs(v) > 0.01 for v in back.joint_speeds[:6])
    assert back.pose[2] == pytest.approx(emu.controller.tcp_pose()[2], abs=1e-3)


def _program(emu: Emulator) -> list[bytes]:
    frames = []
    call(emu, 23, joints=joints7(0.4, 0.1, -0.3, 0.0, 0.2, 0.0), speed=1.0, acc=8.0, mvtime=0.0)
    line(emu, 300.0, 50.0, 200.0, radius=20.0)
    line(emu, 300.0, -50.0, 200.0)
    call(emu, 27, pose1=(330.0, 0.0, 200.0, ROLL, 0.0, 0.0), pose2=(300.0, 50.0, 230.0, ROLL, 0.0, 0.0),
         speed=150.0, acc=2000.0, mvtime=0.0, percent=120.0)
    call(emu, 26, seconds=1.0)
    call(emu, 25, speed=1.0, acc=8.0, mvtime=0.0)
    for _ in range(int(60.0 / 0.01)):  # 60 s of controller time, a develop frame every 10 ms
        emu.advance(0.012 if len(frames) % 2 else 0.008)
        frames.append(reports.encode_develop(emu.snapshot()))
    return frames


def test_stepped_clock_is_deterministic() -> None:
    runs = []
    for _ in range(2):
        e = Emulator(6)
        ready(e)
        runs.append(_program(e))
    assert runs[0] == runs[1]


def test_fast_line_near_the_j1_axis_is_speed_error_c24(emu: Emulator) -> None:
    # Passing 150 mm from the J1 axis at 1000 mm/s needs J1 at about 6.7 rad/s (> 180 deg/s).
    line(emu, 150.0, -200.0, 250.0)
    run_until_idle(emu)
    line(emu, 150.0, 200.0, 250.0, speed=1000.0, acc=50000.0)
    emu.advance(3.0)
    assert call(emu, 15)[1]["error"] == 24
    assert emu.controller.tcp_pose()[1] < 0.0  # stopped before the closest point
    # The same line at 200 mm/s stays within the joint speed limit.
    call(emu, 16)
    ready(emu)
    line(emu, 150.0, -200.0, 250.0)
    run_until_idle(emu)
    line(emu, 150.0, 200.0, 250.0, speed=200.0, acc=50000.0)
    run_until_idle(emu)
    assert call(emu, 15)[1]["error"] == 0
    np.testing.assert_allclose(emu.controller.tcp_pose()[:3], [150.0, 200.0, 250.0], atol=0.01)


def test_target_behind_the_base_is_reached_by_turning_j1(emu: Emulator) -> None:
    q = call(emu, 43, pose=(-250.0, 0.0, 300.0, math.pi, 0.0, 0.0))[1]["joints"]
    assert abs(abs(q[0]) - math.pi) < 1e-5
    call(emu, 23, joints=q, speed=1.0, acc=10.0, mvtime=0.0)
    run_until_idle(emu)
    np.testing.assert_allclose(emu.controller.tcp_pose()[:3], [-250.0, 0.0, 300.0], atol=0.01)


def test_blend_into_a_move_that_arrives_while_the_first_runs(emu: Emulator) -> None:
    radius = 25.0
    line(emu, 307.0, 0.0, 112.0, speed=150.0, radius=radius)
    poses = []
    for _ in range(100):  # 0.4 s: the first move is under way when the next ones arrive
        emu.step()
        poses.append(emu.controller.tcp_pose())
    line(emu, 307.0, 100.0, 112.0, speed=150.0, radius=radius)
    line(emu, 207.0, 100.0, 112.0, speed=150.0)
    poses += run_until_idle(emu)
    pts = np.array([p[:3] for p in poses])
    speeds = np.linalg.norm(np.diff(pts, axis=0), axis=1) / PERIOD
    for corner in (np.array([307.0, 0.0, 112.0]), np.array([307.0, 100.0, 112.0])):
        d = np.linalg.norm(pts - corner, axis=1)
        assert d.min() > 1.0  # the corner is cut: blended
        near = d[1:] < radius
        assert speeds[near].min() > 50.0  # and the TCP does not stop there
        assert np.all(d[d < radius] <= radius + 1e-6)
    np.testing.assert_allclose(pts[-1], [207.0, 100.0, 112.0], atol=0.01)
    assert emu.controller.executor.cmdnum == 0


def test_report_counter_counts_completed_commands(emu: Emulator) -> None:
    call(emu, 23, joints=joints7(0.2), speed=1.0, acc=10.0, mvtime=0.0)
    call(emu, 26, seconds=0.1)
    call(emu, 23, joints=joints7(0.0), speed=1.0, acc=10.0, mvtime=0.0)
    run_until_idle(emu)
    assert emu.snapshot().counter == 3
    call(emu, 23, joints=joints7(0.5), speed=1.0, acc=10.0, mvtime=0.0)
    call(emu, 23, joints=joints7(0.0), speed=1.0, acc=10.0, mvtime=0.0)
    emu.advance(0.2)
    call(emu, 12, state=4)  # discarded commands do not count
    emu.advance(1.0)
    assert emu.snapshot().counter == 3


def test_joint_moves_with_a_radius_blend_without_stopping(emu: Emulator) -> None:
    # The SDK's set_servo_angle(..., radius=r) sends register 24 with the radius in mvtime's slot.
    via = joints7(0.6, -0.2, -0.4, 0.0, 0.6, 0.0)
    end = joints7(1.2, 0.0, -0.2, 0.0, 0.2, 0.0)
    via_tcp = emu.controller.tcp_matrix(np.array(via[:6]))[:3, 3]
    state, reply = call(emu, 24, joints=via, speed=1.0, acc=8.0, radius=30.0)
    assert state == 0
    call(emu, 24, joints=end, speed=1.0, acc=8.0, radius=-1.0)
    qs, tcps = [], []
    for _ in range(2500):
        emu.step()
        qs.append(emu.controller.q.copy())
        tcps.append(emu.controller.tcp_pose()[:3])
        if emu.controller.executor.cmdnum == 0:
            break
    qs_a, tcp_a = np.array(qs), np.array(tcps)
    np.testing.assert_allclose(qs_a[-1], np.array(end[:6], dtype=np.float32), atol=1e-6)
    speed = np.abs(np.diff(qs_a, axis=0)).max(axis=1) / PERIOD
    d = np.linalg.norm(tcp_a - via_tcp, axis=1)
    near = d[1:] < 30.0
    assert near.any() and speed[near].min() > 0.05  # no stop at the via point
    assert d.min() > 1.0  # the via point is rounded off
    assert emu.snapshot().counter == 2
    # Without a radius the arm stops at the via point.
    call(emu, 24, joints=via, speed=1.0, acc=8.0, radius=-1.0)
    call(emu, 24, joints=end, speed=1.0, acc=8.0, radius=-1.0)
    pts = np.array([p[:3] for p in run_until_idle(emu)])
    assert np.linalg.norm(pts - via_tcp, axis=1).min() < 1e-3  # reaches the via point exactly
    assert emu.snapshot().counter == 4


def test_no_trajectory_is_error_c25_and_the_arm_stops(monkeypatch: pytest.MonkeyPatch) -> None:
    """Manual 3.2.1 C25 "planning error": what the controller raises when the planner has no answer."""
    from xarm_emu.controller import motion

    emu = Emulator(6)
    ready(emu)

    def refuse(*args: object, **kwargs: object) -> object:
        raise motion.PlanningError("no trajectory")

    monkeypatch.setattr(motion, "plan_joint_move", refuse)
    call(emu, 23, joints=joints7(0.5), speed=1.0, acc=5.0, mvtime=0.0)
    call(emu, 23, joints=joints7(1.0), speed=1.0, acc=5.0, mvtime=0.0)
    emu.step(2)
    assert emu.controller.error_code == 25 and emu.controller.state == 4
    assert emu.controller.executor.cmdnum == 0
    assert bits(call(emu, 13)[0])[0]


def test_extremely_slow_joint_move_is_accepted_and_moves_at_its_speed() -> None:
    emu = Emulator(6)
    ready(emu)
    state, _ = call(emu, 23, joints=joints7(1.0), speed=1e-4, acc=1e-3, mvtime=0.0)
    assert state & 0x60 == 0
    emu.advance(100.0)
    assert emu.controller.state == 1 and emu.controller.error_code == 0
    assert emu.joints[0] == pytest.approx(1e-4 * (100.0 - 0.05), abs=2e-5)
