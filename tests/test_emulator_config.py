"""Saved configuration across restarts: registers 40 and 39 through the emulator."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import call

from xarm_emu.controller.core.settings import Settings
from xarm_emu.controller.emulator import Emulator


def configure(emu: Emulator) -> None:
    call(emu, 35, pose=(1.0, 2.0, 30.0, 0.1, 0.0, 0.0))
    call(emu, 36, mass=1.5, center=(0.0, 10.0, 40.0))
    call(emu, 51, direction=(0.0, 0.0, 1.0))
    call(emu, 37, sensitivity=5)
    call(emu, 38, sensitivity=2)
    call(emu, 31, jerk=5000.0)
    call(emu, 73, pose=(100.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    call(emu, 52, boundary=(500, -500, 400, -400, 600, 0))
    call(emu, 59, on=1)
    call(emu, 77, on=1)
    call(emu, 138, ionum=2, fun=1)
    call(emu, 146, io_type=0, on=1)


def test_saved_configuration_comes_back_after_restart(tmp_path: Path) -> None:
    emu = Emulator(6, config_dir=tmp_path)
    configure(emu)
    assert call(emu, 40)[0] & 0x60 == 0
    saved = emu.controller.settings.to_dict()
    again = Emulator(6, config_dir=tmp_path)
    s = again.controller.settings
    assert s.tcp_offset == pytest.approx([1.0, 2.0, 30.0, 0.1, 0.0, 0.0], abs=1e-6)
    assert s.tcp_load == pytest.approx([1.5, 0.0, 10.0, 40.0])
    assert s.gravity_direction == [0.0, 0.0, 1.0]
    assert (s.collision_sensitivity, s.teach_sensitivity) == (5, 2)
    assert s.boundary == [500, -500, 400, -400, 600, 0] and s.boundary_on and s.self_collision_on
    assert s.tcp_jerk == 5000.0 and s.world_offset[0] == 100.0
    assert again.io.cgpio.output_functions[2] == 1 and again.io.cgpio_reset_on_stop
    assert {k: v for k, v in s.to_dict().items() if k != "io"} == {
        k: v for k, v in saved.items() if k != "io"}
    snap = again.snapshot()
    assert tuple(snap.tcp_offset) == pytest.approx((1.0, 2.0, 30.0, 0.1, 0.0, 0.0), abs=1e-6)
    assert snap.collision_sensitivity == 5


def test_unsaved_changes_are_lost_and_clean_conf_restores_defaults(tmp_path: Path) -> None:
    emu = Emulator(6, config_dir=tmp_path)
    configure(emu)  # not saved
    assert Emulator(6, config_dir=tmp_path).controller.settings == Settings.for_model(emu.model)
    call(emu, 40)
    call(emu, 39)
    assert emu.controller.settings == Settings.for_model(emu.model)
    assert Emulator(6, config_dir=tmp_path).controller.settings == Settings.for_model(emu.model)


def test_corrupt_file_gives_one_message_is_kept_aside_and_defaults_load(tmp_path: Path) -> None:
    emu = Emulator(6, config_dir=tmp_path)
    configure(emu)
    call(emu, 40)
    files = list(tmp_path.glob("*.json"))
    assert len(files) == 1
    files[0].write_text('{"broken": ')
    again = Emulator(6, config_dir=tmp_path)
    assert again.config_message
    assert again.controller.settings == Settings.for_model(again.model)
    assert any(".corrupt" in p.name for p in tmp_path.iterdir())


def test_configurations_are_keyed_by_serial_number(tmp_path: Path) -> None:
    a = Emulator(6, config_dir=tmp_path)
    call(a, 37, sensitivity=1)
    call(a, 40)
    b = Emulator(7, config_dir=tmp_path)
    assert b.controller.settings.collision_sensitivity == Settings.for_model(b.model).collision_sensitivity
