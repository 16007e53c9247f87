"""Saved configuration store (registers 39/40): round trip, corrupt files, crash safety under SIGKILL."""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from xarm_emu.controller.core.config import ConfigStore, default_config_dir, file_name_for

SN = "XS1305A0123456"

SAMPLE = {
    "tcp_offset": [0.0, 0.0, 172.0, 3.141592653589793, 0.0, 0.0],
    "tcp_load": {"mass": 0.82, "com": [0.0, 0.0, 48.0]},
    "gravity_direction": [0.0, 0.0, -1.0],
    "collision_sensitivity": 3,
    "teach_sensitivity": 1,
    "safety_boundary": [600, -200, 500, -100, 600, -200],
    "safety_boundary_on": False,
    "self_collision": {"on": True, "tool_type": 1, "tool_params": []},
    "io_stop_clear": [True, False],
    "note": "ünïcode ok",
}

# Shared by the test and the writer subprocess: every field of generation n is derived from n, so a
# file mixing two generations is detected by comparing with make_values(values["gen"]).
VALUES_SRC = textwrap.dedent("""
    def make_values(gen):
        return {
            "gen": gen,
            "tcp_offset": [gen + 0.5, -gen, 2.0 * gen, 0.0, 0.0, gen / 7.0],
            "tcp_load": {"mass": gen % 5 + 0.25, "com": [gen, gen + 1, gen + 2]},
            "blob": [gen] * 6000,
            "tail": "end-%d" % gen,
        }
""")
_ns: dict = {}
exec(VALUES_SRC, _ns)
make_values = _ns["make_values"]

WRITER = VALUES_SRC + textwrap.dedent("""
    import sys
    from xarm_emu.controller.core.config import ConfigStore
    store = ConfigStore(sys.argv[1], sys.argv[2])
    gen = int(sys.argv[3])
    store.save(make_values(gen))
    print("ready", flush=True)
    while True:
        gen += 1
        store.save(make_values(gen))
""")


def test_round_trip_and_separate_serial_numbers(tmp_path: Path):
    store = ConfigStore(tmp_path, SN)
    assert store.load() is None and store.last_error is None
    store.save(SAMPLE)
    again = ConfigStore(tmp_path, SN).load()
    assert again == SAMPLE
    other = ConfigStore(tmp_path, "XI1303B9999999")
    assert other.load() is None
    other.save({"x": 1})
    assert ConfigStore(tmp_path, SN).load() == SAMPLE
    # Overwrite, then delete restores "nothing saved".
    store.save({**SAMPLE, "collision_sensitivity": 5})
    assert store.load()["collision_sensitivity"] == 5
    assert store.delete() is True
    assert store.load() is None and store.delete() is False
    assert other.load() == {"x": 1}
    # No temporary files left behind.
    assert sorted(p.name for p in tmp_path.iterdir()) == [file_name_for("XI1303B9999999")]


def test_file_name_from_serial_number_stays_in_directory(tmp_path: Path):
    assert file_name_for(SN) == f"config-{SN}.json"
    evil = ConfigStore(tmp_path, "../../etc/passwd")
    assert evil.path.parent == tmp_path and "/" not in evil.path.name
    assert file_name_for("a/b") != file_name_for("a_b")
    evil.save({"v": 1})
    assert evil.load() == {"v": 1}


def test_values_json_cannot_hold_are_refused_and_old_file_kept(tmp_path: Path):
    store = ConfigStore(tmp_path, SN)
    store.save(SAMPLE)
    with pytest.raises(ValueError):
        store.save({"bad": float("nan")})
    with pytest.raises(TypeError):
        store.save({"bad": object()})
    assert store.load() == SAMPLE
    assert [p.name for p in tmp_path.iterdir()] == [store.path.name]


def _corrupt_cases(path: Path) -> dict[str, bytes]:
    good = path.read_bytes()
    doc = json.loads(good)
    edited = dict(doc, values={**doc["values"], "collision_sensitivity": 4})
    other_sn = dict(doc, robot_sn="XS0000")
    return {
        "truncated": good[: len(good) // 2],
        "garbage": b"\x00\xff\xfe not json",
        "edited": json.dumps(edited).encode(),
        "other_sn": json.dumps(other_sn).encode(),
        "wrong_root": b"[1, 2, 3]",
        "future_version": json.dumps(dict(doc, version=99)).encode(),
    }


CORRUPT_CASES = ["truncated", "garbage", "edited", "other_sn", "wrong_root", "future_version"]


@pytest.mark.parametrize("case", CORRUPT_CASES)
def test_corrupt_file_is_kept_aside_with_one_message(tmp_path: Path, case: str):
    store = ConfigStore(tmp_path, SN)
    store.save(SAMPLE)
    bad = _corrupt_cases(store.path)[case]
    store.path.write_bytes(bad)
    assert store.load() is None
    assert store.last_error is not None and str(store.path) in store.last_error
    assert "default" in store.last_error
    assert not store.path.exists()
    aside = [p for p in tmp_path.iterdir() if p.name.startswith(store.path.name + ".corrupt-")]
    assert len(aside) == 1 and aside[0].read_bytes() == bad
    assert str(aside[0]) in store.last_error
    # The emulator then runs on defaults; a new save works and loads cleanly.
    store.save(SAMPLE)
    assert store.load() == SAMPLE and store.last_error is None


def test_unreadable_file_is_reported(tmp_path: Path):
    # A directory where the file should be cannot be read (works for any user, root included).
    store = ConfigStore(tmp_path, SN)
    store.path.mkdir()
    assert store.load() is None
    assert store.last_error is not None and "cannot read" in store.last_error
    assert not store.path.exists()
    assert any(p.name.startswith(store.path.name + ".corrupt-") for p in tmp_path.iterdir())


def test_file_without_read_permission_is_reported(tmp_path: Path):
    if os.name != "posix" or os.geteuid() == 0:
        pytest.skip("root reads any file: run `make test` as a normal user for this permission check")
    store = ConfigStore(tmp_path, SN)
    store.save(SAMPLE)
    store.path.chmod(0)
    assert store.load() is None
    assert store.last_error is not None and "cannot read" in store.last_error
    assert not store.path.exists()


def test_default_config_dir(monkeypatch: pytest.MonkeyPatch, tmp_path: Path):
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "xdg"))
    assert default_config_dir() == tmp_path / "xdg" / "xarm-emu"
    monkeypatch.delenv("XDG_CONFIG_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    if os.name != "nt":
        assert default_config_dir() == tmp_path / "home" / ".config" / "xarm-emu"


def test_sigkill_during_saves_never_leaves_a_bad_or_mixed_file(tmp_path: Path):
    script = tmp_path / "writer.py"
    script.write_text(WRITER)
    cfg = tmp_path / "cfg"
    rng = random.Random(20240607)
    last_gen = -1
    temps_seen = 0
    # At least 30 kills at random moments, more (up to 90) until 3 of them have hit a save in progress.
    for k in range(90):
        if k >= 30 and temps_seen >= 3:
            break
        start = k * 1_000_000
        proc = subprocess.Popen([sys.executable, str(script), str(cfg), SN, str(start)],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        try:
            assert proc.stdout is not None
            assert proc.stdout.readline() == b"ready\n", proc.stderr.read() if proc.stderr else ""
            time.sleep(rng.uniform(0.0, 0.04))
        finally:
            proc.send_signal(signal.SIGKILL)
            proc.wait()
            if proc.stdout:
                proc.stdout.close()
            if proc.stderr:
                proc.stderr.close()
        temps_seen += any(".tmp-" in p.name for p in cfg.iterdir())
        store = ConfigStore(cfg, SN)
        values = store.load()
        assert store.last_error is None, store.last_error
        assert values is not None
        gen = values["gen"]
        assert values == make_values(gen), "file mixes generations"
        assert gen >= start and gen >= last_gen  # this run's own save, never an older state
        last_gen = gen
        # load() cleaned the dead writer's temporary file
        assert not any(".tmp-" in p.name for p in cfg.iterdir())
    # Evidence that kills really landed inside saves (temporary file present at the kill).
    assert temps_seen >= 3
