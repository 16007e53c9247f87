"""Sampling Cartesian moves at many path times at once (``at_many``, ``pose_many``,
``sample_many``): every answer equals the one-at-a-time ``at`` / ``pose`` / ``sample``
at the same time, for lines, circles, arc-blended runs (register 22), chains split at
unblended corners and moves re-planned from a moving state, at times before the start,
inside and after the end (manual 1.3, 2.1.3.2)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import pose
from hypothesis import given, settings
from hypothesis import strategies as st

from xarm_emu.controller.motion import (
    BlendArc,
    CartesianMove,
    CirclePath,
    CollinearError,
    CompositePath,
    JerkProfile,
    LinePath,
    MoveChain,
    MovingProfile,
    Path,
    SCurve,
    blend_runs,
    plan_blended,
)
from xarm_emu.controller.motion._rot import Slerp, SlerpSet, pose_matrices, pose_matrix

#: Tolerances of the batch against the one-at-a-time answers (positions mm, rotation entries, mm/s).
POS_TOL, ROT_TOL, SPEED_TOL = 1e-12, 1e-15, 1e-12
SPEED, ACC, JERK = 150.0, 2000.0, 20000.0


def times(duration, n=400, seed=0):
    """Ascending path times: the control periods of the move, random ones, both ends exactly, and
    times before the start and after the end."""
    rng = np.random.default_rng(seed)
    ts = np.concatenate([np.arange(0.0, duration + 0.05, 0.004), rng.uniform(-0.5, duration + 0.5, n),
                         [-1e-9, -0.0, 0.0, 1e-12, duration, duration - 1e-12, duration + 1e-9, -3.0,
                          duration + 7.0]])
    return np.sort(ts)


def assert_matches(move, ts):
    """``move.at_many(ts)`` against ``move.at(t)`` for each t, within the tolerances."""
    poses, speeds = move.at_many(ts)
    assert poses.shape == (len(ts), 4, 4) and speeds.shape == (len(ts),)
    assert poses.dtype == np.float64 and speeds.dtype == np.float64
    one = [move.at(float(t)) for t in ts]
    ref = np.array([p for p, _ in one])
    ref_speed = np.array([v for _, v in one])
    assert np.abs(poses[:, :3, 3] - ref[:, :3, 3]).max() <= POS_TOL
    assert np.abs(poses[:, :3, :3] - ref[:, :3, :3]).max() <= ROT_TOL
    assert np.array_equal(poses[:, 3], ref[:, 3])
    assert np.abs(speeds - ref_speed).max() <= SPEED_TOL * max(1.0, np.abs(ref_speed).max())
    return poses, speeds


def move(path, **kw):
    return CartesianMove(path, SPEED, ACC, JERK, **kw)


A = pose(300.0, 0.0, 200.0, math.pi, 0.0, 0.0)


# --- lines -------------------------------------------------------------------------------------------


@pytest.mark.parametrize("target", [
    pose(400.0, 60.0, 250.0, math.pi, 0.0, 0.0),  # position only
    pose(420.0, -50.0, 180.0, math.pi - 0.4, 0.3, 0.8),  # position and orientation
    pose(305.0, 0.0, 200.0, math.pi, 0.0, 1.2),  # the rotation sets the pace
    pose(300.0, 0.0, 200.0, math.pi, 0.2, -0.5),  # orientation only: no TCP travel
    A.copy(),  # zero length
])
def test_line_moves(target):
    mv = move(LinePath(A, target))
    poses, speeds = assert_matches(mv, times(mv.duration))
    # Not a constant answer: the batch travels the line from start to target.
    np.testing.assert_allclose(poses[0], A, atol=1e-9)
    np.testing.assert_allclose(poses[-1], target, atol=1e-9)


def test_line_from_a_path_coordinate_offset():
    mv = move(LinePath(A, pose(400.0, 50.0, 260.0, 3.0, 0.1, 0.2)), s0=40.0)
    assert_matches(mv, times(mv.duration))


def test_line_pose_many_clamps_as_pose():
    line = LinePath(A, pose(380.0, 40.0, 150.0, 2.9, -0.2, 0.4))
    s = np.array([-50.0, -0.0, 0.0, 1e-9, 10.0, line.length / 2, line.length, line.length + 1.0, 1e6])
    ref = np.array([line.pose(float(x)) for x in s])
    got = line.pose_many(s)
    assert np.abs(got - ref).max() <= POS_TOL
    assert np.array_equal(line.linear_ratio_many(s), np.array([line.linear_ratio(float(x)) for x in s]))


# --- circles -----------------------------------------------------------------------------------------


P1 = pose(330.0, 30.0, 200.0, math.pi, 0.2, 0.0)
P2 = pose(300.0, 60.0, 230.0, math.pi - 0.3, 0.0, 0.5)


@pytest.mark.parametrize("percent", [0.0, 30.0, 99.9, 100.0, 120.0, 250.0])
def test_circle_moves(percent):
    mv = move(CirclePath(A, P1, P2, percent))
    poses, _ = assert_matches(mv, times(mv.duration, seed=int(percent)))
    if percent >= 100.0:  # a full turn comes back through the start pose
        np.testing.assert_allclose(poses[0], A, atol=1e-9)


def test_circle_orientation_pieces_and_turns():
    circle = CirclePath(A, P1, P2, 250.0)
    # Angles inside each of the three orientation slerps of each turn, and at their bounds.
    phis = [k * 2.0 * math.pi + f for k in range(3)
            for f in (0.0, circle.phi1 / 2, circle.phi1, (circle.phi1 + circle.phi2) / 2, circle.phi2,
                      (circle.phi2 + 2 * math.pi) / 2)]
    s = np.array([min(p * circle.radius, circle.length) for p in phis])
    ref = np.array([circle.pose(float(x)) for x in s])
    assert np.abs(circle.pose_many(s) - ref).max() <= POS_TOL


# --- blended runs and chains -------------------------------------------------------------------------


CORNERS = [A, pose(360.0, 0.0, 200.0, math.pi, 0.0, 0.0), pose(360.0, 70.0, 220.0, 3.0, 0.1, 0.3),
           pose(300.0, 70.0, 200.0, math.pi, 0.0, 0.0), pose(300.0, 0.0, 200.0, math.pi, 0.0, -0.2),
           pose(300.0, 0.0, 200.0, math.pi, 0.0, 0.4), pose(250.0, 0.0, 200.0, math.pi, 0.0, 0.4),
           pose(200.0, 0.0, 200.0, math.pi, 0.0, 0.4)]


@pytest.mark.parametrize("radii", [
    [20.0, 20.0, 20.0, 20.0, 20.0, 20.0, None],
    [5.0, 10.0, 200.0, 1.0, 30.0, 15.0, None],  # 200: shrunk to half a line; 15: nearly straight on
    [20.0, None, 10.0, None, 5.0, 10.0, None],  # unblended corners: a chain of runs
    [None] * 7,  # every corner a stop
])
def test_blended_runs(radii):
    mv = plan_blended(CORNERS, radii, SPEED, ACC, JERK)
    assert_matches(mv, times(mv.duration, n=800))


def test_chain_with_unblended_corners_is_a_move_chain():
    mv = plan_blended(CORNERS[:5], [20.0, None, 10.0, None], SPEED, ACC, JERK)
    assert isinstance(mv, MoveChain) and len(mv.moves) == 2
    assert any(isinstance(p, BlendArc) for m in mv.moves for p in m.path.pieces)
    poses, _ = assert_matches(mv, times(mv.duration, n=800))
    # Inside the chain at the time the second run starts: its first pose.
    k = np.searchsorted(times(mv.duration, n=800), mv.moves[0].duration)
    assert poses.shape[0] > k


def test_unsorted_times_and_repeats():
    mv = plan_blended(CORNERS, [20.0, 5.0, 30.0, 1.0, 10.0, 10.0, None], SPEED, ACC, JERK)
    ts = np.random.default_rng(3).permutation(np.repeat(times(mv.duration, n=200), 2))
    assert_matches(mv, ts)


def test_empty_times():
    mv = plan_blended(CORNERS, [20.0] * 7, SPEED, ACC, JERK)
    poses, speeds = mv.at_many(np.empty(0))
    assert poses.shape == (0, 4, 4) and speeds.shape == (0,)


# --- moving start (a blend arriving while the arm moves) ---------------------------------------------


@pytest.mark.parametrize(("v0", "a0"), [(0.0, 0.0), (50.0, 100.0), (150.0, 0.0), (120.0, -1500.0),
                                         (300.0, 100.0), (150.0, -3000.0), (100.0, 3000.0)])
def test_moving_profile_start(v0, a0):
    runs = blend_runs(CORNERS, [20.0, 10.0, 30.0, None, 10.0, 10.0, None])
    profile = MovingProfile(runs[0].length, v0, a0, SPEED, ACC, JERK)
    moves = [move(runs[0], profile=profile), *(move(r) for r in runs[1:])]
    assert_matches(moves[0], times(moves[0].duration, n=600))
    assert_matches(MoveChain(moves), times(MoveChain(moves).duration, n=600))


@pytest.mark.parametrize(("distance", "v0", "a0"), [(200.0, 50.0, 100.0), (200.0, 300.0, 100.0),
                                                     (200.0, 150.0, -3000.0), (5.0, 150.0, 2500.0),
                                                     (100.0, -40.0, 0.0)])
def test_moving_profile_sample_many_is_sample(distance, v0, a0):
    profile = MovingProfile(distance, v0, a0, SPEED, ACC, JERK)
    ts = times(profile.duration, n=1000, seed=7)
    s, v, a = profile.sample_many(ts)
    ref = np.array([profile.sample(float(t)) for t in ts])
    # No trigonometry: the same arithmetic gives the same numbers.
    np.testing.assert_array_equal(np.stack([s, v, a], axis=1), ref)


# --- profiles ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("distance", [300.0, 3.0, 0.05, -120.0, 0.0])
def test_scurve_sample_many_is_sample(distance):
    profile = SCurve(distance, SPEED, ACC, JERK)
    # With the segment starts themselves (where the segment index changes).
    ts = np.sort(np.concatenate([times(profile.duration, seed=11), np.array(profile._t)]))
    s, v, a = profile.sample_many(ts)
    ref = np.array([profile.sample(float(t)) for t in ts])
    np.testing.assert_array_equal(np.stack([s, v, a], axis=1), ref)


def test_jerk_profile_from_a_moving_state():
    profile = JerkProfile([(0.1, 500.0), (0.2, 0.0), (0.05, -2000.0)], v0=30.0, a0=-10.0)
    ts = times(profile.duration, seed=5)
    s, v, a = profile.sample_many(ts)
    np.testing.assert_array_equal(np.stack([s, v, a], axis=1),
                                  np.array([profile.sample(float(t)) for t in ts]))
    assert v[0] == 30.0 and a[0] == -10.0  # before the start: the start state


# --- fallbacks ---------------------------------------------------------------------------------------


class _Wave(Path):
    """A path with only the scalar interface: a line with a sideways wave."""

    def __init__(self, t0: np.ndarray, length: float) -> None:
        self.t0, self.length = t0, length

    def pose(self, s: float) -> np.ndarray:
        t = self.t0.copy()
        t[:3, 3] += (s, 5.0 * math.sin(s / 10.0), 0.0)
        return t

    def linear_ratio(self, s: float) -> float:
        return 1.0 + 0.1 * math.cos(s / 10.0)


class _ScalarProfile:
    """A profile with only ``sample``: constant speed over its duration."""

    duration = 2.0

    def sample(self, t: float) -> tuple[float, float, float]:
        t = min(max(t, 0.0), self.duration)
        return 40.0 * t, 40.0 if 0.0 < t < self.duration else 0.0, 0.0


def test_path_without_vectorised_form_loops():
    wave = _Wave(A, 120.0)
    mv = move(wave)
    poses, speeds = assert_matches(mv, times(mv.duration))
    assert np.ptp(poses[:, 1, 3]) > 5.0 and np.ptp(speeds) > 0.0


def test_composite_with_a_piece_without_vectorised_form():
    line = LinePath(A, pose(360.0, 0.0, 200.0, math.pi, 0.0, 0.3))
    wave = _Wave(line.pose(line.length), 80.0)
    back = LinePath(wave.pose(80.0), pose(440.0, 40.0, 230.0, 3.0, 0.0, 0.3))
    path = CompositePath([line, wave, back])
    mv = move(path)
    assert_matches(mv, times(mv.duration, n=600))
    s = np.linspace(-10.0, path.length + 10.0, 301)
    assert np.abs(path.pose_many(s) - np.array([path.pose(float(x)) for x in s])).max() <= POS_TOL
    assert np.array_equal(path.linear_ratio_many(s), [path.linear_ratio(float(x)) for x in s])


def test_profile_without_sample_many():
    mv = CartesianMove(LinePath(A, pose(400.0, 0.0, 200.0, math.pi, 0.0, 0.0)), SPEED, ACC, JERK,
                       profile=_ScalarProfile())  # type: ignore[arg-type]
    assert_matches(mv, times(mv.duration))


# --- rotation helpers --------------------------------------------------------------------------------


def test_pose_matrices_and_slerp_set():
    rng = np.random.default_rng(9)
    q = rng.normal(size=(4, 50))
    q /= np.linalg.norm(q, axis=0)
    p = rng.uniform(-500.0, 500.0, size=(3, 50))
    ref = np.array([pose_matrix(tuple(p[:, k]), tuple(q[:, k])) for k in range(50)])
    assert np.abs(pose_matrices(p, q) - ref).max() <= POS_TOL
    slerps = [Slerp(tuple(q[:, k]), tuple(q[:, k + 1])) for k in range(3)] + [Slerp(tuple(q[:, 5]),
                                                                                    tuple(q[:, 5]))]
    which = rng.integers(0, 4, 200)
    u = rng.uniform(-0.2, 1.2, 200)
    u[:4] = (0.0, 1.0, -0.0, 0.5)
    got = SlerpSet(slerps).at(which, u)
    ref_q = np.array([slerps[w].at(float(x)) for w, x in zip(which, u, strict=True)]).T
    assert np.abs(got - ref_q).max() <= ROT_TOL
    assert np.abs(slerps[0].at_many(u) - np.array([slerps[0].at(float(x)) for x in u]).T).max() <= ROT_TOL


# --- random paths and times --------------------------------------------------------------------------

coord = st.floats(-80.0, 80.0, allow_nan=False)
angle = st.floats(-math.pi, math.pi, allow_nan=False)
poses6 = st.tuples(coord, coord, coord, angle, angle, angle)


def _pose(d):
    return pose(300.0 + d[0], d[1], 250.0 + d[2], math.pi + d[3] / 3, d[4] / 3, d[5])


@settings(max_examples=30, deadline=None)
@given(st.lists(poses6, min_size=2, max_size=5),
       st.lists(st.one_of(st.none(), st.floats(0.0, 60.0)), min_size=4, max_size=4),
       st.lists(st.floats(-1.0, 1.0), min_size=1, max_size=40), st.integers(0, 2 ** 31))
def test_random_blended_moves(corners, radii, fractions, seed):
    mv = plan_blended([_pose(c) for c in corners], radii[:len(corners) - 1], SPEED, ACC, JERK)
    ts = np.sort(np.concatenate([np.asarray(fractions) * 1.5 * mv.duration + 0.25 * mv.duration,
                                 times(mv.duration, n=50, seed=seed)]))
    assert_matches(mv, ts)


@settings(max_examples=30, deadline=None)
@given(poses6, poses6, st.floats(0.0, 300.0), st.lists(st.floats(-0.5, 1.5), min_size=1, max_size=40))
def test_random_circles(p1, p2, percent, fractions):
    try:
        circle = CirclePath(A, _pose(p1), _pose(p2), percent)
    except CollinearError:
        return
    mv = move(circle)
    assert_matches(mv, np.sort(np.asarray(fractions) * mv.duration))
