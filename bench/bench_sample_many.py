"""Sampling a Cartesian move: the cost per control period of ``move.at(t)`` one period at a time (the
baseline) against ``move.at_many(ts)`` for N consecutive periods in one call, measured in the same run
on the moves of the mixed program of :mod:`bench.bench_clock` (xArm6: blended lines, a line, a circle
of 120 %), with the largest difference between both answers.

Target: at_many below 1 us per period at N = 64. Run: ``python -m bench sample_many``.
"""

from __future__ import annotations

import time

import numpy as np

from bench.bench_clock import PROGRAM_SECONDS, _program
from xarm_emu.controller.emulator import Emulator
from xarm_emu.controller.motion import CartesianMove, MoveChain

PERIOD = 0.004
SIZES = (16, 64, 256)
REPEATS = 9

Move = CartesianMove | MoveChain


def program_moves() -> list[Move]:
    """The distinct Cartesian moves of the mixed program (60 s), as the executor plans them."""
    emu = Emulator(6)
    _program(emu)
    moves: dict[int, Move] = {}
    for _ in range(round(PROGRAM_SECONDS / PERIOD)):
        emu.step()
        plan = emu.controller.data.motion.plan
        move = getattr(plan, "move", None)
        if isinstance(move, CartesianMove | MoveChain):
            moves.setdefault(id(move), move)
    return list(moves.values())


def _windows(move: Move, n: int) -> list[np.ndarray]:
    """The move's periods in windows of ``n`` consecutive path times (the last one past the end)."""
    count = int(move.duration / PERIOD) + 1
    return [PERIOD * np.arange(k, k + n, dtype=float) for k in range(0, count, n)]


def _costs(move: Move, windows: list[np.ndarray]) -> tuple[float, float]:
    """Best seconds per period of the ``at`` loop and of ``at_many`` over the windows, measured in
    turns (the machine is shared: the best of each is the figure least disturbed)."""
    times = [float(t) for w in windows for t in w]
    loop = batch = float("inf")
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        for t in times:
            move.at(t)
        t1 = time.perf_counter()
        for w in windows:
            move.at_many(w)
        t2 = time.perf_counter()
        loop, batch = min(loop, (t1 - t0) / len(times)), min(batch, (t2 - t1) / len(times))
    return loop, batch


def _difference(move: Move, windows: list[np.ndarray]) -> tuple[float, float]:
    """Largest difference of positions (mm) and rotation entries, at_many against at."""
    pos = rot = 0.0
    for w in windows:
        poses, _ = move.at_many(w)
        one = np.array([move.at(float(t))[0] for t in w])
        pos = max(pos, float(np.abs(poses[:, :3, 3] - one[:, :3, 3]).max()))
        rot = max(rot, float(np.abs(poses[:, :3, :3] - one[:, :3, :3]).max()))
    return pos, rot


def run() -> list[str]:
    moves = program_moves()
    periods = sum(int(m.duration / PERIOD) + 1 for m in moves)
    lines = [f"{len(moves)} Cartesian moves of the mixed program, {periods} periods"]
    for n in SIZES:
        loop = batch = 0.0
        pos = rot = 0.0
        for move in moves:
            windows = _windows(move, n)
            share = sum(len(w) for w in windows)
            one, many = _costs(move, windows)
            loop += one * share
            batch += many * share
            p, r = _difference(move, windows)
            pos, rot = max(pos, p), max(rot, r)
        total = sum(len(w) for m in moves for w in _windows(m, n))
        lines.append(f"N = {n}: at(t) loop {loop / total * 1e6:.2f} us per period (baseline, same run), "
                     f"at_many {batch / total * 1e6:.2f} us per period ({loop / batch:.1f}x, target < 1 us "
                     f"at N = 64); largest difference {pos:.1e} mm, {rot:.1e} on rotation entries")
    return lines


if __name__ == "__main__":
    print("\n".join(run()))
