"""Orientation conventions (manual 1.5; the vendor controller's canonical forms)."""

import math

import numpy as np
import pytest
from helpers import rx, ry, rz
from hypothesis import given, settings
from hypothesis import strategies as st

from xarm_emu.model.rotations import (
    axis_angle_to_matrix,
    canonical_rpy,
    matrix_to_axis_angle,
    matrix_to_pose,
    matrix_to_pose_aa,
    matrix_to_rpy,
    pose_aa_to_matrix,
    pose_to_matrix,
    rpy_to_matrix,
    snap_seam,
)

PI = math.pi
angle = st.floats(-PI, PI, allow_nan=False)




@given(angle, angle, angle)
@settings(max_examples=200, deadline=None)
def test_rpy_is_fixed_xyz(r, p, y):
    """Manual 1.5: R = Rz(yaw) Ry(pitch) Rx(roll); extraction gives back the same rotation."""
    R = rpy_to_matrix(r, p, y)
    np.testing.assert_allclose(R, rz(y) @ ry(p) @ rx(r), atol=1e-15)
    back = matrix_to_rpy(R)
    assert np.all(np.abs(back) <= PI)
    np.testing.assert_allclose(rpy_to_matrix(*back), R, atol=2e-6 if abs(abs(p) - PI / 2) < 1e-5 else 1e-12)


def test_seam_roll_is_minus_pi_and_zero_pitch_is_negative_zero():
    """Register 44 example: roll bytes C0490FDB (-pi), pitch bytes 80000000 (-0.0)."""
    for roll in (PI, -PI):
        r, p, y = matrix_to_rpy(rpy_to_matrix(roll, 0.0, 0.3))
        assert r == -PI
        assert p == 0.0 and math.copysign(1.0, p) == -1.0
        assert y == pytest.approx(0.3, abs=1e-15)


def test_roll_away_from_seam_keeps_sign():
    r, p, y = matrix_to_rpy(rpy_to_matrix(PI - 1e-3, 0.2, -0.4))
    assert r == pytest.approx(PI - 1e-3, abs=1e-12)
    assert (p, y) == pytest.approx((0.2, -0.4), abs=1e-12)


@pytest.mark.parametrize(
    ("pitch", "expected_roll"),
    [(PI / 2, 0.0 - PI / 6), (-PI / 2, 0.0 + PI / 6), (float(np.float32(PI / 2)), -PI / 6)],
)
def test_gimbal_lock_keeps_yaw_zero(pitch, expected_roll):
    """Vendor article: [0, 90, 30] deg reads back as [-30, 90, 0] deg; the same rotation."""
    r, p, y = canonical_rpy(0.0, pitch, PI / 6)
    assert y == 0.0
    assert p == math.copysign(PI / 2, pitch)
    assert r == pytest.approx(expected_roll, abs=1e-7)
    np.testing.assert_allclose(rpy_to_matrix(r, p, y), rpy_to_matrix(0.0, pitch, PI / 6), atol=1e-7)


def test_axis_angle_manual_examples():
    """Manual 1.5: axis [1, 0, 0] and 180 deg -> [pi, 0, 0]; axis [0.707, 0.707, 0], 90 deg."""
    np.testing.assert_allclose(axis_angle_to_matrix([PI, 0, 0]), rx(PI), atol=1e-15)
    np.testing.assert_array_equal(matrix_to_axis_angle(rx(PI)), [PI, 0.0, 0.0])
    u = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
    rv = u * PI / 2
    np.testing.assert_allclose(matrix_to_axis_angle(axis_angle_to_matrix(rv)), rv, atol=1e-14)


def test_axis_angle_sign_rule_at_pi():
    """At exactly pi the first non-zero axis component is made positive."""
    for axis in ([-1.0, 0.0, 0.0], [0.0, -0.6, 0.8], [0.0, 0.0, -1.0]):
        a = np.array(axis)
        got = matrix_to_axis_angle(axis_angle_to_matrix(a * PI))
        first = next(v for v in got if abs(v) > 1e-9)
        assert first > 0
        assert np.linalg.norm(got) == pytest.approx(PI, abs=1e-12)
        np.testing.assert_allclose(np.abs(got), np.abs(a) * PI, atol=1e-9)


def test_axis_angle_just_below_pi_keeps_direction():
    rv = np.array([0.0, -0.6, 0.8]) * (PI - 1e-7)
    np.testing.assert_allclose(matrix_to_axis_angle(axis_angle_to_matrix(rv)), rv, atol=1e-9)


@given(st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)), st.floats(0.0, PI))
@settings(max_examples=200, deadline=None)
def test_axis_angle_round_trip(axis, phi):
    a = np.array(axis)
    n = np.linalg.norm(a)
    if n < 1e-3:
        return
    rv = a / n * phi
    R = axis_angle_to_matrix(rv)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-14)
    back = matrix_to_axis_angle(R)
    assert np.linalg.norm(back) <= PI + 1e-12
    np.testing.assert_allclose(axis_angle_to_matrix(back), R, atol=1e-12)
    if phi < PI - 1e-6:
        np.testing.assert_allclose(back, rv, atol=1e-9)


def test_tiny_angles_survive():
    rv = np.array([1e-10, -2e-10, 3e-11])
    np.testing.assert_allclose(matrix_to_axis_angle(axis_angle_to_matrix(rv)), rv, rtol=1e-6)


def test_pose_round_trips():
    pose = (100.0, -20.0, 300.0, 0.3, -0.2, 1.1)
    T = pose_to_matrix(pose)
    np.testing.assert_allclose(T[:3, 3], pose[:3])
    np.testing.assert_allclose(matrix_to_pose(T), pose, atol=1e-12)
    aa = matrix_to_pose_aa(T)
    np.testing.assert_allclose(pose_aa_to_matrix(aa), T, atol=1e-12)
    assert tuple(T[3]) == (0.0, 0.0, 0.0, 1.0)


def test_position_noise_snapped():
    T = pose_to_matrix((207.0, 3.6e-14, 112.0, PI, 0.0, 0.0))
    assert matrix_to_pose(T)[1] == 0.0


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_raises_value_error(bad):
    with pytest.raises(ValueError):
        rpy_to_matrix(bad, 0.0, 0.0)
    with pytest.raises(ValueError):
        pose_to_matrix((bad, 0, 0, 0, 0, 0))
    with pytest.raises(ValueError):
        axis_angle_to_matrix([0.0, bad, 0.0])
    R = np.eye(3)
    R[1, 1] = bad
    with pytest.raises(ValueError):
        matrix_to_rpy(R)
    with pytest.raises(ValueError):
        matrix_to_axis_angle(R)


def test_snap_seam_float32_pi():
    assert snap_seam(float(np.float32(PI))) == PI
    assert snap_seam(-float(np.float32(PI))) == -PI
    assert snap_seam(3.0) == 3.0
