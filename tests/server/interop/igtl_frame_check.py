#!/usr/bin/env python3
"""palpd's OpenIGTLink tool pose against the CT file's own affine, with no palp code on this side.

For each CT (torso phantoms written LPS, RAS and PIR by `palp phantom`, or files given with
--ct): reads the NIfTI header (gzip + struct: the sform, else the qform, maps voxel indices to
RAS, as in 3D Slicer and nibabel), runs palpd with --igtl-port and --record, reads the PalpTool
TRANSFORMs off the socket, and checks that each is a recorded tick's pose mapped by that affine:
translation = A (p / spacing), rotation = A3 diag(1/spacing) R(q). Pure Python (no numpy here).

usage: igtl_frame_check.py PALP PALPD WORKDIR [--ct FILE.nii.gz ...]
"""
import csv, gzip, math, os, re, shutil, socket, struct, subprocess, sys, time


def nifti_affine(path):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rb") as f:
        h = f.read(348)
    end = "<" if struct.unpack("<i", h[0:4])[0] == 348 else ">"
    pixdim = struct.unpack(end + "8f", h[76:108])
    qform_code, sform_code = struct.unpack(end + "hh", h[252:256])
    spacing = [abs(pixdim[1]), abs(pixdim[2]), abs(pixdim[3])]
    if sform_code > 0:
        rows = [list(struct.unpack(end + "4f", h[280 + 16 * r:296 + 16 * r])) for r in range(3)]
    elif qform_code > 0:
        b, c, d, qx, qy, qz = struct.unpack(end + "6f", h[256:280])
        a = math.sqrt(max(0.0, 1.0 - (b * b + c * c + d * d)))
        R = [[a*a+b*b-c*c-d*d, 2*(b*c-a*d), 2*(b*d+a*c)],
             [2*(b*c+a*d), a*a+c*c-b*b-d*d, 2*(c*d-a*b)],
             [2*(b*d-a*c), 2*(c*d+a*b), a*a+d*d-c*c-b*b]]
        qfac = -1.0 if pixdim[0] < 0 else 1.0
        scale = [spacing[0], spacing[1], spacing[2] * qfac]
        rows = [[R[r][k] * scale[k] for k in range(3)] + [(qx, qy, qz)[r]] for r in range(3)]
    else:
        raise SystemExit(path + ": no sform or qform")
    return rows, spacing


def quat_matrix(w, x, y, z):
    return [[1 - 2*(y*y+z*z), 2*(x*y-w*z), 2*(x*z+w*y)],
            [2*(x*y+w*z), 1 - 2*(x*x+z*z), 2*(y*z-w*x)],
            [2*(x*z-w*y), 2*(y*z+w*x), 1 - 2*(x*x+y*y)]]


def expected(A, spacing, row):
    p = [float(row["px"]) / spacing[0], float(row["py"]) / spacing[1], float(row["pz"]) / spacing[2]]
    t = [sum(A[r][k] * p[k] for k in range(3)) + A[r][3] for r in range(3)]
    Q = quat_matrix(*(float(row[k]) for k in ("qw", "qx", "qy", "qz")))
    rot = [[sum(A[r][k] / spacing[k] * Q[k][c] for k in range(3)) for c in range(3)] for r in range(3)]
    return rot, t


def read_tool_transforms(port, seconds):
    s = socket.create_connection(("127.0.0.1", port), timeout=5)
    buf, out, end = b"", [], time.time() + seconds
    while time.time() < end:
        chunk = s.recv(65536)
        if not chunk:
            break
        buf += chunk
        while len(buf) >= 58:
            _, kind, name, _, size, _ = struct.unpack(">H12s20sQQQ", buf[:58])
            if len(buf) < 58 + size:
                break
            body, buf = buf[58:58 + size], buf[58 + size:]
            if kind.rstrip(b"\0") == b"TRANSFORM" and name.rstrip(b"\0") == b"PalpTool":
                v = struct.unpack(">12f", body)
                out.append(([[v[0], v[3], v[6]], [v[1], v[4], v[7]], [v[2], v[5], v[8]]], v[9:12]))
    s.close()
    return out


def check(palpd, ct, work, cache):
    A, spacing = nifti_affine(ct)
    rec = os.path.join(work, os.path.basename(ct).split(".")[0] + ".palprec")
    log = open(os.path.join(work, "palpd.log"), "w+")
    env = dict(os.environ, PALP_SCENE_CACHE=cache)
    proc = subprocess.Popen([palpd, "--scene", ct, "--device", "sim", "--port", "0", "--igtl-port", "0",
                             "--no-realtime", "--duration", "5", "--record", rec],
                            stdout=log, stderr=subprocess.STDOUT, env=env)
    port = None
    for _ in range(600):
        log.seek(0)
        m = re.search(r"OpenIGTLink on 127\.0\.0\.1:(\d+)", log.read())
        if m:
            port = int(m.group(1))
            break
        if proc.poll() is not None:
            break
        time.sleep(0.1)
    if port is None:
        log.seek(0)
        raise SystemExit("palpd did not start:\n" + log.read())
    got = read_tool_transforms(port, 1.5)
    proc.wait(timeout=60)
    with open(rec[:-len(".palprec")] + ".csv") as f:
        rows = list(csv.DictReader(f))
    seqs = [int(r["seq"]) for r in rows]
    missing = sum(b - a - 1 for a, b in zip(seqs, seqs[1:]))
    wants = [expected(A, spacing, r) for r in rows]
    unmatched = 0
    for rot, t in got:
        ok = any(all(abs(t[i] - wt[i]) <= 1e-4 * max(1.0, abs(wt[i])) for i in range(3)) and
                 all(abs(rot[r][c] - wr[r][c]) <= 1e-5 for r in range(3) for c in range(3))
                 for wr, wt in wants)
        unmatched += not ok
    name = os.path.basename(ct)
    print(f"{name}: {len(got)} PalpTool transforms, {len(got) - unmatched} equal to a recorded tick "
          f"through the file's affine (recording missed {missing} ticks)")
    if len(got) < 10 or unmatched > missing or unmatched > len(got) // 10:
        raise SystemExit(f"{name}: FAILED: {unmatched} of {len(got)} transforms are no tick's pose")


def main():
    if len(sys.argv) < 4:
        raise SystemExit(__doc__)
    palp, palpd, work = sys.argv[1:4]
    shutil.rmtree(work, ignore_errors=True)  # palp never writes over a CT or a recording
    os.makedirs(work)
    cache = os.path.join(work, "cache")
    cts = sys.argv[sys.argv.index("--ct") + 1:] if "--ct" in sys.argv else []
    if not cts:
        for code in ("LPS", "RAS", "PIR"):
            ct = os.path.join(work, f"torso_{code}.nii.gz")
            subprocess.run([palp, "phantom", "torso", "--dims", "64x48x24", "--orientation", code,
                            "--out", ct], check=True, stdout=subprocess.DEVNULL,
                           env=dict(os.environ, PALP_SCENE_CACHE=cache))
            cts.append(ct)
    for ct in cts:
        check(palpd, ct, work, cache)


if __name__ == "__main__":
    main()
