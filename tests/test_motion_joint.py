"""Joint-space point-to-point moves (register 23, manual 2.1.3.2)."""

from __future__ import annotations

import time

import numpy as np
import pytest
from ruckig import InputParameter, Ruckig, Trajectory

from xarm_emu.controller.motion.joint import plan_joint_move


def _ruckig_duration(q0, q1, v, a, j):
    dof = len(q0)
    inp = InputParameter(dof)
    inp.current_position, inp.target_position = list(q0), list(q1)
    inp.max_velocity = list(np.broadcast_to(v, (dof,)))
    inp.max_acceleration = list(np.broadcast_to(a, (dof,)))
    inp.max_jerk = list(np.broadcast_to(j, (dof,)))
    tr = Trajectory(dof)
    Ruckig(dof).calculate(inp, tr)  # default (time) synchronisation
    return tr.duration


def _sample(tr, n=801):
    ts = np.linspace(0.0, tr.duration, n)
    q, qd, qdd = (np.array(x) for x in zip(*(tr.at(t) for t in ts), strict=True))
    return ts, q, qd, qdd


def _check_limits(tr, v, a, j):
    ts, q, qd, qdd = _sample(tr)
    dt = ts[1] - ts[0]
    v, a, j = (np.broadcast_to(x, (q.shape[1],)) for x in (v, a, j))
    assert np.all(np.abs(qd) <= v * (1 + 1e-9) + 1e-12)
    assert np.all(np.abs(qdd) <= a * (1 + 1e-9) + 1e-12)
    assert np.all(np.abs(np.diff(qdd, axis=0)) / dt <= j * (1 + 1e-6))
    np.testing.assert_allclose(np.diff(q, axis=0) / dt, 0.5 * (qd[1:] + qd[:-1]), atol=np.max(j) * dt * dt)


@pytest.mark.parametrize("seed", range(6))
def test_joint_move_arrives_together_exactly_with_ruckig_duration(seed):
    rng = np.random.default_rng(seed)
    dof = 5 + seed % 3
    q0, q1 = rng.uniform(-3, 3, dof), rng.uniform(-3, 3, dof)
    v, a, j = 0.8, 4.0, 60.0
    tr = plan_joint_move(q0, q1, v, a, j)
    assert tr.duration == pytest.approx(_ruckig_duration(q0, q1, v, a, j), abs=1e-9)
    q, qd, qdd = tr.at(tr.duration)
    assert np.max(np.abs(q - q1)) <= 1e-9 and not qd.any() and not qdd.any()
    np.testing.assert_array_equal(tr.at(tr.duration + 3.0)[0], q1)
    np.testing.assert_array_equal(tr.at(-1.0)[0], q0)
    # Together: no joint is already at its target shortly before the end, every one still moves.
    q_before, qd_before, _ = tr.at(tr.duration - 0.02)
    assert np.all(np.abs(q_before - q1) > 1e-7)
    assert np.all(np.abs(qd_before) > 0.0)
    # And they move on one straight line in joint space (phase synchronisation).
    ts, qs, _, _ = _sample(tr, 101)
    frac = (qs - q0) / (q1 - q0)
    assert np.max(np.ptp(frac, axis=1)) < 1e-9
    _check_limits(tr, v, a, j)


def test_per_joint_limits():
    q0 = np.zeros(6)
    q1 = np.array([1.0, -1.0, 0.5, 2.0, -0.2, 0.0])
    v = np.array([1.0, 2.0, 0.5, 3.0, 1.0, 1.0])
    a = np.array([5.0, 5.0, 2.0, 10.0, 5.0, 5.0])
    tr = plan_joint_move(q0, q1, v, a, 100.0)
    assert tr.duration == pytest.approx(_ruckig_duration(q0, q1, v, a, 100.0), abs=1e-9)
    assert np.max(np.abs(tr.at(tr.duration)[0] - q1)) <= 1e-9
    _check_limits(tr, v, a, 100.0)


def test_zero_move_and_bad_limits():
    q = np.array([0.1, 0.2, 0.3])
    tr = plan_joint_move(q, q, 1.0, 1.0, 1.0)
    assert tr.duration == 0.0
    np.testing.assert_array_equal(tr.at(0.5)[0], q)
    with pytest.raises(ValueError):
        plan_joint_move(q, q + 1, float("nan"), 1.0, 1.0)
    with pytest.raises(ValueError):
        plan_joint_move(q, q + 1, 1.0, -1.0, 1.0)
    with pytest.raises(ValueError):
        plan_joint_move(q, np.zeros(4), 1.0, 1.0, 1.0)


def test_at_is_cheap():
    tr = plan_joint_move(np.zeros(7), np.ones(7), 1.0, 5.0, 50.0)
    t0 = time.perf_counter()
    for i in range(5000):
        tr.at(i * 1e-4)
    assert (time.perf_counter() - t0) / 5000 < 50e-6


def test_move_longer_than_ruckig_allows_runs_as_a_straight_line_within_limits() -> None:
    """Ruckig refuses durations over about two hours; such a move from rest keeps the same line."""
    q0, q1 = np.zeros(6), np.array([1.0, -0.5, 0.0, 0.25, 0.0, 0.0])
    traj = plan_joint_move(q0, q1, 1e-4, 1e-3, 500.0)
    assert traj.duration == pytest.approx(1.0 / 1e-4 + 1e-4 / 1e-3 + 1e-3 / 500.0, rel=1e-9)
    for t in np.linspace(0.0, traj.duration, 97):
        q, qd, qdd = traj.at(float(t))
        assert np.all(np.abs(qd) <= 1e-4 * (1 + 1e-9)) and np.all(np.abs(qdd) <= 1e-3 * (1 + 1e-9))
        u = q[0]  # on the line q0 + u (q1 - q0)
        np.testing.assert_allclose(q, q1 * u, atol=1e-12)
    np.testing.assert_array_equal(traj.at(traj.duration)[0], q1)


def test_planner_failure_from_a_moving_state_is_a_planning_error(monkeypatch: pytest.MonkeyPatch) -> None:
    from xarm_emu.controller.motion import joint

    def refuse(inp: InputParameter, dof: int) -> Trajectory:
        raise joint.PlanningError("ruckig: refused")

    monkeypatch.setattr(joint, "_run", refuse)
    with pytest.raises(joint.PlanningError):
        plan_joint_move(np.zeros(6), np.ones(6), 1.0, 1.0, 10.0, qd0=np.full(6, 0.1))
    assert plan_joint_move(np.zeros(6), np.ones(6), 1.0, 1.0, 10.0).duration > 1.0  # from rest: a line


@pytest.mark.parametrize("straight", [False, True])
def test_position_is_the_joints_of_at_bit_for_bit(straight: bool) -> None:
    """``position(t)`` answers ``at(t)[0]`` (a new array each time) and its floats, before the start,
    along the move and after the end, for ruckig's trajectories and straight lines."""
    q0, q1 = np.array([0.1, -0.4, 0.3, 0.0, 0.7, -0.2]), np.array([1.0, -0.5, 0.0, 0.25, 0.0, 0.4])
    traj = plan_joint_move(q0, q1, 1e-4, 1e-3, 500.0) if straight else plan_joint_move(q0, q1, 1.0, 5.0, 50.0)
    for t in (-1.0, 0.0, *np.linspace(1e-3, traj.duration, 41).tolist(), traj.duration + 1.0):
        q, values = traj.position(t)
        want = traj.at(t)[0]
        assert q.tobytes() == want.tobytes() and q.dtype == np.float64
        assert values == want.tolist() and all(type(v) is float for v in values)
        assert traj.position(t)[0] is not q  # the caller may keep it
