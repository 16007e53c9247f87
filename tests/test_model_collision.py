"""Self-collision geometry (registers 77, 78; C22): distances, zero poses, folded poses, tools."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from xarm_emu.model.collision import (
    NO_TOOL,
    Box,
    Capsule,
    collision_pairs,
    frames_scalar,
    link_capsules,
    link_shapes,
    segment_box_distance,
    segment_distance,
    self_collision,
    shape_distance,
    tool_model,
)
from xarm_emu.model.kinematics import fk, joint_frames
from xarm_emu.model.robots import XARM5, XARM6, XARM7

MODELS = (XARM5, XARM6, XARM7)
AXES = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


# ---- segment distances against hand-computed cases


@pytest.mark.parametrize(
    ("p1", "q1", "p2", "q2", "expected"),
    [
        ((0, 0, 0), (10, 0, 0), (0, 5, 0), (10, 5, 0), 5.0),  # parallel, overlapping
        ((0, 0, 0), (10, 0, 0), (13, 4, 0), (20, 4, 0), 5.0),  # parallel, end to end: 3-4-5
        ((-5, 0, 0), (5, 0, 0), (0, -5, 7), (0, 5, 7), 7.0),  # crossing, 7 apart
        ((0, 0, 0), (10, 0, 0), (5, -5, 0), (5, 5, 0), 0.0),  # intersecting
        ((0, 0, 0), (0, 0, 0), (3, 4, 0), (3, 4, 0), 5.0),  # two points
        ((0, 0, 0), (0, 0, 0), (-10, 2, 0), (10, 2, 0), 2.0),  # point to segment interior
        ((0, 0, 0), (10, 0, 0), (12, 3, 0), (20, 9, 0), math.hypot(2, 3)),  # skew, end points closest
    ],
)
def test_segment_distance_hand_cases(p1, q1, p2, q2, expected) -> None:
    assert segment_distance(p1, q1, p2, q2) == pytest.approx(expected, abs=1e-12)
    assert segment_distance(p2, q2, p1, q1) == pytest.approx(expected, abs=1e-12)
    assert segment_distance(q1, p1, q2, p2) == pytest.approx(expected, abs=1e-12)


def test_capsule_distance_subtracts_radii_and_clamps_at_zero() -> None:
    a = Capsule((0, 0, 0), (100, 0, 0), 10.0, "a", 1)
    b = Capsule((50, 30, 0), (50, 30, 100), 5.0, "b", 3)
    assert shape_distance(a, b) == pytest.approx(15.0)
    c = Capsule((50, 12, 0), (50, 12, 100), 5.0, "c", 3)
    assert shape_distance(a, c) == 0.0


def test_segment_box_distance_hand_cases() -> None:
    box = Box((0.0, 0.0, 0.0), AXES, (10.0, 20.0, 30.0), "box", 7)
    assert segment_box_distance((15, 0, 0), (15, 5, 0), box) == pytest.approx(5.0)  # face
    assert segment_box_distance((13, 24, 0), (13, 24, 0), box) == pytest.approx(5.0)  # edge, 3-4-5
    assert segment_box_distance((-50, 0, 0), (50, 0, 0), box) == 0.0  # through the box
    assert segment_box_distance((13, 24, 42), (30, 50, 80), box) == pytest.approx(13.0)  # corner 3-4-12
    # segment passing a corner diagonally: closest at the segment interior
    assert segment_box_distance((20, 30, -10), (0, 30, 10), box) == pytest.approx(10.0)


def test_segment_box_distance_rotated_box_matches_sampling() -> None:
    c, s = math.cos(0.7), math.sin(0.7)
    box = Box((5.0, -3.0, 2.0), ((c, s, 0.0), (-s, c, 0.0), (0.0, 0.0, 1.0)), (10.0, 4.0, 6.0), "b", 7)
    rng = np.random.default_rng(3)
    for _ in range(50):
        p, q = rng.uniform(-40, 40, 3), rng.uniform(-40, 40, 3)
        R = np.array(box.axes)
        sampled = math.inf
        for t in np.linspace(0.0, 1.0, 2001):
            local = R @ (p + t * (q - p) - np.array(box.center))
            sampled = min(sampled, float(np.linalg.norm(np.maximum(np.abs(local) - box.half, 0.0))))
        got = segment_box_distance(tuple(p), tuple(q), box)
        assert got <= sampled + 1e-9
        assert got == pytest.approx(sampled, abs=0.05)


# ---- frames and shapes


@pytest.mark.parametrize("model", MODELS, ids=lambda m: m.name)
def test_scalar_frames_match_joint_frames(model) -> None:
    rng = np.random.default_rng(1)
    for _ in range(20):
        q = rng.uniform(model.lower, model.upper)
        for f, T in zip(frames_scalar(model, q), joint_frames(model, q), strict=True):
            assert np.allclose(np.array(f).reshape(4, 3).T, T[:3, :4], atol=1e-9)


def test_link_capsules_follow_the_flange() -> None:
    q = np.array([0.4, -0.3, -0.9, 0.5, 1.1, -0.2])
    tool = tool_model(21, [30.0, 100.0])
    caps = link_capsules(XARM6, q, tool)
    T = fk(XARM6, q)
    assert caps[-1].name == "tool 21"
    assert np.allclose(caps[-1].a, T[:3, 3], atol=1e-9)
    assert np.allclose(caps[-1].b, T[:3, 3] + 100.0 * T[:3, 2], atol=1e-9)
    assert np.allclose(caps[-2].b, T[:3, 3], atol=1e-9)  # last module ends at the flange


# ---- zero pose and folded poses


@pytest.mark.parametrize("model", MODELS, ids=lambda m: m.name)
@pytest.mark.parametrize("kind", [0, 1, 2, 3, 4, 5])
def test_zero_pose_is_collision_free(model, kind) -> None:
    hit, dist, _ = self_collision(model, model.zero_joints, tool_model(kind), margin=1.0)
    assert not hit
    assert dist > 1.0


@pytest.mark.parametrize(
    ("model", "q_deg", "pair"),
    [
        # forearm folded back onto the upper arm (J3 towards its +11 deg limit)
        (XARM6, (0, 0, 11, 0, 0, 0), {"forearm"}),
        (XARM6, (0, 40, 8, 0, 0, 0), {"forearm"}),
        (XARM5, (0, 0, 8, 0, 0), {"forearm"}),
        # wrist folded into the base: J5 = 90 deg turns the last module back into the base column
        (XARM6, (0, 0, 0, 0, 90, 0), {"base", "flange"}),
        (XARM5, (0, 0, 0, 90, 0), {"base", "flange"}),
        # xArm7: elbow J4 folded back (its range is -11..225 deg)
        (XARM7, (0, 0, 0, -11, 0, 0, 0), {"forearm"}),
        (XARM7, (0, 0, 0, 0, 0, 90, 0), {"base", "flange"}),
    ],
)
def test_folded_poses_collide(model, q_deg, pair) -> None:
    q = np.radians(q_deg)
    hit, dist, (i, j) = self_collision(model, q)
    assert hit and dist == 0.0
    shapes = link_shapes(model, q)
    assert pair <= {shapes[i].name, shapes[j].name}


def test_forearm_meets_upper_arm_when_folded_back() -> None:
    for a, touching in ((4, False), (8, True)):
        shapes = {s.name: s for s in link_shapes(XARM6, np.radians((0, 0, a, 0, 0, 0)))}
        assert (shape_distance(shapes["upper arm"], shapes["forearm"]) == 0.0) is touching


def test_detection_grows_with_fold_angle() -> None:
    dists = [self_collision(XARM6, np.radians((0, 0, a, 0, 0, 0)))[1] for a in (0, 1, 2, 3, 4)]
    assert all(d1 > d2 for d1, d2 in zip(dists, dists[1:], strict=False))


# ---- tools


def test_long_cylinder_collides_with_base_when_pointing_down_near_it() -> None:
    q = np.radians((0, -100, -10, 0, 110, 0))
    T = fk(XARM6, q)
    assert T[2, 2] < -0.999  # tool axis points down
    assert math.hypot(T[0, 3], T[1, 3]) < 100.0  # flange near the base axis
    free, d0, _ = self_collision(XARM6, q, NO_TOOL, margin=1.0)
    assert not free and d0 > 20.0
    hit, d, (i, j) = self_collision(XARM6, q, tool_model(21, [40.0, 250.0]))
    shapes = link_shapes(XARM6, q, tool_model(21, [40.0, 250.0]))
    assert hit and d == 0.0
    assert {shapes[i].name, shapes[j].name} == {"base", "tool 21"}
    short = self_collision(XARM6, q, tool_model(21, [40.0, 30.0]), margin=1.0)
    assert not short[0]
    box = self_collision(XARM6, q, tool_model(22, [80.0, 80.0, 250.0]))
    assert box[0]


def test_cuboid_tool_orientation_follows_last_joint() -> None:
    # a flat, wide box (400 x 20 mm) sweeps into the forearm only when J6 turns it towards the arm
    q = np.radians((0, 0, 0, 0, 0, 0))
    flat = tool_model(22, [20.0, 400.0, 20.0])
    along_y = self_collision(XARM6, q, flat)[1]
    turned = self_collision(XARM6, np.radians((0, 0, 0, 0, 0, 90)), flat)[1]
    assert along_y != pytest.approx(turned, abs=1.0)


def test_tool_offsets_move_the_tool() -> None:
    base = tool_model(21, [20.0, 50.0])
    moved = tool_model(21, [20.0, 50.0, 0.0, 0.0, 30.0])
    a = link_capsules(XARM6, XARM6.zero_joints, base)[-1]
    b = link_capsules(XARM6, XARM6.zero_joints, moved)[-1]
    assert np.allclose(np.subtract(b.a, a.a), (0.0, 0.0, -30.0), atol=1e-9)  # flange z points down


@pytest.mark.parametrize(("kind", "params"), [(6, []), (21, [10.0]), (21, [0.0, 5.0]), (22, [1.0, 2.0]),
                                              (22, [1.0, -2.0, 3.0]), (21, [math.nan, 5.0]), (99, [])])
def test_bad_tool_models_are_refused(kind, params) -> None:
    with pytest.raises(ValueError):
        tool_model(kind, params)


def test_pairs_skip_adjacent_bodies() -> None:
    for model in MODELS:
        shapes = link_shapes(model, model.zero_joints, tool_model(1))
        pairs = collision_pairs(model, tool_model(1))
        assert pairs
        assert all(abs(shapes[i].body - shapes[j].body) >= 2 for i, j in pairs)


# ---- properties


@st.composite
def configs(draw):
    model = draw(st.sampled_from(MODELS))
    q = [draw(st.floats(lo, hi, allow_nan=False)) for lo, hi in zip(model.lower, model.upper, strict=True)]
    kind = draw(st.sampled_from([0, 1, 5, 21, 22]))
    params = {21: [35.0, 180.0], 22: [60.0, 90.0, 150.0]}.get(kind, [])
    return model, np.array(q), tool_model(kind, params)


@settings(max_examples=150, deadline=None)
@given(configs())
def test_distance_symmetric_and_non_negative(cfg) -> None:
    model, q, tool = cfg
    hit, dist, (i, j) = self_collision(model, q, tool)
    assert dist >= 0.0
    assert hit == (dist == 0.0)
    shapes = link_shapes(model, q, tool)
    d_ij, d_ji = shape_distance(shapes[i], shapes[j]), shape_distance(shapes[j], shapes[i])
    assert d_ij == pytest.approx(d_ji, abs=1e-9)
    assert shape_distance(shapes[i], shapes[j]) == pytest.approx(dist, abs=1e-9)
    for a, b in collision_pairs(model, tool):
        assert shape_distance(shapes[a], shapes[b]) >= dist - 1e-9
    # the zero pose of the same model never collides
    assert not self_collision(model, model.zero_joints, tool, margin=1.0)[0]
