#!/usr/bin/python3
"""Data shaping and summary numbers for tests/bench/paper_figures.sh (the paper's Fig. 4, 5).

  paper_figures.py add-speed FORCE.csv TRAJ.csv OUT.csv
      The force CSV with a speed column (mm/s, the device point's, from the trajectory).
  paper_figures.py fig4 OUT.csv SUMMARY.txt TOOL=FORCE.csv ...
      One table for the chart (every 5th row): tool,t,f_lateral,f_total,f_normal,depth,speed
      (speed empty unless the force CSV has it). Summary: the largest difference of the device
      force between the first tool and each other, tick by tick.
  paper_figures.py ramp-stats SUMMARY.txt FORCE.csv LABEL
      Mean lateral friction and |f| per 1 mm indentation bin, with the law's k z*.
  paper_figures.py speed-stats SUMMARY.txt FORCE.csv TRAJ.csv LABEL
      Friction at the end of each constant-speed segment.
  paper_figures.py fig5a OUT.csv SUMMARY.txt LABEL FORCE.csv FORCE_NOBONE.csv BONE.csv TRAJ.csv
      One table for the charts (every 10th row): t,f_normal,f_bone,f_lateral,f_total,depth,
      rib_pct,bone_dist,over_rib. f_bone = f_normal - f_normal without bone terms (the pressing
      force the ribs add). Summary: forces over ribs against between them, peaks of the bone
      term and whether they lie over ribs.
  paper_figures.py fig5b OUT.csv TICKS.csv
      Adds a finger column (1 for finger tools) for the chart.

Needs numpy (Debian python3-numpy). The numbers go to SUMMARY.txt as "key value" lines.
"""
import csv
import sys

import numpy as np

K_FINGER = 0.4  # N/mm
C_FINGER = 2.0  # mm/N


def read(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    cols = {}
    for i, name in enumerate(header):
        vals = []
        for r in body:
            try:
                vals.append(float(r[i]) if r[i] != "" else np.nan)
            except ValueError:
                vals.append(np.nan)
        cols[name] = np.array(vals)
    return cols


def write(path, header, columns, every=1, text_cols=None, fmt="%.6g"):
    text_cols = text_cols or {}
    n = len(columns[0])
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for i in range(0, n, every):
            w.writerow([c[i] if h in text_cols else fmt % c[i] for h, c in zip(header, columns)])


def surface_force(d):
    d = np.maximum(d, 0.0)
    return ((1.78e-2 * d + 3.82e-3) * d + 2.28e-4) * d


def breakaway(z_max):
    """z* with alpha(z*) z* = 1 (alpha of the spec's step 8), by bisection."""
    zs = z_max - 1.0
    lo, hi = z_max, 10.0 * z_max + 10.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        a = (1.0 / z_max) / (1.0 + (zs / mid) ** 8)
        if a * mid > 1.0:
            hi = mid
        else:
            lo = mid
    return hi


def total(c):
    return np.sqrt(c["fx"] ** 2 + c["fy"] ** 2 + c["fz"] ** 2)


def fig4(out, summary, pairs):
    tools, runs = [], []
    for p in pairs:
        tool, path = p.split("=", 1)
        tools.append(tool)
        runs.append(read(path))
    ref = runs[0]
    lines = []
    col = {h: [] for h in ["tool", "t", "f_lateral", "f_total", "f_normal", "depth", "speed"]}
    for tool, c in zip(tools, runs):
        n = len(c["t"])
        dev = np.max(np.sqrt((c["fx"] - ref["fx"]) ** 2 + (c["fy"] - ref["fy"]) ** 2 +
                             (c["fz"] - ref["fz"]) ** 2))
        lines.append("max_force_diff_vs_%s_N[%s] %.3g" % (tools[0], tool, dev))
        ft = total(c)
        col["tool"] += [tool] * n
        col["t"] += list(c["t"])
        col["f_lateral"] += list(c["f_lateral"])
        col["f_total"] += list(ft)
        col["f_normal"] += list(c["f_normal"])
        col["depth"] += list(c["depth"])
        col["speed"] += list(c.get("speed", np.full(n, np.nan)))
    header = list(col.keys())
    write(out, header, [col[h] for h in header], every=5, text_cols={"tool"})
    with open(summary, "a") as f:
        f.write("\n".join(lines) + "\n")


def fig4_ramp_stats(summary, force_csv, label):
    """Friction per 1 mm indentation bin of the slide-ramp run, and the law's k z*."""
    c = read(force_csv)
    lines = []
    ft = total(c)
    for lo in range(0, 6):
        m = (c["depth"] >= lo + 0.25) & (c["depth"] < lo + 0.75) & (c["n_contact"] > 0)
        if not m.any():
            continue
        d = 0.5 + lo
        z_max = C_FINGER * surface_force(d) + 1.0
        lines.append("%s_depth_%.1fmm f_lateral %.3f N (law k*z* %.3f N), |f| %.3f N, f_s %.3f N" %
                     (label, d, np.mean(c["f_lateral"][m]), K_FINGER * breakaway(z_max),
                      np.mean(ft[m]), surface_force(d)))
    with open(summary, "a") as f:
        f.write("\n".join(lines) + "\n")


def fig4_speed_stats(summary, force_csv, traj_csv, label):
    """Sliding friction in each speed segment of the slide-speed run (its last 0.2 s)."""
    c = read(force_csv)
    tr = read(traj_csv)
    pos = np.stack([tr["px"], tr["py"], tr["pz"]], axis=1)
    v = np.zeros(len(tr["t"]))
    v[1:] = np.linalg.norm(np.diff(pos, axis=0), axis=1) / np.diff(tr["t"])
    lines = []
    # Segments of constant speed (rounded to 0.1 mm/s), at least 0.3 s long.
    vr = np.round(v, 1)
    start = 0
    for i in range(1, len(vr) + 1):
        if i == len(vr) or vr[i] != vr[start]:
            if c["t"][i - 1] - c["t"][start] >= 0.3 and vr[start] > 0:
                m = (c["t"] > c["t"][i - 1] - 0.2) & (c["t"] <= c["t"][i - 1])
                lines.append("%s_segment_t%.2f-%.2fs speed %.1f mm/s f_lateral %.3f N, |f| %.3f N" %
                             (label, c["t"][start], c["t"][i - 1], vr[start],
                              np.mean(c["f_lateral"][m]), np.mean(total(c)[m])))
            start = i
    with open(summary, "a") as f:
        f.write("\n".join(lines) + "\n")
    return v


def add_speed(force_csv, traj_csv, out):
    """Copies a force CSV adding the pad speed (mm/s) from the trajectory."""
    c = read(force_csv)
    tr = read(traj_csv)
    pos = np.stack([tr["px"], tr["py"], tr["pz"]], axis=1)
    v = np.zeros(len(tr["t"]))
    v[1:] = np.linalg.norm(np.diff(pos, axis=0), axis=1) / np.diff(tr["t"])
    header = list(c.keys()) + ["speed"]
    write(out, header, [c[h] for h in c] + [v], fmt="%.17g")


def runs_of(mask):
    """[start, end) index pairs of the True runs of a boolean array."""
    out, i, n = [], 0, len(mask)
    while i < n:
        if mask[i]:
            j = i
            while j < n and mask[j]:
                j += 1
            out.append((i, j))
            i = j
        else:
            i += 1
    return out


def fig5a(out, summary, label, force_csv, nobone_csv, bone_csv, traj_csv):
    c, nb, b = read(force_csv), read(nobone_csv), read(bone_csv)
    f_bone = c["f_normal"] - nb["f_normal"]
    ft = total(c)
    rib_pct = 100.0 * b["bone_cover"]
    over = b["bone_cover"] >= 0.5
    # The slide: all points in contact, away from the press and the lift.
    t = c["t"]
    full = c["n_contact"] == np.nanmax(c["n_contact"])
    slide = full & (t > t[np.argmax(full)] + 0.3) & (t < t[len(t) - 1 - np.argmax(full[::-1])] - 0.3)
    lines = []
    s_over, s_free = slide & over, slide & (b["bone_cover"] == 0.0)
    lines.append("%s slide %.2f-%.2f s, %d ticks; pad over a rib (>= 50%% of points above bone "
                 "within 30 mm) on %d, over no bone on %d" %
                 (label, t[slide][0], t[slide][-1], slide.sum(), s_over.sum(), s_free.sum()))
    lines.append("%s pad depth on the slide: mean %.2f mm, min %.2f, max %.2f (nominal 5)" %
                 (label, np.mean(c["depth"][slide]), np.min(c["depth"][slide]),
                  np.max(c["depth"][slide])))
    for name, arr in [("f_normal", c["f_normal"]), ("f_bone", f_bone), ("f_total", ft),
                      ("f_lateral", c["f_lateral"])]:
        lines.append("%s %s mean over ribs %.3f N, over no bone %.3f N, ratio %.2f" %
                     (label, name, np.mean(arr[s_over]) if s_over.any() else np.nan,
                      np.mean(arr[s_free]) if s_free.any() else np.nan,
                      (np.mean(arr[s_over]) / np.mean(arr[s_free]))
                      if s_over.any() and s_free.any() else np.nan))
    # Rib crossings from the bone map alone: local minima of the distance from the pad centre to
    # the nearest bone (prominence 1 mm). Force peaks: local maxima of the bone term (prominence
    # 0.05 N). A force peak "over a rib" lies within 0.15 s (3 mm of travel) of a crossing.
    from scipy.signal import find_peaks
    ts, dist = t[slide], b["bone_dist_mm"][slide]
    ribs, _ = find_peaks(-dist, prominence=1.0)
    gaps, _ = find_peaks(dist, prominence=1.0)
    lines.append("%s rib crossings (nearest bone closest) at t = %s s, bone %s mm from the pad "
                 "centre; between ribs at t = %s s, %s mm" %
                 (label, " ".join("%.2f" % ts[i] for i in ribs),
                  " ".join("%.1f" % dist[i] for i in ribs),
                  " ".join("%.2f" % ts[i] for i in gaps), " ".join("%.1f" % dist[i] for i in gaps)))
    for name, arr in [("f_bone", f_bone), ("f_normal", c["f_normal"]),
                      ("f_lateral", c["f_lateral"])]:
        a = arr[slide]
        pk, _ = find_peaks(a, prominence=0.05)
        near = [min(abs(ts[p] - ts[r]) for r in ribs) <= 0.15 if len(ribs) else False for p in pk]
        at_ribs = [a[r] for r in ribs]
        at_gaps = [a[g] for g in gaps]
        lines.append("%s %s: %d peaks (prominence 0.05 N), %d of them within 0.15 s of a rib "
                     "crossing; at the crossings %s N, between ribs %s N%s; corr with "
                     "-bone distance %.2f" %
                     (label, name, len(pk), sum(near), " ".join("%.2f" % v for v in at_ribs),
                      " ".join("%.2f" % v for v in at_gaps),
                      ", rib/between ratio %.2f" % (np.mean(at_ribs) / np.mean(at_gaps))
                      if at_ribs and at_gaps else "", np.corrcoef(a, -dist)[0, 1]))
    corr_depth = np.corrcoef(c["f_normal"][slide], c["depth"][slide])[0, 1]
    lines.append("%s corr(f_normal, pad depth) on the slide %.2f" % (label, corr_depth))
    header = ["t", "f_normal", "f_bone", "f_lateral", "f_total", "depth", "rib_pct", "bone_dist",
              "over_rib"]
    cols = [t, c["f_normal"], f_bone, c["f_lateral"], ft, c["depth"], rib_pct, b["bone_dist_mm"],
            over.astype(float)]
    write(out, header, cols, every=10)
    with open(summary, "a") as f:
        f.write("\n".join(lines) + "\n")


def fig5b(out, ticks_csv):
    with open(ticks_csv, newline="") as f:
        rows = list(csv.reader(f))
    header = rows[0] + ["finger", "rate_p25_khz", "rate_p75_khz"]
    i25, i75 = rows[0].index("p25_ns"), rows[0].index("p75_ns")
    with open(out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for r in rows[1:]:
            w.writerow(r + ["1" if r[1].startswith("finger") else "0",
                            "%.1f" % (1e6 / float(r[i75])), "%.1f" % (1e6 / float(r[i25]))])


def main(argv):
    if len(argv) < 2:
        print(__doc__)
        return 2
    cmd = argv[1]
    if cmd == "fig4":
        fig4(argv[2], argv[3], argv[4:])
    elif cmd == "ramp-stats":
        fig4_ramp_stats(argv[2], argv[3], argv[4])
    elif cmd == "speed-stats":
        fig4_speed_stats(argv[2], argv[3], argv[4], argv[5])
    elif cmd == "add-speed":
        add_speed(argv[2], argv[3], argv[4])
    elif cmd == "fig5a":
        fig5a(*argv[2:9])
    elif cmd == "fig5b":
        fig5b(argv[2], argv[3])
    else:
        print(__doc__)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
