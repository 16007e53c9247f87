"""A recorded session for the fidelity tests: the "real arm" is an emulator (with a calibration when
given), the recording proxy sits in front of it and the unchanged SDK drives it through the proxy."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from xarm_emu.model.calibration import Calibration
from xarm_emu.protocol.firmware import SERVE_VERSION
from xarm_emu.server.thread import ServerThread
from xarm_emu.testing import reading_reports, running_emulator, running_proxy, sdk_pointed_at


@contextlib.contextmanager
def sdk_through_proxy(path: Path, calibration: Calibration | None = None,
                      reports: tuple[str, ...] = ("realtime",), model: int | str = 6,
                      firmware: str = SERVE_VERSION, check_joint_limit: bool = True,
                      **emulator: Any) -> Iterator[tuple[ServerThread, Any]]:
    """``(server, arm)``: an emulator of ``model`` at ``firmware`` recorded to ``path`` through the
    proxy, the report ports of ``reports`` that the firmware serves read through it too (``compare``
    wants the real-time report, which the SDK does not open), and an SDK ``XArmAPI`` connected through
    it, enabled, in mode 0 and state 0, disconnected at the end; ``check_joint_limit=False`` lets the
    SDK send joints beyond the arm's limits (the box refuses them)."""
    from xarm.wrapper import XArmAPI

    with running_emulator(model, firmware=firmware, calibration=calibration, **emulator) as st, \
            running_proxy(st, path) as px, sdk_pointed_at(px), \
            reading_reports(px, tuple(k for k in reports if k in px.ports)) if reports \
            else contextlib.nullcontext():  # type: ignore[arg-type]
        time.sleep(0.05)
        arm = XArmAPI("127.0.0.1", is_radian=False, check_joint_limit=check_joint_limit)
        try:
            arm.motion_enable(True)
            arm.set_mode(0)
            arm.set_state(0)
            yield st, arm
        finally:
            arm.disconnect()
            time.sleep(0.05)
