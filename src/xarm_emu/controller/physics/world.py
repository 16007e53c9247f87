"""The physics world: MuJoCo stepped by the controller's control period, never by a clock of its own.

Imported only when a scene has objects (the engine is an optional extra). The arm is a chain of
hinge joints of the joint frames (:mod:`.mjcf`) driven kinematically: each control period its joints
get the speed that takes them from the last period's joints to the controller's, and end exactly on
them, so the engine never moves the arm; it answers what touches what and with what force. Objects
are free bodies; the fingers slide on force-limited position drives.

Settling: once every object has stayed still (below :data:`STILL_SPEED`) for :data:`SETTLE_PERIODS`
periods, with nothing of the arm touching an object and the arm and the fingers either still or
farther than ``mjcf.NEAR`` from every object, the world is settled: the speeds are zeroed and the
engine is not stepped again until the arm or the fingers come that near an object (free fingers
are then put where their drive is told). Nearness is asked of a second copy of the model in which
only the arm and the objects collide. The rule reads only the world's own state, so stepping every
period or jumping over idle ones (controller/emulator.py) gives the same poses.
"""

from __future__ import annotations

import copy
import json
import math
import struct
from collections.abc import Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np

from ...model import kinematics as kin
from ...model.robots import RobotModel
from ...model.rotations import matrix_to_rpy, quat_from_matrix, rpy_to_matrix
from ..scene.contact import Scene
from ..scene.objects import ObjectSpec
from .cell import CellState, fresh_cell
from .hands import Hand
from .mjcf import ARM, FIXTURE, LINK, MM, NEAR, OBJECT_GROUP, TIMESTEP, world_xml

#: Object and finger speeds below this are still (m/s, and rad/s for turning).
STILL_SPEED = 2.0e-4
#: The cup seals on a face its own face is this near (mm), as the cup's lip gives.
SEAL_MM = 1.0
#: Control periods of stillness after which the world is settled.
SETTLE_PERIODS = 25
_STATE = mujoco.mjtState.mjSTATE_INTEGRATION
#: Where a feeder's parts wait, frozen, until it places them (mm, base frame): far from everything,
#: a metre apart.
PARK = (50_000.0, 50_000.0, 0.0)
PARK_STEP = 1000.0
Vec3 = tuple[float, float, float]


@dataclass(slots=True)
class PhysicsState:
    """Every mutable value of the physics world (what a checkpoint carries): the engine's integration
    state (time, positions, speeds, actuator states, solver warm start, controls) as float64 bytes,
    the finger drive's command (opening, mm), the settling count and flag, and the inputs of the last
    stepped period (arm joints and finger command) as bytes."""

    integration: bytes
    ramp: float
    still: int
    settled: bool
    inputs: bytes
    #: The object a vacuum cup holds (its index in the scene, -1: none) and its pose in the flange
    #: frame then (x, y, z mm, then the rotation's nine entries row by row).
    held: int = -1
    relative: tuple[float, ...] = ()
    #: The cell's own state (sensors, feeders, belts): :class:`.cell.CellState`.
    cell: CellState = field(default_factory=CellState)
    #: The scene of the world (its tables as JSON): a restore into a world of another scene
    #: rebuilds the world for this one first (:meth:`.component.PhysicsComponent.restore`).
    scene: str = ""


@dataclass(frozen=True, slots=True)
class Contacts:
    """The contacts of one engine step that touch the arm or hand, sorted out of the engine's contact
    list once for each contact set: the same geom pairs in the same order (an object held or at rest
    period after period) sort out the same, so they are not sorted again."""

    #: The contact set: the engine's geom pairs in contact order, as bytes.
    pairs: bytes
    #: (contact index, geom, geom) of each contact that touches the arm or hand.
    rows: list[tuple[int, int, int]]
    #: The same contacts as (contact index, the arm's geom, whether it is geom1, the object a finger
    #: pad touches or -1): what :meth:`World.arm_torques` sums.
    push: list[tuple[int, int, bool, int]]
    #: The objects both pads touch.
    both: frozenset[int]


@dataclass(frozen=True)
class ObjectPose:
    """Where an object is: centre (mm, base frame), roll/pitch/yaw (deg), whether the hand (both pads)
    or the vacuum cup holds it."""

    name: str
    position: tuple[float, float, float]
    rpy: tuple[float, float, float]
    held: bool


class World:
    """The engine's model and data for one arm, hand and scene; mutable state in :attr:`state`."""

    def __init__(self, model: RobotModel, scene: Scene, hand: Hand | None) -> None:
        self.robot = model
        self.scene = scene
        #: The scene's tables as JSON: what a checkpoint names the world by.
        self.scene_text = json.dumps(scene.to_dict(), sort_keys=True)
        self.hand = hand
        #: Every object of the engine: the scene's, then each feeder's parts (parked until placed);
        #: per feeder, the index of its first part in :attr:`specs`.
        self.specs, self.feeder_base = _engine_objects(scene)
        self.m = mujoco.MjModel.from_xml_string(world_xml(model, scene, hand, self.specs))
        self.d = mujoco.MjData(self.m)
        self._index(model)
        m, dof = self.m, model.dof
        self._near_model()
        self._flange_body = m.body(f"link{dof}").id
        self._near_key: tuple[bytes, bytes] = (b"", b"")
        self._far_key: tuple[bytes, bytes] = (b"", b"")
        self._far_out = False
        self._free_v = np.array([v + k for _, _, v, _ in self.objects for k in range(6)], dtype=int)
        self._free_list: list[int] = self._free_v.tolist()
        self._size = mujoco.mj_stateSize(m, _STATE)
        #: The engine's contacts are read once each time they change (:meth:`_scan`): ``_version``
        #: counts the changes, ``_scanned`` the one read; ``_rows`` what was read (:class:`Contacts`),
        #: ``_pad_map`` the pads on each object.
        self._version = 0
        self._scanned = -1
        self._rows = Contacts(b"", [], [], frozenset())
        self._pad_map: dict[int, set[int]] = {}
        #: Each conveyor's joint (qpos address, dof address) and its belt's speed when running (m/s).
        self._belts = [(int(m.jnt_qposadr[m.joint(f"conveyor:{c.name}").id]),
                        int(m.jnt_dofadr[m.joint(f"conveyor:{c.name}").id]), c.speed * MM)
                       for c in scene.cell.conveyors]
        #: Objects a sensor's beam sees (the engine's geom groups).
        self.ray_groups = np.array([1 if g == OBJECT_GROUP else 0 for g in range(6)], dtype=np.uint8)
        self._initial = (self.d.qpos.copy(), self.d.qvel.copy())
        self.state = PhysicsState(b"", 0.0, 0, False, b"", cell=fresh_cell(scene))
        self.reset()

    def _index(self, model: RobotModel) -> None:
        """Where the arm's joints, the fingers, the pads and the objects stand in the engine's model."""
        m = self.m
        dof = model.dof
        adr = [int(m.jnt_qposadr[m.joint(f"j{k + 1}").id]) for k in range(dof)]
        vadr = [int(m.jnt_dofadr[m.joint(f"j{k + 1}").id]) for k in range(dof)]
        if adr != list(range(adr[0], adr[0] + dof)) or vadr != list(range(vadr[0], vadr[0] + dof)):
            raise RuntimeError("arm joints are not consecutive in the engine model")
        self._q = slice(adr[0], adr[0] + dof)
        self._v = slice(vadr[0], vadr[0] + dof)
        self.fingers = self.hand is not None and self.hand.stroke > 0
        self._fq: list[int] = []
        self._pads: set[int] = set()
        if self.fingers:
            for n in ("finger_a", "finger_b"):
                self._fq.append(int(m.jnt_qposadr[m.joint(n).id]))
                self._pads.add(m.geom(f"{n}_pad").id)
        self._arm_geoms = {g for g in range(m.ngeom) if m.geom_contype[g] & 4}
        self._finger_v = [int(m.jnt_dofadr[m.joint(n).id]) for n in ("finger_a", "finger_b")] \
            if self.fingers else []
        #: Per geom: 1 arm or hand, 2 finger pad, 0 anything else.
        self._kind = np.zeros(m.ngeom, dtype=np.int8)
        self._kind[list(self._arm_geoms)] = 1
        self._arm_idx = np.array(sorted(self._arm_geoms), dtype=int)
        self._kind[list(self._pads)] = 2
        self._kinds: list[int] = self._kind.tolist()
        self.objects: list[tuple[str, int, int, int]] = []  # name, qpos adr, dof adr, geom id
        for o in self.specs:
            j = m.joint(f"object:{o.name}").id
            body = m.body(f"object:{o.name}").id
            self.objects.append((o.name, int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j]),
                                 int(m.body_geomadr[body])))
        self._object_geoms = {g: i for i, (_, _, _, g) in enumerate(self.objects)}

    def _near_model(self) -> None:
        """The model of the nearness test: a copy of the engine's in which only the arm sees."""
        m = self.m
        #: The model of the nearness test (:meth:`_kinematics_at`, :meth:`_far`): the arm's geoms
        #: see objects from ``NEAR``; nothing else collides (fixtures touch nothing, objects only
        #: the arm), so the world's own contacts stay those of its last step.
        self._near_m = near = copy.copy(m)
        near.geom_margin[self._arm_idx] = NEAR
        obj_idx = [g for *_, g in self.objects]
        near.geom_contype[:] = np.where(self._kind > 0, near.geom_contype, 0)
        near.geom_conaffinity[:] = 0
        near.geom_conaffinity[obj_idx] = ARM
        near.geom_contype[obj_idx] = 0
        # the links see the fixtures (and belts) from NEAR too
        near.geom_conaffinity[(m.geom_contype & FIXTURE).astype(bool)] = LINK
        self._near_d = mujoco.MjData(near)

    # -- state ---------------------------------------------------------------------------------
    def capture(self) -> PhysicsState:
        """The world's state as an independent value."""
        buf = np.empty(self._size)
        mujoco.mj_getState(self.m, self.d, buf, _STATE)
        s = self.state
        return PhysicsState(buf.tobytes(), s.ramp, s.still, s.settled, s.inputs, s.held, s.relative,
                            copy.deepcopy(s.cell), self.scene_text)

    def restore(self, state: PhysicsState) -> None:
        """Put ``state`` back exactly (a later step gives what it gave the first time)."""
        buf = np.frombuffer(state.integration, dtype=np.float64)
        if buf.size != self._size:
            raise ValueError("physics state of another world (other objects or arm)")
        mujoco.mj_setState(self.m, self.d, buf.copy(), _STATE)
        mujoco.mj_forward(self.m, self.d)
        self._version += 1
        self.state = PhysicsState(state.integration, state.ramp, state.still, state.settled, state.inputs,
                                  state.held, state.relative, copy.deepcopy(state.cell), self.scene_text)

    def take_over(self, old: World) -> None:
        """Carry what ``old`` (the world of the scene before an edit) has into this one, by name:
        where each object still here is and how it moves, what each feeder placed, each sensor's
        and belt's state, the finger command and the cup's hold. The arm is where :meth:`reset` put
        it."""
        st, was = self.state, old.state
        for i, f in enumerate(self.scene.cell.feeders):
            for j, g in enumerate(old.scene.cell.feeders):
                if g.name == f.name:
                    st.cell.fed[i] = min(was.cell.fed[j], f.count)
                    st.cell.trigger[i] = was.cell.trigger[j]
        for i, sn in enumerate(self.scene.cell.sensors):
            for j, so in enumerate(old.scene.cell.sensors):
                if so.name == sn.name:
                    st.cell.beam[i], st.cell.level[i] = was.cell.beam[j], was.cell.level[j]
                    st.cell.since[i] = was.cell.since[j]
        for i, c in enumerate(self.scene.cell.conveyors):
            for j, b in enumerate(old.scene.cell.conveyors):
                if b.name == c.name:
                    st.cell.running[i] = was.cell.running[j]
        before = {old.objects[i][0]: i for i in old.listed()}
        now = {name: i for i, (name, *_) in enumerate(self.objects)}
        for name, i in before.items():
            if name in now:
                _, a, v, _ = self.objects[now[name]]
                _, oa, ov, _ = old.objects[i]
                self.d.qpos[a: a + 7] = old.d.qpos[oa: oa + 7]
                self.d.qvel[v: v + 6] = old.d.qvel[ov: ov + 6]
        self._freeze_parked()
        st.ramp = was.ramp
        if was.held >= 0 and old.objects[was.held][0] in now:
            st.held, st.relative = now[old.objects[was.held][0]], was.relative
        if self.fingers:
            self._fingers_to(was.ramp)
        mujoco.mj_forward(self.m, self.d)
        self._version += 1

    def reset(self, q: np.ndarray | None = None) -> None:
        """Objects back where the scene puts them, at rest; the arm at ``q`` (zero if None)."""
        mujoco.mj_resetData(self.m, self.d)
        self.d.qpos[:] = self._initial[0]
        if q is not None:
            self.d.qpos[self._q] = q[: self.robot.dof]
        mujoco.mj_forward(self.m, self.d)
        self._version += 1
        self.state = PhysicsState(b"", 0.0, 0, False, b"", cell=fresh_cell(self.scene))

    # -- stepping ------------------------------------------------------------------------------
    def set_force(self, per_pad: float) -> None:
        """The most each pad presses with (N): the finger drive's force limit (both pads' worth)."""
        if self.fingers:
            self.m.actuator_forcerange[0] = (-2.0 * per_pad, 2.0 * per_pad)

    def inputs(self, q: np.ndarray, ramp: float) -> bytes:
        out = np.asarray(q[: self.robot.dof], dtype=float).tobytes() + struct.pack("<d", ramp)
        return out + bytes(self.state.cell.running) if self._belts else out

    def idle(self, q: np.ndarray, ramp: float) -> bool:
        """Whether stepping a period with these inputs would change nothing."""
        return self.state.settled and self.inputs(q, ramp) == self.state.inputs

    def step(self, q: np.ndarray, dt: float, ramp: float) -> None:
        """One control period of ``dt`` s: the arm from its last joints to ``q`` (rad), the finger
        drives told to open to ``ramp`` mm."""
        s = self.state
        inputs = self.inputs(q, ramp)
        if s.settled and inputs == s.inputs:
            return
        m, d = self.m, self.d
        qa = np.asarray(q[: self.robot.dof], dtype=float)
        if s.settled and self._far(qa):
            # the arm and fingers move where nothing is near them: the world stays settled, the
            # free fingers are where their drive is told (they follow it within a period)
            self._fingers_to(ramp)
            s.inputs = inputs
            return
        qpos, qvel = d.qpos, d.qvel  # views into the engine's arrays, read once
        arm_q, arm_v = qpos[self._q], qvel[self._v]
        last = arm_q.copy()
        moving_arm = last.tolist() != qa.tolist()
        np.subtract(qa, last, out=arm_v)
        arm_v /= dt
        if self.fingers:
            d.ctrl[:] = ramp / 2.0 * MM
        for (bq, bv, speed), on in zip(self._belts, self.state.cell.running, strict=True):
            qpos[bq], qvel[bv] = 0.0, speed if on else 0.0
        mujoco.mj_step(m, d, nstep=max(1, round(dt / TIMESTEP)))
        self._version += 1
        arm_q[:] = qa
        arm_v[:] = 0.0
        for bq, _, _ in self._belts:  # the belt's surface moves; the belt stays where it is
            qpos[bq] = 0.0
        self._freeze_parked()
        if s.held >= 0:
            self._carry(qa)
        s.inputs = inputs
        s.settled = False
        # an arm moving where nothing is near it lets the objects settle all the same (asked only
        # when nothing of the arm touches an object: then the world cannot settle anyway)
        still = not self.touching_arm()
        far = still and (moving_arm or self.fingers) and self._far(qa)
        still = still and (far or not moving_arm)
        if still and (self._free_v.size or (self._finger_v and not far)):
            speeds = qvel.tolist()
            still = all(abs(speeds[v]) < STILL_SPEED for v in self._free_list)
            if still and self._finger_v and not far:
                still = all(abs(speeds[v]) < STILL_SPEED for v in self._finger_v)
        s.still = s.still + 1 if still else 0
        if s.still >= SETTLE_PERIODS:
            qvel[:] = 0.0
            d.qacc_warmstart[:] = 0.0
            s.settled = True

    def parked(self) -> list[int]:
        """The objects (indices) of feeders' parts not placed yet."""
        fed = self.state.cell.fed
        return [base + k for base, f, n in zip(self.feeder_base, self.scene.cell.feeders, fed, strict=True)
                for k in range(n, f.count)]

    def _freeze_parked(self) -> None:
        """Parts not placed yet stay where they wait, at rest."""
        if not self.feeder_base:
            return
        qpos, qvel, initial = self.d.qpos, self.d.qvel, self._initial[0]
        for i in self.parked():
            _, a, v, _ = self.objects[i]
            qpos[a: a + 7] = initial[a: a + 7]
            qvel[v: v + 6] = 0.0

    def _fingers_to(self, ramp: float) -> None:
        """Free fingers at the opening ``ramp`` (mm), at rest."""
        if self.fingers:
            half = min(max(ramp / 2.0, 0.0), self.hand.stroke / 2.0) * MM  # type: ignore[union-attr]
            qpos, qvel = self.d.qpos, self.d.qvel
            for a in self._fq:
                qpos[a] = half
            for v in self._finger_v:
                qvel[v] = 0.0

    # -- the vacuum cup ------------------------------------------------------------------------
    def cup_object(self, q: np.ndarray) -> int:
        """The object whose flat face the cup's face lies on (its index, -1: none): the cup's centre
        within :data:`SEAL_MM` of a face, inside its outline, the cup's axis within 10 degrees of the
        face's normal. Spheres have no flat face."""
        hand = self.hand
        if hand is None or hand.cup_radius <= 0:
            return -1
        T = self._flange(np.asarray(q[: self.robot.dof], dtype=float))
        p = T[:3, :3] @ np.array([0.0, 0.0, hand.tip]) + T[:3, 3]  # mm
        axis = T[:3, 2]
        R = np.empty(9)
        for i, (spec, (_, a, _, _)) in enumerate(zip(self.specs, self.objects, strict=True)):
            if spec.shape == "sphere":
                continue
            mujoco.mju_quat2Mat(R, self.d.qpos[a + 3: a + 7])
            Ro = R.reshape(3, 3)
            local = Ro.T @ (p - self.d.qpos[a: a + 3] / MM)
            if spec.shape == "box":
                half = np.asarray(spec.size) / 2.0
                faces = range(3)
            else:  # cylinder: its two round faces, along its own z
                half = np.array([spec.size[0] / 2.0, spec.size[0] / 2.0, spec.size[1] / 2.0])
                faces = range(2, 3)
            for k in faces:
                others = [j for j in range(3) if j != k]
                if spec.shape == "box":
                    inside = all(abs(local[j]) <= half[j] for j in others)
                else:
                    inside = math.hypot(local[0], local[1]) <= half[0]
                if (inside and abs(abs(local[k]) - half[k]) <= SEAL_MM
                        and abs(float(np.dot(Ro[:, k], axis))) > 0.985):
                    return i
        return -1

    def _flange(self, qa: np.ndarray) -> np.ndarray:
        return kin.fk(self.robot, qa)

    def hold(self, index: int, q: np.ndarray) -> None:
        """The cup holds object ``index`` where it is now relative to the flange."""
        _, a, _, _ = self.objects[index]
        T = self._flange(np.asarray(q[: self.robot.dof], dtype=float))
        R = np.empty(9)
        mujoco.mju_quat2Mat(R, self.d.qpos[a + 3: a + 7])
        P = np.eye(4)
        P[:3, :3] = R.reshape(3, 3)
        P[:3, 3] = self.d.qpos[a: a + 3] / MM
        rel = np.linalg.inv(T) @ P
        self.state.held = index
        self.state.relative = tuple(float(x) for x in (*rel[:3, 3], *rel[:3, :3].ravel()))

    def release(self) -> None:
        """The cup lets go: the object falls from where it is."""
        self.state.held = -1
        self.state.relative = ()
        self.state.settled = False

    def _carry(self, qa: np.ndarray) -> None:
        """Put the held object where the flange carries it, at rest in the engine."""
        _, a, v, _ = self.objects[self.state.held]
        r = self.state.relative
        rel = np.eye(4)
        rel[:3, 3] = r[:3]
        rel[:3, :3] = np.asarray(r[3:]).reshape(3, 3)
        P = self._flange(qa) @ rel
        self.d.qpos[a: a + 3] = P[:3, 3] * MM
        self.d.qpos[a + 3: a + 7] = quat_from_matrix(P[:3, :3])
        self.d.qvel[v: v + 6] = 0.0

    def arm_torques(self, gripping: bool = False) -> np.ndarray | None:
        """The joint torques (N m) of what objects press on the arm and the hand: ``J^T f`` of each
        touching contact, at its point, on the arm's joints; None when nothing presses. While the
        hand grips (``gripping``, its device says so) the pads' contacts with an object both pads
        touch are its own squeeze and are left out."""
        self._scan()
        rows = self._rows
        gripped = rows.both if gripping else ()
        pushing = [row for row in rows.push if row[3] not in gripped] if gripped else rows.push
        if not pushing:
            return None
        tau = np.zeros(self.robot.dof)
        m, d = self.m, self.d
        f6 = np.zeros(6)
        jacp = np.zeros((3, m.nv))
        frames = d.contact.frame
        points = d.contact.pos
        for k, arm_geom, first, _ in pushing:
            mujoco.mj_contactForce(m, d, k, f6)
            force = frames[k].reshape(3, 3).T @ f6[:3]  # on geom2, from geom1
            mujoco.mj_jac(m, d, jacp, None, points[k], int(m.geom_bodyid[arm_geom]))
            tau += jacp[:, self._v].T @ (-force if first else force)
        return tau

    def tcp_point(self, q: np.ndarray, offset: Sequence[float]) -> tuple[float, float, float]:
        """The point ``offset`` (mm, flange frame) of the arm at ``q`` (rad), in the base frame (mm),
        from the engine's kinematics of the nearness model (the same joint frames as ``model/``).
        The flange hangs on the arm's joints alone: the nearness model's arm already at ``q`` (the
        objects wherever they were) has it where it is."""
        if q[: self.robot.dof].tobytes() != self._near_key[1]:
            self._kinematics_at(q)
        d = self._near_d
        b = self._flange_body
        r = d.xmat[b].tolist()
        px, py, pz = d.xpos[b].tolist()
        x, y, z = px / MM, py / MM, pz / MM
        ox, oy, oz = float(offset[0]), float(offset[1]), float(offset[2])
        return (x + r[0] * ox + r[1] * oy + r[2] * oz, y + r[3] * ox + r[4] * oy + r[5] * oz,
                z + r[6] * ox + r[7] * oy + r[8] * oz)

    def _far(self, qa: np.ndarray) -> bool:
        """The arm put at ``qa``: whether no part of it is near an object (within ``mjcf.NEAR``),
        asked of the nearness model (once for the same joints and world)."""
        self._kinematics_at(qa)
        if self._far_key != self._near_key:
            mujoco.mj_collision(self._near_m, self._near_d)
            self._far_key, self._far_out = self._near_key, not self._near_d.ncon
        return self._far_out

    def _kinematics_at(self, q: np.ndarray) -> None:
        """The nearness model's bodies where the world's are, the arm at ``q`` (done once for the
        same joints and world)."""
        qpos = self.d.qpos
        qa = q[: self.robot.dof]
        key = (qpos.tobytes(), qa.tobytes())
        if key == self._near_key:
            return
        d = self._near_d
        near = d.qpos
        near[:] = qpos
        near[self._q] = qa
        mujoco.mj_kinematics(self._near_m, d)
        self._near_key = key

    # -- what the world shows ------------------------------------------------------------------
    def _scan(self) -> list[tuple[int, int, int]]:
        """The contacts that touch (not ones only near) the arm or hand, as (contact index, geom,
        geom), read from the engine once after each change; the pads on each object with them."""
        if self._scanned == self._version:
            return self._rows.rows
        self._scanned = self._version
        d = self.d
        n = d.ncon
        geoms = d.contact.geom[:n] if n else None
        pairs = geoms.tobytes() if geoms is not None else b""
        if pairs == self._rows.pairs:
            return self._rows.rows
        rows: list[tuple[int, int, int]] = []
        pads: dict[int, set[int]] = {}
        push: list[tuple[int, int, bool, int]] = []
        if geoms is not None:
            kind, objects = self._kinds, self._object_geoms
            # the world's geoms have no margins: every contact of the engine touches
            for k, (a, b) in enumerate(geoms.tolist()):
                ka, kb = kind[a], kind[b]
                if not (ka or kb):
                    continue
                rows.append((k, a, b))
                first = bool(ka)
                arm_geom, other = (a, b) if first else (b, a)
                push.append((k, arm_geom, first,
                             objects.get(other, -1) if kind[arm_geom] == 2 else -1))
                if ka == 2 and b in objects:
                    pads.setdefault(objects[b], set()).add(a)
                elif kb == 2 and a in objects:
                    pads.setdefault(objects[a], set()).add(b)
        self._rows = Contacts(pairs, rows, push, frozenset(i for i, p in pads.items() if len(p) == 2))
        self._pad_map = pads
        return rows

    def touching_arm(self) -> bool:
        """Whether any part of the arm or hand touches an object."""
        return bool(self._scan())

    def pad_contacts(self) -> dict[int, set[int]]:
        """For each object index, the finger pads that touch it."""
        self._scan()
        return {i: set(p) for i, p in self._pad_map.items()}

    def gripped(self) -> bool:
        """Whether both pads touch one object."""
        self._scan()
        return any(len(p) == 2 for p in self._pad_map.values())

    def opening(self) -> float:
        """The opening between the pads (mm)."""
        if not self._fq:
            return 0.0
        qpos = self.d.qpos
        return (float(qpos[self._fq[0]]) + float(qpos[self._fq[1]])) / MM

    def listed(self) -> list[int]:
        """The objects (indices) there are: the scene's and the parts its feeders have placed."""
        parked = set(self.parked())
        return [i for i in range(len(self.objects)) if i not in parked]

    def listed_specs(self) -> list[ObjectSpec]:
        """The declarations of the objects :meth:`listed` gives, in that order."""
        return [self.specs[i] for i in self.listed()]

    def poses(self) -> list[ObjectPose]:
        """Every object's pose (:meth:`listed`, in that order); held: both pads touch it, or the cup
        holds it."""
        self._scan()
        held = {i for i, pads in self._pad_map.items() if len(pads) == 2}
        if self.state.held >= 0:
            held.add(self.state.held)
        out = []
        for i in self.listed():
            name, a, _, _ = self.objects[i]
            qp = self.d.qpos
            R = np.empty(9)
            mujoco.mju_quat2Mat(R, qp[a + 3: a + 7])
            rpy = np.degrees(matrix_to_rpy(R.reshape(3, 3)))
            out.append(ObjectPose(name, (float(qp[a]) / MM, float(qp[a + 1]) / MM, float(qp[a + 2]) / MM),
                                  (float(rpy[0]), float(rpy[1]), float(rpy[2])), i in held))
        return out

    def place(self, name: str, position: tuple[float, float, float],
              rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        """Put object ``name`` at ``position`` (mm) turned by ``rpy`` (deg), at rest; ValueError for
        an unknown name or a value that is not finite."""
        parked = {self.objects[i][0] for i in self.parked()}
        found = [(a, v) for n, a, v, _ in self.objects if n == name and n not in parked]
        if not found:
            names = ", ".join(n for n, *_ in self.objects if n not in parked)
            raise ValueError(f"no object {name!r} in the scene (objects: {names})")
        a, v = found[0]
        vals = (*position, *rpy)
        if not all(math.isfinite(float(x)) for x in vals):
            raise ValueError("position and rpy must be finite")
        self._put(a, v, position, rpy)

    def feed(self, feeder: int, position: Vec3, rpy: Vec3) -> None:
        """Feeder ``feeder`` places its next part at ``position`` (mm) turned by ``rpy`` (deg), at rest."""
        k = self.state.cell.fed[feeder]
        _, a, v, _ = self.objects[self.feeder_base[feeder] + k]
        self.state.cell.fed[feeder] = k + 1
        self._put(a, v, position, rpy)

    def _put(self, a: int, v: int, position: Vec3, rpy: Vec3) -> None:
        d = self.d
        d.qpos[a: a + 3] = np.asarray(position, dtype=float) * MM
        d.qpos[a + 3: a + 7] = quat_from_matrix(rpy_to_matrix(*np.radians(rpy)))
        d.qvel[v: v + 6] = 0.0
        mujoco.mj_forward(self.m, d)
        self._version += 1
        self.state.settled = False
        self.state.still = 0


def _engine_objects(scene: Scene) -> tuple[list[ObjectSpec], list[int]]:
    """The scene's objects, then each feeder's parts parked until placed; per feeder, its first index."""
    specs: list[ObjectSpec] = list(scene.objects)
    feeder_base: list[int] = []
    for f in scene.cell.feeders:
        feeder_base.append(len(specs))
        for k in range(f.count):
            slot = len(specs) - len(scene.objects)
            park = (PARK[0] + PARK_STEP * slot, PARK[1], PARK[2])
            specs.append(ObjectSpec(f.part_name(k), f.part.shape, f.part.size, f.part.mass, park,
                                    f.part.rpy, f.part.friction, f.part.color))
    return specs, feeder_base
