"""The ``.xrec`` file itself: what is written reads back, a file cut short (a killed proxy) reads up to
its last whole record, and a file that is not a recording gets a clear error."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from xarm_emu.server import xrec


def _report(i: int) -> bytes:
    body = i.to_bytes(4, "big") * 20
    return (4 + len(body)).to_bytes(4, "big") + body


def _write(path: Path, frames: int) -> None:
    w = xrec.RecordWriter(path, "127.0.0.1", {30003: 30003})
    w.opened(1, 30003, "127.0.0.1:5000")
    for i in range(frames):
        w.data(w.now(), 1, 30003, xrec.TO_PROGRAM, _report(i))
    w.close()
    assert w.error is None


def test_written_records_read_back_in_order(tmp_path: Path) -> None:
    path = tmp_path / "s.xrec"
    _write(path, 500)
    recs = list(xrec.read(path))
    assert isinstance(recs[0], xrec.Header) and recs[0].format == xrec.FORMAT
    rpts = [r for r in recs if isinstance(r, xrec.Rpt)]
    assert [r.frame for r in rpts] == [_report(i) for i in range(500)]
    assert path.stat().st_size < 500 * len(_report(0))  # compressed


def test_what_a_killed_proxy_leaves_is_readable(tmp_path: Path) -> None:
    """The file as it stands while the writer still runs (what a killed proxy leaves) holds every
    record written before the last flush; a file cut anywhere reads as a whole prefix."""
    path = tmp_path / "s.xrec"
    w = xrec.RecordWriter(path, "127.0.0.1", {30003: 30003})
    for i in range(200):
        w.data(w.now(), 1, 30003, xrec.TO_PROGRAM, _report(i))
    time.sleep(xrec.FLUSH_EVERY * 2.5)  # at least one flush after the 200th frame was queued
    left = path.read_bytes()
    for i in range(200, 400):
        w.data(w.now(), 1, 30003, xrec.TO_PROGRAM, _report(i))
    w.close()
    snapshot = tmp_path / "killed.xrec"
    snapshot.write_bytes(left)
    assert [r.frame for r in xrec.read(snapshot) if isinstance(r, xrec.Rpt)] == [
        _report(i) for i in range(200)]
    data = path.read_bytes()
    for keep in (len(data) - 1, len(data) * 3 // 4, len(data) // 2, 40):
        snapshot.write_bytes(data[:keep])
        rpts = [r.frame for r in xrec.read(snapshot) if isinstance(r, xrec.Rpt)]
        assert rpts == [_report(i) for i in range(len(rpts))]


def test_not_a_recording(tmp_path: Path) -> None:
    path = tmp_path / "x.xrec"
    path.write_bytes(b"this is not a recording\n" * 10)
    with pytest.raises(xrec.RecordingError, match="not an xarm-emu recording"):
        list(xrec.read(path))
    with pytest.raises(xrec.RecordingError, match="cannot read"):
        list(xrec.read(tmp_path / "missing.xrec"))
