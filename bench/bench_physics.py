"""The physics world's cost on the stepped clock, against a baseline measured in the same run: the
pick-and-place of the physics tests (open, above the 40 mm cube, down, close on it, lift, carry
200 mm, set down, open, retreat: about 12 s of arm time, through the registers in process) with the
cube in the engine, and the same moves by an arm without objects (no engine at all). Each figure is
arm seconds per second of this thread's processor time (a factor of real time that another process
on the machine does not change), the best of a few runs, taken in turns."""

from __future__ import annotations

import importlib.util
import time
from pathlib import Path
from types import ModuleType

REPEATS = 3


def _program() -> ModuleType | None:
    """The tests' pick-and-place program (tests/test_physics_grasp.py), or None without the engine."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return None
    path = Path(__file__).resolve().parent.parent / "tests" / "test_physics_grasp.py"
    spec = importlib.util.spec_from_file_location("physics_program", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def run() -> list[str]:
    prog = _program()
    if prog is None:
        return ["skipped: the physics engine (the 'physics' extra) is not installed"]
    with_objects, bare = prog.speeds(REPEATS)
    return [
        f"pick-and-place with the cube in the engine: {with_objects:.0f}x real time",
        f"the same moves without objects: {bare:.0f}x real time",
        f"ratio without / with objects: {bare / with_objects:.2f}",
    ]


if __name__ == "__main__":
    t0 = time.perf_counter()
    print("\n".join(run()), f"({time.perf_counter() - t0:.1f} s)")
