#!/usr/bin/env python3
"""Where a tick-time tail comes from: reads `palp bench --ticks-csv FILE` and prints the
percentiles per tick status, the share of slow ticks (above the median plus --excess-ns) and the
time between them, which tells a periodic disturbance of the machine (regular gaps, any pose)
from work of the model (tied to statuses or poses)."""
import argparse
import collections
import csv
import sys


def percentile(sorted_values, q):
    if not sorted_values:
        return float("nan")
    i = min(len(sorted_values) - 1, max(0, int(round(q * len(sorted_values) + 0.5)) - 1))
    return sorted_values[i]


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("csv", help="the file palp bench --ticks-csv wrote")
    ap.add_argument("--excess-ns", type=float, default=500.0,
                    help="a tick is slow when it takes this much more than the median (default 500)")
    a = ap.parse_args()
    rows = []
    with open(a.csv, newline="") as f:
        for r in csv.DictReader(f):
            rows.append((int(r["tick"]), int(r["pose"]), int(r["ns"]), int(r["status"])))
    if not rows:
        sys.exit("tick_tail: no rows in " + a.csv)
    ns = sorted(r[2] for r in rows)
    p50 = percentile(ns, 0.5)
    print(f"{len(rows)} ticks: p50 {p50} ns, p90 {percentile(ns, 0.9)}, p99 {percentile(ns, 0.99)}, "
          f"p99.9 {percentile(ns, 0.999)}, max {ns[-1]}")
    by_status = collections.defaultdict(list)
    for r in rows:
        by_status[r[3]].append(r[2])
    for status, v in sorted(by_status.items()):
        v.sort()
        print(f"  status {status:#x}: {len(v)} ticks, p50 {percentile(v, 0.5)}, p99 {percentile(v, 0.99)}")
    limit = p50 + a.excess_ns
    slow_at, t = [], 0.0
    for r in rows:
        if r[2] > limit:
            slow_at.append(t)
        t += r[2]
    share = len(slow_at) / len(rows)
    print(f"slow ticks (> {limit:.0f} ns): {len(slow_at)} = {100 * share:.2f} % of ticks")
    if len(slow_at) > 1:
        gaps = sorted((b - a_) / 1000.0 for a_, b in zip(slow_at, slow_at[1:]))
        print(f"  time between them (summed tick times, us): p10 {percentile(gaps, 0.1):.0f}, "
              f"p50 {percentile(gaps, 0.5):.0f}, p90 {percentile(gaps, 0.9):.0f}")
        common = collections.Counter(round(g / 5) * 5 for g in gaps).most_common(5)
        print("  most common gaps (us, 5 us bins): " +
              ", ".join(f"{g:.0f} ({n})" for g, n in common))
        slow_ns = sorted(r[2] - p50 for r in rows if r[2] > limit)
        print(f"  their excess over the median: p50 {percentile(slow_ns, 0.5):.0f} ns, "
              f"p90 {percentile(slow_ns, 0.9):.0f} ns")
        poses = collections.Counter(r[1] * 20 // (max(x[1] for x in rows) + 1) for r in rows
                                    if r[2] > limit)
        print("  slow ticks per twentieth of the path: " +
              " ".join(str(poses.get(i, 0)) for i in range(20)))


if __name__ == "__main__":
    main()
