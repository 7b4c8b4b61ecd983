#!/usr/bin/env python3
"""The tables of docs/pulse.md (from study_pulse's pulse.csv) and of docs/devices.md "Which
devices can render the pulse" (from pulse_devices.csv beside it), printed as Markdown.

  tests/bench/pulse_tables.py build/studies/pulse.csv
"""
import csv
import math
import os
import sys


def num(text):
    try:
        return float(text)
    except ValueError:
        return math.nan


def rng(values, fmt):
    values = [v for v in values if not math.isnan(v)]
    if not values:
        return "—"
    lo, hi = min(values), max(values)
    return fmt % lo if fmt % lo == fmt % hi else (fmt % lo) + "–" + (fmt % hi)


def seconds(v):
    if math.isnan(v):
        return "—"
    return "%.0f s" % v if v >= 20 else "%.1f s" % v


def per_profile(rows):
    print("| profile | rate | limits held | pulse written (known) | controller acted: known / main's "
          "| late lift vs off: known / main's | no pulse: E < 0 from |")
    print("|---|---|---|---|---|---|---|")
    keys = []
    for r in rows:
        k = (r["profile"], r["rate_hz"])
        if k not in keys:
            keys.append(k)
    for profile, rate in keys:
        mine = [r for r in rows if r["profile"] == profile and r["rate_hz"] == rate]
        pulse = [r for r in mine if num(r["amp_N"]) > 0]
        held = sum(1 for r in pulse if num(r["limits"]) == 1)
        known = [r for r in pulse if r["accounting"] == "known"]
        main = [r for r in pulse if r["accounting"] == "unknown"]
        acted = lambda rs: "%d/%d" % (sum(1 for r in rs if num(r["pc_ticks"]) > 0), len(rs))
        negative = []
        for r in mine:
            if num(r["amp_N"]) == 0 and r["accounting"] == "known":
                s = num(r["energy_negative_s"])
                if not math.isnan(s):
                    negative.append("%s (%g N)" % (seconds(s), num(r["preload_N"])))
        print("| %s | %s kHz | %d/%d | %s | %s / %s | %s / %s | %s |" % (
            profile, "%g" % (num(rate) / 1000), held, len(pulse),
            rng([num(r["active_ratio"]) for r in known], "%.4f"), acted(known), acted(main),
            rng([num(r["late_vs_off"]) for r in known], "%.2f"),
            rng([num(r["late_vs_off"]) for r in main], "%.2f"),
            ", ".join(negative) if negative else "never"))


def pulse_rows(rows):
    print("| profile | preload | A (N) | force / step | written | lift (× expected) | late vs off "
          "| E min / drift / < 0 | pc | main's lift | main's vs off | main's < 0 / pc |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    profiles = []
    for r in rows:
        if r["profile"] not in profiles:
            profiles.append(r["profile"])
    shown = [r for r in rows if r["rate_hz"] == "1000" and r["accounting"] == "known"
             and num(r["amp_N"]) > 0 and r["scenario"] != "clamp"]
    shown.sort(key=lambda r: (profiles.index(r["profile"]), num(r["preload_N"]), num(r["amp_N"])))
    for r in shown:
        m = next(x for x in rows if x["accounting"] == "unknown" and all(
            x[c] == r[c] for c in ("profile", "rate_hz", "scenario", "amp_N")))
        expected = num(r["lift_expected_mm"])
        print("| %s | %s | %g | %.2f / %.2f | %.4f | %.3f (%.2f) | %.2f | %.2f / %.3f / %s | %d "
              "| %.3f | %.2f | %s / %d |" % (
                  r["profile"], "%g N" % num(r["preload_N"]), num(r["amp_N"]), num(r["max_force_N"]),
                  num(r["max_step_N"]) / num(r["step_bound_N"]), num(r["active_ratio"]),
                  num(r["lift_early_mm"]), num(r["lift_early_mm"]) / expected,
                  num(r["late_vs_off"]), num(r["energy_min_mJ"]),
                  num(r["energy_drift_mJ_per_beat"]), seconds(num(r["energy_negative_s"])),
                  num(r["pc_ticks"]), num(m["lift_early_mm"]), num(m["late_vs_off"]),
                  seconds(num(m["energy_negative_s"])), num(m["pc_ticks"])))


def devices(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    amps = []
    for r in rows:
        if r["amp_N"] not in amps:
            amps.append(r["amp_N"])
    print("| profile | max force | preload | " + " | ".join("%s N" % a for a in amps) + " |")
    print("|---|---|---|" + "---|" * len(amps))
    keys = []
    for r in rows:
        k = (r["profile"], r["max_force_N"], r["preload_N"])
        if k not in keys:
            keys.append(k)
    for profile, max_force, preload in keys:
        cells = []
        for a in amps:
            r = next(x for x in rows if (x["profile"], x["max_force_N"], x["preload_N"],
                                          x["amp_N"]) == (profile, max_force, preload, a))
            ratio = num(r["study_lift_ratio"])
            study = r["study_verdict"] if math.isnan(ratio) else "%s (%.3g)" % (
                r["study_verdict"], ratio)
            cells.append(r["verdict"] if r["study_verdict"] == "n/a" else
                         "%s; study %s" % (r["verdict"], study))
        print("| %s | %g N | %s N | %s |" % (profile, num(max_force), preload, " | ".join(cells)))


def main():
    if len(sys.argv) != 2 or sys.argv[1] in ("-h", "--help"):
        print(__doc__.strip())
        return 0 if len(sys.argv) == 2 else 2
    with open(sys.argv[1], newline="") as f:
        rows = list(csv.DictReader(f))
    per_profile(rows)
    print()
    pulse_rows(rows)
    beside = os.path.join(os.path.dirname(sys.argv[1]), "pulse_devices.csv")
    if os.path.exists(beside):
        print()
        devices(beside)
    return 0


if __name__ == "__main__":
    sys.exit(main())
