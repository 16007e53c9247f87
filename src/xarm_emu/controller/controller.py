"""The emulated control box: :class:`Controller` combines the core with the register groups.

See :mod:`.core` for the state machine, dispatch and control step; the ``cmd_*`` modules hold the
register handlers of manual section 2.1.3, grouped as the manual groups them.
"""

from __future__ import annotations

from typing import Any

from .base import Handler, Values
from .cmd_kinematics import KinematicsCommands
from .cmd_motion import MotionCommands
from .cmd_settings import SettingCommands
from .cmd_state import StateCommands
from .core import (  # noqa: F401 - re-exported names of the controller's vocabulary
    BUFFER_CAPACITY,
    FIRMWARE_VERSION,
    MODE_CARTESIAN_TEACH,
    MODE_JOINT_TEACH,
    MODE_POSITION,
    MODE_SERVO,
    STATE_MOVING,
    STATE_SLEEP,
    STATE_STOP,
    STATE_SUSPEND,
    STATE_SYSTEM_RESET,
)


class Controller(StateCommands, MotionCommands, SettingCommands, KinematicsCommands):
    """One emulated control box with its arm."""

    def register_handlers(self) -> dict[int, Handler]:
        h = super().register_handlers()
        h[24] = self._h_register_24
        return h

    def _h_register_24(self, v: Values) -> dict[str, Any] | None:
        # Manual: register 24 selects torque or current in reports (1 byte). The SDK, for
        # firmware >= 1.5.20, sends a joint move with a blend radius on 24 (10 fp32).
        if "joints" in v:
            v2 = dict(v)
            return self._h_move_joint(v2)
        return self._h_report_tau_or_i(v)

