"""Kinematics benchmark: FK and IK time per call (xArm6) beside a plain-numpy reference, IK success rate,
and the joints of one control period of a Cartesian path (the chord solve of ``kinematics.track``) against
the full solve each period (the previous way), both measured in the same run.

Targets: FK <= 10 us, IK <= 100 us (seed within 0.2 rad), IK success >= 99 % from seeds within
0.5 rad of a solution. Run: ``python -m bench.bench_kinematics``.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from bench.bench_clock import _program
from xarm_emu.controller.core import executor as ex
from xarm_emu.controller.emulator import Emulator
from xarm_emu.model.kinematics import POS_TOL, ROT_TOL, fk, ik
from xarm_emu.model.robots import XARM6, XARM7, RobotModel
from xarm_emu.model.rotations import matrix_to_axis_angle, pose_to_matrix


class ReferenceKinematics:
    """Straightforward numpy implementation: 4x4 matmul chain FK and damped-least-squares IK."""

    def __init__(self, model: RobotModel) -> None:
        self.model = model
        self.origins = [pose_to_matrix((*j.origin_xyz, *j.origin_rpy)) for j in model.joints]

    def frames(self, q: np.ndarray) -> list[np.ndarray]:
        T = np.eye(4)
        out = []
        for origin, qi in zip(self.origins, q, strict=True):
            c, s = math.cos(qi), math.sin(qi)
            rz = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
            T = T @ origin @ rz
            out.append(T)
        return out

    def fk(self, q: np.ndarray) -> np.ndarray:
        return self.frames(q)[-1]

    def ik(
        self, target: np.ndarray, seed: np.ndarray, lam: float = 1e-3, iters: int = 100
    ) -> np.ndarray | None:
        q = np.array(seed, dtype=float)
        w = np.array([1e-3, 1e-3, 1e-3, 1.0, 1.0, 1.0])
        for _ in range(iters):
            frames = self.frames(q)
            T = frames[-1]
            dp = target[:3, 3] - T[:3, 3]
            dw = matrix_to_axis_angle(target[:3, :3] @ T[:3, :3].T)
            if np.linalg.norm(dp) <= POS_TOL and np.linalg.norm(dw) <= ROT_TOL:
                return q
            J = np.zeros((6, len(q)))
            for i, F in enumerate(frames):
                z = F[:3, 2]
                J[:3, i] = np.cross(z, T[:3, 3] - F[:3, 3])
                J[3:, i] = z
            J = J * w[:, None]
            e = np.concatenate([dp, dw]) * w
            q = q + J.T @ np.linalg.solve(J @ J.T + lam * lam * np.eye(6), e)
        return None


def _stats(samples: list[float]) -> tuple[float, float]:
    a = np.array(samples) * 1e6
    return float(np.median(a)), float(np.percentile(a, 99))


def _time_calls(fn, args_list) -> tuple[float, float]:
    out = []
    clock = time.perf_counter
    for args in args_list:
        t0 = clock()
        fn(*args)
        out.append(clock() - t0)
    return _stats(out)


def _problems(model: RobotModel, n: int, spread: float, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(seed)
    lo = np.maximum(model.lower, -math.pi) + 0.1
    hi = np.minimum(model.upper, math.pi) - 0.1
    out = []
    for _ in range(n):
        truth = rng.uniform(lo, hi)
        out.append((fk(model, truth), truth + rng.uniform(-spread, spread, model.dof)))
    return out


Segment = tuple[np.ndarray, list[tuple[float, np.ndarray]]]


def _path_targets() -> list[Segment]:
    """The Cartesian plans of the stepped-clock benchmark's 60 s mixed program (xArm6): per plan the
    joints it starts from and, per control period, its path time and flange target."""
    segments: list[tuple[Any, np.ndarray, list[tuple[float, np.ndarray]]]] = []
    joints = ex._CartesianPlan.joints

    def recorded(self: ex._CartesianPlan, t: float, seed: np.ndarray, increment: float = 0.0
                 ) -> np.ndarray | None:
        if not segments or segments[-1][0] is not self:
            segments.append((self, seed.copy(), []))
        segments[-1][2].append((t, self.to_flange(self.move.at(t)[0])))
        return joints(self, t, seed, increment)

    ex._CartesianPlan.joints = recorded  # type: ignore[method-assign]
    try:
        emu = Emulator(6)
        _program(emu)
        emu.advance(60.0)
    finally:
        ex._CartesianPlan.joints = joints  # type: ignore[method-assign]
    return [(q0, points) for _, q0, points in segments]


class _Replay:
    """A recorded path: ``at(t)`` gives the flange target recorded at path time ``t``."""

    def __init__(self, points: list[tuple[float, np.ndarray]]) -> None:
        self.targets = dict(points)
        self.duration = points[-1][0]

    def at(self, t: float) -> tuple[np.ndarray, float]:
        return self.targets[t], 0.0


def _full_solve(plan: Any, t: float, seed: np.ndarray) -> np.ndarray | None:
    """A period as Cartesian plans ran it before the chord solve: the full solve from the first-order
    extrapolation of the last two answers, then from the previous joints."""
    target = plan.to_flange(plan.move.at(t)[0])
    sol = None
    h = plan.full_hist
    if h is not None and seed is h[3] and h[2] > h[0]:
        r = min((t - h[2]) / (h[2] - h[0]), 2.0)
        sol = ik(plan.model, target, seed + (seed - h[1]) * r, limited=False)
    if sol is None:
        sol = ik(plan.model, target, seed, limited=False)
    plan.full_hist = None if sol is None else (
        (h[2], h[3], t, sol) if h is not None and seed is h[3] else (t - 1.0, sol, t, sol))
    return sol


def _chord_solve(plan: Any, t: float, seed: np.ndarray) -> np.ndarray | None:
    """A Cartesian plan's period: its joints (the array of its answer)."""
    answer = plan.joints(t, seed)
    return None if answer is None else answer[0]  # type: ignore[no-any-return]


def _replay(segments: list[Segment], period: Any) -> tuple[float, list[np.ndarray]]:
    """Seconds to run ``period(plan, t, seed)`` over every recorded period, and the joints."""
    out = []
    t0 = time.perf_counter()
    for q0, points in segments:
        plan = ex._CartesianPlan(_Replay(points), lambda T: T, XARM6)  # type: ignore[arg-type]
        plan.full_hist = None  # type: ignore[attr-defined]
        q = q0
        for t, _ in points:
            q = period(plan, t, q)
            out.append(q)
    return time.perf_counter() - t0, out


def path_following(repeats: int = 7) -> str:
    """The report line of one Cartesian control period's joints, chord solve against full solve
    (interleaved runs, best of ``repeats``)."""
    segments = _path_targets()
    n = sum(len(points) for _, points in segments)
    best = {"chord": math.inf, "full": math.inf}
    answers: dict[str, list[np.ndarray]] = {}
    for _ in range(repeats):
        for name, period in (("full", _full_solve), ("chord", _chord_solve)):
            wall, answers[name] = _replay(segments, period)
            best[name] = min(best[name], wall)
    worst = max(float(np.max(np.abs(a - b))) for a, b in zip(answers["chord"], answers["full"], strict=True))
    chord, full = best["chord"] / n * 1e6, best["full"] / n * 1e6
    return (f"  Cartesian period's joints ({n} periods of the 60 s mixed program): chord solve "
            f"{chord:.1f} us, full solve each period (baseline, same run) {full:.1f} us: x{full / chord:.2f};"
            f" answers within {worst:.0e} rad of each other")


def run() -> list[str]:
    """Measure and return the report lines (``python -m bench`` prints them)."""
    model = XARM6
    ref = ReferenceKinematics(model)
    rng = np.random.default_rng(0)
    qs = [(model, q) for q in rng.uniform(-math.pi, math.pi, (5000, model.dof))]
    for m, q in qs[:200]:  # warm-up (code generation, caches)
        fk(m, q)
        ref.fk(q)
    fk_med, fk_p99 = _time_calls(fk, qs)
    rf_med, rf_p99 = _time_calls(ref.fk, [(q,) for _, q in qs])

    probs = _problems(model, 500, 0.2, 1)
    ik_med, ik_p99 = _time_calls(ik, [(model, T, s) for T, s in probs])
    ri_med, ri_p99 = _time_calls(ref.ik, probs[:200])

    lines = [
        f"kinematics bench ({model.name}, times per call in microseconds)",
        f"  FK  ours median {fk_med:7.1f}  p99 {fk_p99:7.1f} | numpy ref median {rf_med:7.1f}"
        f"  p99 {rf_p99:7.1f} | ratio x{rf_med / fk_med:.1f}  (target <= 10 us)",
        f"  IK  ours median {ik_med:7.1f}  p99 {ik_p99:7.1f} | numpy ref median {ri_med:7.1f}"
        f"  p99 {ri_p99:7.1f} | ratio x{ri_med / ik_med:.1f}  (seed within 0.2 rad, target <= 100 us)",
    ]
    for m in (XARM6, XARM7):
        probs = _problems(m, 1000, 0.5, 2)
        ok = 0
        for T, s in probs:
            q = ik(m, T, s)
            if q is None:
                continue
            Tq = fk(m, q)
            if (np.linalg.norm(Tq[:3, 3] - T[:3, 3]) < 1e-3
                    and np.linalg.norm(matrix_to_axis_angle(T[:3, :3] @ Tq[:3, :3].T)) < 1e-5):
                ok += 1
        lines.append(f"  IK success {m.name}: {ok / len(probs):6.1%} of {len(probs)}"
                     " from seeds within 0.5 rad (target >= 99 %)")
    lines.append(path_following())
    return lines


if __name__ == "__main__":
    print("\n".join(run()))
