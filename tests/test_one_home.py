"""One home for each fact of the model layer: the shared helpers are the same objects everywhere, and the
collision geometry follows the joint table of the robot model (manual registers 77/78, 35)."""

from __future__ import annotations

import ast
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

import xarm_emu.controller.motion as motion_pkg
from xarm_emu.controller.core import safety
from xarm_emu.controller.motion import _rot, paths
from xarm_emu.model import collision, dynamics, kinematics, rotations
from xarm_emu.model.robots import XARM5, XARM6, XARM7, RobotModel
from xarm_emu.viewer import scene

Q6 = (0.3, -0.4, -0.6, 0.5, 0.7, -0.2)


def _with_origin(model: RobotModel, k: int, xyz: tuple[float, float, float]) -> RobotModel:
    joints = list(model.joints)
    joints[k] = dataclasses.replace(joints[k], origin_xyz=xyz)
    return dataclasses.replace(model, joints=tuple(joints))


def test_quaternion_and_rpy_helpers_are_the_rotations_ones() -> None:
    assert scene.quat_from_matrix is rotations.quat_from_matrix
    assert _rot.quat_from_matrix is rotations.quat_from_matrix
    assert paths.quat_from_matrix is rotations.quat_from_matrix
    assert dynamics.rpy_to_matrix is rotations.rpy_to_matrix


def test_quat_from_matrix_has_w_non_negative_and_rebuilds_the_matrix() -> None:
    R = rotations.rpy_to_matrix(math.pi, 0.2, -2.9)  # trace < 0: one of the non-trace branches
    q = rotations.quat_from_matrix(R)
    assert q[0] >= 0.0
    np.testing.assert_allclose(_rot.pose_matrix((0.0, 0.0, 0.0), q)[:3, :3], R, atol=1e-12)


@pytest.mark.parametrize("model", [XARM5, XARM6, XARM7], ids=lambda m: m.name)
def test_collision_segments_follow_the_joint_origins(model: RobotModel) -> None:
    """Lengthening the upper arm in a copy of the model moves the capsules beyond it, and only there."""
    q = np.array((0.3, -0.5, -0.8, 0.2, 0.4, 0.1, 0.2)[: model.dof])  # clear of self-collision
    k = 2  # the joint at the elbow end of the upper arm (J3)
    x, y, z = model.joints[k].origin_xyz
    longer = _with_origin(model, k, (x, y - 40.0, z))
    assert longer.name == model.name  # same name: nothing may be cached by name
    before = collision.link_shapes(model, q)
    after = collision.link_shapes(longer, q)
    upper = next(i for i, s in enumerate(before) if s.name == "upper arm")
    elbow_frame = kinematics.joint_frames(longer, q)[k][:3, 3]
    np.testing.assert_allclose(after[upper].b, elbow_frame, atol=1e-9)
    assert math.dist(before[upper].b, after[upper].b) == pytest.approx(40.0, abs=1e-9)
    for i, (s0, s1) in enumerate(zip(before, after, strict=True)):
        assert isinstance(s0, collision.Capsule) and isinstance(s1, collision.Capsule)
        moved = math.dist(s0.a, s1.a) > 1.0
        assert moved == (i > upper)
    # The fast check measures the edited arm's shapes.
    gap = min(collision.shape_distance(after[i], after[j]) for i, j in collision.collision_pairs(longer))
    assert collision.self_collision(longer, q)[1] == pytest.approx(gap, abs=1e-9)
    # The flange moves with it: kinematics does not cache by name either.
    assert np.linalg.norm(kinematics.fk(longer, q)[:3, 3] - kinematics.fk(model, q)[:3, 3]) == \
        pytest.approx(40.0, abs=1e-9)


def test_forearm_length_comes_from_the_joint_table() -> None:
    """The forearm capsule ends ``_FORE_LOW`` above the wrist axis, wherever the table puts the wrist."""
    x, y, z = XARM6.joints[3].origin_xyz
    shorter = _with_origin(XARM6, 3, (x, y - 50.0, z))
    fore0 = next(s for s in collision.link_shapes(XARM6, XARM6.zero_joints) if s.name == "forearm")
    fore1 = next(s for s in collision.link_shapes(shorter, shorter.zero_joints) if s.name == "forearm")
    assert isinstance(fore0, collision.Capsule) and isinstance(fore1, collision.Capsule)
    len0, len1 = math.dist(fore0.a, fore0.b), math.dist(fore1.a, fore1.b)
    assert len0 - len1 == pytest.approx(50.0, abs=1e-9)


@pytest.mark.parametrize("bad", [(math.nan,) + Q6[1:], Q6[:5]])
def test_kinematics_and_collision_share_the_joint_vector_check(bad: tuple[float, ...]) -> None:
    with pytest.raises(ValueError):
        kinematics.fk(XARM6, bad)
    with pytest.raises(ValueError):
        collision.self_collision(XARM6, bad)
    with pytest.raises(ValueError):
        collision.link_shapes(XARM6, bad)


def test_safety_tcp_position_is_the_kinematics_tcp_pose() -> None:
    offset = (10.0, -20.0, 150.0, 0.1, -0.2, 0.3)  # register 35
    expected = kinematics.tcp_pose(XARM6, Q6, offset)[:3, 3]
    np.testing.assert_array_equal(safety.tcp_position(XARM6, Q6, offset), expected)


def test_motion_package_imports_no_controller_module() -> None:
    """The trajectory generators hold no controller state: they import only each other and the model."""
    for path in Path(motion_pkg.__file__).parent.glob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                mod = node.module or ""
                assert node.level != 2 and not mod.startswith("xarm_emu.controller"), (path.name, mod)
                if node.level == 3:
                    assert mod.startswith("model"), (path.name, mod)


def test_ft_sensor_pose_follows_each_models_own_geometry() -> None:
    """Two arms of one name whose upper arms differ by 40 mm give their own F/T sensor origins, each
    read right after the other (a cache keyed by the name would answer the first one's)."""
    from xarm_emu.controller.devices import ft_sensor
    from xarm_emu.controller.emulator import Emulator

    x, y, z = XARM6.joints[2].origin_xyz
    longer = _with_origin(XARM6, 2, (x, y - 40.0, z))
    assert longer.name == XARM6.name
    origins = []
    for model in (XARM6, longer, XARM6, longer):
        emu = Emulator(model, ft_sensor=True, firmware="2.7.103")
        _, origin = ft_sensor._sensor_pose(emu.controller)
        T = kinematics.fk(model, emu.controller.q)
        np.testing.assert_allclose(origin, T[:3, 3] + T[:3, 2] * ft_sensor.SENSOR_HEIGHT, atol=1e-9)
        origins.append(origin)
    assert math.dist(origins[0], origins[1]) == pytest.approx(40.0, abs=1e-9)
    np.testing.assert_allclose(origins[0], origins[2], atol=0)
