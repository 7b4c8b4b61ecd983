#!/usr/bin/env python3
"""Charts distance error against voxel size for both surface methods (docs/prep.md), and
d_surf after its projection onto the trilinear HU iso-surface (prep/maps/iso_projection.hpp).

Reads the rows that build/tests/subvoxel_distance_test prints on stdin and writes an SVG (no
plotting library: the VM has none). Usage:
    build/tests/subvoxel_distance_test | tests/bench/surface_accuracy_chart.py docs/bench/surface_accuracy.svg
"""
import re
import sys

ROW = re.compile(r"^(\w+)\s+(\d+) mm\s+mask rms ([\d.]+) max ([\d.]+) \| subvoxel rms ([\d.]+) max ([\d.]+)"
                 r"(?: \| projected rms ([\d.]+) max ([\d.]+))?")


def main():
    rows = []
    for line in sys.stdin:
        m = ROW.match(line.strip())
        if m:
            rows.append((m.group(1), int(m.group(2))) +
                        tuple(float(v) if v is not None else None for v in m.groups()[2:]))
    if not rows:
        sys.exit("no result rows on stdin")
    width, height, left, right, top, bottom = 720, 440, 70, 190, 40, 60
    x_of = lambda h: left + (h - 0.8) / (3.2 - 0.8) * (width - left - right)
    y_max = 1.8
    y_of = lambda v: top + (1 - v / y_max) * (height - top - bottom)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
           'font-family="sans-serif" font-size="12">',
           f'<rect width="{width}" height="{height}" fill="white"/>',
           f'<text x="{left}" y="22" font-size="14">Distance error within 10 mm of the surface '
           '(partial-volume phantoms, 20 HU noise)</text>']
    for v in [0, 0.3, 0.6, 0.9, 1.2, 1.5, 1.8]:
        y = y_of(v)
        out.append(f'<line x1="{left}" y1="{y:.1f}" x2="{width - right}" y2="{y:.1f}" stroke="#ddd"/>')
        out.append(f'<text x="{left - 8}" y="{y + 4:.1f}" text-anchor="end">{v:.1f}</text>')
    for h in [1, 2, 3]:
        x = x_of(h)
        out.append(f'<text x="{x:.1f}" y="{height - bottom + 18}" text-anchor="middle">{h} mm</text>')
    out.append(f'<text x="{(left + width - right) / 2}" y="{height - 15}" text-anchor="middle">'
               'voxel size</text>')
    out.append(f'<text x="18" y="{(top + height - bottom) / 2}" text-anchor="middle" '
               f'transform="rotate(-90 18 {(top + height - bottom) / 2})">error (mm)</text>')
    # The goal at 3 mm.
    for goal, label in [(0.25, "goal RMS 0.25"), (0.6, "goal max 0.6")]:
        y = y_of(goal)
        out.append(f'<line x1="{x_of(2.8):.1f}" y1="{y:.1f}" x2="{x_of(3.2):.1f}" y2="{y:.1f}" '
                   'stroke="black" stroke-dasharray="2,2"/>')
    series = []
    for shape, dash in [("sphere", ""), ("slab", "6,3")]:
        for method, colour, col in [("mask", "#c0392b", (2, 3)), ("subvoxel", "#2471a3", (4, 5)),
                                    ("projected", "#1e8449", (6, 7))]:
            for stat, idx, marker in [("RMS", col[0], "circle"), ("max", col[1], "square")]:
                pts = sorted((r[1], r[idx]) for r in rows if r[0] == shape and r[idx] is not None)
                if pts:
                    series.append((f"{method} {stat}, {shape}", colour, dash, marker, pts))
    for i, (name, colour, dash, marker, pts) in enumerate(series):
        path = " ".join(f"{x_of(h):.1f},{y_of(v):.1f}" for h, v in pts)
        dash_attr = f' stroke-dasharray="{dash}"' if dash else ""
        out.append(f'<polyline points="{path}" fill="none" stroke="{colour}" stroke-width="1.5"{dash_attr}/>')
        for h, v in pts:
            x, y = x_of(h), y_of(v)
            if marker == "circle":
                out.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="3" fill="{colour}"/>')
            else:
                out.append(f'<rect x="{x - 3:.1f}" y="{y - 3:.1f}" width="6" height="6" fill="{colour}"/>')
        ly = top + 10 + i * 18
        lx = width - right + 15
        out.append(f'<line x1="{lx}" y1="{ly}" x2="{lx + 24}" y2="{ly}" stroke="{colour}" '
                   f'stroke-width="1.5"{dash_attr}/>')
        out.append(f'<text x="{lx + 30}" y="{ly + 4}">{name}</text>')
    out.append("</svg>")
    with open(sys.argv[1], "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
