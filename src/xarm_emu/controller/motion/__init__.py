"""Trajectory generation for the motion engine (manual 1.3, 2.1.3.2): jerk-limited
profiles, joint moves (ruckig), Cartesian paths (line, arc blend, circle) and
servo tracking. Pure math: no controller state, no kinematics."""

from .cartesian import CartesianMove, MoveChain, plan_blended
from .joint import JointTrajectory, plan_joint_move
from .paths import (
    ROT_MM_PER_RAD,
    BlendArc,
    CirclePath,
    CollinearError,
    CompositePath,
    LinePath,
    Path,
    blend_runs,
)
from .profile import JerkProfile, MovingProfile, PlanningError, SCurve
from .servo import ServoTracker

__all__ = [
    "ROT_MM_PER_RAD", "BlendArc", "CartesianMove", "CirclePath", "CollinearError", "CompositePath",
    "JerkProfile", "JointTrajectory",
    "MovingProfile", "LinePath", "MoveChain", "Path", "PlanningError", "SCurve",
    "ServoTracker", "blend_runs", "plan_blended", "plan_joint_move",
]
