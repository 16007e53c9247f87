"""The official SDK's motion calls against the emulator server.

Moves end on their targets with ``wait=True`` and ``wait=False``; durations match an ideal jerk-limited
profile (ruckig with the same limits); lines, blended corners and circles keep their geometry in the
develop report (manual 2.1.6, port 30003, 100 Hz); states 3 and 4 (register 12), go home (25), servo
mode (19, 29), bad input and errors (manual 2.1.3, chapter 3; the SDK's codes for the reply state bits).

Timing: the server runs ``speed`` controller seconds per wall second; controller time = wall time x speed.
"""

from __future__ import annotations

import contextlib
import math
import socket
import struct
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
from helpers import sdk_ready as ready
from helpers import wait_for
from ruckig import InputParameter, Ruckig, Trajectory

from xarm_emu.controller.core.interface import PERIOD
from xarm_emu.protocol import reports
from xarm_emu.server.app import ServerThread

ZERO_POSE = (207.0, 0.0, 112.0)




class DevelopRecorder:
    """Reads the develop report (manual 2.1.6, 100 Hz) on a thread: ``frames`` is a list of
    (wall time, joints tuple, pose tuple, state, cmdnum)."""

    def __init__(self, port: int) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=0.2)
        self.frames: list[tuple[float, tuple[float, ...], tuple[float, ...], int, int]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="develop-recorder", daemon=True)
        self._thread.start()

    def _recv(self, n: int) -> bytes:
        buf = bytearray()
        while len(buf) < n:
            try:
                chunk = self.sock.recv(n - len(buf))
            except TimeoutError:
                if self._stop.is_set():
                    raise
                continue
            if not chunk:
                raise ConnectionError("closed")
            buf += chunk
        return bytes(buf)

    def _run(self) -> None:
        with contextlib.suppress(OSError, ConnectionError):
            while not self._stop.is_set():
                head = self._recv(4)
                (size,) = struct.unpack(">I", head)
                body = self._recv(size - 4)
                t = time.monotonic()
                snap = reports.decode_develop(head + body)
                self.frames.append((t, tuple(snap.joints), tuple(snap.pose), snap.state, snap.cmdnum))

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2)
        self.sock.close()


@pytest.fixture
def recorder() -> Iterator[Callable[[ServerThread], DevelopRecorder]]:
    made: list[DevelopRecorder] = []

    def factory(st: ServerThread) -> DevelopRecorder:
        r = DevelopRecorder(st.ports["develop"])
        made.append(r)
        assert wait_for(lambda: len(r.frames) >= 2)
        return r

    yield factory
    for r in made:
        r.close()


class SnapshotLog:
    """Records (controller time, joints, pose, state, cmdnum) of every snapshot the server encodes into
    a report frame (the develop report's content, stamped with controller time instead of wall time)."""

    def __init__(self, st: ServerThread) -> None:
        self.st, self.frames = st, []
        emu = st.emulator
        orig = emu.snapshot

        def snapshot() -> Any:
            snap = orig()
            self.frames.append((emu.time, tuple(snap.joints), tuple(snap.pose), snap.state, snap.cmdnum))
            return snap

        st.call(lambda: setattr(emu, "snapshot", snapshot))
        assert wait_for(lambda: len(self.frames) >= 2)

    def close(self) -> list:
        self.st.call(lambda: self.st.emulator.__dict__.pop("snapshot", None))
        return list(self.frames)


def ideal_duration(start: list[float], target: list[float], v: float, a: float, j: float) -> float:
    """Time-optimal jerk-limited duration from rest to rest (ruckig, same limits on every axis)."""
    n = len(start)
    inp = InputParameter(n)
    inp.current_position = list(start)
    inp.target_position = list(target)
    inp.current_velocity = inp.current_acceleration = [0.0] * n
    inp.target_velocity = inp.target_acceleration = [0.0] * n
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [v] * n, [a] * n, [j] * n
    traj = Trajectory(n)
    Ruckig(n).calculate(inp, traj)
    return float(traj.duration)


def motion_window(frames: list, start: np.ndarray, target: np.ndarray, key: int,
                  tol: float, start_tol: float = 1e-6) -> tuple[int, int]:
    """Indices of the first frame that left ``start`` and the first frame on ``target``."""
    i0 = next(i for i, f in enumerate(frames)
              if np.max(np.abs(np.array(f[key][:len(start)]) - start)) > start_tol)
    assert i0 >= 1, "recording started after the motion"
    i1 = next(i for i, f in enumerate(frames)
              if i > i0 and np.max(np.abs(np.array(f[key][:len(target)]) - target)) < tol)
    return i0, i1


def window_seconds(frames: list, i0: int, i1: int) -> float:
    """Seconds (of the frames' clock) from the start to the end of a motion: each lies between two
    frames (the last one before and the first one after), taken at the midpoint."""
    start = (frames[i0 - 1][0] + frames[i0][0]) / 2
    end = (frames[i1 - 1][0] + frames[i1][0]) / 2
    return end - start


def assert_brackets(frames: list, stamped: list, window: tuple[int, int],
                    times: tuple[float, float]) -> None:
    """Each received frame of ``window`` (indices) carries a snapshot taken at or after the
    controller time in ``times``, and the frame before it one taken before: the received frames
    bracket the controller's motion window. A frame's controller time is that of the first logged
    snapshot whose joints, as float32 on the wire, are the frame's."""
    def ctl_time(f: tuple) -> float:
        values = np.array(f[1], dtype=np.float32)
        for s in stamped:
            if np.array_equal(np.array(s[1], dtype=np.float32), values):
                return float(s[0])
        raise AssertionError(f"a frame no snapshot matches: {f}")

    for index, t in zip(window, times, strict=True):
        assert ctl_time(frames[index - 1]) < t <= ctl_time(frames[index]) + 1e-9, (index, t)


def joints_deg(st: ServerThread) -> list[float]:
    return st.call(lambda: [math.degrees(x) for x in st.emulator.joints])


def _settled(st: ServerThread) -> Callable[[], bool]:
    """A predicate: the joints did not change over the last 50 ms."""
    def pred() -> bool:
        a = joints_deg(st)
        time.sleep(0.05)
        return joints_deg(st) == a
    return pred


def tcp_xyz(st: ServerThread) -> np.ndarray:
    return np.array(st.call(lambda: st.emulator.controller.tcp_pose()[:3].tolist()))


# -- ending on the target, duration -------------------------------------------------------------

def test_joint_move_wait_true_on_target_with_ideal_duration(make_server, sdk_arm, recorder) -> None:
    speed = 2.0
    st = make_server(speed=speed)
    arm = sdk_arm(st, report_type="real")
    ready(arm)
    rec = recorder(st)
    log = SnapshotLog(st)
    target = [40.0, -20.0, -10.0, 0.0, 15.0, 0.0]
    v_deg, a_deg = 60.0, 300.0
    assert arm.set_servo_angle(angle=target, speed=v_deg, mvacc=a_deg, wait=True) == 0
    assert joints_deg(st) == pytest.approx(target, abs=1e-5)
    stamped = log.close()
    frames = list(rec.frames)
    tgt = np.radians(target)
    final = np.array(stamped[-1][1][:6])  # the wire's float32 target, reached exactly
    assert final == pytest.approx(tgt, abs=1e-6)
    i0, i1 = motion_window(stamped, np.zeros(6), final, 1, 1e-12, 1e-12)
    measured = window_seconds(stamped, i0, i1)  # controller seconds
    # the frames received show the same window: the first that left the start and the first on the
    # target carry snapshots taken after the controller's start and end, the one before each, before
    # (on the controller's clock: a late reading thread or a late report tick changes nothing)
    w0, w1 = motion_window(frames, np.zeros(6), tgt, 1, 1e-5)
    s0, s1 = motion_window(stamped, np.zeros(6), tgt, 1, 1e-5)  # as the frames are read
    assert_brackets(frames, stamped, (w0, w1), (stamped[s0][0], stamped[s1][0]))
    jerk = st.call(lambda: st.emulator.snapshot().joint_jerk)
    ideal = ideal_duration([0.0] * 6, list(tgt), math.radians(v_deg), math.radians(a_deg), jerk)
    assert ideal > 0.5
    assert abs(measured - ideal) / ideal < 0.05, (measured, ideal)
    # the reported joints never overshoot the target on any joint (a synchronised S-curve)
    for f in frames[i0:i1 + 1]:
        q = np.array(f[1][:6])
        assert np.all(np.minimum(0, tgt) - 1e-6 <= q) and np.all(q <= np.maximum(0, tgt) + 1e-6)


def test_joint_move_wait_false_returns_at_once_and_ends_on_target(make_server, sdk_arm) -> None:
    # a quarter of real time: the move takes about 0.7 s of controller time, 2.8 s of wall time, far
    # longer than the return even on a loaded machine
    st = make_server(speed=0.25)
    arm = sdk_arm(st, report_type="real")
    ready(arm)
    target = [-30.0, 10.0, -25.0, 20.0, -10.0, 45.0]
    t0 = time.monotonic()
    assert arm.set_servo_angle(angle=target, speed=90, mvacc=500, wait=False) == 0
    assert time.monotonic() - t0 < 1.0
    # on return the arm is on its way: state 1 (moving, register 13), short of the target
    assert st.call(lambda: (st.emulator.controller.state, st.emulator.controller.is_moving)) == (1, True)
    assert joints_deg(st) != pytest.approx(target, abs=1e-3)
    assert wait_for(lambda: st.call(lambda: st.emulator.controller.state) == 2, 15.0)
    assert joints_deg(st) == pytest.approx(target, abs=1e-5)
    assert wait_for(lambda: arm.angles[:6] == pytest.approx(target, abs=1e-3))


def test_linear_move_is_straight_on_target_with_ideal_duration(make_server, sdk_arm, recorder) -> None:
    """set_position (register 21): every 100 Hz develop frame within 0.1 mm of the segment; end within
    0.01 mm; duration within 5% of the 1-D jerk-limited profile along the path (TCP jerk of the box)."""
    st = make_server(speed=1.0)
    arm = sdk_arm(st, report_type="real")
    ready(arm)
    rec = recorder(st)
    log = SnapshotLog(st)
    p0 = np.array(ZERO_POSE)
    p1 = np.array([307.0, 60.0, 172.0])
    v, a = 150.0, 1500.0
    assert arm.set_position(*p1, 180, 0, 0, speed=v, mvacc=a, wait=True) == 0
    assert tcp_xyz(st) == pytest.approx(p1, abs=0.01)
    code, pose = arm.get_position()
    assert code == 0 and pose[:3] == pytest.approx(list(p1), abs=0.01)
    stamped = log.close()
    frames = list(rec.frames)
    u = (p1 - p0) / np.linalg.norm(p1 - p0)
    worst = 0.0
    for f in frames:
        d = np.array(f[2][:3]) - p0
        s = float(np.clip(d @ u, 0.0, np.linalg.norm(p1 - p0)))
        worst = max(worst, float(np.linalg.norm(d - s * u)))
    assert worst < 0.1, worst
    i0, i1 = motion_window(frames, p0, p1, 2, 0.01)
    assert i1 - i0 > 50  # sampled at 100 Hz over the move
    j0, j1 = motion_window(stamped, p0, np.array(stamped[-1][2][:3]), 2, 1e-9, 1e-9)
    measured = window_seconds(stamped, j0, j1)  # controller seconds (speed 1: also about wall seconds)
    s0, s1 = motion_window(stamped, p0, p1, 2, 0.01)  # as the frames are read
    assert_brackets(frames, stamped, (i0, i1), (stamped[s0][0], stamped[s1][0]))
    tcp_jerk = st.call(lambda: st.emulator.snapshot().tcp_jerk)
    ideal = ideal_duration([0.0], [float(np.linalg.norm(p1 - p0))], v, a, tcp_jerk)
    assert abs(measured - ideal) / ideal < 0.05, (measured, ideal)


def test_linear_move_wait_false_ends_on_target(make_server, sdk_arm) -> None:
    st = make_server(speed=5.0)
    arm = sdk_arm(st, report_type="real")
    ready(arm)
    assert arm.set_position(250, -40, 150, 180, 0, 20, speed=200, mvacc=2000, wait=False) == 0
    assert wait_for(lambda: st.call(lambda: st.emulator.controller.state) == 2)
    code, pose = arm.get_position()
    assert code == 0 and pose[:3] == pytest.approx([250, -40, 150], abs=1e-3)
    assert abs(abs(pose[3]) - 180) < 1e-3 and pose[4:] == pytest.approx([0, 20], abs=1e-3)


# -- geometry: blend, circle --------------------------------------------------------------------

def _dist_to_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    ab = b - a
    s = float(np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + s * ab)))


CORNER_PTS = [np.array(ZERO_POSE), np.array([307.0, 0.0, 112.0]), np.array([307.0, 100.0, 112.0]),
              np.array([207.0, 100.0, 112.0])]
CORNER_R = 20.0


def _queue_corner_moves(arm: Any, gap: float) -> None:
    for p, rad in ((CORNER_PTS[1], CORNER_R), (CORNER_PTS[2], CORNER_R), (CORNER_PTS[3], None)):
        kwargs = {"radius": rad} if rad is not None else {}
        assert arm.set_position(*p, 180, 0, 0, speed=150, mvacc=2000, wait=False, **kwargs) == 0
        time.sleep(gap)


def _check_blended_corners(st: ServerThread, rec: DevelopRecorder, log: SnapshotLog) -> None:
    """Every frame on the polyline (0.1 mm) or within the radius of a corner; each corner cut; the
    TCP never stops between the start and the end (over each 60 ms of controller time, on the
    snapshots the reports encode: frames a late report tick sends back to back show one period);
    state 1 throughout."""
    pts, r = CORNER_PTS, CORNER_R
    assert wait_for(lambda: st.call(lambda: st.emulator.controller.state) == 2, timeout=10)
    stamped = log.close()
    assert tcp_xyz(st) == pytest.approx(pts[3], abs=0.01)
    frames = list(rec.frames)
    xyz = [np.array(f[2][:3]) for f in frames]
    corners = pts[1:3]
    for p in xyz:
        off_path = min(_dist_to_segment(p, pts[k], pts[k + 1]) for k in range(3))
        near_corner = min(float(np.linalg.norm(p - c)) for c in corners)
        assert off_path < 0.1 or near_corner <= r + 0.1, (p, off_path, near_corner)
    min_to_corner = [min(float(np.linalg.norm(p - c)) for p in xyz) for c in corners]
    assert all(d > 2.0 for d in min_to_corner), f"closest approach to each corner (mm): {min_to_corner}"
    i0 = next(i for i, p in enumerate(xyz) if np.linalg.norm(p - pts[0]) > 1.0)
    i1 = next(i for i, p in enumerate(xyz) if i > i0 and np.linalg.norm(p - pts[3]) < 1.0)
    assert {f[3] for f in frames[i0:i1]} == {1}
    times = np.array([f[0] for f in stamped])
    at = [np.array(f[2][:3]) for f in stamped]
    k0 = next(k for k, p in enumerate(at) if np.linalg.norm(p - pts[0]) > 1.0)
    k1 = next(k for k, p in enumerate(at) if k > k0 and np.linalg.norm(p - pts[3]) < 1.0)
    for k in range(k0, k1):
        later = int(np.searchsorted(times, times[k] + 0.06))
        if later < k1:
            assert np.linalg.norm(at[later] - at[k]) > 0.1, ("stopped", times[k], at[k])


def test_blended_corner_stays_within_radius_and_never_stops(make_server, sdk_arm, recorder) -> None:
    """Register 22 (set_position with radius, wait=False): the corners are rounded inside their radius
    and the TCP keeps moving. The control loop is held while the SDK queues the three moves, so the
    box finds them all in its buffer (deterministic)."""
    st = make_server(speed=2.0)
    arm = sdk_arm(st, report_type="real")
    ready(arm)
    rec = recorder(st)
    log = SnapshotLog(st)
    emu = st.emulator
    st.call(lambda: setattr(emu, "step", lambda n=1: None))  # hold controller time
    try:
        _queue_corner_moves(arm, 0.0)
        assert st.call(lambda: emu.controller.executor.cmdnum) == 3
    finally:
        st.call(lambda: delattr(emu, "step"))
    _check_blended_corners(st, rec, log)


def test_blended_corner_with_moves_arriving_during_the_first(make_server, sdk_arm, recorder) -> None:
    """The SDK sends wait=False moves one by one: a move that arrives while the previous blended move
    already runs (here 40 ms later, ~60 mm before the corner) is still blended into it."""
    st = make_server(speed=2.0)
    arm = sdk_arm(st, report_type="real")
    ready(arm)
    rec = recorder(st)
    log = SnapshotLog(st)
    _queue_corner_moves(arm, 0.04)
    _check_blended_corners(st, rec, log)


def test_move_circle_on_the_circle_and_covers_percent(make_server, sdk_arm, recorder) -> None:
    """Register 27: through the current point, pose1 and pose2; 75% of the circumference."""
    st = make_server(speed=2.0)
    arm = sdk_arm(st, report_type="real")
    ready(arm)
    rec = recorder(st)
    centre, radius = np.array([257.0, 0.0, 112.0]), 50.0
    pose1 = [257.0, 50.0, 112.0, 180.0, 0.0, 0.0]
    pose2 = [307.0, 0.0, 112.0, 180.0, 0.0, 0.0]
    assert arm.move_circle(pose1, pose2, 75, speed=150, mvacc=2000, wait=True) == 0
    end = centre + radius * np.array([0.0, -1.0, 0.0])  # 270 degrees on from (207, 0) via (257, 50)
    assert tcp_xyz(st) == pytest.approx(end, abs=0.01)
    frames = list(rec.frames)
    swept, prev = 0.0, None
    for f in frames:
        p = np.array(f[2][:3]) - centre
        assert abs(math.hypot(p[0], p[1]) - radius) < 0.1 and abs(p[2]) < 0.1, p
        ang = math.atan2(p[1], p[0])
        if prev is not None:
            swept += (prev - ang + math.pi) % (2 * math.pi) - math.pi  # clockwise seen from +Z
        prev = ang
    assert math.degrees(swept) == pytest.approx(270.0, abs=0.5)


# -- states, buffer, go home --------------------------------------------------------------------

def test_suspend_then_resume(make_server, sdk_arm) -> None:
    st = make_server(speed=2.0)
    arm = sdk_arm(st, report_type="real")
    ready(arm)
    target = [60.0, 0.0, -30.0, 0.0, 0.0, 0.0]
    assert arm.set_servo_angle(angle=target, speed=40, mvacc=200, wait=False) == 0
    assert wait_for(lambda: joints_deg(st)[0] > 10.0)
    assert arm.set_state(3) == 0
    assert wait_for(lambda: arm.state == 3)
    assert wait_for(_settled(st), timeout=3.0)  # the jerk-limited stop ends
    held = joints_deg(st)
    time.sleep(0.2)
    assert joints_deg(st) == pytest.approx(held, abs=1e-9) and 10.0 < held[0] < 59.0
    assert arm.get_state() == (0, 3)
    assert arm.set_state(0) == 0
    assert wait_for(lambda: st.call(lambda: st.emulator.controller.state) == 2)
    assert joints_deg(st) == pytest.approx(target, abs=1e-5)


def test_stop_empties_the_buffer(make_server, sdk_arm) -> None:
    st = make_server(speed=2.0)
    arm = sdk_arm(st, report_type="real")
    ready(arm)
    for j1 in (30, -30, 30, -30):
        assert arm.set_servo_angle(angle=[j1, 0, 0, 0, 0, 0], speed=60, mvacc=300, wait=False) == 0
    code, n = arm.get_cmdnum()
    assert code == 0 and n >= 3
    assert arm.set_state(4) == 0
    assert arm.get_cmdnum() == (0, 0)  # emptied at once, the move being brought to rest included
    assert wait_for(lambda: arm.state == 4)
    assert wait_for(_settled(st), timeout=2.0)  # the jerk-limited stop ends
    stopped = joints_deg(st)
    time.sleep(0.2)
    assert joints_deg(st) == pytest.approx(stopped, abs=1e-6)
    assert abs(stopped[0]) < 30.0 - 1e-3
    # motion needs set_state(0) again; then a move runs and ends on target
    assert arm.set_state(0) == 0
    assert arm.set_servo_angle(angle=[5, 0, 0, 0, 0, 0], speed=100, mvacc=500, wait=True) == 0
    assert joints_deg(st)[0] == pytest.approx(5.0, abs=1e-5)


def test_move_gohome_returns_to_zero(make_server, sdk_arm) -> None:
    st = make_server(speed=5.0)
    arm = sdk_arm(st, report_type="real")
    ready(arm)
    assert arm.set_servo_angle(angle=[20, -10, -15, 10, 20, -30], speed=120, mvacc=800, wait=False) == 0
    assert arm.move_gohome(speed=60, mvacc=500, wait=True) == 0
    assert joints_deg(st) == pytest.approx([0.0] * 6, abs=1e-5)
    code, pose = arm.get_position()
    assert pose[:3] == pytest.approx(list(ZERO_POSE), abs=1e-3)


# -- servo mode ---------------------------------------------------------------------------------

def test_servo_mode_follows_250hz_stream_within_one_period(make_server, sdk_arm, recorder) -> None:
    """Mode 1, register 29 at 250 Hz: at every report the arm is at least at the target that reached
    the box one control period (4 ms) earlier (compared server-side on the snapshots the develop
    report encodes, and on the develop frames themselves). Lockstep time: each target arrives, then
    the box runs one period, so the stream is 250 Hz of controller time however late the sender's
    thread wakes (a loaded machine would otherwise bunch targets into one period, beyond the joint
    speed limit)."""
    st = make_server(stepped=True, admin=True)
    arm = sdk_arm(st, report_type="real")
    emu = st.emulator
    ready(arm)
    st.call(lambda: st.server.advance(0.1))
    assert arm.set_mode(1) == 0
    assert arm.set_state(0) == 0
    st.call(lambda: st.server.advance(0.1))
    arrivals: list[tuple[float, float]] = []  # (controller time, J1 target)
    checks: list[tuple[float, float]] = []  # (controller time, reported J1)
    orig_handle, orig_snapshot = emu.handle, emu.snapshot

    def handle(code: int, params: bytes) -> tuple[int, bytes]:
        out = orig_handle(code, params)
        if code == 29:
            arrivals.append((emu.time, struct.unpack("<f", params[:4])[0]))
        return out

    def snapshot() -> Any:
        snap = orig_snapshot()
        checks.append((emu.time, snap.joints[0]))
        return snap

    def patch() -> None:
        emu.handle = handle  # type: ignore[method-assign]
        emu.snapshot = snapshot  # type: ignore[method-assign]

    st.call(patch)
    rec = recorder(st)
    n, amp = 250, 0.3  # 1 s, J1 from 0 to 0.3 rad on a smooth monotone ramp (peak 0.47 rad/s)
    targets = [amp * (1 - math.cos(math.pi * k / n)) / 2 for k in range(1, n + 1)]
    t_next = time.monotonic()
    codes = []
    for q1 in targets:
        codes.append(arm.set_servo_angle_j([q1, 0, 0, 0, 0, 0], speed=math.pi, mvacc=20, is_radian=True))
        st.call(lambda: st.server.advance(PERIOD))
        t_next += PERIOD
        time.sleep(max(0.0, t_next - time.monotonic()))
    assert set(codes) == {0}
    st.call(lambda: st.server.advance(PERIOD))
    assert st.call(lambda: emu.joints[0]) == pytest.approx(targets[-1], abs=1e-6)
    st.call(lambda: (delattr(emu, "handle"), delattr(emu, "snapshot")))
    assert len(arrivals) == n
    arr_t = np.array([a[0] for a in arrivals])
    arr_q = np.array([a[1] for a in arrivals])
    late = []
    for t, q in checks:
        k = int(np.searchsorted(arr_t, t - PERIOD - 1e-9, side="right")) - 1  # last target >= 1 period old
        if k >= 0 and q < arr_q[k] - 1e-6:
            late.append((t, q, arr_q[k]))
    assert len(checks) > 80
    assert not late, late[:5]
    # the develop frames show the same: J1 only takes values of the stream, and ends on the last target
    frames = [f for f in rec.frames if f[1][0] > 1e-4]
    assert len(frames) > 80
    for f in frames:
        assert float(np.min(np.abs(arr_q - f[1][0]))) < 1e-6, f[1][0]


# -- bad input and errors -----------------------------------------------------------------------

def _nothing_queued_nothing_moves(st: ServerThread, arm: Any) -> None:
    time.sleep(0.05)
    assert st.call(lambda: st.emulator.controller.executor.cmdnum) == 0
    assert st.call(lambda: st.emulator.joints.tolist()) == [0.0] * 6
    assert not st.call(lambda: st.emulator.controller.is_moving)


def test_nan_speed_and_negative_acceleration_refused(make_server, sdk_arm) -> None:
    """Warning 12 (parameter error), nothing queued, nothing moves (manual Table 1.2)."""
    st = make_server(speed=5.0)
    arm = sdk_arm(st, report_type="real")
    ready(arm)
    # the SDK passes NaN through its min/max clamp unchanged
    arm.set_servo_angle(angle=[10, 0, 0, 0, 0, 0], speed=float("nan"), mvacc=300, wait=False)
    assert arm.get_err_warn_code() == (0, [0, 12])
    _nothing_queued_nothing_moves(st, arm)
    assert arm.clean_warn() == 0
    arm.set_position(250, 0, 112, 180, 0, 0, speed=float("nan"), mvacc=1000, wait=False)
    assert arm.get_err_warn_code() == (0, [0, 12])
    _nothing_queued_nothing_moves(st, arm)
    assert arm.clean_warn() == 0
    # the SDK clamps a negative acceleration itself, so send it through its command layer (register 23)
    ret = arm.arm.arm_cmd.move_joint([0.2, 0, 0, 0, 0, 0, 0], 1.0, -5.0, 0.0)
    assert ret[0] == 2  # the reply carries the warning bit
    assert arm.get_err_warn_code() == (0, [0, 12])
    _nothing_queued_nothing_moves(st, arm)


def test_moves_refused_while_disabled_in_error_or_wrong_mode(make_server, sdk_arm) -> None:
    st = make_server(speed=5.0)
    arm = sdk_arm(st, report_type="real")
    ready(arm)
    # disabled motors: the box is not ready; the SDK refuses from the report, the box from its state
    assert arm.motion_enable(False) == 0
    ret = arm.arm.arm_cmd.move_joint([0.2, 0, 0, 0, 0, 0, 0], 1.0, 5.0, 0.0)
    # the box answers with the "not ready" bit (0x10) alone, which the SDK's command layer does not
    # turn into a code: the call returns 0 and the SDK records that the box is not ready
    assert st.call(lambda: st.emulator.controller.status_byte()) & 0x70 == 0x10
    assert ret[0] == 0 and arm.arm.arm_cmd.state_is_ready is False
    _nothing_queued_nothing_moves(st, arm)
    ready(arm)
    # error: motion calls return 1 (the reply's error bit, 0x40)
    st.call(lambda: st.emulator.inject_error(31))
    assert arm.get_err_warn_code() == (0, [31, 0])
    assert arm.set_servo_angle(angle=[10, 0, 0, 0, 0, 0], speed=50, mvacc=300, wait=False) == 1
    assert arm.set_position(250, 0, 112, 180, 0, 0, speed=100, mvacc=1000, wait=False) == 1
    _nothing_queued_nothing_moves(st, arm)
    assert arm.clean_error() == 0
    ready(arm)
    assert arm.get_err_warn_code() == (0, [0, 0])
    # mode mismatch: a queued move in servo mode, a servo target in position mode -> 0x10, code 9
    assert arm.set_mode(1) == 0 and arm.set_state(0) == 0
    assert wait_for(lambda: arm.mode == 1 and arm.state in (1, 2))
    assert arm.set_servo_angle(angle=[10, 0, 0, 0, 0, 0], speed=50, mvacc=300, wait=False) == 9
    _nothing_queued_nothing_moves(st, arm)
    assert arm.set_mode(0) == 0 and arm.set_state(0) == 0
    assert wait_for(lambda: arm.mode == 0 and arm.state == 2)
    assert arm.set_servo_angle_j([0.1, 0, 0, 0, 0, 0], is_radian=True) == 9
    _nothing_queued_nothing_moves(st, arm)


def test_joint_limit_target_ends_in_c23_or_is_refused(make_server, sdk_arm) -> None:
    st = make_server(speed=5.0)
    arm = sdk_arm(st, report_type="real")
    ready(arm)
    code = arm.set_servo_angle(angle=[0, 0, 30, 0, 0, 0], speed=60, mvacc=300, wait=False)  # J3 > 11 deg
    if code == 0:  # sent: the box raises C23 and nothing moves
        assert arm.get_err_warn_code() == (0, [23, 0])
        assert wait_for(lambda: arm.error_code == 23)
    else:  # the SDK's own range check
        assert code in (-8, -7)
    _nothing_queued_nothing_moves(st, arm)
    assert arm.clean_error() == 0
    ready(arm)
    assert arm.set_servo_angle(angle=[0, 0, -30, 0, 0, 0], speed=120, mvacc=800, wait=True) == 0
    assert joints_deg(st)[2] == pytest.approx(-30.0, abs=1e-5)


def test_emergency_stop_leaves_state_4(make_server, sdk_arm) -> None:
    st = make_server(speed=2.0)
    arm = sdk_arm(st, report_type="real")
    ready(arm)
    assert arm.set_servo_angle(angle=[60, 0, 0, 0, 0, 0], speed=40, mvacc=200, wait=False) == 0
    assert wait_for(lambda: joints_deg(st)[0] > 5.0)
    arm.emergency_stop()
    assert arm.state == 4
    assert arm.get_state() == (0, 4)
    assert arm.get_cmdnum() == (0, 0)
    assert wait_for(_settled(st), timeout=2.0)
    assert joints_deg(st)[0] < 59.0 and arm.get_state() == (0, 4)
