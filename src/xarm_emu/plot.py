"""``xarm-emu plot``: a run drawn against time to a PNG with matplotlib.

Four panels share the time axis: the joint angles (degrees), the TCP position (mm) with its speed
(mm/s, right axis), the joint torques (N m), and the events (errors, warnings, state and IO changes,
client connections) as marks with their text. The input is a Rerun recording of ``xarm-emu
record`` (record.py) or a command trace of ``serve --trace`` (server/trace.py), which holds what the
program read back (GET_JOINT_POS, GET_TCP_POSE, GET_JOINT_TAU, manual 2.1.3) and the joint targets
it sent, and whose replies' state byte (manual 2.1.2) marks errors and warnings.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: Line colours of joints 1..7 (matplotlib's default cycle), so a plot reads the same every time.
JOINT_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2")
EVENT_COLOURS = {"ERROR": "#d62728", "WARN": "#ff7f0e", "INFO": "#7f7f7f", "DEBUG": "#bbbbbb"}


class PlotError(ValueError):
    """The input cannot be plotted; the message says why."""


@dataclass
class Series:
    """Curves and events of one run: entity name -> (times s, values)."""

    curves: dict[str, tuple[list[float], list[float]]] = field(default_factory=dict)
    events: list[tuple[float, str, str]] = field(default_factory=list)  # (t, level, text)
    #: The arm's joint count when the input says it (register 1's reply: '<axis>,<type>,...').
    dof: int | None = None

    def add(self, name: str, t: float, value: float) -> None:
        ts, vs = self.curves.setdefault(name, ([], []))
        ts.append(t)
        vs.append(value)

    def joints(self) -> list[str]:
        return sorted((k for k in self.curves if k.startswith("joints/")), key=lambda k: int(k[8:]))

    def torques(self) -> list[str]:
        return sorted((k for k in self.curves if k.startswith("torques/")), key=lambda k: int(k[9:]))

    def axes(self) -> int:
        """The arm's joints: as the input says, else the joints read, less a seventh that only ever
        read 0 (the registers carry seven joints; a six-axis arm fills the seventh with 0)."""
        if self.dof is not None:
            return self.dof
        n = max((int(k.rsplit("j", 1)[1]) for k in self.curves if "/j" in k), default=0)
        if n == 7 and all(v == 0.0 for k in ("joints/j7", "torques/j7", "targets/j7")
                          for v in self.curves.get(k, ([], []))[1]):
            return 6
        return n


def read_recording(path: Path) -> Series:
    """The curves and events of a Rerun recording written by record.py."""
    try:
        from rerun.chunk import RrdReader
    except ImportError:
        raise PlotError("reading a .rrd needs rerun-sdk: pip install 'xarm-emu[record]'") from None
    try:
        store = RrdReader(str(path)).stream().collect()
    except Exception as exc:  # rerun's own error types
        raise PlotError(f"{path} is not a Rerun recording: {exc}") from None
    series = Series()
    for chunk in store.stream():
        entity = chunk.entity_path.lstrip("/")
        batch = chunk.to_record_batch()
        names = batch.schema.names
        if "time" not in names:
            continue
        times = [ns / 1e9 for ns in batch.column("time").cast("int64").to_pylist()]
        if "Scalars:scalars" in names:
            for t, v in zip(times, batch.column("Scalars:scalars").to_pylist(), strict=True):
                if v:
                    series.add(entity, t, float(v[0]))
        elif entity == "events" and "TextLog:text" in names:
            texts = batch.column("TextLog:text").to_pylist()
            levels = batch.column("TextLog:level").to_pylist() if "TextLog:level" in names else []
            for i, (t, text) in enumerate(zip(times, texts, strict=True)):
                level = levels[i] if i < len(levels) else None
                series.events.append((t, _one(level) or "INFO", _one(text) or ""))
    for ts, vs in series.curves.values():
        order = sorted(range(len(ts)), key=ts.__getitem__)
        ts[:], vs[:] = [ts[i] for i in order], [vs[i] for i in order]
    series.events.sort()
    return series


def _one(value: Any) -> Any:
    return value[0] if isinstance(value, list) and value else value


def _number(v: Any) -> float:
    if isinstance(v, (int, float)):
        return float(v)
    return float(v) if v in ("NaN", "Infinity", "-Infinity") else math.nan


#: Admin commands (server/admin.py) that raise an error: drawn with the errors.
_ERRORS = frozenset({"estop", "error", "servo-error", "gripper-error", "track-error", "end-module-lost",
                     "collision"})


def read_trace(path: Path) -> Series:
    """The curves and events of a command trace (server/trace.py)."""
    series = Series()
    try:
        lines = Path(path).read_text(encoding="utf-8").splitlines()
    except OSError as exc:
        raise PlotError(f"cannot read {path}: {exc.strerror or exc}") from None
    last_pose: tuple[float, list[float]] | None = None
    for n, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
            t = float(rec["t"])
        except (ValueError, KeyError, TypeError):
            raise PlotError(f"{path} line {n} is not a trace line (server/trace.py)") from None
        if "event" in rec:
            if rec["event"] == "outside":  # a fault or input from outside the protocol, as it acted
                who = ("fault schedule" if rec.get("source") == "schedule"
                       else str(rec.get("source") or "admin"))
                cmd = (rec.get("request") or {}).get("cmd") if isinstance(rec.get("request"), dict) else None
                level = "ERROR" if cmd in _ERRORS else "WARN" if cmd == "warning" else "INFO"
                series.events.append((t, level, f"{who}: {rec.get('message') or rec.get('request')}"))
            elif rec["event"] == "start":
                series.events.append((t, "INFO", f"emulator started: xArm {rec.get('model', '?')}, firmware "
                                                 f"{rec.get('firmware', '?')}"))
            else:
                series.events.append((t, "INFO", f"client {rec.get('peer', '?')}: {rec['event']}"))
            continue
        name, values, request = rec.get("name"), rec.get("values") or {}, rec.get("request") or {}
        state = rec.get("state") or 0
        if state & 0x40:
            series.events.append((t, "ERROR", f"{name}: reply with an error active"))
        elif state & 0x20:
            series.events.append((t, "WARN", f"{name}: reply with a warning active"))
        if name == "GET_JOINT_POS" and isinstance(values.get("joints"), list):
            for i, q in enumerate(values["joints"], start=1):
                series.add(f"joints/j{i}", t, math.degrees(_number(q)))
        elif name == "GET_TCP_POSE" and isinstance(values.get("pose"), list):
            pose = [_number(v) for v in values["pose"]]
            for axis, v in zip("xyz", pose[:3], strict=True):
                series.add(f"tcp/{axis}", t, v)
            if last_pose is not None and t > last_pose[0]:
                series.add("tcp/speed", t, math.dist(pose[:3], last_pose[1][:3]) / (t - last_pose[0]))
            last_pose = (t, pose)
        elif name == "GET_JOINT_TAU" and isinstance(values.get("torques"), list):
            for i, tau in enumerate(values["torques"], start=1):
                series.add(f"torques/j{i}", t, _number(tau))
        elif name in ("MOVE_JOINT", "MOVE_SERVOJ") and isinstance(request.get("joints"), list):
            for i, q in enumerate(request["joints"], start=1):
                series.add(f"targets/j{i}", t, math.degrees(_number(q)))
    series.events.sort()
    return series


def read(path: Path) -> Series:
    """A recording (``.rrd``) or a command trace (anything else)."""
    return read_recording(path) if Path(path).suffix == ".rrd" else read_trace(path)


#: The events strip: one lane per level, top to bottom.
LANES = (("ERROR", "errors"), ("WARN", "warnings"), ("INFO", "state, IO, clients"))
LABEL_GAP = 1 / 6  # labels of a lane closer than this share of the time span are left out (marks stay)
LABEL_CHARS = 18  # a label's text is cut to this many characters, so it fits the gap


def _events(ax: Any, shown: list[tuple[float, str, str]], marked: tuple[Any, ...]) -> None:
    """The events strip: a mark per event in its level's lane, the text of errors and warnings
    where it has room (a 10-minute session with hundreds of events stays legible), the counts in
    the lane names; errors and warnings also as dashed lines across the other panels."""
    lane = {level: len(LANES) - 1 - i for i, (level, _) in enumerate(LANES)}
    last_label = dict.fromkeys(lane, -math.inf)
    span = (max(t for t, _, _ in shown) - min(t for t, _, _ in shown)) if shown else 0.0
    for t, level, text in shown:
        colour = EVENT_COLOURS.get(level, "#7f7f7f")
        y = lane.get(level, 0)
        ax.plot([t], [y], marker="|", markersize=10, color=colour, linestyle="none")
        if level in ("ERROR", "WARN"):
            for other in marked:
                other.axvline(t, color=colour, linewidth=0.8, linestyle="--", alpha=1.0 if level == "ERROR"
                              else 0.5)
            if t - last_label[level] >= LABEL_GAP * span:
                cut = text if len(text) <= LABEL_CHARS else text[:LABEL_CHARS - 1] + "…"
                ax.annotate(cut, (t, y), xytext=(3, 3), textcoords="offset points", fontsize=7,
                            color=colour, clip_on=True)
                last_label[level] = t
    counts = {level: sum(1 for _, lv, _ in shown if lv == level) for level, _ in LANES}
    ax.set_yticks([lane[level] for level, _ in LANES],
                  [f"{name} ({counts[level]})" for level, name in LANES], fontsize="small")
    ax.set_ylim(-0.6, len(LANES) - 0.3)


def figure(series: Series, title: str = "", dof: int | None = None) -> Any:
    """The matplotlib figure of ``series`` (module docstring): four panels on one time axis."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise PlotError("plotting needs matplotlib: pip install 'xarm-emu[record]'") from None
    if not series.curves and not series.events:
        raise PlotError("nothing to plot: no joints, poses, torques or events in the input")
    fig, (ax_j, ax_t, ax_tau, ax_e) = plt.subplots(4, 1, sharex=True, figsize=(10, 9),
                                                   gridspec_kw={"height_ratios": [3, 2, 2, 1.3]},
                                                   layout="constrained")
    dof = dof or series.axes()
    for i, name in enumerate(series.joints()[:dof]):
        ts, vs = series.curves[name]
        ax_j.plot(ts, vs, color=JOINT_COLOURS[i % 7], label=f"J{name[8:]}")
    for i in range(1, dof + 1):
        if f"targets/j{i}" in series.curves:  # commanded targets: marks at the time sent, not a path
            ts, vs = series.curves[f"targets/j{i}"]
            ax_j.plot(ts, vs, linestyle="none", marker="x", color=JOINT_COLOURS[(i - 1) % 7],
                      label=f"J{i} target")
    ax_j.set_ylabel("joints (deg)")
    if ax_j.lines:
        ax_j.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")  # off the curves
    for axis, colour in zip("xyz", ("#17becf", "#bcbd22", "#7f7f7f"), strict=True):
        if f"tcp/{axis}" in series.curves:
            ts, vs = series.curves[f"tcp/{axis}"]
            ax_t.plot(ts, vs, color=colour, label=axis)
    ax_t.set_ylabel("TCP (mm)")
    if ax_t.lines:
        ax_t.legend(loc="upper left", bbox_to_anchor=(1.08, 1.0), fontsize="small")
    else:
        ax_t.text(0.5, 0.5, "no TCP pose in this input (the program never read GET_TCP_POSE)",
                  transform=ax_t.transAxes, ha="center", va="center", color="#7f7f7f")
    if "tcp/speed" in series.curves:
        ax_s = ax_t.twinx()
        ts, vs = series.curves["tcp/speed"]
        ax_s.plot(ts, vs, color="#000000", linewidth=0.8, label="speed")
        ax_s.set_ylabel("TCP speed (mm/s)")
    for i, name in enumerate(series.torques()[:dof]):
        ts, vs = series.curves[name]
        ax_tau.plot(ts, vs, color=JOINT_COLOURS[i % 7], label=f"J{name[9:]}")
    ax_tau.set_ylabel("torques (N m)")
    if not ax_tau.lines:
        ax_tau.text(0.5, 0.5, "no torques in this input (the program never read GET_JOINT_TAU)",
                    transform=ax_tau.transAxes, ha="center", va="center", color="#7f7f7f")
    _events(ax_e, [e for e in series.events if e[1] != "DEBUG"], (ax_j, ax_t, ax_tau))
    ax_e.set_xlabel("time (s)")
    if title:
        fig.suptitle(title)
    return fig


def plot(series: Series, out: Path, title: str = "", dof: int | None = None) -> Path:
    """Draw ``series`` to the PNG ``out`` (module docstring); returns ``out``."""
    fig = figure(series, title, dof)  # checks that matplotlib is there
    import matplotlib.pyplot as plt

    out = Path(out)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out
