"""What the 3D view draws, computed from the emulator's state (pure: no viewer library here).

The arm is drawn with the same capsules and boxes the self-collision check uses
(:mod:`xarm_emu.model.collision`), so what you see is what registers 77/78 check. Positions are in
metres (the viewer's unit), orientations as unit quaternions ``(w, x, y, z)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..model import collision
from ..model import kinematics as kin
from ..model.robots import RobotModel
from ..model.rotations import quat_from_matrix, rpy_to_matrix

MM = 0.001  # metres per millimetre


@dataclass(frozen=True)
class Part:
    """One drawn body: a capsule (``radius``, ``length`` along its local z from the origin) or a box
    (``half`` extents about its origin), placed at ``position`` with orientation ``wxyz``."""

    name: str
    kind: str  # "capsule" or "box"
    position: tuple[float, float, float]
    wxyz: tuple[float, float, float, float]
    radius: float = 0.0
    length: float = 0.0
    half: tuple[float, float, float] = (0.0, 0.0, 0.0)
    #: Its own colour (0-255 RGB), else the colour of its group.
    color: tuple[int, int, int] | None = None


def quat_z_to(d: Sequence[float]) -> tuple[float, float, float, float]:
    """Shortest rotation taking +z onto the direction ``d``."""
    n = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    if n == 0.0:
        return (1.0, 0.0, 0.0, 0.0)
    x, y, z = d[0] / n, d[1] / n, d[2] / n
    if z < -1.0 + 1e-12:
        return (0.0, 1.0, 0.0, 0.0)  # half turn about x
    w = 1.0 + z  # from the half-angle identity for (0, 0, 1) x d
    q = (w, -y, x, 0.0)
    m = math.sqrt(sum(c * c for c in q))
    return (q[0] / m, q[1] / m, q[2] / m, q[3] / m)


def arm_parts(model: RobotModel, q: Sequence[float] | np.ndarray,
              tool: collision.ToolModel = collision.NO_TOOL) -> list[Part]:
    """The arm (and its end tool) at joints ``q`` as drawable parts."""
    parts: list[Part] = []
    for i, shape in enumerate(collision.link_shapes(model, q, tool)):
        name = f"{i:02d}_{shape.name}"
        if isinstance(shape, collision.Capsule):
            a, b = shape.a, shape.b
            d = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
            parts.append(Part(name, "capsule", (a[0] * MM, a[1] * MM, a[2] * MM), quat_z_to(d),
                              radius=shape.radius * MM, length=math.sqrt(sum(c * c for c in d)) * MM))
        else:
            R = np.array(shape.axes, dtype=float).T  # columns: the box axes
            c = shape.center
            parts.append(Part(name, "box", (c[0] * MM, c[1] * MM, c[2] * MM), quat_from_matrix(R),
                              half=(shape.half[0] * MM, shape.half[1] * MM, shape.half[2] * MM)))
    return parts


Wxyz = tuple[float, float, float, float]


def tcp_frame(model: RobotModel, q: Sequence[float] | np.ndarray,
              tcp_offset: Sequence[float]) -> tuple[tuple[float, float, float], Wxyz]:
    """Position (m) and orientation of the TCP in the base frame (the TCP offset applied)."""
    T = kin.tcp_pose(model, q, tcp_offset)
    p = T[:3, 3] * MM
    return (float(p[0]), float(p[1]), float(p[2])), quat_from_matrix(T[:3, :3])


def boundary_box(boundary: Sequence[float]) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """Centre and size (m) of the safety boundary of register 52 (x max, x min, y max, ... mm)."""
    xM, xm, yM, ym, zM, zm = (float(v) * MM for v in boundary)
    return ((xM + xm) / 2, (yM + ym) / 2, (zM + zm) / 2), (xM - xm, yM - ym, zM - zm)


def capsule_mesh(radius: float, length: float, segments: int = 16,
                 rings: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """A closed triangle mesh of a capsule from z = 0 to z = ``length`` (vertices, faces): rings of
    ``segments`` vertices between one vertex at each pole."""
    profile: list[tuple[float, float]] = []  # (r, z) of the rings, bottom to top, poles excluded
    for k in range(1, rings + 1):  # bottom hemisphere
        a = -math.pi / 2 + (math.pi / 2) * k / rings
        profile.append((radius * math.cos(a), radius * math.sin(a)))
    for k in range(rings):  # top hemisphere
        a = (math.pi / 2) * k / rings
        profile.append((radius * math.cos(a), length + radius * math.sin(a)))
    verts: list[tuple[float, float, float]] = [(0.0, 0.0, -radius)]  # bottom pole
    for r, z in profile:
        for s in range(segments):
            t = 2 * math.pi * s / segments
            verts.append((r * math.cos(t), r * math.sin(t), z))
    top = len(verts)
    verts.append((0.0, 0.0, length + radius))  # top pole
    faces: list[tuple[int, int, int]] = []
    for s in range(segments):  # bottom cap, facing down
        faces.append((0, 1 + (s + 1) % segments, 1 + s))
    for i in range(len(profile) - 1):
        for s in range(segments):
            a0, a1 = 1 + i * segments + s, 1 + i * segments + (s + 1) % segments
            b0, b1 = a0 + segments, a1 + segments
            faces.append((a0, a1, b1))
            faces.append((a0, b1, b0))
    last = 1 + (len(profile) - 1) * segments
    for s in range(segments):  # top cap
        faces.append((last + s, last + (s + 1) % segments, top))
    return np.array(verts, dtype=np.float32), np.array(faces, dtype=np.uint32)


#: The xArm gripper's full stroke in position pulses (register 124 gripper position) and in metres.
GRIPPER_PULSES = 850.0
GRIPPER_STROKE = 0.085
FINGER_HALF = (0.006, 0.004, 0.025)  # m: half extents of one drawn finger
CUP_RADIUS = 0.02  # m: the drawn vacuum cup
CUP_LENGTH = 0.05


def gripper_parts(model: RobotModel, q: Sequence[float] | np.ndarray, position: float) -> list[Part]:
    """The xArm gripper's two fingers on the flange, apart by the opening that the gripper position
    (0 closed .. :data:`GRIPPER_PULSES` open) gives."""
    T = kin.fk(model, q)
    R = T[:3, :3]
    flange = T[:3, 3] * MM
    opening = max(0.0, min(1.0, float(position) / GRIPPER_PULSES)) * GRIPPER_STROKE
    wxyz = quat_from_matrix(R)
    parts = []
    for name, side in (("finger_a", 1.0), ("finger_b", -1.0)):
        local = np.array([0.0, side * (opening / 2 + FINGER_HALF[1]), 0.06])
        c = flange + R @ local
        parts.append(Part(f"tool_{name}", "box", (float(c[0]), float(c[1]), float(c[2])), wxyz,
                          half=FINGER_HALF))
    return parts


@dataclass(frozen=True)
class GripperShape:
    """How a parallel gripper is drawn: its body (half extents, m) on the flange, its fingers' half
    extents and the depth (m, along the flange's z axis) of the fingers' centres."""

    body_half: tuple[float, float, float]
    finger_half: tuple[float, float, float]
    finger_depth: float


#: The drawn shape of each gripper ``serve --gripper`` attaches besides the xArm gripper (sizes
#: rounded from the vendors' drawings: the Robotiq 2F-85 and 2F-140 about 0.15 m and 0.2 m long, the
#: BIO gripper a wide body with short fingers).
GRIPPER_SHAPES = {
    "robotiq-2f85": GripperShape((0.037, 0.037, 0.035), (0.011, 0.005, 0.025), 0.125),
    "robotiq-2f140": GripperShape((0.037, 0.037, 0.035), (0.013, 0.006, 0.035), 0.17),
    "bio": GripperShape((0.04, 0.085, 0.03), (0.012, 0.006, 0.03), 0.09),
    "bio-g1": GripperShape((0.04, 0.085, 0.03), (0.012, 0.006, 0.03), 0.09),
}


def end_gripper_parts(model: RobotModel, q: Sequence[float] | np.ndarray, kind: str,
                      opening_mm: float) -> list[Part]:
    """A Robotiq or BIO gripper, G2 or G1 (``kind``, a key of :data:`GRIPPER_SHAPES`) on the flange: its body
    and two fingers apart by ``opening_mm``."""
    shape = GRIPPER_SHAPES[kind]
    T = kin.fk(model, q)
    R = T[:3, :3]
    flange = T[:3, 3] * MM
    wxyz = quat_from_matrix(R)
    body = flange + R @ np.array([0.0, 0.0, shape.body_half[2]])
    parts = [Part("tool_body", "box", (float(body[0]), float(body[1]), float(body[2])), wxyz,
                  half=shape.body_half)]
    opening = max(0.0, float(opening_mm)) * MM
    for name, side in (("finger_a", 1.0), ("finger_b", -1.0)):
        c = flange + R @ np.array([0.0, side * (opening / 2 + shape.finger_half[1]), shape.finger_depth])
        parts.append(Part(f"tool_{name}", "box", (float(c[0]), float(c[1]), float(c[2])), wxyz,
                          half=shape.finger_half))
    return parts


def vacuum_parts(model: RobotModel, q: Sequence[float] | np.ndarray) -> list[Part]:
    """The vacuum cup: a short capsule along the flange's z axis."""
    T = kin.fk(model, q)
    a = T[:3, 3] * MM
    return [Part("tool_cup", "capsule", (float(a[0]), float(a[1]), float(a[2])),
                 quat_z_to(tuple(float(v) for v in T[:3, 2])), radius=CUP_RADIUS, length=CUP_LENGTH)]


#: The linear track as drawn (m): the rail's cross-section, the carriage under the arm's base.
RAIL_HALF_WIDTH = 0.08
RAIL_HALF_HEIGHT = 0.03
CARRIAGE_HALF = (0.11, 0.11, 0.015)


def track_parts(length: float, position: float) -> list[Part]:
    """The linear track in the arm's base frame: the carriage right under the base and the rail, of
    ``length`` mm, along the base's y axis (the emulator's choice of mounting), with its origin
    ``position`` mm behind the carriage, so the rail slides under the arm as the carriage travels."""
    z_carriage = -CARRIAGE_HALF[2]
    z_rail = 2 * z_carriage - RAIL_HALF_HEIGHT
    centre_y = (0.5 * float(length) - float(position)) * MM
    identity = (1.0, 0.0, 0.0, 0.0)
    return [Part("track_rail", "box", (0.0, centre_y, z_rail), identity,
                 half=(RAIL_HALF_WIDTH, 0.5 * float(length) * MM, RAIL_HALF_HEIGHT)),
            Part("track_carriage", "box", (0.0, 0.0, z_carriage), identity, half=CARRIAGE_HALF)]


#: The drawn F/T sensor: a disc of the sensor's height (controller/devices/ft_sensor.py) on the flange.
FT_SENSOR_RADIUS = 0.04  # m
#: Half the side of the square drawn for a contact plane, and its drawn thickness (m).
PLANE_HALF = 0.4
PLANE_THICKNESS = 0.002


def ft_sensor_parts(model: RobotModel, q: Sequence[float] | np.ndarray, height_mm: float) -> list[Part]:
    """The six-axis F/T sensor between flange and tool: a disc ``height_mm`` thick along the flange's
    z axis (a capsule of that length less its rounded ends)."""
    T = kin.fk(model, q)
    a = T[:3, 3] * MM
    length = max(0.0, height_mm * MM)
    return [Part("ft_sensor", "capsule", (float(a[0]), float(a[1]), float(a[2])),
                 quat_z_to(tuple(float(v) for v in T[:3, 2])), radius=FT_SENSOR_RADIUS, length=length)]


def contact_parts(shapes: Sequence[Any]) -> list[Part]:
    """The contact scene (controller/scene/contact.py): each plane a thin square about its point, normal
    along the square's z; each box as it is. Shapes are read by their fields, base frame, mm."""
    parts: list[Part] = []
    for i, s in enumerate(shapes):
        name = f"{i:02d}_{getattr(s, 'name', 'shape')}"
        if hasattr(s, "normal"):
            p = np.asarray(s.point, dtype=float) * MM
            parts.append(Part(name, "box", (float(p[0]), float(p[1]), float(p[2])),
                              quat_z_to(tuple(float(v) for v in s.normal)),
                              half=(PLANE_HALF, PLANE_HALF, PLANE_THICKNESS / 2)))
        else:
            lo, hi = np.asarray(s.min, dtype=float) * MM, np.asarray(s.max, dtype=float) * MM
            c, h = (lo + hi) / 2, (hi - lo) / 2
            parts.append(Part(name, "box", (float(c[0]), float(c[1]), float(c[2])), (1.0, 0.0, 0.0, 0.0),
                              half=(float(h[0]), float(h[1]), float(h[2]))))
    return parts


#: Radius of a sensor's beam as drawn (m).
BEAM_RADIUS = 0.002
#: Colours of a running and a stopped belt, and of a clear and an interrupted beam.
BELT_RUNNING, BELT_STOPPED = (60, 160, 60), (90, 90, 90)
BEAM_CLEAR, BEAM_CUT = (220, 200, 40), (230, 40, 40)


def cell_parts(cell: Any, status: dict[str, list[dict[str, Any]]]) -> list[Part]:
    """A cell's belts as their boxes (green while running) and its sensors' beams as thin capsules or
    their regions as boxes (red while interrupted): ``cell`` as the scene declares it
    (controller/scene/cell.py), ``status`` as ``xarm-emu scene --json`` lists its elements."""
    parts: list[Part] = []
    for c, st in zip(cell.conveyors, status.get("conveyors", []), strict=False):
        lo, hi = np.asarray(c.min, dtype=float) * MM, np.asarray(c.max, dtype=float) * MM
        m, h = (lo + hi) / 2, (hi - lo) / 2
        parts.append(Part(f"belt_{c.name}", "box", (float(m[0]), float(m[1]), float(m[2])),
                          (1.0, 0.0, 0.0, 0.0), half=(float(h[0]), float(h[1]), float(h[2])),
                          color=BELT_RUNNING if st["running"] else BELT_STOPPED))
    for s, st in zip(cell.sensors, status.get("sensors", []), strict=False):
        tint = BEAM_CUT if st["interrupted"] else BEAM_CLEAR
        if s.beam is not None:
            a, b = np.asarray(s.beam[0], dtype=float) * MM, np.asarray(s.beam[1], dtype=float) * MM
            d = b - a
            parts.append(Part(f"beam_{s.name}", "capsule", (float(a[0]), float(a[1]), float(a[2])),
                              quat_z_to(tuple(float(v) for v in d)), radius=BEAM_RADIUS,
                              length=float(np.linalg.norm(d)), color=tint))
        else:
            lo, hi = np.asarray(s.region[0], dtype=float) * MM, np.asarray(s.region[1], dtype=float) * MM
            m, h = (lo + hi) / 2, (hi - lo) / 2
            parts.append(Part(f"region_{s.name}", "box", (float(m[0]), float(m[1]), float(m[2])),
                              (1.0, 0.0, 0.0, 0.0), half=(float(h[0]), float(h[1]), float(h[2])), color=tint))
    return parts


def object_parts(shapes: Sequence[Sequence[Any]], poses: Sequence[dict[str, Any]]) -> list[Part]:
    """The scene's loose objects where the physics world has them: ``shapes`` are (name, shape, size
    mm[, colour r, g, b from 0 to 1]) as the scene declares them, ``poses`` what
    ``Emulator.scene_objects()`` answers. A box is drawn as itself, a sphere as a capsule of no
    length, a cylinder as the box around it."""
    parts = []
    for spec, pose in zip(shapes, poses, strict=True):
        name, shape, size = str(spec[0]), str(spec[1]), [float(v) for v in spec[2]]
        tint: tuple[int, int, int] | None = None
        if len(spec) > 3:
            r, g, b = (int(round(255 * float(v))) for v in spec[3][:3])
            tint = (r, g, b)
        R = rpy_to_matrix(*np.radians(pose["rpy"]))
        c = np.asarray(pose["position"], dtype=float) * MM
        wxyz = quat_from_matrix(R)
        centre = (float(c[0]), float(c[1]), float(c[2]))
        if shape == "sphere":
            parts.append(Part(f"object_{name}", "capsule", centre, wxyz, radius=size[0] / 2 * MM,
                              color=tint))
            continue
        if shape == "cylinder":
            half = (size[0] / 2 * MM, size[0] / 2 * MM, size[1] / 2 * MM)
        else:
            half = (size[0] / 2 * MM, size[1] / 2 * MM, size[2] / 2 * MM)
        parts.append(Part(f"object_{name}", "box", centre, wxyz, half=half, color=tint))
    return parts
