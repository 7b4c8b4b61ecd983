#!/usr/bin/env python3
"""Charts the bone mask's scores on the shared CT changed as other protocols change it
(docs/prep.md, "The shared CT changed as other protocols change it"): Dice, precision and rib
recall per case as bars, the unchanged CT's values as lines, the surface distance written beside.

Reads the Markdown rows build/tests/bone_robustness_test prints on stdin (the oral-contrast rows
included) and writes an SVG (no plotting library: the VM has none). Usage:
    build/tests/bone_robustness_test | \
        tests/bench/bone_robustness_chart.py docs/bench/bone_robustness.svg
"""
import html
import sys

METRICS = (("Dice", 2, "#1f77b4"), ("precision", 3, "#ff7f0e"), ("rib recall", 6, "#2ca02c"))


def read_rows(lines):
    rows = []
    for line in lines:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 8 or cells[0] in ("the shared CT", "") or cells[0].startswith("---"):
            continue
        try:
            values = [float(cells[i]) for i in (2, 3, 4, 5, 6)]
        except ValueError:
            continue
        rows.append((cells[0], cells[1], values))
    return rows


def main():
    if len(sys.argv) != 2 or sys.argv[1] in ("-h", "--help"):
        sys.exit(__doc__)
    rows = read_rows(sys.stdin)
    if not rows or rows[0][0] != "as it is":
        sys.exit("no result rows on stdin (the first must be 'as it is')")
    label_w, bar_w, right, top, row_h = 430, 420, 90, 50, 34
    lo, hi = 0.4, 1.0
    width = label_w + bar_w + right
    height = top + row_h * len(rows) + 66
    x_of = lambda v: label_w + (min(max(v, lo), hi) - lo) / (hi - lo) * bar_w
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
           'font-family="sans-serif" font-size="12">',
           f'<rect width="{width}" height="{height}" fill="white"/>',
           f'<text x="{width / 2}" y="20" text-anchor="middle" font-size="14">Bone mask on the '
           'shared CT changed as other protocols change it (against the expert labels)</text>']
    for t in (0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0):
        x = x_of(t)
        out.append(f'<line x1="{x}" y1="{top - 8}" x2="{x}" y2="{height - 61}" stroke="#ddd"/>')
        out.append(f'<text x="{x}" y="{height - 46}" text-anchor="middle">{t:.1f}</text>')
    base = rows[0][2]
    for name, column, colour in METRICS:
        x = x_of(base[column - 2])
        out.append(f'<line x1="{x}" y1="{top - 8}" x2="{x}" y2="{height - 61}" stroke="{colour}" '
                   'stroke-dasharray="4 3"/>')
    for r, (name, offset, v) in enumerate(rows):
        y = top + r * row_h
        out.append(f'<text x="{label_w - 8}" y="{y + row_h / 2 + 4}" text-anchor="end">'
                   f'{html.escape(name)}</text>')
        for m, (metric, column, colour) in enumerate(METRICS):
            value = v[column - 2]
            yy = y + 4 + m * 9
            out.append(f'<rect x="{label_w}" y="{yy}" width="{x_of(value) - label_w:.1f}" '
                       f'height="8" fill="{colour}"/>')
        out.append(f'<text x="{label_w + bar_w + 6}" y="{y + row_h / 2 + 4}">'
                   f'{v[3]:.2f} mm</text>')
    legend_y = height - 28
    x = label_w
    for metric, _, colour in METRICS:
        out.append(f'<rect x="{x}" y="{legend_y - 9}" width="10" height="10" fill="{colour}"/>')
        out.append(f'<text x="{x + 14}" y="{legend_y}">{metric}</text>')
        x += 110
    out.append(f'<text x="{label_w}" y="{legend_y + 18}">dashed lines: the CT as it is; '
               'right: mean symmetric surface distance</text>')
    out.append('</svg>')
    with open(sys.argv[1], "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
