"""Each benchmark figure beside the landed code's, measured in the same run (``python -m bench
--against REF``): the sources of git revision ``REF`` (``git archive``: no checkout is changed) run
the same benchmark modules first, in a child process whose imports, and its children's, come from
them; then this tree's run prints each of its lines with the landed line of the same wording and the
ratio (this / landed) of every number on it."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tarfile
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

_NUMBER = re.compile(r"-?\d+(?:\.\d+)?")


@contextmanager
def landed_tree(ref: str) -> Iterator[Path]:
    """A temporary directory holding ``src`` and ``bench`` of git revision ``ref``."""
    root = Path(__file__).resolve().parent.parent
    with tempfile.TemporaryDirectory(prefix="bench-landed-") as tmp:
        archive = Path(tmp) / "landed.tar"
        subprocess.run(["git", "-C", str(root), "archive", "-o", str(archive), ref, "src", "bench"],
                       check=True)
        with tarfile.open(archive) as tar:
            tar.extractall(tmp, filter="data")
        yield Path(tmp)


def landed_lines(tree: Path, selected: list[str]) -> list[str]:
    """The output lines of the landed tree's ``python -m bench`` for ``selected`` modules."""
    env = dict(os.environ, PYTHONPATH=f"{tree / 'src'}{os.pathsep}{tree}")
    out = subprocess.run([sys.executable, "-m", "bench", *selected], cwd=tree, env=env,
                         capture_output=True, text=True, check=False)
    return out.stdout.splitlines()


def shape(line: str) -> str:
    """A line's wording with its numbers left out (how a figure is matched to the landed one)."""
    return _NUMBER.sub("#", line.strip())


def compared(line: str, landed: list[str]) -> list[str]:
    """``line``, then the first unused landed line of the same wording and the ratio of each number
    on them (taken out of ``landed``); ``line`` alone when there is none."""
    key = shape(line)
    for i, other in enumerate(landed):
        if shape(other) == key:
            del landed[i]
            ours = [float(x) for x in _NUMBER.findall(line)]
            theirs = [float(x) for x in _NUMBER.findall(other)]
            ratios = ", ".join(f"{a / b:.2f}" if b else "-" for a, b in zip(ours, theirs, strict=True))
            return [line, f"    landed: {other.strip()}", f"    this / landed: {ratios}"]
    return [line]
