#!/usr/bin/env python3
"""The force-depth curve of `contact_feel --csv` as an SVG plot, drawn by hand
(no plotting library): felt (sim::ContactRenderer) and raw (World::feedback,
averaged) force against depth from the first touch, per material; the whole
range on the left, the first 3 mm on the right.

    build/tests/bench/sim/contact_feel --csv | scripts/force_depth_svg.py > docs/images/force_depth.svg
"""
import csv
import sys

COLOURS = {"rubber": "#1f6fb4", "clay": "#c0602a"}
W, H = 900, 380
PANEL_W, PANEL_H = 360, 270
MARGIN_L, MARGIN_T = 70, 50


def nice_ticks(top, n=5):
    """Round ticks from 0 covering `top` in at most n steps."""
    for step in (0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1, 2, 5, 10):
        if top / step <= n:
            count = int(top / step) + (0 if abs(top / step - round(top / step)) < 1e-9 else 1)
            return [i * step for i in range(count + 1)], step
    return [0, top], top


def panel(out, x0, series, x_max, title):
    y_top = max(f for s in series.values() for d, f in s if d <= x_max + 1e-9) * 1.05
    y_ticks, _ = nice_ticks(y_top)
    y_max = y_ticks[-1]
    x_ticks, _ = nice_ticks(x_max, 6)
    x_ticks = [t for t in x_ticks if t <= x_max + 1e-9]

    def px(d):
        return x0 + d / x_max * PANEL_W

    def py(f):
        return MARGIN_T + PANEL_H - f / y_max * PANEL_H

    out.append(f'<text x="{x0 + PANEL_W / 2}" y="{MARGIN_T - 14}" text-anchor="middle" font-weight="bold">{title}</text>')
    out.append(f'<rect x="{x0}" y="{MARGIN_T}" width="{PANEL_W}" height="{PANEL_H}" fill="none" stroke="#444"/>')
    for t in y_ticks:
        out.append(f'<line x1="{x0}" x2="{x0 + PANEL_W}" y1="{py(t):.1f}" y2="{py(t):.1f}" stroke="#ddd"/>')
        out.append(f'<text x="{x0 - 6}" y="{py(t) + 4:.1f}" text-anchor="end">{t:g}</text>')
    for t in x_ticks:
        out.append(f'<line x1="{px(t):.1f}" x2="{px(t):.1f}" y1="{MARGIN_T}" y2="{MARGIN_T + PANEL_H}" stroke="#eee"/>')
        out.append(f'<text x="{px(t):.1f}" y="{MARGIN_T + PANEL_H + 16}" text-anchor="middle">{t:g}</text>')
    out.append(f'<text x="{x0 + PANEL_W / 2}" y="{MARGIN_T + PANEL_H + 36}" text-anchor="middle">depth from first touch (mm)</text>')
    out.append(f'<text transform="translate({x0 - 48},{MARGIN_T + PANEL_H / 2}) rotate(-90)" text-anchor="middle">force (N)</text>')
    for (material, kind), points in series.items():
        pts = " ".join(f"{px(d):.1f},{py(f):.1f}" for d, f in points if d <= x_max + 1e-9)
        dash = "" if kind == "felt" else ' stroke-dasharray="5,4"'
        colour = COLOURS.get(material, "#333")
        out.append(f'<polyline points="{pts}" fill="none" stroke="{colour}" stroke-width="2"{dash}/>')
        for d, f in points:
            if d <= x_max + 1e-9 and kind == "felt":
                out.append(f'<circle cx="{px(d):.1f}" cy="{py(f):.1f}" r="2" fill="{colour}"/>')


def main():
    rows = list(csv.DictReader(open(sys.argv[1]) if len(sys.argv) > 1 else sys.stdin))
    series = {}
    for r in rows:
        d = float(r["depth_mm"])
        series.setdefault((r["material"], "felt"), []).append((d, float(r["felt_N"])))
        series.setdefault((r["material"], "raw"), []).append((d, float(r["raw_N"])))
    x_max = max(d for s in series.values() for d, _ in s)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="sans-serif" font-size="12">',
           f'<rect width="{W}" height="{H}" fill="white"/>']
    panel(out, MARGIN_L, series, x_max, "Force vs depth, 2 cm tool on the 7 cm ball")
    panel(out, MARGIN_L + PANEL_W + 90, series, 3.0, "The first 3 mm")
    y = H - 12
    x = MARGIN_L
    for (material, kind) in series:
        colour = COLOURS.get(material, "#333")
        dash = "" if kind == "felt" else ' stroke-dasharray="5,4"'
        out.append(f'<line x1="{x}" x2="{x + 28}" y1="{y - 4}" y2="{y - 4}" stroke="{colour}" stroke-width="2"{dash}/>')
        label = f"{material}, {'felt (rendered)' if kind == 'felt' else 'raw (world, averaged)'}"
        out.append(f'<text x="{x + 34}" y="{y}">{label}</text>')
        x += 200
    out.append("</svg>")
    print("\n".join(out))


if __name__ == "__main__":
    main()
