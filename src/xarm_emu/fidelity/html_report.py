"""The page ``xarm-emu compare -o report.html`` writes: one self-contained HTML file a person reads.

It shows a verdict per area (replies, timing, path, torques, currents, codes, rates) against the
tolerances, the windows the comparison could not decide, the commands that differ most with charts
of the recorded against the replayed (inline SVG, :mod:`.svg`: no extra, no file beside the page),
the error and warning codes and the report rates. It is rendered from the comparison's JSON
(:meth:`~.compare.Comparison.to_json`, every field documented in docs/real-arms.md) and a few
downsampled series for the charts (:func:`report_data`), read defensively: a field it does not find
is left out of the page, never guessed. Its size is bounded whatever the recording's length: the
tables list at most :data:`WORST` commands and :data:`UNDECIDED_ROWS` windows, each chart at most
:data:`POINTS` points per line.
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..server.command_port import PURE_READS
from .svg import COLOURS, Line, chart

#: The areas of the verdict: (key, heading, the totals that decide it).
AREAS: tuple[tuple[str, str, tuple[str, ...]], ...] = (
    ("replies", "Replies", ("reply_differences",)),
    ("timing", "Timing", ("duration_s", "code_timing_s")),
    ("path", "Path", ("path_mm", "path_deg")),
    ("torques", "Torques", ("torque_rms", "torque_max")),
    ("currents", "Currents", ("current_rms", "current_max")),
    ("codes", "Codes", ("code_differences",)),
    ("rates", "Rates", ("report_rate_rel",)),
)
#: Units of the totals, for the page.
UNITS = {"duration_s": "s", "code_timing_s": "s", "path_mm": "mm", "path_deg": "deg", "torque_rms": "N.m",
         "torque_max": "N.m", "current_rms": "A", "current_max": "A", "report_rate_rel": "(relative)"}
#: Totals that need the real-time report (port 30000): not compared in a recording without it.
NEEDS_REALTIME = frozenset({"duration_s", "torque_rms", "torque_max", "current_rms", "current_max"})
#: The commands listed in the table of those that differ most, and of them charted.
WORST = 10
CHARTED = 3
#: The most points per line of a chart (a command's frames are taken evenly up to it).
POINTS = 400
#: The most undecided windows listed (the page says how many more there are).
UNDECIDED_ROWS = 50

WITHIN, OUTSIDE, NOT_COMPARED = "within", "outside", "not compared"
#: Requests that change nothing the arm does, listed with the command before them (:func:`groups`):
#: the pure reads (manual 2.1.3: version, serial number, state, command count, codes, pose, joints)
#: and the feedback mask (register 254, firmware 2.x), which the SDK sets before and after each move.
QUIET = PURE_READS | {254}


# -- the data the page is made of -----------------------------------------------------------------

def report_data(result: Any, charted: int = CHARTED, points: int = POINTS) -> dict[str, Any]:
    """The comparison's JSON with, under ``worst``, the commands that differ most (:func:`worst`) and,
    under ``charts``, the recorded and replayed series of the first ``charted`` of them (at most
    ``points`` frames each): what :func:`render` reads."""
    data = result.to_json()
    charts = []
    rec, rep = getattr(result, "recorded", None), getattr(result, "replayed", None)
    data["worst"] = worst(data)
    for c in data["worst"]:
        a, b = (c.get("samples") or (0, 0))[:2]
        if rec is None or rep is None or b <= a or b > len(rec) or b > len(rep):
            continue
        idx = slice(a, b, max(1, math.ceil((b - a) / points)))
        charts.append({"request": c.get("index"),
                       "t": rec.t[idx].tolist(),
                       "torques": [x.torques[idx].tolist() for x in (rec, rep)],
                       "currents": [x.currents[idx].tolist() for x in (rec, rep)],
                       "tcp": [x.pos[idx].tolist() for x in (rec, rep)]})
        if len(charts) == charted:
            break
    data["charts"] = charts
    return data


def _num(v: Any) -> float | None:
    try:
        x = float(v)
    except (TypeError, ValueError):
        return None
    return x


def groups(commands: Any) -> list[dict[str, Any]]:
    """The commands as a person reads a program: each command that may change the arm with the
    requests after it that do not (:data:`QUIET`: the state, codes, joints and pose a program polls
    while it waits, the feedback mask the SDK sets around a move), its frames running to the next
    command that may. A group is its first command's
    fields (``index``, ``t``, ``register``, ``name``, ``duration``) with, over the group, the largest
    of each measure, ``samples`` spanning its frames, ``requests`` its request numbers and
    ``replies`` those whose reply differs (``index``, ``name``, ``recorded_reply``, ``replayed_reply``)."""
    out: list[dict[str, Any]] = []
    for c in commands if isinstance(commands, list) else []:
        if not isinstance(c, dict):
            continue
        if not out or c.get("register") not in QUIET:
            g = {k: c.get(k) for k in ("index", "t", "register", "name", "duration")}
            g.update(requests=[], replies=[], samples=list((c.get("samples") or (0, 0))[:2]))
            out.append(g)
        g = out[-1]
        g["requests"].append(c.get("index"))
        if c.get("reply_differs") and c.get("inside") is None:  # inside an undecided window: not flagged
            g["replies"].append({k: c.get(k) for k in ("index", "name", "recorded_reply", "replayed_reply")})
        for key in _MEASURES:
            v = _num(c.get(key))
            if v is not None:
                g[key] = max(_num(g.get(key)) or 0.0, v)
        a, b = (c.get("samples") or (0, 0))[:2]
        if b > a:
            g["samples"] = [min(g["samples"][0], a) if g["samples"][1] > g["samples"][0] else a,
                            max(g["samples"][1], b)]
    return out


#: The per-command measures a group takes the largest of.
_MEASURES = ("path_mm", "path_deg", "torque_max", "torque_rms", "current_max", "current_rms")


def excess(c: Mapping[str, Any], tol: Mapping[str, float]) -> float:
    """How far one command is outside its tolerances, as the largest ratio of a measure to its
    tolerance (a differing reply counts as infinitely far)."""
    if c.get("reply_differs") or c.get("replies"):
        return math.inf
    worst_ratio = 0.0
    for key in _MEASURES:
        v, t = _num(c.get(key)), tol.get(key)
        if v is not None and t:
            worst_ratio = max(worst_ratio, v / t)
    d = c.get("duration")
    if isinstance(d, (list, tuple)) and len(d) == 2:
        rec, rep = _num(d[0]), _num(d[1])
        t = tol.get("duration_s")
        if rec is None or rep is None or not (math.isfinite(rec) and math.isfinite(rep)):
            return math.inf
        if t:
            worst_ratio = max(worst_ratio, abs(rec - rep) / t)
    return worst_ratio


def worst(data: Mapping[str, Any], n: int = WORST) -> list[dict[str, Any]]:
    """The ``n`` command groups (:func:`groups`) furthest from their tolerances (:func:`excess`),
    the furthest first, each with its ``excess``; one that differs in nothing is not listed."""
    tol = data.get("tolerances") or {}
    scored = [(excess(g, tol), g) for g in groups(data.get("commands"))]
    scored = [(e, g) for e, g in scored if e > 0.0]
    scored.sort(key=lambda eg: -eg[0])
    return [{**g, "excess": e} for e, g in scored[:n]]


def verdicts(data: Mapping[str, Any]) -> list[dict[str, Any]]:
    """One row per area: ``area``, ``verdict`` (within, outside, not compared) and its ``measures``
    (``key``, ``value``, ``tolerance``, ``outside``, ``compared``)."""
    totals = data.get("totals") or {}
    tol = data.get("tolerances") or {}
    failed = {str(f).split()[0] for f in data.get("failures", []) if str(f).split()}
    realtime = (_num(totals.get("samples")) or 0) > 0
    rows = []
    for area, heading, keys in AREAS:
        measures = []
        for key in keys:
            value = _num(totals.get(key))
            compared = value is not None and (realtime or key not in NEEDS_REALTIME)
            if key == "report_rate_rel" and not data.get("rates"):
                compared = False
            limit = _num(tol.get(key))
            out = key in failed or (compared and value is not None and limit is not None and value > limit)
            measures.append({"key": key, "value": value, "tolerance": limit, "outside": out,
                             "compared": compared})
        verdict = (OUTSIDE if any(m["outside"] for m in measures) else
                   WITHIN if any(m["compared"] for m in measures) else NOT_COMPARED)
        rows.append({"area": area, "heading": heading, "verdict": verdict, "measures": measures})
    return rows


# -- the page -------------------------------------------------------------------------------------

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 1450px; color: #222; }
h1 { font-size: 1.4em; } h2 { font-size: 1.15em; margin-top: 1.6em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: .5em 0; } td, th { border: 1px solid #ccc; padding: 3px 8px; }
th { background: #f3f3f3; text-align: left; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
.within { background: #e3f4e1; } .outside { background: #fbe0de; }
.not-compared { background: #eee; color: #666; }
.overall { font-size: 1.1em; padding: .5em .8em; display: inline-block; }
code { font-size: .85em; word-break: break-all; }
svg.chart { margin: 4px 8px 4px 0; } svg text { font-size: 11px; fill: #333; }
svg .title { font-size: 12.5px; font-weight: 600; } svg .frame { fill: none; stroke: #999; }
svg .grid { stroke: #e5e5e5; } .charts { display: flex; flex-wrap: wrap; }
"""


def _cls(verdict: str) -> str:
    return verdict.replace(" ", "-")


def _val(v: float | None, key: str = "") -> str:
    if v is None:
        return "-"
    if key in ("reply_differences", "code_differences"):
        return f"{v:.0f}"
    return f"{v:.4g}"


def render(data: Mapping[str, Any]) -> str:
    """The whole page for ``data`` (:func:`report_data`, or the ``--json`` output with or without
    ``charts``)."""
    e = html.escape
    totals = data.get("totals") or {}
    failures = [str(f) for f in data.get("failures", [])]
    parts = ["<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
             f"<title>xarm-emu compare: xArm {e(str(data.get('model', '?')))}</title>",
             f"<style>{_STYLE}</style></head><body>",
             f"<h1>Recording against the emulator: xArm {e(str(data.get('model', '?')))}, firmware "
             f"{e(str(data.get('firmware', '?')))}</h1>"]
    n_req, n_frames = _num(totals.get("requests")), _num(totals.get("samples"))
    parts.append(f"<p>{_val(n_req, 'reply_differences')} requests replayed, "
                 f"{_val(n_frames, 'reply_differences')} real-time frames compared.</p>")
    overall = OUTSIDE if failures else WITHIN
    parts.append(f"<p class='overall {overall}' id='overall' data-verdict='{overall}'>"
                 + ("Within every tolerance." if not failures else
                    "Outside the tolerances: " + e("; ".join(failures)) + ".") + "</p>")
    parts += _verdict_table(data)
    parts += _undecided(data)
    parts += _worst(data)
    parts += _codes(data)
    parts += _rates(data)
    parts += _per_joint(data)
    parts.append("</body></html>\n")
    return "".join(parts)


def _verdict_table(data: Mapping[str, Any]) -> list[str]:
    out = ["<h2>Verdict per area</h2><table id='verdicts'><tr><th>area</th><th>verdict</th>"
           "<th>measure</th><th>value</th><th>tolerance</th></tr>"]
    for row in verdicts(data):
        ms = row["measures"]
        area = _cls(row["verdict"])
        for n, m in enumerate(ms):
            head = (f"<tr class='verdict' data-area='{row['area']}' data-verdict='{row['verdict']}'>"
                    f"<td rowspan='{len(ms)}' class='{area}'>{row['heading']}</td>"
                    f"<td rowspan='{len(ms)}' class='{area}'>{row['verdict']}</td>") if n == 0 else "<tr>"
            unit = UNITS.get(m["key"], "")
            value = f"{_val(m['value'], m['key'])} {unit}" if m["compared"] else NOT_COMPARED
            own = _cls(OUTSIDE if m["outside"] else WITHIN if m["compared"] else NOT_COMPARED)
            out.append(f"{head}<td class='{own}'>{m['key']}</td><td class='num {own}'>{value}</td>"
                       f"<td class='num {own}'>{_val(m['tolerance'], m['key'])}</td></tr>")
    out.append("</table>")
    return out


def _undecided(data: Mapping[str, Any]) -> list[str]:
    """The windows the comparison could not decide (``undecided``) and its notes."""
    e = html.escape
    rows = [r for r in data.get("undecided", []) or [] if isinstance(r, dict)]
    notes = [str(n) for n in data.get("notes", []) or []]
    out = ["<h2>What could not be decided</h2>"]
    if not rows and not notes:
        out.append("<p id='undecided-none'>Nothing: every request was placed on its control period and "
                   "every measure compared.</p>")
        return out
    if rows:
        out.append(f"<p>{len(rows)} {'window' if len(rows) == 1 else 'windows'} in which the recording "
                   "cannot tell which control period a request took effect in; nothing inside is "
                   "flagged.</p><table id='undecided'>"
                   "<tr><th>request</th><th>command</th><th>from (s)</th><th>to (s)</th><th>why</th></tr>")
        for r in rows[:UNDECIDED_ROWS]:
            out.append(f"<tr class='undecided'><td class='num'>{e(str(r.get('request', '')))}</td>"
                       f"<td>{e(str(r.get('name') or ''))}</td>"
                       f"<td class='num'>{_val(_num(r.get('from')))}</td>"
                       f"<td class='num'>{_val(_num(r.get('to')))}</td>"
                       f"<td>{e(str(r.get('why', '')))}</td></tr>")
        out.append("</table>")
        if len(rows) > UNDECIDED_ROWS:
            out.append(f"<p>... and {len(rows) - UNDECIDED_ROWS} more (the JSON lists them all).</p>")
    out += [f"<p class='note'>note: {e(n)}</p>" for n in notes]
    return out


def _what_differs(c: Mapping[str, Any], tol: Mapping[str, float]) -> str:
    e = html.escape
    bits = []
    for r in (c.get("replies") or [])[:3]:
        bits.append(f"reply to request {r.get('index')} ({e(str(r.get('name') or '?'))}): recorded "
                    f"<code>{e(str(r.get('recorded_reply', '')))}</code>, emulator "
                    f"<code>{e(str(r.get('replayed_reply', '')))}</code>")
    if len(c.get("replies") or []) > 3:
        bits.append(f"{len(c['replies']) - 3} more replies")
    d = c.get("duration")
    if isinstance(d, (list, tuple)) and len(d) == 2:
        bits.append(f"duration {_val(_num(d[0]))} s recorded, {_val(_num(d[1]))} s emulator")
    for key in ("path_mm", "path_deg", "torque_max", "current_max"):
        v, t = _num(c.get(key)), tol.get(key)
        if v is not None and v > 0:
            mark = " class='outside'" if t is not None and v > t else ""
            bits.append(f"<span{mark}>{key} {v:.4g} {UNITS[key]}</span>")
    return "; ".join(bits) or "-"


def _worst(data: Mapping[str, Any]) -> list[str]:
    e = html.escape
    tol = data.get("tolerances") or {}
    given = data.get("worst")
    rows = given if isinstance(given, list) and all(isinstance(g, dict) and "excess" in g for g in given) \
        else worst(data)
    out = ["<h2>The commands that differ most</h2>"]
    if not rows:
        out.append("<p id='worst-none'>None: every command is within its tolerances.</p>")
        return out
    out.append("<p>Each command with the reads a program polls after it (state, codes, joints, pose) "
               "and the real-time frames up to the next command; measures are the largest over them, "
               "outside their tolerance in red.</p>"
               "<table id='worst'><tr><th>request</th><th>controller time (s)</th><th>command</th>"
               "<th>requests</th><th>times its tolerance</th><th>what differs</th></tr>")
    for c in rows:
        name = f"{c.get('name') or '?'} ({c.get('register', '?')})"
        reqs = c.get("requests") or []
        span = f"{reqs[0]}-{reqs[-1]}" if len(reqs) > 1 else str(c.get("index"))
        ratio = ("reply" if c.get("replies") else "-" if not math.isfinite(c["excess"])
                 else f"{c['excess']:.3g}")
        verdict = OUTSIDE if c["excess"] > 1 else WITHIN
        out.append(f"<tr class='worst {verdict}' data-request='{c.get('index')}'>"
                   f"<td class='num'>{c.get('index')}</td><td class='num'>{_val(_num(c.get('t')))}</td>"
                   f"<td>{e(name)}</td><td class='num'>{span}</td><td class='num'>{ratio}</td>"
                   f"<td>{_what_differs(c, tol)}</td></tr>")
    out.append("</table>")
    commands = {c.get("index"): c for c in rows}
    for ch in data.get("charts", []) or []:
        c = commands.get(ch.get("request")) or {}
        out.append(f"<h3 class='chart-of' data-request='{ch.get('request')}'>request {ch.get('request')}: "
                   f"{e(str(c.get('name') or '?'))} at t = {_val(_num(c.get('t')))} s</h3>"
                   "<div class='charts'>")
        out += _charts(ch)
        out.append("</div>")
    return out


def _charts(ch: Mapping[str, Any]) -> list[str]:
    """Torques, currents (recorded solid, emulator dashed, a colour per joint) and the TCP path seen
    from above, of one command."""
    t = [float(x) for x in ch.get("t", [])]
    out = []
    for key, title, unit in (("torques", "joint torque", "N.m"), ("currents", "motor current", "A")):
        pair = ch.get(key)
        if not (isinstance(pair, list) and len(pair) == 2 and pair[0]):
            continue
        rec, rep = pair
        lines = []
        for j in range(len(rec[0])):
            colour = COLOURS[j % len(COLOURS)]
            lines.append(Line(f"J{j + 1}", colour, t, [row[j] for row in rec]))
            lines.append(Line(f"J{j + 1} emulator", colour, t, [row[j] for row in rep], dashed=True,
                              legend=False))
        out.append(chart(f"{title}: recorded (solid), emulator (dashed)", lines, "controller time (s)",
                         f"{title} ({unit})"))
    tcp = ch.get("tcp")
    if isinstance(tcp, list) and len(tcp) == 2 and tcp[0]:
        rec, rep = tcp
        lines = [Line("recorded", COLOURS[0], [p[0] for p in rec], [p[1] for p in rec]),
                 Line("emulator", COLOURS[1], [p[0] for p in rep], [p[1] for p in rep], dashed=True)]
        out.append(chart("TCP path seen from above", lines, "x (mm)", "y (mm)", equal=True))
    return out


def _codes(data: Mapping[str, Any]) -> list[str]:
    codes = data.get("codes") or {}
    first = [r for r in codes.get("first_seen", []) or [] if isinstance(r, dict)]
    runs = [r for r in codes.get("reports", []) or [] if isinstance(r, dict)]
    replies = [r for r in codes.get("replies", []) or [] if isinstance(r, dict)]
    if not (first or runs or replies):
        return []

    def when(v: Any) -> str:
        x = _num(v)
        return "never" if x is None else f"{x:.3f} s"

    out = ["<h2>Error and warning codes</h2>"]
    if first:
        out.append("<table id='codes'><tr><th>code</th><th>first seen recorded</th><th>emulator</th></tr>")
        for r in first:
            differs = (r.get("recorded") is None) != (r.get("emulator") is None)
            out.append(f"<tr{' class=outside' if differs else ''}><td>{html.escape(str(r.get('code')))}</td>"
                       f"<td>{when(r.get('recorded'))}</td><td>{when(r.get('emulator'))}</td></tr>")
        out.append("</table>")
    if replies:
        out.append("<table><tr><th>get_err_warn_code at (s)</th><th>recorded error, warning</th>"
                   "<th>emulator error, warning</th></tr>")
        out += [f"<tr class='outside'><td class='num'>{_val(_num(r.get('t')))}</td>"
                f"<td>{_pair(r.get('recorded'))}</td>"
                f"<td>{_pair(r.get('emulator'))}</td></tr>" for r in replies[:UNDECIDED_ROWS]]
        out.append("</table>")
    if runs:
        out.append("<table><tr><th>controller time (s)</th><th>report port</th><th>frames</th>"
                   "<th>recorded error, warning</th><th>emulator error, warning</th></tr>")
        out += [f"<tr class='outside'><td class='num'>{_val(_num(r.get('t')))}</td><td>{r.get('port')}</td>"
                f"<td class='num'>{r.get('frames')}</td><td>{_pair(r.get('recorded'))}</td>"
                f"<td>{_pair(r.get('emulator'))}</td></tr>" for r in runs[:UNDECIDED_ROWS]]
        out.append("</table>")
    return out


def _pair(v: Any) -> str:
    return ", ".join(str(x) for x in v) if isinstance(v, (list, tuple)) else "-"


def _rates(data: Mapping[str, Any]) -> list[str]:
    rates = data.get("rates") or {}
    if not rates:
        return []
    out = ["<h2>Report rates</h2><table id='rates'><tr><th>port</th><th>recorded (Hz)</th>"
           "<th>emulator (Hz)</th></tr>"]
    for port, pair in sorted(rates.items()):
        if isinstance(pair, (list, tuple)) and len(pair) >= 2:
            out.append(f"<tr><td>{html.escape(str(port))}</td><td class='num'>{_val(_num(pair[0]))}</td>"
                       f"<td class='num'>{_val(_num(pair[1]))}</td></tr>")
    out.append("</table>")
    return out


def _per_joint(data: Mapping[str, Any]) -> list[str]:
    pj = data.get("per_joint") or {}
    keys = [k for k in ("torque_rms", "torque_mean", "current_rms", "current_mean")
            if isinstance(pj.get(k), list)]
    if not keys:
        return []
    n = max(len(pj[k]) for k in keys)
    out = ["<h2>Per joint (recorded - emulator)</h2><table id='per-joint'><tr><th>joint</th>"
           + "".join(f"<th>{k}</th>" for k in keys) + "</tr>"]
    for j in range(n):
        cells = "".join(f"<td class='num'>{_val(_num(pj[k][j]) if j < len(pj[k]) else None)}</td>"
                        for k in keys)
        out.append(f"<tr><td>J{j + 1}</td>{cells}</tr>")
    out.append("</table>")
    return out


def write(data: Mapping[str, Any], path: Path) -> None:
    """Render ``data`` to ``path``, whole or not at all (a temporary file renamed over it)."""
    tmp = path.with_name(path.name + ".tmp")
    try:
        tmp.write_text(render(data), encoding="utf-8")
        tmp.replace(path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_report(result: Any, path: Path) -> None:
    """The page of a comparison (:func:`report_data`) written to ``path``."""
    write(report_data(result), path)


__all__ = ["AREAS", "render", "report_data", "verdicts", "worst", "write", "write_report"]
