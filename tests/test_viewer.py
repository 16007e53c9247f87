"""The 3D view (viewer/): the drawn parts are the self-collision model's, placed by the kinematics;
the viser server answers on loopback and follows the emulator."""

from __future__ import annotations

import math
import urllib.request

import numpy as np
import pytest
from helpers import call, joints7, ready, wait_for

from xarm_emu.controller.emulator import Emulator
from xarm_emu.model import collision
from xarm_emu.model import kinematics as kin
from xarm_emu.model import rotations as rot
from xarm_emu.viewer import scene


def rotation(wxyz: tuple[float, float, float, float]) -> np.ndarray:
    w, x, y, z = wxyz
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


@pytest.mark.parametrize("dof", [5, 6, 7])
def test_capsules_are_placed_on_the_collision_segments(dof: int) -> None:
    emu = Emulator(dof)
    q = np.linspace(0.3, -0.2, dof)
    parts = scene.arm_parts(emu.model, q)
    shapes = collision.link_shapes(emu.model, q)
    assert len(parts) == len(shapes)
    for part, shape in zip(parts, shapes, strict=True):
        assert isinstance(shape, collision.Capsule) and part.kind == "capsule"
        a = np.array(part.position)
        end = a + rotation(part.wxyz) @ np.array([0.0, 0.0, part.length])
        np.testing.assert_allclose(a, np.array(shape.a) / 1000.0, atol=1e-12)
        np.testing.assert_allclose(end, np.array(shape.b) / 1000.0, atol=1e-9)
        assert part.radius == pytest.approx(shape.radius / 1000.0)


def test_box_tool_orientation_follows_the_flange() -> None:
    model = Emulator(6).model
    tool = collision.tool_model(22, (40.0, 60.0, 100.0))
    q = np.array([0.4, 0.0, 0.0, 0.0, 0.5, 0.3])
    box = [p for p in scene.arm_parts(model, q, tool) if p.kind == "box"][0]
    R = rotation(box.wxyz)
    np.testing.assert_allclose(R, kin.fk(model, q)[:3, :3], atol=1e-9)
    assert box.half == pytest.approx((0.02, 0.03, 0.05))


def test_quaternions_round_trip() -> None:
    rng = np.random.default_rng(1)
    for _ in range(50):
        R = rot.rpy_to_matrix(*rng.uniform(-math.pi, math.pi, 3))
        np.testing.assert_allclose(rotation(scene.quat_from_matrix(R)), R, atol=1e-12)
        d = rng.normal(size=3)
        z = rotation(scene.quat_z_to(d)) @ np.array([0.0, 0.0, 1.0])
        np.testing.assert_allclose(z, d / np.linalg.norm(d), atol=1e-12)
    z = rotation(scene.quat_z_to((0.0, 0.0, -2.0))) @ np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(z, [0.0, 0.0, -1.0], atol=1e-12)


def test_capsule_mesh_is_closed_and_within_the_capsule() -> None:
    verts, faces = scene.capsule_mesh(0.05, 0.3)
    edges: dict[tuple[int, int], int] = {}
    for f in faces:
        for i in range(3):
            a, b = int(f[i]), int(f[(i + 1) % 3])
            edges[(min(a, b), max(a, b))] = edges.get((min(a, b), max(a, b)), 0) + 1
    assert all(n == 2 for n in edges.values())  # every edge shared by two triangles: watertight
    r = np.hypot(verts[:, 0], verts[:, 1])
    assert r.max() == pytest.approx(0.05, rel=1e-6)
    assert verts[:, 2].min() == pytest.approx(-0.05, abs=1e-7)
    assert verts[:, 2].max() == pytest.approx(0.35, abs=1e-7)


def test_boundary_box() -> None:
    centre, size = scene.boundary_box((400, -200, 300, -300, 600, 0))
    assert centre == pytest.approx((0.1, 0.0, 0.3)) and size == pytest.approx((0.6, 0.6, 0.6))


def test_viewer_serves_on_loopback_and_follows_the_emulator(make_server) -> None:  # type: ignore[no-untyped-def]
    pytest.importorskip("viser")
    st = make_server(view=True, view_port=0)
    port = st.ports["view"]
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=5) as r:
        assert r.status == 200 and b"<html" in r.read().lower()
    viewer = st.server.viewer
    assert viewer is not None
    emu = st.emulator
    st.call(lambda: ready(emu))
    st.call(lambda: call(emu, 79, on=1))
    st.call(lambda: call(emu, 23, joints=joints7(0.8), speed=2.0, acc=10.0, mvtime=0.0))
    assert wait_for(lambda: st.call(lambda: abs(emu.controller.q[0] - 0.8) < 1e-6))
    n = viewer.updates
    assert wait_for(lambda: viewer.updates > n + 2)
    arm = [k for k in viewer._handles if k.startswith("/arm/")]
    ghost = [k for k in viewer._handles if k.startswith("/physical/")]
    assert arm and ghost and len(arm) == len(ghost)
    expected = scene.arm_parts(emu.model, emu.controller.q)[-1]
    assert tuple(viewer._handles[arm[-1]].position) == pytest.approx(expected.position, abs=1e-6)
