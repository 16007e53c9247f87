"""The project's TOML files (fleets, fault schedules, contact scenes, calibrations, compare
tolerances) are read by one loader and refused in one format: one line naming the file, and the line
and column where the TOML reader gives them."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from xarm_emu.controller.scene.contact import load_scene
from xarm_emu.fidelity.compare import load_tolerances
from xarm_emu.model.calibration import load as load_calibration
from xarm_emu.server.faults import read_schedule
from xarm_emu.server.fleet import load_fleet

#: Each kind of file: its loader, its name in messages, a table of the wrong type and an unknown key.
KINDS: dict[str, tuple[Callable[[Path], Any], str, str, str]] = {
    "fleet": (load_fleet, "fleet file", '[[arm]]\nhost = 5\n', '[[arm]]\ncolour = "red"\n'),
    "faults": (read_schedule, "fault schedule", '[[fault]]\nat = "soon"\ndo = "estop"\n',
               '[[fault]]\nat = 1\ndo = "estop"\ncolour = 1\n'),
    "scene": (load_scene, "scene file", '[[plane]]\npoint = 1\nnormal = [0, 0, 1]\nstiffness = 1\n',
              '[[plane]]\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\nstiffness = 1\ncolour = 1\n'),
    "objects": (load_scene, "scene file",
                '[[object]]\nshape = "box"\nsize = [1, 1, 1]\nmass = "heavy"\nposition = [0, 0, 0]\n',
                '[[object]]\nshape = "box"\nsize = [1, 1, 1]\nmass = 1\nposition = [0, 0, 0]\ncolour = 1\n'),
    "calibration": (load_calibration, "calibration file", 'torque_constants = "high"\n', 'colour = 1\n'),
    "tolerances": (load_tolerances, "tolerances file", 'path_mm = "tight"\n', 'colour = 1\n'),
}


def refusal(loader: Callable[[Path], Any], path: Path) -> str:
    with pytest.raises(ValueError) as info:
        loader(path)
    message = str(info.value)
    assert "\n" not in message
    return message


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_every_kind_of_file_is_refused_in_one_format(tmp_path: Path, kind: str) -> None:
    loader, what, wrong_type, unknown_key = KINDS[kind]
    path = tmp_path / f"{kind}.toml"
    head = re.escape(f"{what} {path}")

    assert re.fullmatch(head + r": cannot be read: No such file or directory", refusal(loader, path))

    path.write_text("# a comment\n[[table]\nx = 1\n")
    assert re.fullmatch(head + r", line 2, column \d+: not valid TOML: \S.*", refusal(loader, path))

    path.write_text(wrong_type)
    assert re.fullmatch(head + r": (\S.*: )?\S+ (must be|is) .*", refusal(loader, path))

    path.write_text(unknown_key)
    assert re.fullmatch(head + r": (\S.*: )?unknown key 'colour'; known: \S.*", refusal(loader, path))


def test_a_schedule_entry_the_server_refuses_names_the_file(make_server, tmp_path: Path) -> None:
    path = tmp_path / "faults.toml"
    path.write_text('[[fault]]\nat = 1\ndo = "servo-error"\njoint = 9\ncode = "S23"\n')
    with pytest.raises(ValueError) as info:
        make_server(faults=path)
    assert str(info.value).startswith(f"fault schedule {path}: fault 1 (servo-error at 1 s): "
                                      "joint 9 out of range")
