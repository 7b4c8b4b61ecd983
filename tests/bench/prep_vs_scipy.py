#!/usr/bin/python3
"""Side-by-side timing of `palp prep` against scipy's distance_transform_edt.

Case A (the issue's speed target): a 384x384x160 torso phantom at 0.8x0.8x1.5 mm.
  palp:  the whole `palp prep FILE --out DIR --no-cache` (read CT, segment, both signed maps,
         write four .nii.gz), wall clock of the process.
  scipy: just the two signed maps of the same masks (four distance_transform_edt calls with the
         true anisotropic sampling, combined exactly as the spec defines D), masks already in
         memory. The two sets of maps are compared voxel for voxel inside the band.
Case B: a 512x512x400 torso phantom at 0.8x0.8x1.0 mm: the time of the two distance-map
  stages and the peak memory of the whole prep process, from prep.json.

Requires python3-numpy and python3-scipy (Debian packages); exits 0 with a message otherwise.
Usage: tests/bench/prep_vs_scipy.py [--palp build/server/palp] [--runs 5] [--work DIR]
Prints a Markdown table and writes the raw figures as JSON (--json FILE).
"""
import argparse
import gzip
import json
import os
import platform
import statistics
import subprocess
import sys
import time


def nifti_load(path):
    """Minimal NIfTI-1 reader (little endian, uint8 / float32 / int16) -> (array, spacing)."""
    import numpy as np

    with gzip.open(path, "rb") if path.endswith(".gz") else open(path, "rb") as f:
        raw = f.read()
    header = np.frombuffer(raw[:348], dtype=np.uint8)
    dims = np.frombuffer(raw[40:56], dtype="<i2")
    datatype = int(np.frombuffer(raw[70:72], dtype="<i2")[0])
    pixdim = np.frombuffer(raw[76:108], dtype="<f4")
    offset = int(np.frombuffer(raw[108:112], dtype="<f4")[0])
    dtype = {2: np.uint8, 4: np.int16, 16: np.float32}[datatype]
    nx, ny, nz = int(dims[1]), int(dims[2]), int(dims[3])
    data = np.frombuffer(raw[offset:], dtype=np.dtype(dtype).newbyteorder("<"), count=nx * ny * nz)
    del header
    # File order is i fastest: reshape to (k, j, i).
    return data.reshape(nz, ny, nx), (float(pixdim[3]), float(pixdim[2]), float(pixdim[1]))


def scipy_signed_maps(body, bone, sampling, band):
    """The two signed maps exactly as the spec defines them, via scipy; returns (maps, seconds)."""
    import numpy as np
    from scipy.ndimage import distance_transform_edt

    h = min(sampling)
    t0 = time.perf_counter()
    maps = []
    for mask in (body, bone):
        inside = mask != 0
        to_outside = distance_transform_edt(inside, sampling=sampling)
        to_inside = distance_transform_edt(~inside, sampling=sampling)
        d = np.where(inside, to_outside - h / 2, -(to_inside - h / 2))
        maps.append(np.clip(d, -band, band).astype(np.float32))
    return maps, time.perf_counter() - t0


def run(cmd):
    return subprocess.run(cmd, check=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


SURFACE = ["--surface", "mask"]  # set from --surface in main()


def timed_prep(palp, ct, out_dir, runs):
    walls, jsons = [], []
    for _ in range(runs):
        t0 = time.perf_counter()
        run([palp, "prep", ct, "--out", out_dir, "--no-cache", "--quiet"] + SURFACE)
        walls.append(time.perf_counter() - t0)
        with open(os.path.join(out_dir, "prep.json")) as f:
            jsons.append(json.load(f))
    return walls, jsons


def machine():
    model = ""
    try:
        with open("/proc/cpuinfo") as f:
            model = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    # the kernel's transparent huge pages decide much of prep's time (docs/benchmarks.md)
    thp = "unknown"
    try:
        with open("/sys/kernel/mm/transparent_hugepage/enabled") as f:
            text = f.read()
        thp = text[text.index("[") + 1 : text.index("]")]
    except (OSError, ValueError):
        pass
    return (f"{platform.system()} {platform.release()}, {os.cpu_count()} cores, {model}, "
            f"transparent huge pages: {thp}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--palp", default="build/server/palp")
    ap.add_argument("--runs", type=int, default=5, help="timed runs of each measurement (median)")
    ap.add_argument("--scipy-runs", type=int, default=3)
    ap.add_argument("--work", default="/tmp/palp-bench")
    ap.add_argument("--json", default=None, help="write raw figures here")
    ap.add_argument("--skip-large", action="store_true", help="skip case B (512x512x400)")
    ap.add_argument("--surface", default="mask", choices=["mask", "subvoxel"],
                    help="palp prep's surface method (mask: its maps must equal scipy's voxel for voxel)")
    args = ap.parse_args()
    try:
        import numpy as np  # noqa: F401
        import scipy  # noqa: F401
    except ImportError:
        print("prep_vs_scipy: python3-numpy and python3-scipy are not installed; nothing measured")
        return 0
    import numpy as np

    os.makedirs(args.work, exist_ok=True)
    palp = os.path.abspath(args.palp)
    results = {"machine": machine(), "runs": args.runs}

    # Case A.
    ct_a = os.path.join(args.work, "torso_384x384x160.nii.gz")
    run([palp, "phantom", "torso", "--dims", "384x384x160", "--spacing", "0.8x0.8x1.5", "--out", ct_a])
    prep_a = os.path.join(args.work, "prep_384")
    SURFACE[1] = args.surface
    results["surface"] = args.surface
    run([palp, "prep", ct_a, "--out", prep_a, "--no-cache", "--quiet"] + SURFACE)  # warm-up (page cache, memory)
    walls, jsons = timed_prep(palp, ct_a, prep_a, args.runs)
    body, spacing = nifti_load(os.path.join(prep_a, "body.nii.gz"))
    bone, _ = nifti_load(os.path.join(prep_a, "bone.nii.gz"))
    band = jsons[-1]["parameters"]["distance_band_mm"]
    scipy_times = []
    for _ in range(args.scipy_runs):
        maps, seconds = scipy_signed_maps(body, bone, spacing, band)
        scipy_times.append(seconds)
    max_diff = 0.0
    for name, ref in zip(("d_surf", "d_bone"), maps):
        ours, _ = nifti_load(os.path.join(prep_a, name + ".nii.gz"))
        max_diff = max(max_diff, float(np.max(np.abs(ours.astype(np.float64) - ref))))
    del maps, body, bone, ours, ref  # free scipy's arrays before timing case B
    stage_median = {
        stage: statistics.median(j["timings_s"][stage] for j in jsons) for stage in jsons[-1]["timings_s"]
    }
    results["case_a"] = {
        "grid": "384x384x160 @ 0.8x0.8x1.5 mm",
        "palp_prep_wall_s": walls,
        "palp_prep_wall_median_s": statistics.median(walls),
        "palp_stage_median_s": stage_median,
        "palp_peak_memory_mib": jsons[-1]["peak_memory_bytes"] / 2**20,
        "scipy_two_maps_s": scipy_times,
        "scipy_two_maps_median_s": statistics.median(scipy_times),
        "speedup": statistics.median(scipy_times) / statistics.median(walls),
        "max_abs_difference_mm": max_diff,
    }

    # Case B.
    if not args.skip_large:
        ct_b = os.path.join(args.work, "torso_512x512x400.nii.gz")
        run([palp, "phantom", "torso", "--dims", "512x512x400", "--spacing", "0.8x0.8x1.0", "--out", ct_b])
        prep_b = os.path.join(args.work, "prep_512")
        walls_b, jsons_b = timed_prep(palp, ct_b, prep_b, args.runs)
        maps_s = [j["timings_s"]["d_surf"] + j["timings_s"]["d_bone"] for j in jsons_b]
        results["case_b"] = {
            "grid": "512x512x400 @ 0.8x0.8x1.0 mm",
            "both_maps_s": maps_s,
            "both_maps_median_s": statistics.median(maps_s),
            "first_run_both_maps_s": maps_s[0],
            "prep_wall_median_s": statistics.median(walls_b),
            "peak_memory_mib": [j["peak_memory_bytes"] / 2**20 for j in jsons_b],
            "stage_median_s": {
                stage: statistics.median(j["timings_s"][stage] for j in jsons_b)
                for stage in jsons_b[-1]["timings_s"]
            },
        }

    a = results["case_a"]
    print(f"machine: {results['machine']}")
    print("| case | palp | scipy | ratio |")
    print("|---|---|---|---|")
    print(
        f"| 384x384x160 @ 0.8x0.8x1.5 mm | whole prep {a['palp_prep_wall_median_s']:.2f} s "
        f"| two signed maps {a['scipy_two_maps_median_s']:.2f} s | {a['speedup']:.1f}x |"
    )
    print(f"max |palp - scipy| over both maps: {a['max_abs_difference_mm']:.2e} mm")
    print("palp stages (median s): " + ", ".join(f"{k} {v:.3f}" for k, v in a["palp_stage_median_s"].items()))
    if "case_b" in results:
        b = results["case_b"]
        print(
            f"512x512x400 @ 0.8x0.8x1.0 mm: both maps {b['both_maps_median_s']:.2f} s median "
            f"(first run {b['first_run_both_maps_s']:.2f} s), whole prep {b['prep_wall_median_s']:.2f} s, "
            f"peak memory {max(b['peak_memory_mib']):.0f} MiB"
        )
        print("  stages (median s): " + ", ".join(f"{k} {v:.3f}" for k, v in b["stage_median_s"].items()))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
