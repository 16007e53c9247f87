"""A read-only configuration folder (a read-only volume, a ConfigMap): ``serve`` starts, loads what
is saved there (manual 2.1.3, register 40 saved it), says once in the log that saving is off, and
answers save_conf as a box that cannot save, without a traceback."""

from __future__ import annotations

import os
import struct
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest
from helpers import accepts, connect, port_args, recv_exact, serve_ports, wait_for

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.frame import STATE_WARNING, encode_request

SAVE_CONF = 40
SET_TCP_OFFSET = 35
OFFSET = (0.0, 0.0, 120.5, 0.0, 0.0, 0.0)


def _ask(s: object, tid: int, register: int, params: bytes = b"") -> bytes:
    s.sendall(encode_request(tid, register, params))  # type: ignore[attr-defined]
    head = recv_exact(s, 6)  # type: ignore[arg-type]
    return head + recv_exact(s, struct.unpack(">H", head[4:6])[0])  # type: ignore[arg-type]


def _read_tcp_offset(s: object) -> tuple[float, ...]:
    """Input registers 77-82 (TCP offset, 0.1 mm / 0.1 deg) through the standard Modbus map."""
    s.sendall(struct.pack(">HHHB", 9, 0, 6, 1) + struct.pack(">BHH", 4, 77, 6))  # type: ignore[attr-defined]
    head = recv_exact(s, 6)  # type: ignore[arg-type]
    body = recv_exact(s, struct.unpack(">H", head[4:6])[0])  # type: ignore[arg-type]
    assert body[1] == 4 and body[2] == 12, body.hex()
    return tuple(v / 10 for v in struct.unpack(">6h", body[3:15]))


@pytest.fixture
def read_only_mount(tmp_path: Path):  # type: ignore[no-untyped-def]
    """A tmpfs holding one save, then remounted read-only (needs root and mount)."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    where = tmp_path / f"ro-{uuid.uuid4().hex[:6]}"
    where.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=4m", "tmpfs", str(where)],
                      capture_output=True).returncode != 0:
        pytest.skip("cannot mount a tmpfs here")
    try:
        yield where
    finally:
        subprocess.run(["umount", "-l", str(where)], capture_output=True)


def test_serve_on_a_folder_remounted_read_only_after_one_save(read_only_mount: Path, tmp_path: Path) -> None:
    cfg = read_only_mount
    emu = Emulator(6, config_dir=cfg)
    state, _ = emu.handle(SET_TCP_OFFSET, struct.pack("<6f", *OFFSET))
    assert state & 0x40 == 0
    emu.handle(SAVE_CONF, b"")
    assert list(cfg.glob("config-*.json"))
    assert subprocess.run(["mount", "-o", "remount,ro", str(cfg)], capture_output=True).returncode == 0
    with pytest.raises(OSError):
        (cfg / "probe").write_text("x")

    baseline, _ = _serve_and_check(tmp_path / "rw", tmp_path / "rw.log", saved=False)
    started, text = _serve_and_check(cfg, tmp_path / "serve.log", saved=True)
    # answered within 2 s of the start, or as fast as the same start on a writable folder on a
    # machine so busy that the interpreter alone takes longer (twice that, for noise)
    assert started < max(2.0, 2 * baseline), (started, baseline)
    assert "Traceback" not in text, text
    assert text.count("saving is off") == 1, text
    assert "read-only file system" in text


def _serve_and_check(cfg: Path, log_path: Path, saved: bool) -> tuple[float, str]:
    """Start ``serve`` on ``cfg``; seconds until get_state is answered, and the log."""
    ports, last = serve_ports()
    t0 = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-m", "xarm_emu.cli", "serve", *port_args(*ports),
                             "--config-dir", str(cfg), "--log-level", "INFO"],
                            stdout=open(log_path, "w"), stderr=subprocess.STDOUT,  # noqa: SIM115
                            env={**os.environ, "COLUMNS": "500"})
    try:
        assert wait_for(lambda: accepts(last) or proc.poll() is not None, 15.0)
        assert proc.poll() is None, log_path.read_text()
        with connect(ports[0]) as s:
            reply = _ask(s, 1, 13)  # get_state answered
            started = time.monotonic() - t0
            assert reply[6] == 13
            if saved:
                assert _read_tcp_offset(s) == pytest.approx(OFFSET, abs=0.05)  # the saved one, loaded
                save = _ask(s, 2, SAVE_CONF)
                assert save[6] == SAVE_CONF and save[7] & STATE_WARNING  # cannot save: warning
                assert _ask(s, 3, 13)[6] == 13  # and goes on answering
    finally:
        proc.terminate()
        proc.wait(10)
    return started, log_path.read_text()
