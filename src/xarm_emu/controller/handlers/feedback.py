"""Registers 253 and 254: feedback (``FirmwareProfile.feedback``; the manual V1.6.0 lacks them).

- 254 SET_FEEDBACK_TYPE ``[mask]``: the feedback types the requesting connection wants
  (1 motion start, 2 motion finish, 4 trigger, 32 other start, 64 other finish). It applies to tasks
  queued afterwards, on that connection only. Empty reply.
- 253 FEEDBACK_CHECK: empty reply at once; a MOTION_FINISH frame carrying 253's transaction id
  follows once every task queued before it has finished.

The frames themselves come from :class:`~xarm_emu.controller.core.feedback.FeedbackQueue`.
"""

from __future__ import annotations

from ..core.controller_protocol import Controller
from ..core.feedback import feedback_queue
from ..core.interface import Binding, Values


def set_feedback_type(ctl: Controller, v: Values) -> None:
    """Register 254: the connection's feedback mask (a request from outside a connection keeps no mask)."""
    feedback_queue(ctl).set_mask(int(v["mask"]))
    return None


def feedback_check(ctl: Controller, v: Values) -> None:
    """Register 253: answered now; the MOTION_FINISH frame marks the end of every earlier task."""
    feedback_queue(ctl).check(ctl)
    return None


#: The registers of this module, bound (:class:`~xarm_emu.controller.core.interface.Binding`).
BINDINGS: tuple[Binding, ...] = (
    Binding(253, feedback_check),
    Binding(254, set_feedback_type),
)
