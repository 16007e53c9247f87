"""Safety benchmark: one self-collision check (xArm7, xArm Gripper and cuboid tool) and one per-step check,
beside a plain-numpy reference (4x4 frame chain, vectorised segment distances) timed in the same run.

Target: one self-collision check <= 100 us on xArm7. Run: ``python -m bench.bench_safety``.
"""

from __future__ import annotations

import time

import numpy as np

from xarm_emu.controller.core.safety import check_path_step
from xarm_emu.model.collision import Capsule, collision_pairs, link_shapes, self_collision, tool_model
from xarm_emu.model.kinematics import joint_frames
from xarm_emu.model.robots import XARM6, XARM7, RobotModel

N = 2000


def _numpy_seg_dist(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray) -> float:
    """Clamped closest points with numpy vectors (the same maths, no scalar unrolling)."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, e, f = d1 @ d1, d2 @ d2, d2 @ r
    c, b = d1 @ r, d1 @ d2
    denom = a * e - b * b
    s = np.clip((b * f - c * e) / denom, 0.0, 1.0) if denom > 1e-12 else 0.0
    t = (b * s + f) / e
    if t < 0.0:
        t, s = 0.0, np.clip(-c / a, 0.0, 1.0)
    elif t > 1.0:
        t, s = 1.0, np.clip((b - c) / a, 0.0, 1.0)
    return float(np.linalg.norm(r + d1 * s - d2 * t))


class ReferenceCollision:
    """Naive reference: numpy 4x4 ``joint_frames`` chain, numpy transforms and distances per pair."""

    def __init__(self, model: RobotModel, tool) -> None:
        self.model = model
        zero = link_shapes(model, model.zero_joints, tool)
        self.pairs = collision_pairs(model, tool)
        # recover each capsule's local endpoints from the zero pose
        self.local = []
        from xarm_emu.model import collision as col

        for row, shape in zip(col._local_shapes(model, tool), zero, strict=True):
            assert isinstance(shape, Capsule)
            self.local.append((row[1] + 1, np.array([*row[2], 1.0]), np.array([*row[3], 1.0]), row[4]))

    def check(self, q: np.ndarray) -> float:
        frames = [np.eye(4), *joint_frames(self.model, q)]
        world = ([(frames[f] @ a)[:3] for f, a, _, _ in self.local],
                 [(frames[f] @ b)[:3] for f, _, b, _ in self.local])
        best = np.inf
        for i, j in self.pairs:
            d = _numpy_seg_dist(world[0][i], world[1][i], world[0][j], world[1][j])
            best = min(best, max(d - self.local[i][3] - self.local[j][3], 0.0))
        return best


def _time(fn, qs) -> float:
    t0 = time.perf_counter()
    for q in qs:
        fn(q)
    return (time.perf_counter() - t0) / len(qs) * 1e6


def run() -> list[str]:
    """Return report lines (per-call microseconds, ratio to the numpy reference, agreement)."""
    rng = np.random.default_rng(7)
    lines = []
    gripper = tool_model(1)
    for model in (XARM7, XARM6):
        qs = [rng.uniform(model.lower, model.upper) for _ in range(N)]
        ref = ReferenceCollision(model, gripper)
        worst = max(abs(self_collision(model, q, gripper)[1] - ref.check(q)) for q in qs[:200])
        fast = _time(lambda q, m=model: self_collision(m, q, gripper), qs)
        slow = _time(ref.check, qs[: N // 4])
        lines.append(f"{model.name} self_collision (xArm Gripper): {fast:7.1f} us/check, numpy reference "
                     f"{slow:7.1f} us, ratio {slow / fast:4.1f}x, max |difference| {worst:.2e} mm")
    box = tool_model(22, [80.0, 60.0, 150.0])
    qs = [rng.uniform(XARM7.lower, XARM7.upper) for _ in range(N)]
    t_box = _time(lambda q: self_collision(XARM7, q, box), qs)
    lines.append(f"xArm7 self_collision (cuboid tool): {t_box:7.1f} us/check")
    steps = [(q, q + rng.normal(0.0, 0.004, 7)) for q in qs]
    boundary = (700.0, -700.0, 700.0, -700.0, 951.5, -400.0)
    per_step = _time(lambda s: check_path_step(XARM7, s[0], s[1], gripper, True, boundary, True), steps)
    lines.append(f"xArm7 check_path_step (collision + boundary, no stop): {per_step:7.1f} us/step "
                 "(budget 4000 us control period)")
    return lines


if __name__ == "__main__":
    for line in run():
        print(line)
