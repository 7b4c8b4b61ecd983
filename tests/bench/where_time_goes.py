#!/usr/bin/env python3
"""Where a build's and a test run's time went, from the files ninja and ctest leave behind.

  tests/bench/where_time_goes.py BUILD_DIR

Reads BUILD_DIR/.ninja_log (each step's start and end, ms; the last entry per output) and
BUILD_DIR/Testing/Temporary/LastTest.log (each test's time). Prints the compile and link seconds
(CPU, summed over the parallel jobs) by area, the slowest steps, the test seconds by executable
or suite and the slowest tests. Wall time is not in these files: time the command itself.
"""
import collections
import os
import re
import sys


def area(output):
    if output.startswith("/"):
        return "outside the build tree"
    parts = output.split("/")
    if parts[0] == "tests":
        for name in ("bench", "adversarial", "fuzz"):
            if name in parts[:2]:
                return "tests/" + name
        return "tests (unit and end-to-end)"
    return parts[0]


def build(build_dir):
    path = os.path.join(build_dir, ".ninja_log")
    steps = {}
    seen = set()  # one step with several outputs (a link and its byproducts) is logged per output
    with open(path) as f:
        for line in f:
            if line.startswith("#"):
                continue
            start, end, _, output, command_hash = line.rstrip("\n").split("\t")
            if (start, end, command_hash) in seen:
                continue
            seen.add((start, end, command_hash))
            steps[output] = (int(end) - int(start)) / 1000.0
    compile_s = collections.Counter()
    compile_n = collections.Counter()
    link_s = 0.0
    link_n = 0
    for output, s in steps.items():
        if output.endswith((".o", ".gch")):
            compile_s[area(output)] += s
            compile_n[area(output)] += 1
        else:
            link_s += s
            link_n += 1
    total = sum(steps.values())
    print("build: %d steps, %.0f s of CPU in all" % (len(steps), total))
    print("| what | steps | CPU s |")
    print("|---|---|---|")
    for name, s in compile_s.most_common():
        print("| compile %s | %d | %.0f |" % (name, compile_n[name], s))
    print("| link and other steps | %d | %.0f |" % (link_n, link_s))
    print("\nslowest steps:")
    for output, s in sorted(steps.items(), key=lambda kv: -kv[1])[:10]:
        print("  %6.1f s  %s" % (s, output))


def tests(build_dir):
    path = os.path.join(build_dir, "Testing", "Temporary", "LastTest.log")
    if not os.path.exists(path):
        print("\nno %s: run ctest first" % path)
        return
    with open(path, errors="replace") as f:
        text = f.read()
    names = re.findall(r"\d+/\d+ Test: (\S+)", text)
    times = [float(t) for t in re.findall(r"Test time =\s+([\d.]+) sec", text)]
    pairs = sorted(zip(times, names), reverse=True)
    print("\ntests: %d, %.0f s summed over the parallel jobs" % (len(pairs), sum(times)))
    # CTest's names: EXECUTABLE:Suite (tests/tools/gtest_suites.cmake), or one name for a
    # program run whole (palpview_main_test, the fuzz pass)
    suites = collections.Counter()
    for t, n in pairs:
        suites[n.split(":")[0]] += t
    print("by executable (top 10):")
    for n, t in suites.most_common(10):
        print("  %6.1f s  %s" % (t, n))
    print("slowest tests:")
    for t, n in pairs[:10]:
        print("  %6.1f s  %s" % (t, n))


def main():
    if len(sys.argv) != 2 or sys.argv[1] in ("-h", "--help"):
        print(__doc__.strip())
        return 0 if len(sys.argv) == 2 else 2
    build(sys.argv[1])
    tests(sys.argv[1])
    return 0


if __name__ == "__main__":
    sys.exit(main())
