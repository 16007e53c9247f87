"""`xarm-emu plot`: a PNG whose pixels show the data: the joint curve's colour where the values put
it, an error mark at its time, from a Rerun recording and from a command trace."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest
from helpers import run_cli, wait_for

from xarm_emu.client import Client
from xarm_emu.plot import EVENT_COLOURS, JOINT_COLOURS, Series, plot, read_trace
from xarm_emu.testing import running_emulator

image = pytest.importorskip("matplotlib.image")


def pixels_of(png: Path, colour: str, tol: int = 40) -> np.ndarray:
    """(row, column) of the pixels within ``tol`` of ``colour`` (#rrggbb)."""
    img = (image.imread(str(png))[:, :, :3] * 255).astype(int)
    want = np.array([int(colour[i:i + 2], 16) for i in (1, 3, 5)])
    return np.argwhere(np.abs(img - want).sum(axis=2) <= tol)


def test_joint_ramp_and_error_mark_land_where_the_data_says(tmp_path: Path) -> None:
    series = Series()
    for k in range(101):  # J1 from 0 to 90 degrees over 10 s; an error at t = 5 s
        series.add("joints/j1", k * 0.1, 9.0 * k * 0.1)
    series.events.append((5.0, "ERROR", "error C31"))
    out = plot(series, tmp_path / "run.png")
    blue = pixels_of(out, JOINT_COLOURS[0])
    assert len(blue) > 200
    columns = np.unique(blue[:, 1])
    cut = np.argmax(np.diff(columns))  # the legend, right of the panel, after the widest gap
    blue = blue[blue[:, 1] <= columns[cut]]
    left, right = blue[:, 1].min(), blue[:, 1].max()  # the curve spans t = 0 .. 10 s

    def row_at(fraction: float) -> float:
        col = left + fraction * (right - left)
        return float(np.median(blue[np.abs(blue[:, 1] - col) <= 1][:, 0]))
    assert row_at(0.1) > row_at(0.4) > row_at(0.7)  # rising: higher on the image as time goes on
    rise = (row_at(0.1) - row_at(0.4)) / (row_at(0.4) - row_at(0.7))
    assert rise == pytest.approx(1.0, rel=0.1)  # a straight ramp
    red = pixels_of(out, EVENT_COLOURS["ERROR"], tol=30)
    columns = np.unique(red[:, 1])
    middle = left + 0.5 * (right - left)
    assert np.any(np.abs(columns - middle) <= 3)  # the error mark at t = 5 s
    assert red[:, 0].min() < blue[:, 0].max()  # drawn across the joints panel too


def test_plot_of_a_trace_draws_what_the_program_read(tmp_path: Path) -> None:
    trace = tmp_path / "wire.jsonl"
    with running_emulator(speed=5.0, trace=trace) as st:
        with Client("127.0.0.1", st.ports["command"]) as c:
            c.motion_enable(True)
            c.set_mode(0)
            c.set_state(0)
            c.call(23, joints=(0.8, 0, 0, 0, 0, 0, 0), speed=1.0, acc=10.0, mvtime=0.0)
            for _ in range(40):
                c.get_joints()
                c.get_position()
                time.sleep(0.01)
            assert wait_for(lambda: c.get_state() == 2)
            c.get_joints()
    series = read_trace(trace)
    ts, j1 = series.curves["joints/j1"]
    assert j1[0] == pytest.approx(0.0, abs=0.5) and j1[-1] == pytest.approx(math.degrees(0.8), abs=0.01)
    assert series.curves["targets/j1"][1] == [pytest.approx(math.degrees(0.8), abs=1e-3)]
    assert "tcp/speed" in series.curves and max(series.curves["tcp/speed"][1]) > 10.0
    out = tmp_path / "trace.png"
    code, text = run_cli("plot", str(trace), "-o", str(out), "--dof", "6")
    assert code == 0 and text.strip() == f"wrote {out}"
    blue = pixels_of(out, JOINT_COLOURS[0])
    assert len(blue) > 100


def test_plot_of_a_recording(tmp_path: Path) -> None:
    pytest.importorskip("rerun")
    from xarm_emu.protocol.reports import ReportSnapshot
    from xarm_emu.record import SessionRecorder

    path = tmp_path / "s.rrd"
    rec = SessionRecorder(path)
    for k in range(50):
        rec.report(ReportSnapshot(state=1, joints=(0.02 * k,) + (0.0,) * 6), t=k * 0.02)
    rec.report(ReportSnapshot(error=31), rich=True, t=0.5)
    rec.close()
    out = tmp_path / "rec.png"
    code, _ = run_cli("plot", str(path), "-o", str(out))
    assert code == 0
    assert len(pixels_of(out, JOINT_COLOURS[0])) > 100
    assert len(pixels_of(out, EVENT_COLOURS["ERROR"], tol=30)) > 20


def test_plot_refuses_what_it_cannot_read(tmp_path: Path) -> None:
    bad = tmp_path / "bad.jsonl"
    bad.write_text("not json\n")
    code, out = run_cli("plot", str(bad), "-o", str(tmp_path / "x.png"))
    assert code == 2 and out.strip() == f"{bad} line 1 is not a trace line (server/trace.py)"
    code, out = run_cli("plot", str(tmp_path / "missing.rrd"))
    assert code == 2 and out.startswith("no such file")


def _panels(fig) -> list:  # type: ignore[no-untyped-def]
    """The figure's panels top to bottom (a right-hand axis shares its panel)."""
    rows = {}
    for ax in fig.axes:
        rows.setdefault(ax.get_subplotspec().rowspan.start, ax)
    return [rows[k] for k in sorted(rows)]


def test_a_six_axis_trace_has_no_j7_and_marks_its_targets(tmp_path: Path) -> None:
    from xarm_emu.plot import figure

    trace = tmp_path / "wire.jsonl"
    with running_emulator(speed=5.0, trace=trace) as st:
        with Client("127.0.0.1", st.ports["command"]) as c:
            c.motion_enable(True)
            c.set_mode(0)
            c.set_state(0)
            c.call(23, joints=(0.5, 0, 0, 0, 0, 0, 0), speed=1.0, acc=10.0, mvtime=0.0)
            for _ in range(20):
                c.get_joints()
                time.sleep(0.01)
            assert wait_for(lambda: c.get_state() == 2)
    series = read_trace(trace)
    assert len(series.joints()) == 7  # the register carries seven joints
    fig = figure(series, "trace")
    joints, tcp, torques, events = _panels(fig)
    labels = [t.get_text() for t in joints.get_legend().get_texts()]
    assert labels == [f"J{i}" for i in range(1, 7)] + ["J1 target", "J2 target", "J3 target", "J4 target",
                                                       "J5 target", "J6 target"]
    target = next(line for line in joints.lines if line.get_label() == "J1 target")
    assert target.get_linestyle() == "None" and target.get_marker() == "x"  # a mark, not a path
    assert not torques.lines and "no torques" in " ".join(t.get_text() for t in torques.texts)
    fig.savefig(tmp_path / "trace.png", dpi=100)


def test_the_events_strip_of_a_ten_minute_session_stays_legible(tmp_path: Path) -> None:
    from xarm_emu.plot import figure

    series = Series()
    for k in range(601):
        series.add("joints/j1", float(k), 30.0 * math.sin(k / 60.0))
    for t in range(0, 600, 2):
        series.events.append((float(t), "INFO", f"state {1 + t % 3}"))
    for t in range(15, 600, 30):
        series.events.append((float(t), "WARN", "warning W11 speed limit"))
    for t in range(40, 600, 60):
        series.events.append((float(t), "ERROR", "error C31 collision"))
    series.events.sort()
    fig = figure(series, "ten minutes")
    assert len(_panels(fig)) == 4
    events = _panels(fig)[3]
    assert [t.get_text() for t in events.get_yticklabels()] == ["errors (10)", "warnings (20)",
                                                               "state, IO, clients (300)"]
    fig.savefig(tmp_path / "events.png", dpi=100)
    renderer = fig.canvas.get_renderer()
    boxes = [t.get_window_extent(renderer) for t in events.texts]
    assert len(boxes) >= 8  # most errors and warnings carry their text
    assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])  # none on another
