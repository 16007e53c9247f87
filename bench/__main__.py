"""Run every ``bench/bench_*.py`` module's ``run() -> list[str]`` and print its lines.

``python -m bench`` runs them all; ``python -m bench roundtrip reports`` runs only those named;
``python -m bench --against main ...`` runs the same modules of the landed code (git revision
``main``) first and prints each figure beside the landed one, with their ratio (:mod:`bench.against`).
"""

from __future__ import annotations

import importlib
import sys
import time
import traceback
from pathlib import Path


def modules(selected: list[str]) -> list[str]:
    names = sorted(p.stem for p in Path(__file__).parent.glob("bench_*.py"))
    if selected:
        names = [n for n in names if n.removeprefix("bench_") in selected or n in selected]
    return names


def main(argv: list[str]) -> int:
    landed: list[str] | None = None
    if argv[:1] == ["--against"] and len(argv) >= 2:
        from bench.against import landed_lines, landed_tree

        ref, argv = argv[1], argv[2:]
        print(f"== the landed code ({ref}) first", flush=True)
        with landed_tree(ref) as tree:
            landed = landed_lines(tree, argv)
    failed = 0
    for name in modules(argv):
        print(f"== {name}", flush=True)
        t0 = time.perf_counter()
        try:
            mod = importlib.import_module(f"bench.{name}")
            lines = mod.run()
        except Exception:  # noqa: BLE001 - one broken benchmark must not hide the others
            traceback.print_exc()
            failed += 1
            continue
        for line in lines:
            if landed is None:
                print(f"  {line}", flush=True)
                continue
            from bench.against import compared

            for out in compared(f"  {line}", landed):
                print(out, flush=True)
        print(f"  ({time.perf_counter() - t0:.1f} s)", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
