"""Lite 6, UFACTORY 850 and xArm 7T as robot models: frames, limits, identity, IK, collision, gravity.

The reference chains here are written out from the vendor's URDF joint origins (metres converted to mm,
1.5708 and 3.1416 read as exact pi/2 and pi) and chained as 4x4 transforms in this file, without
``model.kinematics``. The 850 is also checked against its modified D-H table from the vendor's
"kinematic and dynamic parameters" article.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import assert_ik_round_trips

from xarm_emu.model.collision import link_shapes, self_collision
from xarm_emu.model.dynamics import gravity_torques, mass_matrix, torques_to_currents
from xarm_emu.model.inertials import STANDARD_GRAVITY, get_inertials, torque_constants
from xarm_emu.model.kinematics import fk, ik, jacobian, joint_frames, within_limits
from xarm_emu.model.robots import (
    LITE6,
    MODEL_NAMES,
    MODELS,
    UF850,
    VACUUM_WIRING,
    XARM6,
    XARM7,
    XARM7T,
    RobotModel,
    get_model,
    robot_sn_problem,
)
from xarm_emu.model.rotations import matrix_to_axis_angle, matrix_to_pose
from xarm_emu.protocol.firmware import PARTS, first

PI = math.pi
H = PI / 2
NEW = (LITE6, UF850, XARM7T)

# URDF joint origins, (x, y, z) mm and (roll, pitch, yaw) rad, per joint.
REFERENCE_ORIGINS: dict[str, list[tuple[tuple[float, float, float], tuple[float, float, float]]]] = {
    "Lite6": [
        ((0, 0, 243.5), (0, 0, 0)),
        ((0, 0, 0), (H, -H, PI)),
        ((200.2, 0, 0), (-PI, 0, H)),
        ((87, -227.61, 0), (H, 0, 0)),
        ((0, 0, 0), (H, 0, 0)),
        ((0, 62.5, 0), (-H, 0, 0)),
    ],
    "850": [
        ((0, 0, 364), (0, 0, 0)),
        ((0, 0, 0), (H, -H, 0)),
        ((390, 0, 0), (-PI, 0, -H)),
        ((150, 426, 0), (-H, 0, 0)),
        ((0, 0, 0), (-H, 0, 0)),
        ((0, -90, 0), (H, 0, 0)),
    ],
    "xArm7T": [
        ((-0.52471, 0, 266.8), (0, 0, 0)),
        ((0, 0, 0), (H, 0, 0)),
        ((0, 292.89, 0), (-H, 0, 0)),
        ((52.665, 0, 0), (-H, 0, 0)),
        ((77.699, 342.58, 0), (-H, 0, 0)),
        ((0, 0, 0), (-H, 0, 0)),
        ((75.998, -96.156, 0), (H, 0, 0)),
    ],
}


def _rot(axis: int, a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    m = np.eye(4)
    m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
    return m


def _trans(x: float, y: float, z: float) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def reference_frames(model: RobotModel, q) -> list[np.ndarray]:
    """Trans(xyz) . Rz(yaw) . Ry(pitch) . Rx(roll) . Rz(q) per joint, from the table above."""
    T = np.eye(4)
    out = []
    for (xyz, (roll, pitch, yaw)), qi in zip(REFERENCE_ORIGINS[model.name], q, strict=True):
        T = T @ _trans(*xyz) @ _rot(2, yaw) @ _rot(1, pitch) @ _rot(0, roll) @ _rot(2, qi)
        out.append(T)
    return out


def random_joints(model: RobotModel, rng: np.random.Generator, margin: float = 0.1) -> np.ndarray:
    lo = np.maximum(model.lower, -PI) + margin
    hi = np.minimum(model.upper, PI) - margin
    return rng.uniform(lo, hi)


# ---- frames


@pytest.mark.parametrize("model", NEW, ids=lambda m: m.name)
def test_fk_matches_the_reference_chain(model: RobotModel) -> None:
    rng = np.random.default_rng(11)
    vectors = [np.zeros(model.dof), np.full(model.dof, 0.5), *(random_joints(model, rng) for _ in range(5))]
    for q in vectors:
        ref = reference_frames(model, q)
        T = fk(model, q)
        assert np.abs(T[:3, 3] - ref[-1][:3, 3]).max() < 1e-6
        assert np.abs(T[:3, :3] - ref[-1][:3, :3]).max() < 1e-9
        for frame, expected in zip(joint_frames(model, q), ref, strict=True):
            assert np.abs(frame[:3, 3] - expected[:3, 3]).max() < 1e-6
            assert np.abs(frame[:3, :3] - expected[:3, :3]).max() < 1e-9


def _mdh(alpha_deg: float, a: float, theta: float, d: float) -> np.ndarray:
    return _rot(0, math.radians(alpha_deg)) @ _trans(a, 0, 0) @ _rot(2, theta) @ _trans(0, 0, d)


def test_850_positions_match_its_modified_dh_table() -> None:
    """Rows (theta offset deg, d, alpha deg, a) of the vendor's 850 table; same joint signs as the URDF."""
    rows = [(0, 364, 0, 0), (90, 0, 90, 0), (90, 0, 180, 390), (0, 426, -90, 150), (0, 0, -90, 0),
            (0, 90, 90, 0)]
    rng = np.random.default_rng(5)
    for q in [np.zeros(6), *(random_joints(UF850, rng) for _ in range(5))]:
        T = np.eye(4)
        for (off, d, alpha, a), qi in zip(rows, q, strict=True):
            T = T @ _mdh(alpha, a, qi + math.radians(off), d)
        assert np.abs(fk(UF850, q)[:3, 3] - T[:3, 3]).max() < 1e-6


def test_lite6_positions_agree_with_its_modified_dh_table() -> None:
    """The Lite 6 D-H table rounds four lengths differently from the URDF (243.3 vs 243.5, 200 vs 200.2,
    227.6 vs 227.61, 61.5 vs 62.5 mm): same joint signs, positions apart by at most the sum, 1.41 mm."""
    rows = [(0, 243.3, 0, 0), (-90, 0, -90, 0), (-90, 0, 180, 200), (0, 227.6, 90, 87), (0, 0, 90, 0),
            (0, 61.5, -90, 0)]
    rng = np.random.default_rng(6)
    for q in [np.zeros(6), *(random_joints(LITE6, rng) for _ in range(8))]:
        T = np.eye(4)
        for (off, d, alpha, a), qi in zip(rows, q, strict=True):
            T = T @ _mdh(alpha, a, qi + math.radians(off), d)
        assert np.linalg.norm(fk(LITE6, q)[:3, 3] - T[:3, 3]) <= 1.41 + 1e-9


@pytest.mark.parametrize(
    ("model", "expected", "tol"),
    [
        # the vendor's URDF lengths put the Lite 6 flange at z = 153.59 mm (153.6 to 0.1 mm)
        (LITE6, (87.0, 0.0, 153.6), 0.05),
        (UF850, (150.0, 0.0, 238.0), 1e-6),
        # the 7T's mirrored origins carry calibrated lengths: within 0.5 mm of the xArm 7's zero pose
        (XARM7T, (206.0, 0.0, 120.5), 0.5),
    ],
    ids=["Lite6", "850", "xArm7T"],
)
def test_zero_pose_flange(model: RobotModel, expected, tol: float) -> None:
    pose = matrix_to_pose(fk(model, model.zero_joints))
    assert np.abs(pose[:3] - np.array(expected)).max() <= tol
    # flange pointing straight down: roll 180 deg, pitch 0, yaw 0
    assert abs(abs(pose[3]) - PI) < 1e-9 and abs(pose[4]) < 1e-9 and abs(pose[5]) < 1e-9
    # the model's own zero_pose field is what its chain gives
    assert np.abs(np.array(model.zero_pose[:3]) - pose[:3]).max() < 1e-6


@pytest.mark.parametrize("model", NEW, ids=lambda m: m.name)
def test_jacobian_matches_finite_differences(model: RobotModel) -> None:
    q = random_joints(model, np.random.default_rng(2))
    J = jacobian(model, q)
    eps = 1e-6
    for k in range(model.dof):
        dq = np.zeros(model.dof)
        dq[k] = eps
        T1, T0 = fk(model, q + dq), fk(model, q - dq)
        np.testing.assert_allclose(J[:3, k], (T1[:3, 3] - T0[:3, 3]) / (2 * eps), atol=1e-4)
        w = matrix_to_axis_angle(T1[:3, :3] @ T0[:3, :3].T) / (2 * eps)
        np.testing.assert_allclose(J[3:, k], w, atol=1e-6)


# ---- IK


@pytest.mark.parametrize("model", NEW, ids=lambda m: m.name)
def test_fk_of_ik_reproduces_random_poses(model: RobotModel) -> None:
    assert_ik_round_trips(model, random_joints)


@pytest.mark.parametrize("model", NEW, ids=lambda m: m.name)
def test_ik_with_restarts_from_zero_seed(model: RobotModel) -> None:
    rng = np.random.default_rng(8)
    solved = 0
    for _ in range(30):
        T = fk(model, random_joints(model, rng))
        q = ik(model, T, np.zeros(model.dof), restarts=True)
        if q is not None:
            solved += 1
            assert np.linalg.norm(fk(model, q)[:3, 3] - T[:3, 3]) < 1e-3
    assert solved >= 27


def test_ik_keeps_lite6_j3_in_its_one_sided_range() -> None:
    """Lite 6 J3 runs -3.5..300 deg: a solution near 250 deg is returned as 250, not as -110."""
    q = np.radians([10, 20, 250, 30, 40, 50])
    sol = ik(LITE6, fk(LITE6, q), q + 0.05)
    assert sol is not None
    np.testing.assert_allclose(sol, q, atol=1e-6)


# ---- limits and ranges


def test_joint_limits_in_degrees() -> None:
    deg = np.degrees
    # Lite 6: J2 +/-150, J3 -3.5..300, J5 +/-124
    assert deg(LITE6.upper[1]) == pytest.approx(150, abs=1e-5)
    assert (deg(LITE6.lower[2]), deg(LITE6.upper[2])) == pytest.approx((-3.5, 300), abs=1e-5)
    assert deg(LITE6.upper[4]) == pytest.approx(124, abs=1e-5)
    # 850: J2 +/-132, J3 -242..3.5, J5 +/-124
    assert deg(UF850.lower[1]) == pytest.approx(-132, abs=1e-5)
    assert (deg(UF850.lower[2]), deg(UF850.upper[2])) == pytest.approx((-242, 3.5), abs=1e-5)
    # both: J1, J4, J6 +/-360
    for m in (LITE6, UF850):
        assert [deg(m.upper[k]) for k in (0, 3, 5)] == pytest.approx([360] * 3)


def test_xarm7t_limits_mirror_the_xarm7_on_j2_j4_j6() -> None:
    for k in range(7):
        if k in (1, 3, 5):
            assert (XARM7T.lower[k], XARM7T.upper[k]) == pytest.approx((-XARM7.upper[k], -XARM7.lower[k]))
        else:
            assert (XARM7T.lower[k], XARM7T.upper[k]) == (XARM7.lower[k], XARM7.upper[k])


def test_within_limits_follows_each_models_table() -> None:
    assert within_limits(LITE6, np.radians([0, 0, 290, 0, 0, 0]))
    assert not within_limits(LITE6, np.radians([0, 0, -5, 0, 0, 0]))
    assert not within_limits(LITE6, np.radians([0, 0, 0, 0, 125, 0]))
    assert within_limits(UF850, np.radians([0, 0, -240, 0, 0, 0]))
    assert not within_limits(UF850, np.radians([0, 133, 0, 0, 0, 0]))
    assert within_limits(XARM7T, np.radians([0, 0, 0, -200, 0, 0, 0]))
    assert not within_limits(XARM7, np.radians([0, 0, 0, -200, 0, 0, 0]))


def test_speed_payload_and_reach() -> None:
    assert LITE6.max_tcp_speed == 500.0 and LITE6.max_tcp_speed < XARM6.max_tcp_speed
    assert all(m.max_joint_speed == pytest.approx(PI) for m in NEW)  # 180 deg/s
    assert (LITE6.rated_payload, LITE6.reach) == (0.6, 440.0)
    assert (UF850.rated_payload, UF850.reach) == (5.0, 850.0)
    assert (XARM7T.rated_payload, XARM7T.reach) == (XARM7.rated_payload, XARM7.reach)
    # the Lite 6 reach is about the length of its arm stretched out: upper arm + forearm (+ offsets)
    stretched = np.radians([0, 0, 180, 0, 0, 0])
    wrist = joint_frames(LITE6, stretched)[4][:3, 3]
    assert wrist[2] - LITE6.joints[0].origin_xyz[2] == pytest.approx(LITE6.reach, abs=20)


# ---- identity, lookup, tool IO


def test_identity_fields() -> None:
    assert [(m.axis, m.robot_type, m.sn_prefix) for m in NEW] == [(6, 9, "LI"), (6, 12, "FX"), (7, 13, "CS")]
    firsts = [first(PARTS[f"{m.name} arm"]) if f"{m.name} arm" in PARTS else None for m in NEW]
    assert firsts == [None, "2.1.0", "2.4.0"]
    assert LITE6.default_box_sn == "DL1000"
    for m in (*MODELS.values(), *NEW):
        assert robot_sn_problem(m, m.default_robot_sn) is None
        assert m.default_robot_sn.startswith(m.sn_prefix)


def test_robot_sn_rules() -> None:
    assert robot_sn_problem(XARM6, "XI1305") is None  # an xArm with a newer serial number
    problem = robot_sn_problem(LITE6, "LI1305")
    assert problem is not None and "1305" in problem
    assert robot_sn_problem(LITE6, "LI8500") is None
    assert robot_sn_problem(LITE6, "XI1006") is not None  # wrong prefix
    assert robot_sn_problem(UF850, "FX12a4") is not None  # non-digit
    assert robot_sn_problem(XARM7T, "CS") is not None


def test_get_model_by_name_and_number() -> None:
    assert [get_model(n) for n in (5, 6, 7)] == [MODELS[5], MODELS[6], MODELS[7]]
    assert [get_model(n) for n in ("5", "6", "7")] == [MODELS[5], MODELS[6], MODELS[7]]
    assert get_model(np.int64(6)) is XARM6
    for name in ("lite6", "Lite 6", "LITE-6", "ufactory_lite6"):
        assert get_model(name) is LITE6
    for name in ("850", "uf850", "UFACTORY 850"):
        assert get_model(name) is UF850
    for name in ("7t", "7T", "xarm7t", "xArm 7T"):
        assert get_model(name) is XARM7T
    assert get_model("xarm6") is XARM6
    assert all(get_model(name).key == name for name in MODEL_NAMES)
    assert len(set(MODEL_NAMES)) == len(MODEL_NAMES) == 6


@pytest.mark.parametrize("bad", [4, "4", "lite7", "", True, None, 6.5, "xarm"])
def test_get_model_refuses_unknown_names_listing_the_known_ones(bad) -> None:
    with pytest.raises(ValueError) as err:
        get_model(bad)
    assert all(name in str(err.value) for name in MODEL_NAMES)


def test_tool_io_differences() -> None:
    assert XARM6.tool_io.digital_inputs == ("TI0", "TI1") and XARM6.tool_io.ti2_address is None
    assert LITE6.tool_io.digital_inputs == ("TI0", "TI1", "TI2")
    assert len(UF850.tool_io.digital_inputs) == 5
    assert LITE6.tool_io.ti2_address == UF850.tool_io.ti2_address == 0x0A12
    assert LITE6.tool_io.ti2_teach_button and not UF850.tool_io.ti2_teach_button
    assert XARM7T.tool_io == XARM7.tool_io


def test_lite6_gripper_and_vacuum_wiring() -> None:
    gripper = LITE6.tool_io.gripper
    assert gripper is not None and UF850.tool_io.gripper is None
    commands = [gripper.command(*outs) for outs in ((1, 0), (0, 1), (0, 0), (1, 1))]
    assert commands == ["open", "close", "stop", None]
    v1, v2 = VACUUM_WIRING[1], VACUUM_WIRING[2]
    assert (v1.outputs, v1.on, v1.off, v1.object_input) == (("TO0", "TO1"), (1, 0), (0, 1), "TI0")
    assert (v2.outputs, v2.object_input) == (("TO3", "TO4"), "TI3")


# ---- self-collision


@pytest.mark.parametrize("model", NEW, ids=lambda m: m.name)
def test_zero_pose_is_collision_free(model: RobotModel) -> None:
    hit, dist, _ = self_collision(model, model.zero_joints, margin=1.0)
    assert not hit and dist > 1.0


@pytest.mark.parametrize(
    ("model", "q_deg", "pair"),
    [
        # the last module turned back into the base column by the wrist joint
        (LITE6, (0, 0, 0, 0, 90, 0), {"base", "flange"}),
        (UF850, (0, 0, 0, 0, -90, 0), {"base", "flange"}),
        (XARM7T, (0, 0, 0, 0, 0, -90, 0), {"base", "flange"}),
        # the folded forearm swung into the base by the shoulder
        (LITE6, (0, 90, 0, 0, 0, 0), {"base", "forearm"}),
        (UF850, (0, -90, 0, 0, 0, 0), {"base", "forearm"}),
        # xArm 7T elbow at its +11 deg end (the mirror of the xArm 7's -11)
        (XARM7T, (0, 0, 0, 11, 0, 0, 0), {"forearm"}),
    ],
)
def test_folded_poses_collide(model: RobotModel, q_deg, pair) -> None:
    q = np.radians(q_deg)
    hit, dist, (i, j) = self_collision(model, q)
    assert hit and dist == 0.0
    shapes = link_shapes(model, q)
    assert pair <= {shapes[i].name, shapes[j].name}


@pytest.mark.parametrize("model", NEW, ids=lambda m: m.name)
def test_link_shapes_follow_the_joint_frames(model: RobotModel) -> None:
    q = random_joints(model, np.random.default_rng(9))
    flange = fk(model, q)[:3, 3]
    last = [s for s in link_shapes(model, q) if s.name == "flange"][0]
    assert np.linalg.norm(np.array(last.b) - flange) < 1e-9
    base = link_shapes(model, q)[0]
    assert np.linalg.norm(np.array(base.b) - joint_frames(model, q)[0][:3, 3]) < 1e-9


# ---- inertials and gravity


def test_inertial_sets_per_model() -> None:
    assert [get_inertials(m).name for m in NEW] == [
        "xarm6_type9_HT_BR2", "xarm6_type12_HT_LDBR2", "xarm7_type13_HT_BR2"]
    assert get_inertials(6) is get_inertials(XARM6)  # the xArm 6 stays the default for six axes
    for m in NEW:
        assert len(get_inertials(m).links) == m.dof
    # the 850 is the heaviest, the Lite 6 the lightest moving arm
    masses = [get_inertials(m).total_mass for m in (LITE6, XARM6, UF850)]
    assert masses == sorted(masses)


def _coms(model: RobotModel) -> list[tuple[float, np.ndarray]]:
    """(mass, COM in the base frame, mm) per link at zero joints, through the reference chain."""
    frames = reference_frames(model, np.zeros(model.dof))
    return [(lk.mass, (T @ np.array([*lk.com, 1.0]))[:3]) for lk, T in zip(get_inertials(model).links, frames,
                                                                           strict=True)]


@pytest.mark.parametrize("model", NEW, ids=lambda m: m.name)
def test_zero_pose_gravity_by_hand(model: RobotModel) -> None:
    """J1 is vertical: gravity has no moment about it. J2 is horizontal (axis +/-y, through x = x2):
    the motor holds -z2_y * g * sum(m_i (x_i - x2)) over the links beyond it."""
    g = STANDARD_GRAVITY
    tau = gravity_torques(model, model.zero_joints)
    assert tau[0] == pytest.approx(0.0, abs=1e-12)
    j2 = reference_frames(model, np.zeros(model.dof))[1]
    z2, x2 = j2[:3, 2], j2[0, 3]
    assert abs(abs(z2[1]) - 1.0) < 1e-12
    lever = sum(m * (c[0] - x2) for m, c in _coms(model)[1:]) / 1000.0  # kg.m
    expected = -z2[1] * g * lever
    assert tau[1] == pytest.approx(expected, rel=1e-9)
    assert lever > 0.0  # the links beyond the shoulder hang forward of it at the zero pose
    # a payload of the rated mass at the flange adds its weight times the flange's lever arm
    mp = model.rated_payload
    tau_p = gravity_torques(model, model.zero_joints, payload_mass=mp)
    assert tau_p[1] - tau[1] == pytest.approx(-z2[1] * g * mp * (model.zero_pose[0] - x2) / 1000.0, rel=1e-9)


def test_zero_pose_gravity_signs_and_sizes() -> None:
    tau = {m.name: gravity_torques(m, m.zero_joints) for m in (LITE6, XARM6, UF850, XARM7T)}
    assert tau["Lite6"][1] < 0 < tau["850"][1]  # opposite J2 axes (base +y and -y)
    assert tau["xArm7T"][1] > 0 > gravity_torques(XARM7, XARM7.zero_joints)[1]  # mirrored J2 axis
    # the heavier, longer 850 holds more at its shoulder than the xArm 6, the Lite 6 less
    assert abs(tau["Lite6"][1]) < abs(tau["xArm6"][1]) < abs(tau["850"][1])


@pytest.mark.parametrize("model", NEW, ids=lambda m: m.name)
def test_gravity_at_random_poses_matches_lever_arm_sums(model: RobotModel) -> None:
    g = np.array([0.0, 0.0, -STANDARD_GRAVITY])
    rng = np.random.default_rng(12)
    links = get_inertials(model).links
    for _ in range(3):
        q = random_joints(model, rng)
        frames = reference_frames(model, q)
        coms = [(lk.mass, (T @ np.array([*lk.com, 1.0]))[:3]) for lk, T in zip(links, frames, strict=True)]
        expected = []
        for j, T in enumerate(frames):
            moment = sum(np.cross((c - T[:3, 3]) / 1000.0, m * g) for m, c in coms[j:])
            expected.append(-float(np.dot(T[:3, 2], moment)))
        np.testing.assert_allclose(gravity_torques(model, q), expected, atol=1e-9)


@pytest.mark.parametrize("model", NEW, ids=lambda m: m.name)
def test_mass_matrix_symmetric_positive_definite(model: RobotModel) -> None:
    m = mass_matrix(model, random_joints(model, np.random.default_rng(4)), model.rated_payload)
    assert np.allclose(m, m.T, atol=1e-12)
    assert np.linalg.eigvalsh(m).min() > 0


def test_currents_use_each_models_torque_constants() -> None:
    for m in NEW:
        tau = gravity_torques(m, m.zero_joints)
        kt = torque_constants(m)
        assert kt.shape == (m.dof,) and np.all(kt > 0)
        np.testing.assert_allclose(torques_to_currents(m, tau) * kt, tau)
    assert not np.allclose(torque_constants(LITE6), torque_constants(XARM6))
    np.testing.assert_array_equal(torque_constants(XARM7T), torque_constants(XARM7))
