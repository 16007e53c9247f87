"""Kinematics against the manual's examples (registers 41, 43, 44) and self-consistency checks."""

import math
import struct

import numpy as np
import pytest
from helpers import assert_ik_round_trips

from xarm_emu.model.kinematics import (
    fk,
    flange_target,
    ik,
    jacobian,
    joint_frames,
    pose_offset,
    tcp_pose,
    tcp_positions,
    within_limits,
)
from xarm_emu.model.robots import MODELS, ROBOT_MODELS, XARM5, XARM6, XARM7, get_model
from xarm_emu.model.rotations import matrix_to_axis_angle, matrix_to_pose, pose_to_matrix, snap_seam

PI = math.pi


def f32(b: bytes) -> float:
    return struct.unpack("<f", b)[0]


def f32_bytes(v: float) -> bytes:
    return struct.pack("<f", v)


def rot_err(A, B) -> float:
    return float(np.linalg.norm(matrix_to_axis_angle(A[:3, :3] @ B[:3, :3].T)))


def reachable_joints(model, rng):
    """Random joints inside the limits (0.1 rad margin); xArm5 keeps its flange level (J4 = -(J2 + J3))."""
    lo = np.maximum(model.lower, -PI) + 0.1
    hi = np.minimum(model.upper, PI) - 0.1
    while True:
        q = rng.uniform(lo, hi)
        if model.fixed_roll_pitch:
            q[3] = -(q[1] + q[2])
        if np.all(q >= lo) and np.all(q <= hi):
            return q


def test_models_table():
    assert [get_model(d).dof for d in (5, 6, 7)] == [5, 6, 7]
    assert all(len(m.joints) == m.dof and m.lower.shape == (m.dof,) for m in MODELS.values())
    assert XARM6.upper[1] == pytest.approx(math.radians(120), abs=1e-6)  # manual 1.3: J2 -118..120 deg
    assert XARM7.lower[3] == pytest.approx(math.radians(-11), abs=1e-6)  # xArm7 J4 -11..225 deg
    with pytest.raises(ValueError):
        get_model(4)


def test_register44_example_xarm6():
    """Manual register 44: J1 = bytes 92 0A 86 3F (float32 pi/3) -> x 103.5, y 179.2673, z 112."""
    q1 = f32(bytes([0x92, 0x0A, 0x86, 0x3F]))
    pose = matrix_to_pose(fk(XARM6, [q1, 0, 0, 0, 0, 0, 0]))
    assert pose[:3] == pytest.approx([103.5, 179.2673, 112.0], abs=1e-3)
    assert f32_bytes(pose[3]) == bytes([0xDB, 0x0F, 0x49, 0xC0])  # roll = -pi
    assert f32_bytes(pose[4]) == bytes([0x00, 0x00, 0x00, 0x80])  # pitch = -0.0, signed zero
    assert f32_bytes(pose[5]) == bytes([0x92, 0x0A, 0x86, 0x3F])  # yaw = +pi/3


@pytest.mark.parametrize(
    ("model", "zero"), [(XARM5, (207, 0, 112)), (XARM6, (207, 0, 112)), (XARM7, (206, 0, 120.5))]
)
def test_zero_joints_give_zero_pose(model, zero):
    pose = matrix_to_pose(fk(model, np.zeros(model.dof)))
    assert pose[:3] == pytest.approx(zero, abs=1e-9)
    assert abs(pose[3]) == pytest.approx(PI, abs=1e-12)
    assert pose[4:] == pytest.approx([0.0, 0.0], abs=1e-12)
    assert model.zero_pose[:3] == pytest.approx(zero)


@pytest.mark.parametrize("model", [XARM5, XARM6, XARM7])
def test_unrolled_fk_matches_numpy_chain(model):
    rng = np.random.default_rng(1)
    for _ in range(50):
        q = rng.uniform(-PI, PI, model.dof)
        frames = joint_frames(model, q)
        assert len(frames) == model.dof
        np.testing.assert_allclose(fk(model, q), frames[-1], atol=1e-9)


@pytest.mark.parametrize("key", sorted(ROBOT_MODELS))
def test_tcp_positions_of_many_states_equal_each_state_s_tcp_pose(key):
    """The array form of the unrolled chain (a replay's batch) gives every state's TCP position of
    :func:`tcp_pose`, with a TCP offset and a user frame."""
    model = ROBOT_MODELS[key]
    q = np.random.default_rng(3).uniform(-PI, PI, (60, 7))
    tcp, user = (5.0, -10.0, 120.0, 0.1, 0.2, -0.3), (100.0, 50.0, -20.0, 0.3, -0.2, 1.0)
    many = tcp_positions(model, q, tcp, user)
    one = np.array([tcp_pose(model, row, tcp, user)[:3, 3] for row in q])
    np.testing.assert_allclose(many, one, rtol=0, atol=1e-9)
    flange = [fk(model, row)[:3, 3] for row in q[:4]]
    np.testing.assert_allclose(tcp_positions(model, q[:4]), flange, atol=1e-9)


@pytest.mark.parametrize("model", [XARM5, XARM6, XARM7])
def test_jacobian_matches_finite_differences(model):
    rng = np.random.default_rng(2)
    q = rng.uniform(-1, 1, model.dof)
    J = jacobian(model, q)
    assert J.shape == (6, model.dof)
    T0 = fk(model, q)
    h = 1e-6
    for i in range(model.dof):
        dq = np.zeros(model.dof)
        dq[i] = h
        T1 = fk(model, q + dq)
        np.testing.assert_allclose((T1[:3, 3] - T0[:3, 3]) / h, J[:3, i], atol=1e-3)
        w = matrix_to_axis_angle(T1[:3, :3] @ T0[:3, :3].T) / h
        np.testing.assert_allclose(w, J[3:, i], atol=1e-6)


def test_register43_example_xarm6():
    """Manual register 43: (400, 0, 200, pi, 0, 0) on xArm6 from zero joints.

    The vendor controller replies J2 = 0.0817986, J3 = -0.6411543, J5 = 0.5593557.
    The bytes printed in our manual text (38 88 A7 3D, 88 22 24 BF, 81 31 0F 3F) decode 4-7e-6 rad away
    from those, close to the rounded labels; they are checked to 1e-5 only.
    """
    pose = [f32(f32_bytes(v)) for v in (400.0, 0.0, 200.0, PI, 0.0, 0.0)]
    pose[3:] = [snap_seam(a) for a in pose[3:]]
    q = ik(XARM6, pose_to_matrix(pose), np.zeros(6))
    assert q is not None
    assert [q[1], q[2], q[4]] == pytest.approx([0.0817986, -0.6411543, 0.5593557], abs=3e-7)
    assert [q[0], q[3], q[5]] == pytest.approx([0, 0, 0], abs=1e-9)
    printed = [bytes.fromhex(h) for h in ("3888A73D", "882224BF", "81310F3F")]
    assert [q[1], q[2], q[4]] == pytest.approx([f32(b) for b in printed], abs=1e-5)


def test_xarm5_closed_form_same_plane_solution():
    """xArm6 with J4 = 0 reduces to xArm5: the same J2/J3 and J4(xArm5) = J5(xArm6)."""
    q = ik(XARM5, pose_to_matrix((400, 0, 200, PI, 0, 0)), np.zeros(5))
    assert q is not None
    assert list(q) == pytest.approx([0, 0.0817987279, -0.641154590, 0.559355862, 0], abs=1e-8)


@pytest.mark.parametrize("model", [XARM5, XARM6, XARM7])
def test_fk_of_ik_reproduces_random_poses(model):
    assert_ik_round_trips(model, reachable_joints)


@pytest.mark.parametrize("model", [XARM5, XARM6])
def test_seed_near_solution_returns_that_solution(model):
    rng = np.random.default_rng(4)
    for _ in range(20):
        truth = reachable_joints(model, rng)
        if model is XARM6 and abs(truth[4]) < 0.2:  # wrist singularity: J4/J6 not unique
            continue
        q = ik(model, fk(model, truth), truth + rng.uniform(-0.05, 0.05, model.dof))
        assert q is not None
        np.testing.assert_allclose(q, truth, atol=1e-6)


def test_xarm7_posture_follows_seed():
    """Redundant arm: a seed near a solution gives a solution near it (minimum-norm steps)."""
    rng = np.random.default_rng(5)
    for _ in range(20):
        truth = reachable_joints(XARM7, rng)
        q = ik(XARM7, fk(XARM7, truth), truth + rng.uniform(-0.01, 0.01, 7))
        assert q is not None
        assert np.max(np.abs(q - truth)) < 0.05
        assert np.array_equal(ik(XARM7, fk(XARM7, truth), truth), truth)


def test_xarm5_accepts_only_level_flange():
    assert ik(XARM5, pose_to_matrix((300, 100, 150, -PI, 0, 0.5)), np.zeros(5)) is not None
    assert ik(XARM5, pose_to_matrix((300, 100, 150, PI - 0.1, 0, 0)), np.zeros(5)) is None
    assert ik(XARM5, pose_to_matrix((300, 100, 150, PI, 0.05, 0)), np.zeros(5)) is None


def test_limited_wraps_to_pi_when_limits_allow():
    truth = np.array([3.5, 0.2, -0.8, 0.1, 0.7, -3.4])
    T = fk(XARM6, truth)
    q = ik(XARM6, T, truth, limited=True)
    assert q is not None
    assert q[0] == pytest.approx(3.5 - 2 * PI, abs=1e-9) and q[5] == pytest.approx(-3.4 + 2 * PI, abs=1e-9)
    q = ik(XARM6, T, truth, limited=False)
    assert q is not None and q[0] == pytest.approx(3.5, abs=1e-9)
    # J3 below -pi is allowed by its limits (-225 deg) and is not wrapped out of them
    truth = np.array([0.0, 1.0, -3.5, 0.0, 0.5, 0.0])
    q = ik(XARM6, fk(XARM6, truth), truth)
    assert q is not None and q[2] == pytest.approx(-3.5, abs=1e-9)


def test_within_limits():
    assert within_limits(XARM6, np.zeros(6))
    assert within_limits(XARM6, [0, 2.094395, 0, 0, 0, 0])
    assert not within_limits(XARM6, [0, 2.1, 0, 0, 0, 0])
    assert not within_limits(XARM6, [0, 0, 0, 0, -1.7, 0])
    assert not within_limits(XARM6, [math.nan, 0, 0, 0, 0, 0])
    assert not within_limits(XARM6, [0, 0])


def test_bad_input_is_clean():
    T = pose_to_matrix((400, 0, 200, PI, 0, 0))
    bad = T.copy()
    bad[0, 3] = math.nan
    assert ik(XARM6, bad, np.zeros(6)) is None
    assert ik(XARM6, T, [0, math.inf, 0, 0, 0, 0]) is None
    assert ik(XARM6, np.eye(3), np.zeros(6)) is None
    assert ik(XARM6, pose_to_matrix((2000, 0, 200, PI, 0, 0)), np.zeros(6)) is None  # out of reach
    assert ik(XARM5, pose_to_matrix((2000, 0, 200, PI, 0, 0)), np.zeros(5)) is None
    with pytest.raises(ValueError):
        fk(XARM6, [0, math.nan, 0, 0, 0, 0])
    with pytest.raises(ValueError):
        jacobian(XARM6, [0, 0, 0])


def test_tcp_offset_hand_computed():
    """Manual 1.5 / register 35: the offset is in the flange frame (tool z points down at zero)."""
    q = np.zeros(6)
    p = matrix_to_pose(tcp_pose(XARM6, q, (0, 0, 100, 0, 0, 0)))
    assert p == pytest.approx([207, 0, 12, -PI, 0, 0], abs=1e-9)
    p = matrix_to_pose(tcp_pose(XARM6, q, (50, 0, 0, 0, 0, 0)))
    assert p[:3] == pytest.approx([257, 0, 112], abs=1e-9)
    p = matrix_to_pose(tcp_pose(XARM6, q, (0, 50, 0, 0, 0, 0)))
    assert p[:3] == pytest.approx([207, -50, 112], abs=1e-9)
    # turning the tool +90 deg about its own (downward) z shows as yaw -90 deg in the base frame
    p = matrix_to_pose(tcp_pose(XARM6, q, (0, 0, 0, 0, 0, PI / 2)))
    assert p == pytest.approx([207, 0, 112, -PI, 0, -PI / 2], abs=1e-9)


def test_user_offset_hand_computed():
    """Register 73: the offset is the user frame's pose in the base frame.

    xArm user manual example: offset (1000, 0, 0, 0, 0, 180 deg) turns (207, 0, 112, 180, 0, 0)
    into (793, 0, 112, 180, 0, 180). A non-symmetric case pins the direction of the transform.
    """
    p = matrix_to_pose(tcp_pose(XARM6, np.zeros(6), user_offset=(1000, 0, 0, 0, 0, PI)))
    assert p[:3] == pytest.approx([793, 0, 112], abs=1e-9)
    assert abs(p[3]) == pytest.approx(PI) and abs(p[5]) == pytest.approx(PI) and p[4] == pytest.approx(0)
    p = matrix_to_pose(tcp_pose(XARM6, np.zeros(6), user_offset=(100, 0, 0, 0, 0, PI / 2)))
    assert p == pytest.approx([0, -107, 112, -PI, 0, -PI / 2], abs=1e-9)


def test_flange_target_inverts_tcp_pose_and_feeds_ik():
    tcp = (10, -20, 150, 0.1, -0.2, 0.3)
    user = (50, 60, -10, 0.05, 0.0, 0.7)
    truth = np.array([0.3, 0.4, -1.0, 0.2, 0.8, -0.3])
    T_user = tcp_pose(XARM6, truth, tcp, user)
    np.testing.assert_allclose(flange_target(T_user, tcp, user), fk(XARM6, truth), atol=1e-9)
    q = ik(XARM6, flange_target(T_user, tcp, user), truth + 0.1)
    assert q is not None
    np.testing.assert_allclose(q, truth, atol=1e-6)


def test_pose_offset_register76_example():
    """Register 76 example: (400, 0, 200, pi, 0, 0) to (400, 0, 100, pi, 0, 0) -> z = -100, no rotation."""
    D = pose_offset(pose_to_matrix((400, 0, 200, PI, 0, 0)), pose_to_matrix((400, 0, 100, PI, 0, 0)))
    assert matrix_to_pose(D) == pytest.approx([0, 0, -100, 0, 0, 0], abs=1e-9)


def test_each_model_object_keeps_its_own_generated_chain_when_calls_alternate() -> None:
    """The generated code is looked up per model object: calls that alternate between arms, and
    between two objects of the same arm with different joint origins, each get their own chain
    (checked against the plain numpy chain)."""
    import dataclasses

    j = XARM6.joints[2]
    moved = dataclasses.replace(j, origin_xyz=(j.origin_xyz[0] + 10.0, *j.origin_xyz[1:]))
    other6 = dataclasses.replace(XARM6, joints=(*XARM6.joints[:2], moved, *XARM6.joints[3:]))
    q = (0.3, -0.4, -0.6, 0.2, 0.5, -0.1, 0.25)
    for model in (XARM6, XARM7, XARM6, other6, XARM6, other6, XARM5, XARM6):
        want = joint_frames(model, q[: model.dof])[-1]
        assert np.allclose(fk(model, q[: model.dof]), want, atol=1e-9)
    assert not np.allclose(fk(XARM6, q[:6]), fk(other6, q[:6]), atol=1.0)
