"""A Cartesian plan follows its path with the chord solve (model/kinematics.py ``track``, called from
controller/core/executor.py ``_CartesianPlan.joints``): along lines (register 21), arcs (27) and blended lines
(22) of the xArm6, xArm7, Lite 6 and 850 every period's joints put the flange on the path within the
solver's convergence tolerance (|dp| <= 1e-6 mm, |d theta| <= 1e-7 rad) and agree with a full solve
from the previous joints; a line into a singularity or a joint limit stops with the same error at the
same period as a plan that runs the full solve every period; a checkpoint taken mid-line continues
identically."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from helpers import count_calls, ready

from xarm_emu.controller.core import executor as ex
from xarm_emu.controller.core.interface import C_KINEMATIC, C_SPEED
from xarm_emu.controller.emulator import Emulator
from xarm_emu.model import kinematics as kin
from xarm_emu.model import rotations as rot

PI = math.pi
#: Joint positions (fractions of each joint's range) the moves start from, away from singularities.
START_FRACTIONS = {
    6: (0.5, 0.45, 0.55, 0.5, 0.6, 0.5),
    7: (0.5, 0.45, 0.55, 0.5, 0.6, 0.5, 0.5),
    "lite6": (0.5, 0.5, 0.7, 0.5, 0.6, 0.5),
    "850": (0.5, 0.45, 0.55, 0.5, 0.6, 0.5),
}
#: Joint agreement with a full solve from the previous joints (rad): two answers that both pass the
#: convergence test differ by at most about the joint motion that the rotation tolerance allows.
AGREE = 1e-6


def send(emu: Emulator, code: int, **values: Any) -> int:
    reg = emu.controller.registers[code]
    return emu.handle(code, reg.request.encode(values))[0]


def at_start(arm: int | str) -> tuple[Emulator, np.ndarray]:
    """An emulator of ``arm`` at rest at its start joints, and the TCP pose there (x, y, z, r, p, y)."""
    emu = Emulator(arm, firmware="2.7.103" if arm == "850" else "1.6.0")  # the 850 needs 2.1.0 or later
    ready(emu)
    m = emu.controller.model
    q = m.lower + np.asarray(START_FRACTIONS[arm]) * (m.upper - m.lower)
    joints = tuple(float(v) for v in q) + (0.0,) * (7 - m.dof)
    assert send(emu, 23, joints=joints, speed=1.0, acc=8.0, mvtime=0.0) == 0
    emu.advance(6.0)
    assert not emu.controller.is_moving and emu.controller.error_code == 0
    return emu, rot.matrix_to_pose(kin.fk(m, emu.controller.q))


def offset(pose: np.ndarray, dx: float, dy: float, dz: float, droll: float = 0.0) -> tuple[float, ...]:
    return (pose[0] + dx, pose[1] + dy, pose[2] + dz, pose[3] + droll, pose[4], pose[5])


def queue_moves(emu: Emulator, name: str, pose: np.ndarray) -> None:
    move = {"speed": 120.0, "acc": 1500.0, "mvtime": 0.0}
    if name == "line":
        assert send(emu, 21, pose=offset(pose, -40.0, -30.0, -20.0, 0.15), **move) == 0
    elif name == "arc":
        assert send(emu, 27, pose1=offset(pose, -30.0, 20.0, 0.0), pose2=offset(pose, 0.0, 40.0, -10.0),
                    percent=120.0, **move) == 0
    else:  # two blended lines and a last one
        assert send(emu, 22, pose=offset(pose, -40.0, 0.0, 0.0), radius=15.0, **move) == 0
        assert send(emu, 22, pose=offset(pose, -40.0, 40.0, 0.0), radius=15.0, **move) == 0
        assert send(emu, 21, pose=offset(pose, 0.0, 40.0, -20.0), **move) == 0


def on_target(model: Any, q: np.ndarray, target: np.ndarray) -> bool:
    T = kin.fk(model, q)
    return (float(np.linalg.norm(T[:3, 3] - target[:3, 3])) <= kin.POS_TOL
            and float(np.linalg.norm(rot.matrix_to_axis_angle(target[:3, :3] @ T[:3, :3].T))) <= kin.ROT_TOL)


def follow(emu: Emulator) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Step ``emu`` through its queued Cartesian moves: per period the joints before and after and the
    flange target of the plan."""
    ctl = emu.controller
    out = []
    while True:
        q_prev = ctl.q.copy()
        emu.step(1)
        plan = ctl.executor.data.plan
        if plan is None:
            return out
        assert isinstance(plan, ex._CartesianPlan)
        pose = plan.move.at(min(ctl.executor.data.t, plan.duration))[0]
        out.append((q_prev, ctl.q.copy(), plan.to_flange(pose)))


@pytest.mark.parametrize("arm", [6, "lite6", "850"])
@pytest.mark.parametrize("name", ["line", "arc", "blend"])
def test_tracked_joints_agree_with_the_full_solve(arm: int | str, name: str,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    emu, pose = at_start(arm)
    refreshes = count_calls(monkeypatch, kin, "step_matrix")
    queue_moves(emu, name, pose)
    periods = follow(emu)
    assert emu.controller.error_code == 0
    assert len(periods) > 80
    for q_prev, q, target in periods:
        assert on_target(emu.controller.model, q, target)
        plain = kin.ik(emu.controller.model, target, q_prev, limited=False)
        assert plain is not None
        np.testing.assert_allclose(q, plain, rtol=0.0, atol=AGREE)
    # the step matrix is kept from period to period: refreshed in a small share of the periods
    assert refreshes[0] < len(periods) / 5


@pytest.mark.parametrize("name", ["line", "arc", "blend"])
def test_xarm7_keeps_the_full_solve(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """The redundant arm's posture is the full solve's, to the bit, as before the chord solve."""
    emu, pose = at_start(7)
    queue_moves(emu, name, pose)
    tracked = follow(emu)
    monkeypatch.setattr(ex._CartesianPlan, "joints", previous_joints)
    emu, pose = at_start(7)
    queue_moves(emu, name, pose)
    full = follow(emu)
    assert len(tracked) == len(full) > 80
    for (_, q, target), (_, q_full, _) in zip(tracked, full, strict=True):
        assert on_target(emu.controller.model, q, target)
        assert q.tobytes() == q_full.tobytes()


def previous_joints(self: ex._CartesianPlan, t: float, seed: np.ndarray, increment: float = 0.0
                    ) -> ex.Answer | None:
    """A Cartesian plan's period as it was before the chord solve: the full solve from the first-order
    extrapolation of the last two answers, then from the previous joints (each pose sampled alone)."""
    pose, speed = self.move.at(t)
    self.tcp_speed = speed
    target = self.to_flange(pose)
    sol = None
    h = getattr(self, "_old", None)
    if h is not None and seed is h[3] and h[2] > h[0]:
        r = min((t - h[2]) / (h[2] - h[0]), 2.0)
        sol = kin.ik(self.model, target, seed + (seed - h[1]) * r, limited=False)
    if sol is None:
        sol = kin.ik(self.model, target, seed, limited=False)
    self._old = None if sol is None else (  # type: ignore[attr-defined]
        (h[2], h[3], t, sol) if h is not None and seed is h[3] else (t - 1.0, sol, t, sol))
    return None if sol is None else (sol, sol.tolist())


def run_into(start: tuple[float, ...], pose: tuple[float, ...]) -> tuple[int, int, np.ndarray]:
    """The error code, the periods run and the joints of a line from ``start`` to ``pose`` (xArm6)."""
    emu = Emulator(6)
    ready(emu)
    assert send(emu, 21, pose=start, speed=150.0, acc=2000.0, mvtime=0.0) == 0
    emu.advance(4.0)
    assert emu.controller.error_code == 0
    assert send(emu, 21, pose=pose, speed=150.0, acc=2000.0, mvtime=0.0) == 0
    periods = 0
    while emu.controller.is_moving and periods < 3000:
        emu.step(1)
        periods += 1
    return emu.controller.error_code, periods, emu.controller.q.copy()


LINES_INTO = {  # start, target, the error
    "shoulder limit": ((200.0, 0.0, 300.0, PI, 0.0, 0.0), (-200.0, 0.0, 300.0, PI, 0.0, 0.0), C_KINEMATIC),
    "wrist limit": ((300.0, 0.0, 200.0, PI, 0.0, 0.0), (300.0, 0.0, 200.0, PI, -1.5, 0.0), C_KINEMATIC),
    "wrist singularity": ((300.0, -20.0, 300.0, PI, -0.2, 0.0), (300.0, 20.0, 300.0, PI, -0.8, 0.0),
                          C_SPEED),
    "wrist singularity 2": ((300.0, -2.0, 300.0, PI, -0.2, 0.0), (300.0, 2.0, 300.0, PI, -1.0, 0.0),
                            C_SPEED),
}


@pytest.mark.parametrize("name", sorted(LINES_INTO))
def test_line_into_a_limit_or_singularity_fails_as_before(name: str,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    start, pose, code = LINES_INTO[name]
    tracked = run_into(start, pose)
    monkeypatch.setattr(ex._CartesianPlan, "joints", previous_joints)
    full = run_into(start, pose)
    assert tracked[0] == full[0] == code
    assert tracked[1] == full[1]
    np.testing.assert_allclose(tracked[2], full[2], rtol=0.0, atol=AGREE)


def test_checkpoint_mid_line_continues_identically() -> None:
    emu, pose = at_start(6)
    assert send(emu, 22, pose=offset(pose, 40.0, 0.0, 0.0), radius=15.0, speed=120.0, acc=1500.0,
                mvtime=0.0) == 0
    assert send(emu, 21, pose=offset(pose, 40.0, 40.0, 0.0), speed=120.0, acc=1500.0, mvtime=0.0) == 0
    emu.advance(0.2)
    plan = emu.controller.executor.data.plan
    assert isinstance(plan, ex._CartesianPlan) and plan._matrix is not None and len(plan._hist) == 4
    cp = emu.checkpoint()
    first = []
    for _ in range(150):
        emu.step(1)
        first.append(emu.controller.q.tobytes())
    emu.restore(cp)
    again = []
    for _ in range(150):
        emu.step(1)
        again.append(emu.controller.q.tobytes())
    assert again == first
    assert emu.controller.is_moving or emu.controller.error_code == 0


def _steps_by_definition(h: tuple[tuple[float, tuple[float, ...]], ...], t: float) -> int:
    """The classification as its definition reads: steady bounds first, then equal steps."""
    if len(h) < 4:
        return ex._UNSTEADY
    t0, t1, t2, t3 = (x[0] for x in h)
    step, d = t3 - t2, t - t3
    lo, hi = step / ex._EXTRAPOLATE_MAX, step * ex._EXTRAPOLATE_MAX
    if not (lo <= t1 - t0 <= hi and lo <= t2 - t1 <= hi and 0.0 <= d <= hi):
        return ex._UNSTEADY
    tol = step * 1e-9
    if abs(t1 - t0 - step) <= tol and abs(t2 - t1 - step) <= tol and abs(d - step) <= tol:
        return ex._EQUAL
    return ex._STEADY


def test_steps_classifies_path_times_as_defined() -> None:
    """The equal-steps-first test answers as the definition, for summed path times, near-equal and
    uneven steps, zero, negative, subnormal, huge and non-finite steps and short histories."""
    rng = np.random.default_rng(7)
    cases: list[tuple[list[float], float]] = []
    for _ in range(3000):
        step = float(rng.choice([0.004, 0.0001, 1e-300, 5e-324, 0.0, -0.004, 1e300, 1.7e308]))
        times = [float(rng.uniform(0.0, 10.0))]
        for _ in range(4):
            kind = rng.integers(0, 4)
            jitter = (0.0 if kind == 0 else step * float(rng.choice([1e-10, 1e-9, 2e-9, 0.4, 1.5, 2.5]))
                      * float(rng.choice([-1.0, 1.0])))
            times.append(times[-1] + step + jitter)
        cases.append((times[:4], times[4]))
    inf, nan = math.inf, math.nan
    cases += [([0.0, 1.0, 2.0, inf], inf), ([0.0, 1.0, 2.0, inf], 5.0), ([0.0, 1.0, 2.0, 3.0], inf),
              ([-inf, 0.0, 1.0, 2.0], 3.0),
              ([0.0, 1.0, 2.0, nan], 4.0), ([0.0, 0.0, 0.0, 0.0], 0.0), ([0.0, 0.0, 0.0, 0.0], -0.0),
              ([0.0, -0.0, 0.0, -0.0], 0.0), ([0.0, 1.0, 2.0, 3.0], 3.0), ([0.0, 1.0], 2.0)]
    seen = set()
    for times, t in cases:
        h = tuple((x, (x,)) for x in times)
        want = _steps_by_definition(h, t)
        assert ex._steps(h, t) == want, (times, t)
        seen.add(want)
    assert seen == {ex._UNSTEADY, ex._STEADY, ex._EQUAL}
