"""A one-page printable summary of a run: self-contained HTML with inline SVG figures drawn from numpy.

No UI or plotting library (this module imports numpy and the standard library only), no script,
no external URL: the file prints the same offline and years later. Used by the dashboard's
"Summary for print (HTML)" downloads and by ``beam calibrate --report FILE.html``.

:func:`band_svg` draws a time series with its 95 % bands and calibration window;
:func:`handout_html` puts a title, key numbers, tables, figures and notes on one A4 page.
"""

from __future__ import annotations

import html
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Series", "band_svg", "handout_html", "micrometres", "nice_ticks"]

#: Points drawn per series at most (a record has a few thousand; an SVG of more prints slowly).
MAX_SVG_POINTS = 1500


@dataclass(frozen=True)
class Series:
    """One layer of :func:`band_svg`.

    Parameters
    ----------
    label : str
        Legend text.
    time_s : array
        Abscissa (s).
    value : array
        Ordinate (plot unit), or the lower edge of a band.
    upper : array, optional
        Upper edge: the series is a band (filled between ``value`` and ``upper``).
    colour : str
        CSS colour.
    style : {"line", "dots", "dashed", "band"}
        How it is drawn (``"band"`` when ``upper`` is given).
    opacity : float
        Fill or stroke opacity.
    """

    label: str
    time_s: np.ndarray
    value: np.ndarray
    upper: np.ndarray | None = None
    colour: str = "#1f77b4"
    style: str = "line"
    opacity: float = 1.0
    extra: dict = field(default_factory=dict)


def nice_ticks(lo: float, hi: float, count: int = 6) -> np.ndarray:
    """About ``count`` round tick values (a 1, 2 or 5 × 10^k step, the nearest to the range / (count - 1)
    in ratio) inside ``[lo, hi]``."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return np.array([lo]) if math.isfinite(lo) else np.array([0.0])
    raw = (hi - lo) / max(count - 1, 1)
    power = 10.0 ** math.floor(math.log10(raw))
    step = power * min((1.0, 2.0, 5.0, 10.0), key=lambda m: abs(math.log(m * power / raw)))
    first = math.ceil(lo / step - 1e-9) * step
    ticks = np.arange(first, hi + 0.5 * step * 1e-6 + step * 1e-9, step)
    return ticks[(ticks >= lo - 1e-9 * step) & (ticks <= hi + 1e-9 * step)]


def micrometres(value_m: float) -> str:
    """A length in µm with sensible digits: ``"3.21 µm"``, ``"1273 µm"`` (never an exponent), ``"–"`` if not finite."""
    if not math.isfinite(value_m):
        return "–"
    um = 1e6 * value_m
    return f"{um:.0f} µm" if abs(um) >= 100 else f"{um:.3g} µm"


def _fmt(value: float) -> str:
    text = f"{value:.6g}"
    return "0" if text in ("-0", "0") else text


def _finite(arrays: list[np.ndarray]) -> np.ndarray:
    return np.concatenate([a[np.isfinite(a)] for a in arrays]) if arrays else np.array([])


#: Unique ids of the clip paths (several figures share one page).
_CLIP_IDS = itertools.count(1)


def _thin(*arrays: np.ndarray) -> list[np.ndarray]:
    n = arrays[0].size
    k = max(1, -(-n // MAX_SVG_POINTS))
    return [np.asarray(a, float)[::k] for a in arrays]


def band_svg(series: Sequence[Series], *, title: str, x_label: str, y_label: str,
             window_s: tuple[float, float] | None = None, width_px: int = 720, height_px: int = 280) -> str:
    """An inline ``<svg>`` of time series and bands (drawn in the order given) with axes and a legend.

    Parameters
    ----------
    series : sequence of Series
        Layers, bottom first.
    title, x_label, y_label : str
        Texts (units in the labels).
    window_s : (float, float), optional
        Calibration window (s), shaded.
    width_px, height_px : int
        Size of the drawing (the page scales it to its width).

    Returns
    -------
    str
        An ``<svg>`` element (no ``xmlns`` URL: inline SVG in HTML needs none).
    """
    left, right, top = 62, 12, 26
    # the legend: entries left to right, wrapped into rows under the axis label
    widths = [26 + 6 * len(s.label) for s in series]
    places, x, row = [], left, 0
    for width in widths:
        if x > left and x + width > width_px - right:
            x, row = left, row + 1
        places.append((x, row))
        x += width
    bottom = 50 + 16 * (row + 1)
    w, h = width_px - left - right, height_px - top - bottom
    xs = [np.asarray(s.time_s, float) for s in series if np.size(s.time_s)]
    ys = [np.asarray(a, float) for s in series for a in (s.value, s.upper) if a is not None and np.size(a)]
    x_all, y_all = _finite(xs), _finite(ys)
    x0, x1 = (float(x_all.min()), float(x_all.max())) if x_all.size else (0.0, 1.0)
    y0, y1 = (float(y_all.min()), float(y_all.max())) if y_all.size else (-1.0, 1.0)
    if x1 <= x0:
        x1 = x0 + 1.0
    pad = 0.05 * (y1 - y0 or 1.0)
    y0, y1 = y0 - pad, y1 + pad

    def px(x):
        return left + (np.asarray(x, float) - x0) / (x1 - x0) * w

    def py(y):
        return top + (y1 - np.asarray(y, float)) / (y1 - y0) * h

    clip_id = f"clip{next(_CLIP_IDS)}"
    out = [(f'<svg class="figure" viewBox="0 0 {width_px} {height_px}" width="100%" role="img" '
            f'aria-label="{html.escape(title)}" font-family="sans-serif" font-size="11">'),
           (f'<text x="{width_px / 2:.0f}" y="16" text-anchor="middle" font-size="13" font-weight="bold">'
            f'{html.escape(title)}</text>'),
           f'<clipPath id="{clip_id}"><rect x="{left}" y="{top}" width="{w}" height="{h}"/></clipPath>']
    clip = f'clip-path="url(#{clip_id})"'
    if window_s is not None:
        a, b = (float(np.clip(px(v), left, left + w)) for v in window_s)
        out.append(f'<rect x="{a:.1f}" y="{top}" width="{max(b - a, 0):.1f}" height="{h}" fill="#fdd49e" '
                   f'fill-opacity="0.45"/>')
    for s in series:
        if not np.size(s.time_s):
            continue
        if s.upper is not None:
            t, lo, hi = _thin(s.time_s, s.value, s.upper)
            pts = np.concatenate([np.column_stack([px(t), py(hi)]), np.column_stack([px(t), py(lo)])[::-1]])
            pts = pts[np.all(np.isfinite(pts), axis=1)]
            out.append(f'<polygon {clip} fill="{s.colour}" fill-opacity="{s.opacity}" stroke="none" points="'
                       + " ".join(f"{x:.1f},{y:.1f}" for x, y in pts) + '"/>')
            continue
        t, v = _thin(s.time_s, s.value)
        ok = np.isfinite(t) & np.isfinite(v)
        X, Y = px(t[ok]), py(v[ok])
        if s.style == "dots":
            out.append(f'<g {clip} fill="{s.colour}" fill-opacity="{s.opacity}">'
                       + "".join(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="1.2"/>' for x, y in zip(X, Y)) + "</g>")
        else:
            dash = ' stroke-dasharray="5,3"' if s.style == "dashed" else ""
            out.append(f'<polyline {clip} fill="none" stroke="{s.colour}" stroke-opacity="{s.opacity}" '
                       f'stroke-width="1.4"{dash} points="' + " ".join(f"{x:.1f},{y:.1f}" for x, y in zip(X, Y)) + '"/>')
    out.append(f'<rect x="{left}" y="{top}" width="{w}" height="{h}" fill="none" stroke="#444"/>')
    for tx in nice_ticks(x0, x1):
        X = float(px(tx))
        out.append(f'<line x1="{X:.1f}" y1="{top + h}" x2="{X:.1f}" y2="{top + h + 4}" stroke="#444"/>'
                   f'<text x="{X:.1f}" y="{top + h + 16}" text-anchor="middle">{_fmt(tx)}</text>')
    for ty in nice_ticks(y0, y1, 5):
        Y = float(py(ty))
        out.append(f'<line x1="{left - 4}" y1="{Y:.1f}" x2="{left}" y2="{Y:.1f}" stroke="#444"/>'
                   f'<text x="{left - 6}" y="{Y + 4:.1f}" text-anchor="end">{_fmt(ty)}</text>')
    out.append(f'<text x="{left + w / 2:.0f}" y="{top + h + 30}" text-anchor="middle">{html.escape(x_label)}</text>'
               f'<text transform="translate(14,{top + h / 2:.0f}) rotate(-90)" text-anchor="middle">'
               f'{html.escape(y_label)}</text>')
    for s, (x, row) in zip(series, places):
        y = top + h + 46 + 16 * row
        dash = ' stroke-dasharray="3,2"' if s.style in ("dashed", "dots") else ""
        mark = (f'<rect x="{x}" y="{y - 8}" width="14" height="8" fill="{s.colour}" fill-opacity="{s.opacity}"/>'
                if s.upper is not None else
                f'<line x1="{x}" y1="{y - 4}" x2="{x + 14}" y2="{y - 4}" stroke="{s.colour}" stroke-width="2"{dash}/>')
        out.append(mark + f'<text x="{x + 18}" y="{y}">{html.escape(s.label)}</text>')
    out.append("</svg>")
    return "".join(out)


_CSS = """
@page { size: A4; margin: 12mm; }
body { font-family: sans-serif; font-size: 10.5pt; color: #222; max-width: 190mm; margin: 0 auto; }
h1 { font-size: 15pt; margin: 0 0 2mm 0; }
h2 { font-size: 11.5pt; margin: 4mm 0 1mm 0; }
.sub { color: #555; margin: 0 0 3mm 0; }
.numbers { display: flex; flex-wrap: wrap; gap: 3mm; margin: 2mm 0; }
.number { border: 1px solid #bbb; border-radius: 2mm; padding: 1.5mm 3mm; min-width: 32mm; }
.number .value { font-size: 15pt; font-weight: bold; }
.number .label { font-size: 8.5pt; color: #555; }
table { border-collapse: collapse; width: 100%; font-size: 9.5pt; }
th, td { border-bottom: 1px solid #ddd; padding: 0.8mm 2mm; text-align: left; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
ul { margin: 1mm 0; padding-left: 5mm; }
svg.figure { display: block; margin: 1mm 0; }
"""


def handout_html(title: str, subtitle: str, numbers: Sequence[tuple[str, str]],
                 tables: Sequence[tuple[str, Sequence[str], Sequence[Sequence[str]]]] = (),
                 figures: Sequence[str] = (), notes: Sequence[str] = ()) -> str:
    """A self-contained one-page HTML document.

    Parameters
    ----------
    title, subtitle : str
        Heading and one line under it (plain text; escaped).
    numbers : sequence of (label, value)
        Key numbers, shown large (plain text; units in the value).
    tables : sequence of (heading, column names, rows)
        Tables of plain-text cells; a cell that parses as a number is right-aligned.
    figures : sequence of str
        ``<svg>`` elements from :func:`band_svg` (inserted as they are).
    notes : sequence of str
        Sentences in a list at the end (plain text).
    """
    e = html.escape
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">', f"<title>{e(title)}</title>",
             f"<style>{_CSS}</style></head><body>", f"<h1>{e(title)}</h1>", f'<p class="sub">{e(subtitle)}</p>',
             '<div class="numbers">']
    parts += [f'<div class="number"><div class="value">{e(value)}</div><div class="label">{e(label)}</div></div>'
              for label, value in numbers]
    parts.append("</div>")
    parts += list(figures)
    for heading, columns, rows in tables:
        parts.append(f"<h2>{e(heading)}</h2><table><thead><tr>" + "".join(f"<th>{e(c)}</th>" for c in columns)
                     + "</tr></thead><tbody>")
        for row in rows:
            cells = []
            for cell in row:
                try:
                    float(str(cell).replace("−", "-").split()[0])
                    cells.append(f'<td class="num">{e(str(cell))}</td>')
                except (ValueError, IndexError):
                    cells.append(f"<td>{e(str(cell))}</td>")
            parts.append("<tr>" + "".join(cells) + "</tr>")
        parts.append("</tbody></table>")
    if notes:
        parts.append("<h2>Notes</h2><ul>" + "".join(f"<li>{e(n)}</li>" for n in notes) + "</ul>")
    parts.append("</body></html>")
    return "\n".join(parts)
