"""The physics world as an MJCF document, built from the project's own tables: the joint frames of
``model/robots.py``, the link capsules of ``model/collision.py``, the link inertials of
``model/inertials.py``, the hand of :mod:`.hands`, the scene's fixed planes and boxes and its loose
objects. No meshes. A pure function of its inputs: the same scene gives the same document, byte for
byte (and so the same engine model).

Units: the engine works in metres, kilograms and seconds; the tables are in mm.

An object's friction is that of its every contact (its geoms have the higher priority), so a
scene's ``friction`` says how the object grips and slides. Collision groups (MuJoCo's
contype/conaffinity bits): fixtures (planes, boxes, belts) touch objects and links only;
objects touch everything; the arm's links (bit ``LINK``) touch objects and fixtures, the hand objects
only. A conveyor is a fixture on a slide joint (:func:`_conveyor`). What the TCP presses into a fixture
is measured apart (the spring-damper of controller/scene/contact.py); a link pressing into one is a
contact of the engine, as an object's, and the arm still follows the controller: the engine never
moves it.
"""

from __future__ import annotations

from collections.abc import Sequence
from xml.sax.saxutils import quoteattr

import numpy as np

from ...model.collision import _link_capsules
from ...model.inertials import get_inertials
from ...model.robots import RobotModel
from ...model.rotations import quat_from_matrix, rpy_to_matrix
from ..scene.cell import ConveyorSpec
from ..scene.contact import Box, Plane, Scene
from ..scene.objects import ObjectSpec
from .hands import Hand

MM = 0.001
#: The engine's time step (s): one per control period of 4 ms, the implicit integrator (stable for
#: the stiff finger drive and contacts at this step).
TIMESTEP = 0.004
#: The arm's joints: an inertia so large that nothing the engine applies moves them within a step
#: (the controller moves them; kg m^2).
ARM_ARMATURE = 1.0e4
#: Mass of one finger (kg).
FINGER_MASS = 0.05
#: Position gain of the finger drive (N/m): fingers held this far short of where the motor is told
#: press with this force per metre (shared by the two pads), up to the hand's force on each.
FINGER_KP = 6000.0
FINGER_KV = 40.0

FIXTURE, OBJECT, ARM, LINK = 1, 2, 4, 8
#: The geom group of objects (what a sensor's beam sees).
OBJECT_GROUP = 1
#: An arm or hand this near an object (m) makes the world step (:meth:`.world.World.step`).
NEAR = 0.01
#: Contacts: as stiff as the engine allows at its step (time constant two steps) and hard (impedance
#: near 1 from the first 0.5 mm), so a squeezed object is pressed into by a fraction of a millimetre.
SOLREF = "0.008 1"
SOLIMP = "0.99 0.999 0.0005 0.5 2"


def _f(*v: float) -> str:
    return " ".join(repr(round(float(x), 12)) for x in v)


def _quat(R: np.ndarray) -> str:
    return _f(*quat_from_matrix(R))


def _rpy_quat(rpy: Sequence[float] | np.ndarray) -> str:
    return _quat(rpy_to_matrix(float(rpy[0]), float(rpy[1]), float(rpy[2])))


def _capsule(a: Sequence[float], b: Sequence[float], radius: float, name: str, fixtures: bool) -> str:
    """A link's capsule; ``fixtures``: it touches the fixtures too (links past the first, whose
    capsule reaches the mounting face and turns only about the base's axis)."""
    ends = _f(*(np.asarray(a) * MM), *(np.asarray(b) * MM))
    touch = (f'contype="{ARM | LINK}" conaffinity="{FIXTURE}"' if fixtures
             else f'contype="{ARM}" conaffinity="0"')
    return f'<geom name={quoteattr(name)} type="capsule" fromto="{ends}" size="{_f(radius * MM)}" {touch}/>'


def _arm(model: RobotModel, hand: Hand | None) -> tuple[list[str], str]:
    """The base geoms (in the world body) and the nested link bodies of the arm."""
    caps = _link_capsules(model)
    by_frame: dict[int, list[str]] = {}
    for i, c in enumerate(caps):
        geom = _capsule(c.a, c.b, c.radius, f"link{c.body}_{i}", c.frame >= 1)
        by_frame.setdefault(c.frame, []).append(geom)
    inertials = get_inertials(model).links
    close = ""
    out = ""
    last = model.dof - 1
    for k, j in enumerate(model.joints):
        R = rpy_to_matrix(*j.origin_rpy)
        li = inertials[k]
        ixx, iyy, izz, ixy, ixz, iyz = li.inertia
        out += (f'<body name="link{k + 1}" pos="{_f(*(np.asarray(j.origin_xyz) * MM))}" quat="{_quat(R)}"'
                f' gravcomp="1">'
                f'<joint name="j{k + 1}" type="hinge" axis="0 0 1" armature="{ARM_ARMATURE!r}"'
                f' limited="false"/>'
                f'<inertial pos="{_f(*li.com_m)}" mass="{_f(li.mass)}"'
                f' fullinertia="{_f(max(ixx, 1e-6), max(iyy, 1e-6), max(izz, 1e-6), ixy, ixz, iyz)}"/>')
        out += "".join(by_frame.get(k, []))
        if k == last and hand is not None:
            out += _hand(hand)
        close += "</body>"
    return by_frame.get(-1, []), out + close


def _hand(h: Hand) -> str:
    """The hand's bodies in the flange frame: the housing, then two fingers on slide joints along
    flange y (their joint value is half the opening, m)."""
    hz, hh = h.housing
    out = (f'<geom name="housing" type="box" pos="0 0 {_f(hz * MM)}" size="{_f(*(np.asarray(hh) * MM))}"'
           f' contype="{ARM}" conaffinity="0" friction="{_f(h.friction)} 0.005 0.0001"/>')
    if h.cup_radius > 0:  # the cup: a short cylinder whose face is at the tip
        out += (f'<geom name="cup" type="cylinder" pos="0 0 {_f((h.tip - 5.0) * MM)}"'
                f' size="{_f(h.cup_radius * MM, 5.0 * MM)}" contype="{ARM}" conaffinity="0"/>')
    if h.stroke <= 0:
        return out
    px, py, pz = h.pad_half
    for name, side in (("finger_a", 1.0), ("finger_b", -1.0)):
        out += (f'<body name="{name}" pos="0 0 {_f(h.pad_center_z * MM)}" gravcomp="1">'
                f'<joint name="{name}" type="slide" axis="0 {_f(side)} 0" range="0 {_f(h.stroke / 2 * MM)}"'
                f' limited="true" damping="1"/>'
                f'<geom name="{name}_pad" type="box" pos="0 {_f(side * py * MM)} 0"'
                f' size="{_f(px * MM, py * MM, pz * MM)}" mass="{_f(FINGER_MASS)}" contype="{ARM}"'
                f' conaffinity="0" condim="4" friction="{_f(h.friction)} 0.01 0.0001"/>'
                f'</body>')
    return out


def _fixture(s: Plane | Box) -> str:
    common = f'contype="{FIXTURE}" conaffinity="0" friction="{_f(s.friction)} 0.005 0.0001"'
    if isinstance(s, Plane):
        n = np.asarray(s.normal, dtype=float)
        z = np.array([0.0, 0.0, 1.0])
        axis = np.cross(z, n)
        if np.linalg.norm(axis) < 1e-12:
            R = np.eye(3) if n[2] > 0 else np.diag([1.0, -1.0, -1.0])
        else:
            axis /= np.linalg.norm(axis)
            ang = float(np.arccos(np.clip(np.dot(z, n), -1.0, 1.0)))
            K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
            R = np.eye(3) + np.sin(ang) * K + (1 - np.cos(ang)) * K @ K
        return (f'<geom name={quoteattr("plane:" + s.name)} type="plane" size="0 0 1"'
                f' pos="{_f(*(np.asarray(s.point) * MM))}" quat="{_quat(R)}" {common}/>')
    lo, hi = np.asarray(s.min) * MM, np.asarray(s.max) * MM
    return (f'<geom name={quoteattr("box:" + s.name)} type="box" pos="{_f(*((lo + hi) / 2))}"'
            f' size="{_f(*((hi - lo) / 2))}" {common}/>')


def _object(o: ObjectSpec) -> str:
    size = np.asarray(o.size) * MM
    if o.shape == "box":
        gsize = _f(*(size / 2))
    elif o.shape == "cylinder":
        gsize = _f(size[0] / 2, size[1] / 2)
    else:
        gsize = _f(size[0] / 2)
    rpy = np.radians(o.rpy)
    return (f'<body name={quoteattr("object:" + o.name)} pos="{_f(*(np.asarray(o.position) * MM))}"'
            f' quat="{_rpy_quat(rpy)}"><freejoint name={quoteattr("object:" + o.name)}/>'
            f'<geom type="{o.shape}" size="{gsize}" mass="{_f(o.mass)}" rgba="{_f(*o.color)}"'
            f' contype="{OBJECT}" conaffinity="{FIXTURE | OBJECT | ARM}" condim="4" priority="1"'
            f' group="{OBJECT_GROUP}"'
            f' friction="{_f(o.friction)} 0.01 0.0001"/></body>')


def _finger_drive(h: Hand) -> str:
    """One force-limited position drive on finger a; finger b follows it through a joint coupling, as
    the fingers of a parallel gripper are geared together (each pad presses with the hand's force)."""
    return (f'<equality><joint joint1="finger_b" joint2="finger_a" polycoef="0 1 0 0 0"'
            f' solref="{SOLREF}" solimp="{SOLIMP}"/></equality>'
            f'<actuator><position name="finger" joint="finger_a" kp="{FINGER_KP!r}" kv="{FINGER_KV!r}"'
            f' forcelimited="true" forcerange="{_f(-2 * h.force, 2 * h.force)}"/></actuator>')


def _conveyor(c: ConveyorSpec) -> str:
    """A belt: a box on a slide joint along its direction, driven kinematically (its joint speed is
    the belt's; its position is put back every step), so what rests on it is carried by friction."""
    lo, hi = np.asarray(c.min) * MM, np.asarray(c.max) * MM
    name = quoteattr("conveyor:" + c.name)
    return (f'<body name={name} pos="{_f(*((lo + hi) / 2))}">'
            f'<joint name={name} type="slide" axis="{_f(*c.direction)}" armature="{ARM_ARMATURE!r}"'
            f' limited="false"/>'
            f'<geom type="box" size="{_f(*((hi - lo) / 2))}" mass="1" contype="{FIXTURE}" conaffinity="0"'
            f' friction="{_f(c.friction)} 0.005 0.0001"/></body>')


def world_xml(model: RobotModel, scene: Scene, hand: Hand | None,
              objects: Sequence[ObjectSpec] | None = None) -> str:
    """The MJCF document of the arm ``model`` with ``hand`` on its flange in ``scene``, with
    ``objects`` (the scene's own unless given) and the scene's conveyors."""
    base, arm = _arm(model, hand)
    fixtures = "".join(_fixture(s) for s in scene.shapes)
    bodies = "".join(_object(o) for o in (scene.objects if objects is None else objects))
    bodies += "".join(_conveyor(c) for c in scene.cell.conveyors)
    return (f'<mujoco model="xarm-emu">'
            f'<option timestep="{TIMESTEP!r}" integrator="implicitfast" cone="elliptic" impratio="10"'
            f'/>'
            f'<default><geom solref="{SOLREF}" solimp="{SOLIMP}"/></default>'
            f'<worldbody>{"".join(base)}{arm}{fixtures}{bodies}</worldbody>'
            + (_finger_drive(hand) if hand is not None and hand.stroke > 0 else "")
            + '</mujoco>')
