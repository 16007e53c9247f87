"""What the firmware 2.x report frames carry beyond the manual's (rich bytes 284-287 and 433-586,
the real-time report of port 30000), read from the controller into the one report snapshot
(``Emulator.snapshot``) that every report encoder of ``protocol/reports.py`` takes."""

from __future__ import annotations

import math

from ..model import rotations as rot
from ..protocol.reports import ReportSnapshot
from .applications.reduced import reduced_of
from .core.controller_protocol import Controller
from .handlers.service import extra_state


def firmware2_fields(ctl: Controller, snap: ReportSnapshot) -> ReportSnapshot:
    """Fill ``snap``'s 2.x fields from controller ``ctl``; returns ``snap``.

    Bytes 284-287 carry the counter of registers 74/75 (``user_counter``), which both SDKs read there.
    The reduced-mode block and the motion flags are the values registers 53, 66 and 80 answer.
    """
    s = ctl.settings
    snap.counter = int(ctl.user_counter) & 0xFFFFFFFF
    roll, pitch, yaw = snap.pose[3:6]
    if all(math.isfinite(x) for x in (roll, pitch, yaw)):
        snap.pose_aa = tuple(float(x) for x in rot.rpy_to_axis_angle(roll, pitch, yaw))
    snap.report_current = bool(s.report_current)
    extra = extra_state(ctl)
    snap.approx_motion = bool(extra.approx_motion)
    snap.cart_continuous = bool(extra.cartesian_velocity_continuous)
    reduced = reduced_of(ctl)  # registers 47-50, 58 and 60, as register 53 reports them
    snap.reduced_mode = bool(reduced.on)
    snap.reduced_tcp_boundary = tuple(int(x) for x in s.boundary)
    snap.fence = bool(s.boundary_on)
    snap.reduced_max_tcp_speed = float(reduced.tcp_speed)
    snap.reduced_max_joint_speed = float(reduced.joint_speed)
    if reduced.joint_ranges:
        snap.reduced_joint_ranges = tuple(float(x) for x in reduced.joint_ranges)
    snap.collision_rebound = bool(reduced.rebound)
    snap.timestamp_us = int(round(ctl.time * 1e6))
    snap.joint_accelerations = tuple(float(x) for x in ctl.qdd) + (0.0,) * (7 - ctl.dof)
    return snap
