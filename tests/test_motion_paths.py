"""Cartesian paths and timed moves: line (register 21), circle (27), arc-blended
lines (22) (manual 1.3 notes 1-2, 2.1.3.2)."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from helpers import pose

from xarm_emu.controller.motion.cartesian import CartesianMove, MoveChain, plan_blended
from xarm_emu.controller.motion.paths import ROT_MM_PER_RAD, CirclePath, CollinearError, LinePath

DT = 0.004


def rot_angle(r0, r1):
    c = (np.trace(r0.T @ r1) - 1) / 2
    return math.acos(min(max(c, -1.0), 1.0))


def run(move, dt=DT):
    ts = np.append(np.arange(0.0, move.duration, dt), move.duration)
    out = [move.at(t) for t in ts]
    return ts, np.array([o[0] for o in out]), np.array([o[1] for o in out])


def test_line_samples_on_segment_exact_end_and_speed():
    t0, t1 = pose(300, -100, 250, math.pi, 0, 0), pose(450, 120, 180, math.pi, 0.2, 0.3)
    mv = CartesianMove(LinePath(t0, t1), 200.0, 2000.0, 20000.0)
    ts, T, v = run(mv, 0.001)
    p0, p1 = t0[:3, 3], t1[:3, 3]
    d = (p1 - p0) / np.linalg.norm(p1 - p0)
    rel = T[:, :3, 3] - p0
    along = rel @ d
    off = np.linalg.norm(rel - np.outer(along, d), axis=1)
    assert off.max() < 1e-6
    assert along.min() > -1e-9 and along.max() < np.linalg.norm(p1 - p0) + 1e-9
    np.testing.assert_allclose(T[-1], t1, atol=1e-9)
    np.testing.assert_allclose(T[0], t0, atol=1e-9)
    # Position dominates: cruise at the given linear speed, never faster.
    assert v.max() == pytest.approx(200.0, rel=1e-9)
    fd = np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1) / np.diff(ts)
    assert fd.max() <= 200.0 * (1 + 1e-6)
    # Rotations stay proper and go the short way (monotone angle from the start).
    ang = np.array([rot_angle(t0[:3, :3], r) for r in T[:, :3, :3]])
    assert np.all(np.diff(ang) >= -1e-9)
    assert ang[-1] == pytest.approx(rot_angle(t0[:3, :3], t1[:3, :3]), abs=1e-9)


def test_orientation_only_speed_maps_1000_to_180_deg_per_s():
    t0, t1 = pose(300, 0, 200, math.pi, 0, 0), pose(300, 0, 200, math.pi, 0, math.radians(90))
    speed = 500.0  # -> 90 deg/s
    mv = CartesianMove(LinePath(t0, t1), speed, 5000.0, 100000.0)
    ts, T, v = run(mv, 0.001)
    assert np.abs(T[:, :3, 3] - t0[:3, 3]).max() < 1e-9
    assert v.max() == 0.0  # no TCP travel
    w = np.array([rot_angle(a, b) for a, b in zip(T[:-1, :3, :3], T[1:, :3, :3], strict=True)]) / np.diff(ts)
    assert w.max() == pytest.approx(math.radians(90), rel=1e-3)
    assert w.max() <= math.radians(90) * (1 + 1e-6)
    # Long cruise: duration is about angle / rate plus the ramps.
    assert mv.duration == pytest.approx(1.0 + speed / 5000.0 + 5000.0 / 100000.0, abs=1e-6)


def test_combined_move_timed_by_rotation_when_it_dominates():
    # 10 mm with a 90 deg turn at speed 100: the rotation would need 90 deg at 18 deg/s.
    t0, t1 = pose(300, 0, 200), pose(310, 0, 200, 0, 0, math.pi / 2)
    mv = CartesianMove(LinePath(t0, t1), 100.0, 1000.0, 10000.0)
    assert mv.path.length == pytest.approx(ROT_MM_PER_RAD * math.pi / 2)
    ts, T, v = run(mv, 0.001)
    assert v.max() == pytest.approx(100.0 * 10.0 / mv.path.length, rel=1e-9)
    w = np.array([rot_angle(a, b) for a, b in zip(T[:-1, :3, :3], T[1:, :3, :3], strict=True)]) / np.diff(ts)
    assert w.max() <= 100.0 / ROT_MM_PER_RAD * (1 + 1e-6)


def test_circle_samples_on_circle_cover_percent_and_pass_points():
    t0 = pose(300, 0, 200, math.pi, 0, 0)
    p1 = pose(400, 100, 250, math.pi, 0, 0.5)
    p2 = pose(500, 0, 300, math.pi, 0, 1.0)
    for percent in (50.0, 100.0, 137.5, 250.0):
        path = CirclePath(t0, p1, p2, percent)
        mv = CartesianMove(path, 150.0, 1500.0, 15000.0)
        ts, T, v = run(mv)
        pts = T[:, :3, 3]
        c, n = np.array(path.center), np.array(path.normal)
        assert np.abs(np.linalg.norm(pts - c, axis=1) - path.radius).max() < 1e-6
        assert np.abs((pts - c) @ n).max() < 1e-6
        for p in (t0, p1, p2):  # the circle goes through all three points
            assert abs(np.linalg.norm(p[:3, 3] - c) - path.radius) < 1e-9
        e1, e2 = np.array(path.e1), np.array(path.e2)
        ang = np.unwrap(np.arctan2((pts - c) @ e2, (pts - c) @ e1))
        assert ang[-1] - ang[0] == pytest.approx(2 * math.pi * percent / 100, abs=1e-9)
        assert np.all(np.diff(ang) >= -1e-12)  # one direction: start -> P1 -> P2
        assert path.phi1 < path.phi2
        assert v.max() <= 150.0 * (1 + 1e-9)
    # Passing P1: the pose there is P1's pose.
    path = CirclePath(t0, p1, p2, 100.0)
    np.testing.assert_allclose(path.pose(path.radius * path.phi1), p1, atol=1e-9)
    np.testing.assert_allclose(path.pose(path.radius * path.phi2), p2, atol=1e-9)
    np.testing.assert_allclose(path.pose(path.length), t0, atol=1e-9)


def test_circle_collinear_or_coincident_raises():
    t0 = pose(300, 0, 200)
    with pytest.raises(CollinearError):
        CirclePath(t0, pose(350, 0, 200), pose(400, 0, 200), 50)
    with pytest.raises(CollinearError):
        CirclePath(t0, pose(350, 10, 210), pose(400, 20, 220), 50)
    with pytest.raises(CollinearError):
        CirclePath(t0, t0, pose(400, 0, 200), 50)
    with pytest.raises(CollinearError):
        CirclePath(t0, pose(350, 50, 200), pose(350, 50, 200), 50)


def _dist_to_segment(p, a, b):
    d = b - a
    u = np.clip((p - a) @ d / (d @ d), 0.0, 1.0)
    return np.linalg.norm(p - (a + np.outer(u, d)), axis=1)


@pytest.mark.parametrize("turn_deg", [30.0, 90.0, 150.0])
def test_blended_corner_never_stops_and_stays_within_radius(turn_deg):
    r = 25.0
    th = math.radians(turn_deg)
    a = np.array([200.0, 0.0, 200.0])
    b = a + np.array([150.0, 0.0, 0.0])
    c = b + 120.0 * np.array([math.cos(th), math.sin(th), 0.0])
    poses = [pose(*p, math.pi, 0, 0) for p in (a, b, c)]
    speed, acc = 100.0, 2000.0
    mv = plan_blended(poses, [r, r], speed, acc, 20000.0)
    assert isinstance(mv, CartesianMove)
    ts, T, v = run(mv, 0.001)
    pts = T[:, :3, 3]
    np.testing.assert_allclose(T[-1], poses[-1], atol=1e-9)
    # Cruise speed through the corner: never zero there, no jump between samples.
    near = np.linalg.norm(pts - b, axis=1) <= r + 1e-9
    assert near.any() and v[near].min() == pytest.approx(speed, rel=1e-9)
    assert np.abs(np.diff(v)).max() <= acc * 0.001 * (1 + 1e-6)
    # Every point is on one of the two lines or within the radius of the corner.
    on_line = np.minimum(_dist_to_segment(pts, a, b), _dist_to_segment(pts, b, c)) < 1e-6
    assert np.all(on_line | near)
    assert not on_line[near & (np.linalg.norm(pts - b, axis=1) < r - 1e-6)].any()  # really rounded
    # Corner cut: arc radius rho = r / tan(turn/2), centre rho / cos(turn/2) from the corner.
    rho = r / math.tan(th / 2)
    assert np.linalg.norm(pts - b, axis=1).min() == pytest.approx(rho / math.cos(th / 2) - rho, abs=1e-3)


def test_blend_radius_shrinks_to_half_the_shorter_line_and_none_stops():
    a, b, c = np.array([0.0, 0, 0]), np.array([40.0, 0, 0]), np.array([40.0, 200.0, 0])
    poses = [pose(*p) for p in (a, b, c)]
    mv = plan_blended(poses, [100.0, None], 100.0, 2000.0, 20000.0)
    ts, T, v = run(mv, 0.001)
    pts = T[:, :3, 3]
    off = np.minimum(_dist_to_segment(pts, a, b), _dist_to_segment(pts, b, c))
    dist_b = np.linalg.norm(pts - b, axis=1)
    assert np.all((off < 1e-6) | (dist_b <= 20.0 + 1e-9))  # shrunk to 40/2
    assert dist_b.max() > 20.0 and (off > 1.0).any()
    # Radius None at the corner: the TCP stops there (two S-curves).
    mv2 = plan_blended(poses + [pose(200, 200, 0)], [None, 10.0, 10.0], 100.0, 2000.0, 20000.0)
    assert isinstance(mv2, MoveChain) and len(mv2.moves) == 2
    t_corner = mv2.moves[0].duration
    T_c, v_c = mv2.at(t_corner)
    np.testing.assert_allclose(T_c[:3, 3], b, atol=1e-9)
    assert v_c == 0.0
    np.testing.assert_allclose(mv2.at(mv2.duration)[0], pose(200, 200, 0), atol=1e-9)


def test_blended_chain_with_several_corners_is_continuous():
    pts = [(300, 0, 200), (400, 0, 200), (400, 100, 200), (300, 100, 250), (300, 0, 250)]
    poses = [pose(*p, math.pi, 0, 0.1 * k) for k, p in enumerate(pts)]
    mv = plan_blended(poses, [20, 20, 20, 20], 150.0, 3000.0, 30000.0)
    ts, T, v = run(mv)
    step = np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1)
    assert step.max() <= 150.0 * DT * (1 + 1e-6)
    inner = (ts > 0.2) & (ts < mv.duration - 0.2)
    assert v[inner].min() > 0.5 * 150.0
    np.testing.assert_allclose(T[-1], poses[-1], atol=1e-9)


def test_at_is_cheap():
    poses = [pose(300, 0, 200), pose(400, 0, 200, 0, 0, 0.3), pose(400, 100, 200)]
    mv = plan_blended(poses, [20.0], 100.0, 1000.0, 10000.0)
    t0 = time.perf_counter()
    for i in range(5000):
        mv.at(i * 1e-3)
    assert (time.perf_counter() - t0) / 5000 < 50e-6


@pytest.mark.parametrize("seed", range(5))
def test_random_blended_chains_stay_near_corners_and_end_exactly(seed):
    rng = np.random.default_rng(seed)
    pts = [rng.uniform(-300, 300, 3) for _ in range(5)]
    radii = list(rng.uniform(0.0, 80.0, 4))
    poses = [pose(*p, math.pi, 0.0, rng.uniform(-0.3, 0.3)) for p in pts]
    mv = plan_blended(poses, radii, 200.0, 3000.0, 30000.0)
    ts, T, v = run(mv)
    xyz = T[:, :3, 3]
    np.testing.assert_allclose(T[-1], poses[-1], atol=1e-9)
    off = np.min([_dist_to_segment(xyz, pts[k], pts[k + 1]) for k in range(4)], axis=0)
    near = np.zeros(len(xyz), dtype=bool)
    for k in range(1, 4):  # effective radius: at most half of either adjacent line
        half_in, half_out = np.linalg.norm(pts[k] - pts[k - 1]) / 2, np.linalg.norm(pts[k + 1] - pts[k]) / 2
        r = min(radii[k - 1], half_in, half_out)
        near |= np.linalg.norm(xyz - pts[k], axis=1) <= r + 1e-9
    assert np.all((off < 1e-6) | near)
    # One run (all corners blended): the TCP only rests at both ends.
    assert isinstance(mv, CartesianMove)
    assert np.all(np.linalg.norm(np.diff(xyz, axis=0), axis=1)[1:-1] > 0.0)
