"""Line charts as inline SVG for the comparison page (html_report.py): no plotting library, so the
page needs no extra and no file beside it."""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from dataclasses import dataclass

#: One colour per joint (and recorded/emulator pairs share their joint's colour).
COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b")


@dataclass(frozen=True)
class Line:
    """One polyline: its legend label, colour, dashed or solid, and its points (NaN: a gap)."""

    label: str
    colour: str
    xs: Sequence[float]
    ys: Sequence[float]
    dashed: bool = False
    #: Listed in the legend (the emulator's line of a joint shares the recorded one's entry).
    legend: bool = True


def ticks(lo: float, hi: float, n: int = 5) -> list[float]:
    """About ``n`` round tick values covering [lo, hi] (1, 2 or 5 times a power of ten apart)."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return [lo] if math.isfinite(lo) else []
    raw = (hi - lo) / max(n - 1, 1)
    power = 10.0 ** math.floor(math.log10(raw))
    step = next(m * power for m in (1.0, 2.0, 5.0, 10.0) if m * power >= raw)
    first = math.ceil(lo / step - 1e-9) * step
    out = []
    v = first
    while v <= hi + step * 1e-9:
        out.append(0.0 if abs(v) < step * 1e-9 else v)
        v += step
    return out


def _extent(values: list[float]) -> tuple[float, float]:
    finite = [v for v in values if math.isfinite(v)]
    if not finite:
        return 0.0, 1.0
    lo, hi = min(finite), max(finite)
    if hi - lo < 1e-12:
        pad = abs(lo) * 0.05 or 1e-3
        return lo - pad, hi + pad
    pad = (hi - lo) * 0.04
    return lo - pad, hi + pad


def _fmt(v: float) -> str:
    return f"{v:.4g}"


def chart(title: str, lines: Sequence[Line], xlabel: str, ylabel: str, width: int = 460, height: int = 280,
          equal: bool = False) -> str:
    """An SVG line chart of ``lines`` with axes, round ticks and a legend; ``equal``: one unit is as
    long on both axes (a path seen from above)."""
    left, right, top, bottom = 62, 12, 26, 44
    listed = [ln for ln in lines if ln.legend]
    per_row = 7 if all(len(ln.label) <= 3 for ln in listed) else 3
    legend_rows = math.ceil(len(listed) / per_row)
    h_plot = height - top - bottom
    w_plot = width - left - right
    xlo, xhi = _extent([x for ln in lines for x in ln.xs])
    ylo, yhi = _extent([y for ln in lines for y in ln.ys])
    if equal:  # the same scale on both axes, the shorter range widened about its middle
        scale = max((xhi - xlo) / w_plot, (yhi - ylo) / h_plot)
        xm, ym = (xlo + xhi) / 2, (ylo + yhi) / 2
        xlo, xhi = xm - scale * w_plot / 2, xm + scale * w_plot / 2
        ylo, yhi = ym - scale * h_plot / 2, ym + scale * h_plot / 2

    def px(x: float) -> float:
        return left + (x - xlo) / (xhi - xlo) * w_plot

    def py(y: float) -> float:
        return top + (yhi - y) / (yhi - ylo) * h_plot

    total_h = height + 16 * legend_rows
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" class="chart" width="{width}" height="{total_h}" '
           f'viewBox="0 0 {width} {total_h}" role="img" aria-label="{html.escape(title)}">',
           f'<text x="{width / 2:.1f}" y="16" text-anchor="middle" class="title">{html.escape(title)}</text>',
           f'<rect x="{left}" y="{top}" width="{w_plot}" height="{h_plot}" class="frame"/>']
    for v in ticks(xlo, xhi):
        x = px(v)
        out.append(f'<line x1="{x:.1f}" y1="{top}" x2="{x:.1f}" y2="{top + h_plot}" class="grid"/>'
                   f'<text x="{x:.1f}" y="{top + h_plot + 14}" text-anchor="middle">{_fmt(v)}</text>')
    for v in ticks(ylo, yhi):
        y = py(v)
        out.append(f'<line x1="{left}" y1="{y:.1f}" x2="{left + w_plot}" y2="{y:.1f}" class="grid"/>'
                   f'<text x="{left - 4}" y="{y + 4:.1f}" text-anchor="end">{_fmt(v)}</text>')
    out.append(f'<text x="{left + w_plot / 2:.1f}" y="{top + h_plot + 32}" text-anchor="middle">'
               f'{html.escape(xlabel)}</text>'
               f'<text x="14" y="{top + h_plot / 2:.1f}" text-anchor="middle" '
               f'transform="rotate(-90 14 {top + h_plot / 2:.1f})">{html.escape(ylabel)}</text>')
    for ln in lines:
        dash = ' stroke-dasharray="5 3"' if ln.dashed else ""
        for run in _runs(ln.xs, ln.ys):
            points = " ".join(f"{px(x):.1f},{py(y):.1f}" for x, y in run)
            out.append(f'<polyline class="series" data-label="{html.escape(ln.label)}" fill="none" '
                       f'stroke="{ln.colour}" stroke-width="1.3"{dash} points="{points}"/>')
    for n, ln in enumerate(listed):
        x = left + (n % per_row) * (w_plot / per_row)
        y = height + 16 * (n // per_row) + 6
        dash = ' stroke-dasharray="5 3"' if ln.dashed else ""
        out.append(f'<line x1="{x:.1f}" y1="{y - 4}" x2="{x + 18:.1f}" y2="{y - 4}" stroke="{ln.colour}" '
                   f'stroke-width="1.5"{dash}/><text x="{x + 22:.1f}" y="{y}">{html.escape(ln.label)}</text>')
    out.append("</svg>")
    return "".join(out)


def _runs(xs: Sequence[float], ys: Sequence[float]) -> list[list[tuple[float, float]]]:
    """The stretches of finite points (a NaN breaks the line)."""
    runs: list[list[tuple[float, float]]] = [[]]
    for x, y in zip(xs, ys, strict=False):
        if math.isfinite(x) and math.isfinite(y):
            runs[-1].append((x, y))
        elif runs[-1]:
            runs.append([])
    return [r for r in runs if len(r) >= 2 or (len(r) == 1 and len(runs) == 1)]
