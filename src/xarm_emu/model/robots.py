"""Immutable descriptions of the xArm 5, 6 and 7 arms.

Joint frames are the vendor URDF joint origins, with lengths converted to mm and the +/-1.5708 roll
values replaced by exact +/-pi/2. Each joint turns about its local z axis after the fixed origin
transform ``Trans(xyz) . Rz(yaw) Ry(pitch) Rx(roll)``; the flange (default TCP) is the frame after the
last joint.

Joint limits are those the SDK checks for the xArm's joint limit tables, which are the radian forms of the
manual's tables (manual 1.3 Table 1.1, 4.2-4.4). The Cartesian range is the manual's (4.1).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

HALF_PI = math.pi / 2.0
TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class JointSpec:
    """One revolute joint: fixed origin in the parent frame (mm, rad), then rotation about local z."""

    name: str
    origin_xyz: tuple[float, float, float]
    origin_rpy: tuple[float, float, float]
    lower: float
    upper: float


@dataclass(frozen=True)
class RobotModel:
    """An xArm model. ``axis``/``robot_type`` are what the version string and register 8 report."""

    name: str
    dof: int
    axis: int
    robot_type: int
    joints: tuple[JointSpec, ...]
    max_joint_speed: float
    zero_pose: tuple[float, float, float, float, float, float]
    # Cartesian range (manual 4.1): ((x_min, x_max), (y_min, y_max), (z_min, z_max)) in mm,
    # then roll/pitch/yaw bounds in rad.
    tcp_range: tuple[tuple[float, float], ...] = field(
        default=((-700.0, 700.0), (-700.0, 700.0), (-400.0, 951.5),
                 (-math.pi, math.pi), (-math.pi, math.pi), (-math.pi, math.pi))
    )
    # xArm5 Cartesian targets must keep the flange level: roll = +/-pi, pitch = 0 (as the SDK requires).
    fixed_roll_pitch: bool = False
    max_joint_acc: float = 20.0  # rad/s^2, manual 1.3 Table 1.2 (1145 deg/s^2)
    max_joint_jerk: float = 500.0  # rad/s^3, manual 1.3 Table 1.2 (28647 deg/s^3)
    max_tcp_speed: float = 1000.0  # mm/s, manual 1.3 Table 1.2
    max_tcp_acc: float = 50000.0  # mm/s^2
    max_tcp_jerk: float = 10000.0  # mm/s^3
    # Rated payload in kg (manual 4.2-4.4: xArm5 3 kg, xArm6 5 kg, xArm7 3.5 kg). Register 36 refuses a
    # heavier payload or a centre of mass farther than ``payload_com_limit`` mm from the flange on any
    # axis; the manual gives no bound there, so this is the emulator's, wide enough for its 400 mm example.
    rated_payload: float = 5.0
    payload_com_limit: float = 1000.0

    @property
    def lower(self) -> np.ndarray:
        """Lower joint limits (rad), length ``dof``."""
        return np.array([j.lower for j in self.joints], dtype=float)

    @property
    def upper(self) -> np.ndarray:
        """Upper joint limits (rad), length ``dof``."""
        return np.array([j.upper for j in self.joints], dtype=float)

    @property
    def zero_joints(self) -> np.ndarray:
        """All-zero joint vector of length ``dof``."""
        return np.zeros(self.dof)


def joint_values(model: RobotModel, q: Sequence[float] | np.ndarray) -> list[float]:
    """The first ``dof`` values of ``q`` as floats (extra values, such as the wire J7 of a 6-axis arm, are
    ignored); ``ValueError`` when there are fewer than ``dof`` or one is not finite."""
    qs = q.tolist() if isinstance(q, np.ndarray) else [float(v) for v in q]
    if len(qs) < model.dof:
        raise ValueError(f"{model.name} needs {model.dof} joint values, got {len(qs)}")
    qs = qs[: model.dof]
    for v in qs:
        if not math.isfinite(v):
            raise ValueError(f"non-finite joint value {v!r}")
    return qs


def _j(name: str, xyz: tuple[float, float, float], roll: float, lo: float, hi: float) -> JointSpec:
    return JointSpec(name, (float(xyz[0]), float(xyz[1]), float(xyz[2])), (roll, 0.0, 0.0), lo, hi)


# Limits in rad (the SDK's values; manual 1.3: +/-360, -118..120, -225..11, -97..180, -11..225 degrees).
_FULL = (-TWO_PI, TWO_PI)
_SHOULDER = (-2.059488, 2.094395)
_ELBOW = (-3.92699, 0.191986)
_ELBOW7 = (-0.191986, 3.92699)
_WRIST = (-1.692969, math.pi)

XARM5 = RobotModel(
    name="xArm5",
    dof=5,
    axis=5,
    robot_type=5,
    joints=(
        _j("joint1", (0, 0, 267), 0.0, *_FULL),
        _j("joint2", (0, 0, 0), -HALF_PI, *_SHOULDER),
        _j("joint3", (53.5, -284.5, 0), 0.0, *_ELBOW),
        _j("joint4", (77.5, 342.5, 0), 0.0, *_WRIST),
        _j("joint5", (76, 97, 0), -HALF_PI, *_FULL),
    ),
    max_joint_speed=math.pi,
    zero_pose=(207.0, 0.0, 112.0, math.pi, 0.0, 0.0),
    fixed_roll_pitch=True,
    rated_payload=3.0,
)

XARM6 = RobotModel(
    name="xArm6",
    dof=6,
    axis=6,
    robot_type=6,
    joints=(
        _j("joint1", (0, 0, 267), 0.0, *_FULL),
        _j("joint2", (0, 0, 0), -HALF_PI, *_SHOULDER),
        _j("joint3", (53.5, -284.5, 0), 0.0, *_ELBOW),
        _j("joint4", (77.5, 342.5, 0), -HALF_PI, *_FULL),
        _j("joint5", (0, 0, 0), HALF_PI, *_WRIST),
        _j("joint6", (76, 97, 0), -HALF_PI, *_FULL),
    ),
    max_joint_speed=math.pi,
    zero_pose=(207.0, 0.0, 112.0, math.pi, 0.0, 0.0),
)

XARM7 = RobotModel(
    name="xArm7",
    dof=7,
    axis=7,
    robot_type=7,
    joints=(
        _j("joint1", (0, 0, 267), 0.0, *_FULL),
        _j("joint2", (0, 0, 0), -HALF_PI, *_SHOULDER),
        _j("joint3", (0, -293, 0), HALF_PI, *_FULL),
        _j("joint4", (52.5, 0, 0), HALF_PI, *_ELBOW7),
        _j("joint5", (77.5, -342.5, 0), HALF_PI, *_FULL),
        _j("joint6", (0, 0, 0), HALF_PI, *_WRIST),
        _j("joint7", (76, 97, 0), -HALF_PI, *_FULL),
    ),
    max_joint_speed=math.pi,
    zero_pose=(206.0, 0.0, 120.5, math.pi, 0.0, 0.0),
    rated_payload=3.5,
)

MODELS: dict[int, RobotModel] = {5: XARM5, 6: XARM6, 7: XARM7}


def get_model(dof: int) -> RobotModel:
    """Model for 5, 6 or 7 axes; ``ValueError`` otherwise."""
    try:
        return MODELS[int(dof)]
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"no xArm model with {dof!r} axes (expected 5, 6 or 7)") from None
