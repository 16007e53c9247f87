"""`xarm-emu compare -o report.html`: the page a person reads (fidelity/html_report.py), parsed back
for its verdicts per area, its charts of the recorded against the replayed, and what it could not decide."""

from __future__ import annotations

import json
import re
import time
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import pytest
from helpers import run_cli, wait_for

from xarm_emu.client import Client
from xarm_emu.fidelity import html_report
from xarm_emu.fidelity.compare import DEFAULT_TOLERANCES
from xarm_emu.model.calibration import Calibration
from xarm_emu.model.inertials import torque_constants
from xarm_emu.model.robots import get_model
from xarm_emu.protocol.firmware import SERVE_VERSION
from xarm_emu.testing import reading_reports, running_emulator, running_proxy

#: The "real arm": torque constants 10 % above the emulator's and torque offsets (the torques and
#: currents differ, the geometry and timing do not).
MOVED = Calibration(model="6", torque_constants=tuple(float(k) * 1.1 for k in torque_constants(get_model(6))),
                    torque_offsets=(0.0, 0.3, -0.2, 0.0, 0.1, 0.0))


class Page(HTMLParser):
    """What a test reads of the page: the verdict rows, the overall verdict, the charts' lines."""

    def __init__(self, text: str) -> None:
        super().__init__()
        self.verdicts: dict[str, str] = {}
        self.overall: str | None = None
        self.charts: list[list[dict[str, str]]] = []  # per <svg>: its polylines' attributes
        self.tags: set[str] = set()
        self.ids: set[str] = set()
        self.undecided_rows = 0
        self.worst: list[tuple[str, str]] = []  # (request, class)
        self.charted: list[str] = []  # the requests charted, in order
        self.feed(text)

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = {k: v or "" for k, v in attrs}
        self.tags.add(tag)
        if "id" in a:
            self.ids.add(a["id"])
        classes = a.get("class", "").split()
        if tag == "tr" and "verdict" in classes:
            self.verdicts[a["data-area"]] = a["data-verdict"]
        if tag == "tr" and "undecided" in classes:
            self.undecided_rows += 1
        if tag == "tr" and "worst" in classes:
            self.worst.append((a["data-request"], a["class"]))
        if tag == "h3" and "chart-of" in classes:
            self.charted.append(a["data-request"])
        if a.get("id") == "overall":
            self.overall = a["data-verdict"]
        if tag == "svg":
            self.charts.append([])
        if tag == "polyline":
            self.charts[-1].append(a)


def _points(line: dict[str, str]) -> list[tuple[float, float]]:
    return [(float(x), float(y)) for x, y in (p.split(",") for p in line["points"].split())]


@pytest.fixture(scope="module")
def moved(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A recording through the proxy of an emulator with moved torque constants (the real-time and
    normal reports read through it): a joint move, a linear move and a read of the joints."""
    path = tmp_path_factory.mktemp("html") / "moved.xrec"
    with running_emulator(firmware=SERVE_VERSION, calibration=MOVED) as st, running_proxy(st, path) as px, \
            reading_reports(px, ("realtime", "normal")):
        time.sleep(0.05)
        with Client("127.0.0.1", px.ports["command"]) as c:
            c.get_version()
            c.motion_enable(True)
            c.set_mode(0)
            c.set_state(0)
            c.call(23, joints=(0.6, -0.2, -0.3, 0, 0.4, 0, 0), speed=2.0, acc=10.0, mvtime=0.0)
            c.call(21, pose=(300, 50, 200, 3.14159, 0, 0), speed=300, acc=2000, mvtime=0.0)
            assert wait_for(lambda: c.get_state() == 2 and c.get_cmdnum() == 0)
            c.get_joints()
        time.sleep(0.3)  # normal report frames after the last request
    return path


def test_the_page_gives_a_verdict_per_area_and_charts_the_worst_commands(moved: Path, tmp_path: Path) -> None:
    out = tmp_path / "report.html"
    code, text = run_cli("compare", str(moved), "-o", str(out))
    assert code == 1, text
    page = Page(out.read_text(encoding="utf-8"))
    assert page.overall == "outside"
    assert page.verdicts == {"replies": "within", "timing": "within", "path": "within", "torques": "outside",
                             "currents": "outside", "codes": "within", "rates": "within"}
    # the commands that differ most, the furthest first, the first three charted: torques and currents
    # per joint, recorded solid and the emulator's dashed, and the TCP path seen from above
    data = json.loads(run_cli("compare", str(moved), "--json")[1])
    listed = html_report.worst(data)
    assert [r for r, _ in page.worst] == [str(g["index"]) for g in listed]
    assert all(cls == "worst outside" for _, cls in page.worst)
    assert [g["excess"] for g in listed] == sorted((g["excess"] for g in listed), reverse=True)
    line = next(c["index"] for c in data["commands"] if c["register"] == 21)
    assert str(line) in [r for r, _ in page.worst]  # the linear move, with the reads polled after it
    # the first of them that have real-time frames (a request before the first frame has none)
    listed_requests = [r for r, _ in page.worst]
    assert 1 <= len(page.charted) <= html_report.CHARTED and len(page.charts) == 3 * len(page.charted)
    assert page.charted == sorted(page.charted, key=listed_requests.index)
    with_frames = [str(g["index"]) for g in listed if g["samples"][1] > g["samples"][0]]
    assert page.charted == with_frames[:html_report.CHARTED]
    torques = page.charts[0]
    labels = [ln["data-label"] for ln in torques]
    assert labels == [f"J{j}{s}" for j in range(1, 7) for s in ("", " emulator")]
    assert all("stroke-dasharray" in ln for ln in torques[1::2]) and not any("stroke-dasharray" in ln
                                                                          for ln in torques[::2])
    j2, j2_emu = _points(torques[2]), _points(torques[3])  # the shoulder carries the arm: they differ
    assert len(j2) == len(j2_emu) >= 2 and j2 != j2_emu
    assert max(len(_points(ln)) for chart in page.charts for ln in chart) <= html_report.POINTS
    tcp = page.charts[2]
    assert [ln["data-label"] for ln in tcp] == ["recorded", "emulator"]
    assert _points(tcp[0]) == _points(tcp[1])  # the same path, to the pixel
    assert "undecided-none" in page.ids
    # self-contained: no script, no stylesheet or image fetched from anywhere
    text = out.read_text(encoding="utf-8")
    assert "script" not in page.tags and "link" not in page.tags and "img" not in page.tags
    assert not re.search(r"(src|href)=", text)


def test_json_carries_the_tolerances_the_page_judges_by(moved: Path) -> None:
    code, out = run_cli("compare", str(moved), "--json", "--tolerances", "/dev/null")
    assert code == 1
    data = json.loads(out)
    assert data["tolerances"] == pytest.approx(DEFAULT_TOLERANCES)
    rows = {r["area"]: r for r in html_report.verdicts(data)}
    assert rows["torques"]["verdict"] == "outside" and rows["path"]["verdict"] == "within"
    # rendered from the JSON alone (no charts): the same verdicts
    page = Page(html_report.render(data))
    assert page.verdicts["torques"] == "outside" and page.charts == []


def _synthetic(**extra: Any) -> dict[str, Any]:
    """A comparison's JSON as compare writes it for a recording of the command port only."""
    data: dict[str, Any] = {
        "model": "6", "firmware": "2.7.103",
        "notes": ["not compared: move durations, joint torques and currents"],
        "totals": {"requests": 3, "samples": 0, "reply_differences": 1, "duration_s": 0.0, "path_mm": 0.0,
                   "path_deg": 0.0, "torque_rms": 0.0, "torque_max": 0.0, "current_rms": 0.0,
                   "current_max": 0.0, "code_differences": 0, "code_timing_s": 0.0, "report_rate_rel": 0.0},
        "tolerances": dict(DEFAULT_TOLERANCES), "per_joint": {}, "codes": {}, "rates": {},
        "failures": ["reply_differences 1 > 0"],
        "commands": [{"index": 0, "t": 0.1, "register": 1, "name": "GET_VERSION", "reply_differs": False},
                     {"index": 1, "t": 0.2, "register": 23, "name": "MOVE_JOINT", "reply_differs": False},
                     {"index": 2, "t": 0.3, "register": 42, "name": "GET_JOINT_POS", "reply_differs": True,
                      "recorded_reply": "0a0b", "replayed_reply": "0a0c"}]}
    data.update(extra)
    return data


def test_what_a_recording_cannot_show_is_not_compared_and_said() -> None:
    undecided = [{"request": 1, "name": "MOVE_JOINT", "from": 0.196, "to": 0.212,
                  "why": "the request came within a round trip of a period boundary"}]
    page = Page(html_report.render(_synthetic(undecided=undecided)))
    assert page.verdicts == {"replies": "outside", "timing": "within", "path": "within",
                             "torques": "not compared", "currents": "not compared", "codes": "within",
                             "rates": "not compared"}
    assert page.undecided_rows == 1
    # the differing read is listed with the move it polled after, as a reply difference
    assert page.worst == [("1", "worst outside")]
    text = html_report.render(_synthetic(undecided=undecided))
    assert "the request came within a round trip of a period boundary" in text
    assert "note: not compared: move durations" in text


def test_the_page_reads_what_it_finds_and_guesses_nothing() -> None:
    """A JSON of another version (fields missing or of other shapes): a page, no exception."""
    page = Page(html_report.render({"model": "6", "totals": {"reply_differences": "x"}, "commands": [1, None],
                                    "codes": {"first_seen": [None]}, "rates": {"30000": "?"}}))
    assert page.overall == "within" and set(page.verdicts.values()) == {"not compared"}


def test_a_page_that_cannot_be_written_leaves_nothing_half_written(moved: Path, tmp_path: Path) -> None:
    out = tmp_path / "missing-dir" / "report.html"
    code, text = run_cli("compare", str(moved), "-o", str(out))
    assert code == 1 and text.strip().startswith(f"cannot write {out}:")
    assert not out.parent.exists()
