"""Motion information and kinematics registers (manual 2.1.3, registers 8, 41-45, 55, 76, 91)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..model import kinematics as kin
from ..model import rotations as rot
from .base import (
    WARN_NO_SOLUTION,
    CommandWarning,
    Handler,
    Values,
)
from .core import (
    ControllerCore,
)
from .poses import wire_pose_to_matrix


class KinematicsCommands(ControllerCore):
    """Registers 8, 41-45, 55, 76 and 91."""

    def register_handlers(self) -> dict[int, Handler]:
        h = super().register_handlers()
        h.update({
            8: self._h_kinematics_params,
            41: lambda v: {"pose": tuple(self.tcp_pose())},
            42: self._h_joint_states,
            43: self._h_ik,
            44: self._h_fk,
            45: self._h_joint_limit,
            55: lambda v: {"torques": self.joint_torques7()},
            76: self._h_pose_offset,
            91: self._h_pose_aa,
        })
        return h

    def _h_kinematics_params(self, v: Values) -> dict[str, Any]:
        params: list[float] = []
        for j in self.model.joints:
            params += [j.origin_xyz[0] / 1000.0, j.origin_xyz[1] / 1000.0, j.origin_xyz[2] / 1000.0,
                       *j.origin_rpy]
        params += [0.0] * (42 - len(params))
        return {"valid": 1, "dof": self.dof, "robot_type": self.model.robot_type, "params": tuple(params)}


    def _h_joint_states(self, v: Values) -> dict[str, Any]:
        """Register 42: joint positions; SDKs asking ``num`` blocks also get velocities and efforts."""
        out: dict[str, Any] = {"joints": self.joints7()}
        blocks = int(v.get("num", 1)) & 0x0F
        if blocks >= 2:
            out["velocities"] = self.joints7(self.qd)
        if blocks >= 3:
            out["efforts"] = self.joint_torques7()
        return out

    # kinematics registers
    def _h_ik(self, v: Values) -> dict[str, Any]:
        T = wire_pose_to_matrix(v["pose"])
        q = kin.ik(self.model, self.flange_target(T), self.q, restarts=True)
        if q is None:
            raise CommandWarning(WARN_NO_SOLUTION)
        return {"joints": self.joints7(q)}

    def _h_fk(self, v: Values) -> dict[str, Any]:
        q = np.asarray(v["joints"][: self.dof], dtype=float)
        return {"pose": tuple(rot.matrix_to_pose(self.tcp_matrix(q)))}

    def _h_joint_limit(self, v: Values) -> dict[str, Any]:
        q = np.asarray(v["joints"][: self.dof], dtype=float)
        ok = bool(np.all(np.isfinite(q))) and kin.within_limits(self.model, q)
        return {"limited": 0 if ok else 1}

    def _h_pose_offset(self, v: Values) -> dict[str, Any]:
        aa_in = int(v["input_aa"]) == 1
        aa_out = int(v["output_aa"]) == 1
        to_m = rot.pose_aa_to_matrix if aa_in else wire_pose_to_matrix
        T1 = to_m(np.asarray(v["pose1"], dtype=float))
        T2 = to_m(np.asarray(v["pose2"], dtype=float))
        D = kin.pose_offset(T1, T2)
        out = rot.matrix_to_pose_aa(D) if aa_out else rot.matrix_to_pose(D)
        return {"pose": tuple(out)}

    def _h_pose_aa(self, v: Values) -> dict[str, Any]:
        return {"pose": tuple(rot.matrix_to_pose_aa(self.tcp_matrix()))}

