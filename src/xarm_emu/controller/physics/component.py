"""The physics world as a controller component: stepped once a control period after the gripper
(so it sees this period's joints and finger command), it tells the gripper where its fingers stopped.

The finger drive: the gripper's own model (controller/devices/gripper.py) says where the fingers are told to
go and how fast; here that command (:attr:`PhysicsState.ramp`, mm of opening) runs toward the target
at the gripper's speed and the engine's force-limited finger drives follow it. Where a pad meets an
object the fingers stop and the drive presses with the hand's force; the gripper's reported position
is then the fingers' own (:attr:`TwinFingers.position`), and its status says the fingers stopped on an
object (motion bits 2, what the SDK's wait for a grip reads as done). Free fingers report the command
itself, so a gripper that closes on nothing moves exactly as without the engine. The command presses
(runs past the fingers) only while both pads hold one object; once the object slips out, the fingers
close on at the gripper's speed (:data:`FREE_LEAD_PERIODS`).

Collision detection (C31, manual 3.2.1, at the sensitivity of register 37): the force of the scene's
planes and boxes on the TCP (their spring-damper, :func:`..scene.contact.scene_wrench`) and the engine's
contact forces of objects on the arm and hand (:meth:`.world.World.arm_torques`) enter the joint
torques as ``J^T f``; the largest external joint torque is checked against the sensitivity's
threshold every period (:func:`..core.safety.collision_detected`), so pushing the tool into the table
raises C31 as a real push would; sensitivity 0 never does.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from ...model import kinematics as kin
from ...model.robots import VACUUM_WIRING
from ..core import safety
from ..core.controller_protocol import Controller
from ..core.interface import C_COLLISION, NOT_IDLE
from ..devices.gripper import SPEED_TO_PULSES, SPEED_TOP, TwinFingers
from ..scene import contact
from .cell import CellRunner
from .driven import driven
from .hands import XARM_MM_PER_PULSE
from .mjcf import FINGER_KP
from .world import PhysicsState, World

#: A command this far (mm) from where the free fingers are is where they are (the drive's lag).
FOLLOW_MM = 0.05
#: How many periods of the gripper's speed the command may run ahead of fingers that hold nothing
#: (more than the drive's lag behind a command moving at that speed, about 1.7 periods).
FREE_LEAD_PERIODS = 3


def _inside(shape: contact.Plane | contact.Box, p: tuple[float, float, float]) -> bool:
    """Whether the point ``p`` (mm) is inside the fixture ``shape`` (plain floats: asked every period;
    the fixture's own penetration says the same)."""
    x, y, z = p
    if isinstance(shape, contact.Plane):
        (px, py, pz), (nx, ny, nz) = shape.point, shape.normal
        return (px - x) * nx + (py - y) * ny + (pz - z) * nz > 0.0
    lo, hi = shape.min, shape.max
    return lo[0] < x < hi[0] and lo[1] < y < hi[1] and lo[2] < z < hi[2]


class PhysicsComponent:
    """Steps :attr:`world` every control period and couples the xArm gripper's fingers to it."""

    def __init__(self, world: World, device: Any, vacuum: Any = None, lite6: Any = None) -> None:
        self.world = world
        #: The Lite 6 gripper's pneumatic jaws (controller/devices/lite6_gripper.py), when they are the
        #: hand: the finger drive follows their opening and presses with the hand's force.
        self.lite6 = lite6
        #: The vacuum gripper (controller/devices/vacuum.py), when it is the hand.
        self.vacuum = vacuum
        #: The gripper whose fingers the twin moves itself (the xArm gripper), when it is the hand.
        self.device: TwinFingers | None = device.twin_fingers() if device is not None else None
        if self.device is not None:
            self.world.state.ramp = self.device.position * XARM_MM_PER_PULSE
        hand = world.hand
        #: A gripper on the tool bus whose own model moves its fingers (Robotiq, BIO), when it is
        #: the hand (:mod:`.driven`).
        self.driven = driven(device, hand)
        #: How far (mm) the command runs ahead of fingers stopped on an object: the drive's full force.
        #: (The drive holds finger a, half the opening, and presses with the force of both pads.)
        self.squeeze = (2 * (2 * hand.force / FINGER_KP) / 0.001 + 1.0) if hand is not None else 0.0
        #: The scene's conveyors, sensors and feeders on the box's IO (:meth:`attach_io`), if any.
        self.cell: CellRunner | None = None
        self._io: Any = None

    def attach_io(self, io: Any) -> None:
        """Tie the scene's cell elements to ``io``, the box's IO module (ValueError for an input or
        output the box does not have)."""
        self._io = io
        self.cell = CellRunner(self.world, io) if self.world.scene.cell else None

    def rebuild(self, scene: contact.Scene, q: np.ndarray) -> None:
        """The world of ``scene`` (objects or cell elements added, removed or changed) in place of
        this one, the arm at ``q``: every object, feeder, sensor and belt still in it goes on as it
        was (:meth:`.world.World.take_over`); ValueError for a cell on IO the box lacks."""
        old = self.world
        new = World(old.robot, scene, old.hand)
        new.reset(q)
        new.take_over(old)
        cell = CellRunner(new, self._io) if scene.cell else None
        self.world, self.cell = new, cell

    def restore(self, state: PhysicsState) -> None:
        """Put ``state`` back, in a world of the scene it was captured in."""
        if state.scene and state.scene != self.world.scene_text:
            scene = contact.parse_scene(json.loads(state.scene))
            self.world = World(self.world.robot, scene, self.world.hand)
            self.cell = CellRunner(self.world, self._io) if self.world.scene.cell else None
        self.world.restore(state)

    def _driven_ramp(self) -> float:
        """A driven gripper's command: its own fingers' opening (its model moves them and stops them
        at the object the engine found), pressing past it while it grips; its force setting limits
        the drive."""
        f = self.driven
        assert f is not None
        force = f.force
        self.world.set_force(force)
        if f.gripping and self.world.gripped():  # pressing only while both pads hold the object
            return f.opening - 2 * (2 * force / FINGER_KP) / 0.001 - 1.0
        return f.opening

    def _driven_contact(self) -> None:
        """Tell a driven gripper where both pads met one object (its status then says so), and that
        it is gone when the fingers open."""
        f = self.driven
        assert f is not None
        w = self.world
        touching = w.gripped()
        if touching and f.closing and not f.met:
            f.meet(w.opening())
        else:
            f.part(touching)

    def _vacuum(self, ctl: Controller) -> None:
        """The cup seals on a flat face under it (the pressure input then rises as the pump runs) and
        holds that object while the pump runs; the pump stopped, it lets go."""
        v, w = self.vacuum, self.world
        pumping = any(v.pumping_on(k) for k in VACUUM_WIRING)
        sealed = w.cup_object(ctl.data.q)
        if w.state.held >= 0 and not pumping:
            w.release()
        elif w.state.held < 0 and pumping and sealed >= 0 and any(v.pressure_on(k) for k in VACUUM_WIRING):
            w.hold(sealed, ctl.data.q)
        v.object_present = w.state.held >= 0 or sealed >= 0

    def _ramp(self, dt: float) -> float:
        """This period's finger command (mm of opening)."""
        if self.driven is not None:
            return self._driven_ramp()
        if self.lite6 is not None and self.world.hand is not None:
            return float(self.lite6.opening) * self.world.hand.stroke
        ramp = self.world.state.ramp
        g = self.device
        if g is None or not self.world.fingers:
            return ramp
        if not (g.enabled and not g.error and g.mode == 0):
            return ramp
        target = g.target * XARM_MM_PER_PULSE
        measured = self.world.opening()
        step = min(g.speed, SPEED_TOP) * SPEED_TO_PULSES * XARM_MM_PER_PULSE * dt
        if target > ramp:  # opening: the command never lags behind the fingers
            ramp = max(ramp, measured)
        elif target < ramp:  # closing on something: press, no further
            # Pressing (the command a squeeze past the fingers) only while both pads hold one object;
            # an object that slips out leaves the fingers closing on at the gripper's speed, not
            # springing the squeeze's length in one step into the object's edge.
            lead = self.squeeze if self.world.gripped() else FREE_LEAD_PERIODS * step
            ramp = max(ramp, measured - lead)
        if abs(target - ramp) <= step:
            return target
        return ramp + math.copysign(step, target - ramp)

    def external_torques(self, ctl: Controller) -> np.ndarray | None:
        """The joint torques (N m) of the scene's fixtures pressing on the TCP: ``J^T f``; None when
        the TCP touches none of them."""
        q = ctl.data.q
        shapes = contact.scene_of(ctl).shapes
        if not shapes:
            return None
        p = self.world.tcp_point(q, ctl.settings.tcp_offset)
        for s in shapes:
            if _inside(s, p):
                break
        else:
            return None
        T = kin.fk(ctl.model, q)
        off = T[:3, :3] @ np.asarray(ctl.settings.tcp_offset[:3], dtype=float)
        f = contact.scene_wrench(ctl)[:3]
        r = off * 0.001  # m
        J = kin.jacobian(ctl.model, q)  # flange: linear (mm/rad) over angular rows
        return np.asarray(J[:3].T @ f * 0.001 + J[3:].T @ np.cross(r, f))

    def _collision(self, ctl: Controller) -> None:
        sens = ctl.settings.collision_sensitivity
        if not sens or ctl.error_code or not all(ctl.enabled):
            return
        gripping = bool(self.device is not None and self.device.gripped) or bool(
            self.driven is not None and self.driven.gripping) or bool(
            self.lite6 is not None and self.lite6.command == "close")
        tau = self.external_torques(ctl)
        if self.world.touching_arm():
            arm = self.world.arm_torques(gripping)
            if arm is not None:
                tau = arm if tau is None else tau + arm
        if tau is not None and tau.any() and safety.collision_detected(
                sens, float(np.max(np.abs(tau))), safety.collision_thresholds(ctl.model)):
            ctl.raise_error(C_COLLISION)

    def step(self, dt: float, ctl: Controller) -> None:
        self._collision(ctl)
        w = self.world
        ramp = self._ramp(dt)
        w.state.ramp = ramp
        if self.cell is not None:
            self.cell.before(ctl)
        w.step(ctl.data.q, dt, ramp)
        if self.cell is not None:
            self.cell.after(ctl)
        if self.driven is not None:
            self._driven_contact()
        if self.vacuum is not None:
            self._vacuum(ctl)
        g = self.device
        if g is None or not w.fingers:
            return
        measured = w.opening()
        gripping = w.gripped()  # both pads on one object
        # the grip is made when the drive presses with the hand's full force (or its target is reached)
        full = ramp <= measured - (self.squeeze - 1.0) or ramp == g.target * XARM_MM_PER_PULSE
        pressing = gripping and full and g.target * XARM_MM_PER_PULSE < measured - FOLLOW_MM
        g.gripped = pressing and not g.error and g.enabled
        if abs(measured - ramp) <= FOLLOW_MM or not (pressing or g.moving):
            g.position = ramp / XARM_MM_PER_PULSE
        else:
            g.position = measured / XARM_MM_PER_PULSE

    def idle_until(self, ctl: Controller) -> float:
        """Idle while the world is settled and neither the arm nor the finger command would move,
        and the cell elements change nothing (up to a feeder's next part)."""
        if not self.world.state.settled:
            return NOT_IDLE
        until = math.inf if self.cell is None else self.cell.idle_until(ctl)
        if until == NOT_IDLE:
            return NOT_IDLE
        return until if self.world.idle(ctl.data.q, self._ramp(ctl.period)) else NOT_IDLE
