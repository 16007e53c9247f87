"""Grippers whose own model moves the fingers (the Robotiq 2F-85 and 2F-140, the BIO gripper): the
engine's finger pads follow the model's opening, and where both pads meet one object the model is
told the object's width, so it stops its fingers there and its status says "object" (Robotiq's gOBJ
2, the BIO's motion bits 2), as it does for an object played with ``set-input gripper-object``.

Each adapter answers, in the model's own units: the opening (mm), whether the fingers are closing,
whether the model grips (stopped on an object), the force each pad presses with (N, from the
model's force register), where the fingers met an object, and when the object is gone.
"""

from __future__ import annotations

from typing import Any, Protocol

from ..devices import bio_gripper as bio
from ..devices.bio_gripper import BioGripper
from ..devices.bio_gripper_g1 import BioGripperG1
from ..devices.robotiq import OBJ_MOVING, RobotiqGripper
from .hands import Hand


class DrivenFingers(Protocol):
    """What the physics component asks of a gripper whose model moves its fingers."""

    @property
    def opening(self) -> float: ...
    @property
    def closing(self) -> bool: ...
    @property
    def gripping(self) -> bool: ...
    @property
    def force(self) -> float: ...
    @property
    def met(self) -> bool: ...
    def meet(self, width: float) -> None: ...
    def part(self, touching: bool) -> None: ...


class RobotiqFingers:
    """The Robotiq 2F-85 and 2F-140 (controller/devices/robotiq.py): force from rFR over the
    model's range; positions count up as the fingers close."""

    def __init__(self, r: RobotiqGripper) -> None:
        self.r = r

    @property
    def opening(self) -> float:
        return self.r.opening_mm

    @property
    def closing(self) -> bool:
        return self.r.moving and self.r.goal > self.r.position

    @property
    def gripping(self) -> bool:
        return self.r.gripping

    @property
    def force(self) -> float:
        m = self.r.model
        return m.force_min + (m.force_max - m.force_min) * self.r.rFR / 255.0

    @property
    def met(self) -> bool:
        return self.r.object_mm is not None

    def meet(self, width: float) -> None:
        r = self.r
        width = min(width, r.model.stroke_mm)
        r.set_object(width)
        r.position = min(r.position, r._counts_at(width))  # the fingers stopped where they met it

    def part(self, touching: bool) -> None:
        r = self.r
        if r.object_mm is not None and not touching and not r.gripping and r.gOBJ == OBJ_MOVING:
            r.object_mm = None  # opening away from it: nothing between the fingers any more


class BioFingers:
    """The BIO gripper (controller/devices/bio_gripper.py): its fingers open 71..150 mm, positions
    count up as they open; its force register (1..100) scales the hand's force. The G1
    (bio_gripper_g1.py) the same over its 50..130 positions, one a millimetre (``hands.BIO_G1_HAND``),
    always at the hand's force (it has no force setting)."""

    def __init__(self, b: BioGripper, hand: Hand) -> None:
        self.b = b
        self.most = hand.force
        self.g1 = isinstance(b, BioGripperG1)

    @property
    def opening(self) -> float:
        return self.b.opening_mm

    @property
    def closing(self) -> bool:
        return self.b.moving and self.b.goal < self.b.position

    @property
    def gripping(self) -> bool:
        return self.b.detected and not self.b.code

    @property
    def force(self) -> float:
        return self.most if self.g1 else self.most * self.b.force / bio.FORCE_MAX

    @property
    def met(self) -> bool:
        return self.b.object_mm is not None

    def meet(self, width: float) -> None:
        b = self.b
        lo, hi, _ = b.object_range
        width = min(max(width, lo), hi)
        b.set_object(width)
        b.position = max(b.position, b._object_position(width))  # the fingers stopped where they met it

    def part(self, touching: bool) -> None:
        b = self.b
        if b.object_mm is not None and not touching and not b.detected and not self.closing:
            b.object_mm = None  # opening away from it: nothing between the fingers any more


def driven(device: Any, hand: Hand | None) -> DrivenFingers | None:
    """The adapter of ``device`` when it is a gripper whose model moves its fingers and ``hand`` has
    fingers in the engine."""
    if hand is None or hand.stroke <= 0:
        return None
    if isinstance(device, RobotiqGripper):
        return RobotiqFingers(device)
    if isinstance(device, BioGripper):
        return BioFingers(device, hand)
    return None
