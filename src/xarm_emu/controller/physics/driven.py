"""Grippers whose own model moves the fingers (the Robotiq 2F-85 and 2F-140, the BIO gripper): the
engine's finger pads follow the model's opening, and where both pads meet one object the model is
told the object's width, so it stops its fingers there and its status says "object" (Robotiq's gOBJ
2, the BIO's motion bits 2), as it does for an object played with ``set-input gripper-object``.

What a gripper's model answers of its fingers, in its own units, is the gripper's own
(``ToolDevice.driven_fingers``, a ``DrivenFingers`` of controller/devices/gripper.py): the opening
(mm), whether the fingers are closing, whether the model grips (stopped on an object), the force
each pad presses with (N), where the fingers met an object, and when the object is gone.
"""

from __future__ import annotations

from typing import Any

from ..devices.gripper import DrivenFingers
from .hands import Hand


def driven(device: Any, hand: Hand | None) -> DrivenFingers | None:
    """The fingers of ``device`` (the gripper on the tool bus, or None) when its own model moves them
    and ``hand`` has fingers in the engine."""
    if device is None or hand is None or hand.stroke <= 0:
        return None
    fingers: DrivenFingers | None = device.driven_fingers(hand.force)
    return fingers
