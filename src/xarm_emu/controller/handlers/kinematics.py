"""Motion information and kinematics registers (manual section 2.1.3, registers 8, 41-45, 55, 76, 91)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...model import kinematics as kin
from ...model import rotations as rot
from ..core.controller_protocol import Controller
from ..core.interface import WARN_NO_SOLUTION, Binding, CommandWarning, Values
from ..core.poses import wire_pose_to_matrix


def kinematics_params(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 8: the joint frames (origin xyz in m, rpy in rad) of the model."""
    params: list[float] = []
    for j in ctl.model.joints:
        params += [j.origin_xyz[0] / 1000.0, j.origin_xyz[1] / 1000.0, j.origin_xyz[2] / 1000.0,
                   *j.origin_rpy]
    params += [0.0] * (42 - len(params))
    return {"valid": 1, "dof": ctl.dof, "robot_type": ctl.model.robot_type, "params": tuple(params)}


def joint_states(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 42: joint positions; SDKs asking ``num`` blocks also get velocities and efforts
    (84 bytes for three blocks)."""
    out: dict[str, Any] = {"joints": ctl.joints7()}
    blocks = int(v.get("num", 1)) & 0x0F
    if blocks >= 2:
        out["velocities"] = ctl.joints7(ctl.qd)
    if blocks >= 3:
        out["efforts"] = ctl.joint_torques7()
    return out


def ik(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 43: inverse kinematics of a TCP pose, seeded with the current joints."""
    T = wire_pose_to_matrix(v["pose"])
    q = kin.ik(ctl.model, ctl.flange_target(T), ctl.q, restarts=True)
    if q is None:
        raise CommandWarning(WARN_NO_SOLUTION)
    return {"joints": ctl.joints7(q)}


def fk(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 44: forward kinematics of joint values."""
    q = np.asarray(v["joints"][: ctl.dof], dtype=float)
    return {"pose": tuple(rot.matrix_to_pose(ctl.tcp_matrix(q)))}


def joint_limit(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 45: 1 when joint values are outside the limits (or not finite)."""
    q = np.asarray(v["joints"][: ctl.dof], dtype=float)
    ok = bool(np.all(np.isfinite(q))) and kin.within_limits(ctl.model, q)
    return {"limited": 0 if ok else 1}


def pose_offset(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 76: the offset between two poses, RPY or axis-angle in and out."""
    to_m = rot.pose_aa_to_matrix if int(v["input_aa"]) == 1 else wire_pose_to_matrix
    T1 = to_m(np.asarray(v["pose1"], dtype=float))
    T2 = to_m(np.asarray(v["pose2"], dtype=float))
    D = kin.pose_offset(T1, T2)
    out = rot.matrix_to_pose_aa(D) if int(v["output_aa"]) == 1 else rot.matrix_to_pose(D)
    return {"pose": tuple(out)}


def tcp_pose(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 41: the TCP pose (user frame, TCP offset applied)."""
    return {"pose": tuple(ctl.tcp_pose())}


def joint_torques(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 55: the theoretical joint torques."""
    return {"torques": ctl.joint_torques7()}


def tcp_pose_aa(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 91: the TCP pose with its orientation as an axis-angle vector."""
    return {"pose": tuple(rot.matrix_to_pose_aa(ctl.tcp_matrix()))}


#: The registers of this module, bound (:class:`~xarm_emu.controller.core.interface.Binding`).
BINDINGS: tuple[Binding, ...] = (
    Binding(8, kinematics_params),
    Binding(41, tcp_pose),
    Binding(42, joint_states),
    Binding(43, ik),
    Binding(44, fk),
    Binding(45, joint_limit),
    Binding(55, joint_torques),
    Binding(76, pose_offset),
    Binding(91, tcp_pose_aa),
)
