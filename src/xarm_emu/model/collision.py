"""Self-collision geometry of the arms of ``robots.py`` (manual registers 77 and 78; error C22, manual 3.2.1).

Each link is one or more capsules (a segment fixed in a joint frame plus a radius, mm); the end tool of
register 78 is a capsule (built-in tools, cylinder 21) or a box (cuboid 22) in the flange frame.

Link geometry. Segments follow the joint frames of ``robots.py`` and take their lengths from its joint
origins (``_link_capsules``): the base column up to J1's origin, the upper arm from J2 to J3 (xArm7: to J3,
then the elbow offset to J4), the elbow offset and the forearm (x and y of the origin of the joint at the
wrist end of the forearm), the wrist module about the axis of the last but one joint and the last module
down to the flange (y of the last joint's origin). The only collision data are the radii, estimates of
the joint modules' housings (no vendor collision model is published in a form we can read): base column
and shoulder 60, upper arm 46, elbow module 50, forearm tube 38, wrist module 40, last module and flange
35 mm; and three splits: the top 110 mm of the forearm belong to the elbow body, the forearm capsule stops
45 mm above the wrist axis, the wrist module is 90 mm long (``XARM_GEOMETRY``, also used for the xArm 7T).
Lite 6 and 850 have their own radii and splits (``LinkGeometry``), the emulator's estimates. Where a
module's housing is a cylinder about its own joint axis the capsule lies on that axis, which makes it
invariant to that joint. Parts of a link that always touch a neighbour through the joint are left to the
neighbour (adjacent bodies are never checked).

Checked pairs. Every pair of bodies at least two apart in the chain, except pairs that can never meet
(elbow vs wrist, kept apart by the forearm) and the forearm vs the last module, which the J5 (xArm5: J4,
xArm7: J6) range brings side by side at 180 deg with a designed clearance (modelled: 1 mm).

Built-in tools (register 78 types 1-5, no parameters): the manual gives only their names; each is
modelled as a capsule along the flange z axis with an estimated envelope (radius, length): the length is
the usual TCP offset of the tool (xArm Gripper 172 mm, see UFACTORY examples), the others are estimates
from the vendors' published outline sizes. Custom tools (type 21 cylinder: radius, height, x, y, z
offset; type 22 cuboid: x, y, z, x, y, z offset; the parameter order of the SDK's
``set_collision_tool_model``) start at the flange (plus the offset) and extend along flange +z; the box
axes are the flange (default TCP) axes, as the manual says. The cylinder is enclosed by a capsule (its
rounded ends reach ``radius`` beyond the flat faces: conservative); the box is exact.

Speed: the joint chain is evaluated in scalar Python using the fact that every joint origin rotation is
a quarter-turn rotation (a signed permutation; Rx(0) and Rx(+/-pi/2), those of the xArm, take a shortcut),
and distances are closed-form scalar code (segment-segment
after Ericson, segment-box by piecewise quadratics). ``bench/bench_safety.py`` measures it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .robots import RobotModel, joint_values
from .rotations import rpy_to_matrix

Vec = tuple[float, float, float]

TOOL_NONE = 0
TOOL_CYLINDER = 21
TOOL_CUBOID = 22


@dataclass(frozen=True)
class Capsule:
    """Segment ``a``-``b`` swept by a sphere of ``radius`` (mm). ``body`` is its index in the chain.

    ``frame`` is where ``a`` and ``b`` are given: -1 the base frame (world, what ``link_shapes`` returns),
    k the frame after joint k+1 (``joint_frames`` index: how the link geometry is laid out).
    """

    a: Vec
    b: Vec
    radius: float
    name: str
    body: int
    frame: int = -1


@dataclass(frozen=True)
class Box:
    """Oriented box: ``center``, unit ``axes`` (3 vectors) and ``half`` extents along them (mm)."""

    center: Vec
    axes: tuple[Vec, Vec, Vec]
    half: Vec
    name: str
    body: int


Shape = Capsule | Box


@dataclass(frozen=True)
class ToolModel:
    """End tool of register 78 in the flange frame: ``kind`` (type number), ``params`` as received."""

    kind: int
    params: tuple[float, ...]
    capsule: tuple[Vec, Vec, float] | None = None  # a, b, radius
    box: tuple[Vec, Vec] | None = None  # center, half extents (axes = flange axes)


# Built-in tools: (name, radius, length) in mm, along flange +z (module docstring: estimates).
BUILTIN_TOOLS: dict[int, tuple[str, float, float]] = {
    1: ("xArm Gripper", 45.0, 172.0),
    2: ("xArm Vacuum Gripper", 40.0, 126.0),
    3: ("xArm BIO Gripper", 45.0, 150.0),
    4: ("Robotiq 2F-85", 50.0, 174.0),
    5: ("Robotiq 2F-140", 75.0, 244.0),
}


def tool_model(kind: int, params: Sequence[float] = ()) -> ToolModel:
    """Register 78 tool: 0 none, 1-5 built-in, 21 cylinder (r, h, dx, dy, dz), 22 cuboid (x, y, z, dx, ...).

    Missing offsets are 0. ``ValueError`` for an unknown type or non-positive / non-finite sizes.
    """
    kind = int(kind)
    p = [float(v) for v in params]
    if not all(math.isfinite(v) for v in p):
        raise ValueError("tool parameters must be finite")
    if kind == TOOL_NONE:
        return ToolModel(0, ())
    if kind in BUILTIN_TOOLS:
        _, r, length = BUILTIN_TOOLS[kind]
        return ToolModel(kind, (), capsule=((0.0, 0.0, 0.0), (0.0, 0.0, length), r))
    if kind == TOOL_CYLINDER:
        if len(p) < 2 or p[0] <= 0.0 or p[1] <= 0.0:
            raise ValueError("cylinder tool needs radius > 0 and height > 0")
        dx, dy, dz = (p[2:5] + [0.0, 0.0, 0.0])[:3]
        return ToolModel(kind, tuple(p[:5]), capsule=((dx, dy, dz), (dx, dy, dz + p[1]), p[0]))
    if kind == TOOL_CUBOID:
        if len(p) < 3 or min(p[:3]) <= 0.0:
            raise ValueError("cuboid tool needs x, y, z > 0")
        dx, dy, dz = (p[3:6] + [0.0, 0.0, 0.0])[:3]
        return ToolModel(kind, tuple(p[:6]),
                         box=((dx, dy, dz + p[2] / 2.0), (p[0] / 2.0, p[1] / 2.0, p[2] / 2.0)))
    raise ValueError(f"unknown self-collision tool type {kind}")


NO_TOOL = tool_model(TOOL_NONE)

# --------------------------------------------------------------------------------------------------------
# Link capsules per model, derived from the joint origins of ``robots.py`` (see the module docstring).
# Collision data proper is only the radii, the splits along the forearm and the wrist module's length.

@dataclass(frozen=True)
class LinkGeometry:
    """Collision data of one model's links (mm): capsule radii and the splits along the arm.

    ``fore_top``: the top of the forearm (elbow side) that belongs to the elbow body; ``fore_low``: how
    far above the wrist axis the forearm capsule ends; ``wrist_half``: half the wrist module's length.
    """

    base: float
    upper: float
    elbow: float
    fore: float
    wrist: float
    last: float
    fore_top: float
    fore_low: float
    wrist_half: float


#: The xArm 5/6/7 (and xArm 7T, the same joint modules) housings, as in the module docstring.
XARM_GEOMETRY = LinkGeometry(60.0, 46.0, 50.0, 38.0, 40.0, 35.0, 110.0, 45.0, 45.0)
#: Lite 6. ESTIMATE (the emulator's own, no vendor collision model): smaller joint modules, scaled to
#: its shorter links (upper arm 200 mm, forearm 228 mm, wrist to flange 62.5 mm).
LITE6_GEOMETRY = LinkGeometry(40.0, 35.0, 36.0, 28.0, 30.0, 28.0, 70.0, 35.0, 35.0)
#: UFACTORY 850. ESTIMATE (the emulator's own): larger modules for its 390 mm upper arm and 426 mm
#: forearm.
UF850_GEOMETRY = LinkGeometry(75.0, 60.0, 62.0, 48.0, 45.0, 42.0, 130.0, 55.0, 50.0)

_GEOMETRY: dict[str, LinkGeometry] = {"lite6": LITE6_GEOMETRY, "850": UF850_GEOMETRY}


def link_geometry(model: RobotModel) -> LinkGeometry:
    """The collision data of ``model`` (by its key; the xArm's for any other)."""
    return _GEOMETRY.get(model.key, XARM_GEOMETRY)


_ORIGIN: Vec = (0.0, 0.0, 0.0)


def _roll_code(roll: float) -> int:
    """0, +1 or -1 for an origin roll of 0, +pi/2 or -pi/2 (the only ones the fast chain supports)."""
    if abs(roll) < 1e-12:
        return 0
    if abs(roll - math.pi / 2) < 1e-12:
        return 1
    if abs(roll + math.pi / 2) < 1e-12:
        return -1
    raise ValueError("collision chain supports roll 0 or +/-pi/2 only")


def _origin_rotation(rpy: tuple[float, float, float]) -> tuple[float, ...]:
    """Rz(yaw) Ry(pitch) Rx(roll) as 9 row-major entries, each snapped to 0 or +/-1 (quarter turns)."""
    roll, pitch, yaw = rpy
    m = rpy_to_matrix(roll, pitch, yaw)
    out = []
    for v in m.reshape(-1).tolist():
        r = round(v)
        if abs(v - r) > 1e-12:
            raise ValueError("collision chain supports origin rotations in quarter turns only")
        out.append(float(r))
    return tuple(out)


def _in_child(model: RobotModel, k: int, p: Vec) -> Vec:
    """Point ``p`` of joint ``k``'s parent frame in joint ``k``'s own frame (at zero joint angle)."""
    j = model.joints[k]
    ox, oy, oz = j.origin_xyz
    vx, vy, vz = p[0] - ox, p[1] - oy, p[2] - oz
    m = _origin_rotation(j.origin_rpy)  # child coordinates = m^T (p - o)
    return (m[0] * vx + m[3] * vy + m[6] * vz, m[1] * vx + m[4] * vy + m[7] * vz,
            m[2] * vx + m[5] * vy + m[8] * vz)


def _link_capsules(model: RobotModel) -> tuple[Capsule, ...]:
    """The link capsules of ``model`` in its joint frames (``Capsule.frame``), bodies numbered from 1.

    Layout: base column (J1 origin), upper arm (origin of the joint after the shoulder, xArm7: two joints
    with the elbow J4 side offset), elbow offset and forearm (origin of the joint at the wrist end of the
    forearm: x is the elbow offset, y the forearm length), wrist module (about the axis of the last but
    one joint) and last module (the last joint origin's y, down to the flange).
    """
    dof = model.dof
    if dof not in (5, 6, 7):
        raise ValueError(f"no self-collision layout for {dof} axes")
    g = link_geometry(model)
    j = model.joints
    b = 1 if dof == 7 else 0  # xArm7: one more upper body (J3), so later bodies shift by one
    wrist_j = 4 if dof == 7 else 3  # joint whose origin ends the forearm
    ex, fy, _ = j[wrist_j].origin_xyz
    top = math.copysign(g.fore_top, fy)
    caps = [
        Capsule(_ORIGIN, j[0].origin_xyz, g.base, "base", 1, -1),
        Capsule(_ORIGIN, j[2].origin_xyz, g.upper, "upper arm", 2, 1),
    ]
    if dof == 7:
        caps.append(Capsule(_ORIGIN, j[3].origin_xyz, g.elbow, "elbow J4 side", 3, 2))
    parent = wrist_j - 1  # frame of the elbow and the top of the forearm
    fore_a, fore_b = (ex, top, 0.0), (ex, fy - math.copysign(g.fore_low, fy), 0.0)
    if dof == 5:  # no joint turns about the forearm: it stays in the elbow frame
        fore = Capsule(fore_a, fore_b, g.fore, "forearm", 4, parent)
    else:  # it lies on the axis of the joint at its end, in that joint's frame
        fore = Capsule(_in_child(model, wrist_j, fore_a), _in_child(model, wrist_j, fore_b), g.fore,
                       "forearm", 4 + b, wrist_j)
    last = dof - 1
    lx = j[last].origin_xyz[0]
    caps += [
        Capsule(_ORIGIN, (ex, 0.0, 0.0), g.elbow, "elbow", 3 + b, parent),
        Capsule((ex, 0.0, 0.0), (ex, top, 0.0), g.fore, "forearm top", 3 + b, parent),
        fore,
        Capsule((0.0, 0.0, -g.wrist_half), (0.0, 0.0, g.wrist_half), g.wrist, "wrist", 5 + b, last - 1),
        Capsule(_in_child(model, last, (lx, 0.0, 0.0)), _ORIGIN, g.last, "flange", 6 + b, last),
    ]
    return tuple(caps)


# Body pairs two or more apart that are not checked (module docstring), per dof.
_SKIP_56 = frozenset({(3, 5), (3, 6), (4, 6)})
_SKIP: dict[int, frozenset[tuple[int, int]]] = {
    5: _SKIP_56,
    6: _SKIP_56,
    7: frozenset({(1, 3), (2, 4), (4, 6), (4, 7), (5, 7)}),
}


class _Layout:
    """What the checks need of one model, computed once: link rows, origin codes, checked pairs."""

    __slots__ = ("model", "links", "codes", "pairs")

    def __init__(self, model: RobotModel) -> None:
        self.model = model
        self.links: list[tuple] = [("c", c.frame, c.a, c.b, c.radius, c.name, c.body)
                                   for c in _link_capsules(model)]
        self.codes = _origin_codes(model)
        self.pairs: dict[tuple[int, bool], list[tuple[int, int]]] = {}


_LAYOUTS: dict[int, _Layout] = {}


def _layout(model: RobotModel) -> _Layout:
    """The cached layout of ``model`` (keyed by the object itself: an edited copy gets its own)."""
    lay = _LAYOUTS.get(id(model))
    if lay is None or lay.model is not model:
        lay = _LAYOUTS[id(model)] = _Layout(model)
    return lay


def collision_pairs(model: RobotModel, tool: ToolModel = NO_TOOL) -> list[tuple[int, int]]:
    """Indices (into ``link_shapes``) of the shape pairs checked for ``model`` with ``tool``."""
    shapes = _local_shapes(model, tool)
    skip = _SKIP[model.dof]
    out = []
    for i in range(len(shapes)):
        for j in range(i + 1, len(shapes)):
            bi, bj = shapes[i][-1], shapes[j][-1]
            lo, hi = min(bi, bj), max(bi, bj)
            if hi - lo >= 2 and (lo, hi) not in skip:
                out.append((i, j))
    return out


def _local_shapes(model: RobotModel, tool: ToolModel) -> list[tuple]:
    """(kind, frame, data..., name, body) rows; tool last, as body dof + 1."""
    rows = list(_layout(model).links)
    flange, body = model.dof - 1, model.dof + 1
    if tool.capsule is not None:
        a, b, r = tool.capsule
        rows.append(("c", flange, a, b, r, f"tool {tool.kind}", body))
    elif tool.box is not None:
        center, half = tool.box
        rows.append(("b", flange, center, half, f"tool {tool.kind}", body))
    return rows


# --------------------------------------------------------------------------------------------------------
# Fast scalar joint chain


_OriginCode = tuple[int, float, float, float, tuple[float, ...]]


def _origin_codes(model: RobotModel) -> tuple[_OriginCode, ...]:
    """Per joint: 0/+1/-1 for an origin rotation Rx(0)/Rx(+pi/2)/Rx(-pi/2), 2 for any other quarter-turn
    rotation (its 9 entries follow), then the origin."""
    out: list[_OriginCode] = []
    for j in model.joints:
        roll, pitch, yaw = j.origin_rpy
        x, y, z = (float(v) for v in j.origin_xyz)
        if pitch == 0.0 and yaw == 0.0 and abs(abs(roll) - math.pi) > 1e-12:
            out.append((_roll_code(roll), x, y, z, ()))
        else:
            out.append((2, x, y, z, _origin_rotation(j.origin_rpy)))
    return tuple(out)


def frames_scalar(model: RobotModel, q: Sequence[float]) -> list[tuple[float, ...]]:
    """Joint frames as 12-tuples (x axis, y axis, z axis, origin), same frames as ``joint_frames``."""
    codes = _layout(model).codes
    xx, xy, xz, yx, yy, yz, zx, zy, zz = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
    px = py = pz = 0.0
    out: list[tuple[float, ...]] = []
    cos, sin = math.cos, math.sin
    for (code, ox, oy, oz, m), qi in zip(codes, q, strict=False):
        px, py, pz = (px + xx * ox + yx * oy + zx * oz, py + xy * ox + yy * oy + zy * oz,
                      pz + xz * ox + yz * oy + zz * oz)
        if code == 1:  # Rx(+pi/2): new y = z, new z = -y
            yx, yy, yz, zx, zy, zz = zx, zy, zz, -yx, -yy, -yz
        elif code == -1:  # Rx(-pi/2): new y = -z, new z = y
            yx, yy, yz, zx, zy, zz = -zx, -zy, -zz, yx, yy, yz
        elif code == 2:  # any quarter-turn rotation: new axis k = sum_i m[i][k] axis_i
            xx, xy, xz, yx, yy, yz, zx, zy, zz = (
                m[0] * xx + m[3] * yx + m[6] * zx, m[0] * xy + m[3] * yy + m[6] * zy,
                m[0] * xz + m[3] * yz + m[6] * zz,
                m[1] * xx + m[4] * yx + m[7] * zx, m[1] * xy + m[4] * yy + m[7] * zy,
                m[1] * xz + m[4] * yz + m[7] * zz,
                m[2] * xx + m[5] * yx + m[8] * zx, m[2] * xy + m[5] * yy + m[8] * zy,
                m[2] * xz + m[5] * yz + m[8] * zz)
        c, s = cos(qi), sin(qi)
        xx, xy, xz, yx, yy, yz = (c * xx + s * yx, c * xy + s * yy, c * xz + s * yz,
                                  c * yx - s * xx, c * yy - s * xy, c * yz - s * xz)
        out.append((xx, xy, xz, yx, yy, yz, zx, zy, zz, px, py, pz))
    return out


_IDENT = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)


def _xf(f: tuple[float, ...], v: Vec) -> Vec:
    x, y, z = v
    return (f[9] + f[0] * x + f[3] * y + f[6] * z, f[10] + f[1] * x + f[4] * y + f[7] * z,
            f[11] + f[2] * x + f[5] * y + f[8] * z)


def link_shapes(model: RobotModel, q: Sequence[float] | np.ndarray, tool: ToolModel = NO_TOOL) -> list[Shape]:
    """World-frame (base frame) shapes of the links and the tool at joints ``q`` (mm)."""
    frames = frames_scalar(model, joint_values(model, q))
    out: list[Shape] = []
    for row in _local_shapes(model, tool):
        f = _IDENT if row[1] < 0 else frames[row[1]]
        if row[0] == "c":
            out.append(Capsule(_xf(f, row[2]), _xf(f, row[3]), row[4], row[5], row[6]))
        else:
            axes = ((f[0], f[1], f[2]), (f[3], f[4], f[5]), (f[6], f[7], f[8]))
            out.append(Box(_xf(f, row[2]), axes, row[3], row[4], row[5]))
    return out


def link_capsules(
    model: RobotModel, q: Sequence[float] | np.ndarray, tool: ToolModel = NO_TOOL
) -> list[Capsule]:
    """World-frame capsules of the links (and of a capsule tool; a cuboid tool is in ``link_shapes``)."""
    return [s for s in link_shapes(model, q, tool) if isinstance(s, Capsule)]


# --------------------------------------------------------------------------------------------------------
# Distances (scalar)


def segment_distance(p1: Vec, q1: Vec, p2: Vec, q2: Vec) -> float:
    """Minimum distance between segments p1-q1 and p2-q2 (closest points, clamped; Ericson 5.1.9)."""
    d1x, d1y, d1z = q1[0] - p1[0], q1[1] - p1[1], q1[2] - p1[2]
    d2x, d2y, d2z = q2[0] - p2[0], q2[1] - p2[1], q2[2] - p2[2]
    rx, ry, rz = p1[0] - p2[0], p1[1] - p2[1], p1[2] - p2[2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    eps = 1e-12
    if a <= eps and e <= eps:
        s = t = 0.0
    elif a <= eps:
        s = 0.0
        t = min(max(f / e, 0.0), 1.0)
    else:
        c = d1x * rx + d1y * ry + d1z * rz
        if e <= eps:
            t = 0.0
            s = min(max(-c / a, 0.0), 1.0)
        else:
            b = d1x * d2x + d1y * d2y + d1z * d2z
            denom = a * e - b * b
            s = min(max((b * f - c * e) / denom, 0.0), 1.0) if denom > eps * a * e else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = min(max(-c / a, 0.0), 1.0)
            elif t > 1.0:
                t = 1.0
                s = min(max((b - c) / a, 0.0), 1.0)
    dx = rx + d1x * s - d2x * t
    dy = ry + d1y * s - d2y * t
    dz = rz + d1z * s - d2z * t
    return math.sqrt(dx * dx + dy * dy + dz * dz)


def segment_box_distance(p: Vec, q: Vec, box: Box) -> float:
    """Minimum distance between segment p-q and a solid oriented box (0 when they meet).

    In box coordinates the squared distance is, between the parameters where the segment crosses a face
    plane, a quadratic in the segment parameter; each piece is minimised in closed form.
    """
    cx, cy, cz = box.center
    a: list[float] = []
    d: list[float] = []
    for ax in box.axes:
        ua = (p[0] - cx) * ax[0] + (p[1] - cy) * ax[1] + (p[2] - cz) * ax[2]
        ub = (q[0] - cx) * ax[0] + (q[1] - cy) * ax[1] + (q[2] - cz) * ax[2]
        a.append(ua)
        d.append(ub - ua)
    h = box.half
    ts = [0.0, 1.0]
    for k in range(3):
        if d[k] != 0.0:
            for bound in (h[k], -h[k]):
                t = (bound - a[k]) / d[k]
                if 0.0 < t < 1.0:
                    ts.append(t)
    ts.sort()
    best = math.inf
    for i in range(len(ts) - 1):
        t0, t1 = ts[i], ts[i + 1]
        tm = 0.5 * (t0 + t1)
        num = den = 0.0
        active = []
        for k in range(3):
            x = a[k] + tm * d[k]
            if x > h[k]:
                active.append((a[k] - h[k], d[k]))
            elif x < -h[k]:
                active.append((a[k] + h[k], d[k]))
        if not active:
            return 0.0
        for u, v in active:
            num += u * v
            den += v * v
        t = -num / den if den > 0.0 else t0
        t = t0 if t < t0 else (t1 if t > t1 else t)
        s = 0.0
        for u, v in active:
            w = u + t * v
            s += w * w
        if s < best:
            best = s
    return math.sqrt(best)


def shape_distance(s1: Shape, s2: Shape) -> float:
    """Surface distance between two shapes (0 when they overlap)."""
    if isinstance(s1, Box):
        s1, s2 = s2, s1
    if isinstance(s1, Box):
        raise ValueError("box-box distance is not supported (only one tool is a box)")
    if isinstance(s2, Box):
        return max(segment_box_distance(s1.a, s1.b, s2) - s1.radius, 0.0)
    return max(segment_distance(s1.a, s1.b, s2.a, s2.b) - s1.radius - s2.radius, 0.0)


def self_collision(
    model: RobotModel, q: Sequence[float] | np.ndarray, tool: ToolModel = NO_TOOL, margin: float = 0.0
) -> tuple[bool, float, tuple[int, int]]:
    """(collides, minimum surface distance mm, (i, j) indices into ``link_shapes``) over checked pairs.

    Collides when the minimum distance is below ``margin`` (mm); a distance of 0 means overlap.
    """
    rows = _local_shapes(model, tool)
    key = (len(rows), tool.box is not None)
    cache = _layout(model).pairs
    pairs = cache.get(key)
    if pairs is None:
        pairs = cache[key] = collision_pairs(model, tool)
    frames = frames_scalar(model, joint_values(model, q))
    world: list = []  # plain tuples (a, b, radius) for capsules; Box objects for a cuboid tool
    for row in rows:
        f = _IDENT if row[1] < 0 else frames[row[1]]
        if row[0] == "c":
            world.append((_xf(f, row[2]), _xf(f, row[3]), row[4]))
        else:
            axes = ((f[0], f[1], f[2]), (f[3], f[4], f[5]), (f[6], f[7], f[8]))
            world.append(Box(_xf(f, row[2]), axes, row[3], row[4], row[5]))
    best, best_pair = math.inf, (-1, -1)
    seg = segment_distance
    for i, j in pairs:
        s1, s2 = world[i], world[j]
        if type(s2) is Box:
            d = segment_box_distance(s1[0], s1[1], s2) - s1[2]
        else:
            d = seg(s1[0], s1[1], s2[0], s2[1]) - s1[2] - s2[2]
        if d < 0.0:
            d = 0.0
        if d < best:
            best, best_pair = d, (i, j)
    return (best <= 0.0 or best < margin), best, best_pair
