#!/usr/bin/python3
"""Helpers for tests/bench/palpd_fanout.sh and palpd_netem.sh (standard library only).

  palpd_bench.py stall HOST PORT SECONDS     connect, say Hello, never read (tiny receive buffer)
  palpd_bench.py garbage HOST PORT SECONDS   random bytes, bad prefixes, undecodable messages
                                             after a Hello; reconnects when dropped
  palpd_bench.py link TUN_A TUN_B SECONDS DELAY_MS LOSS_PCT [SEED]
                                             a point-to-point link between two TUN devices that
                                             delays every packet and drops a fraction of them in
                                             each direction (netem's "delay D loss L" on both ends)
  palpd_bench.py summary NAME STATS_JSON PROBE_JSON...
                                             one table row: misses, lateness, latency, delivery
  palpd_bench.py hog SECONDS                 a CPU hog: spins for SECONDS (pin it with taskset)
  palpd_bench.py wake-table RESULTS_JSONL    palpd_wake.sh's rows as one Markdown table: per
                                             case and variant the median and the worst of the
                                             repeats (misses, lateness, latency, CPU)

Every mode is bounded by its SECONDS (and the garbage client by a message count as well).
"""
import fcntl
import json
import os
import random
import select
import signal
import socket
import struct
import sys
import time
from collections import deque


def varint(n):
    out = bytearray()
    while True:
        b = n & 0x7F
        n >>= 7
        if n:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


def frame(body):
    return varint(len(body)) + body


def hello(name):
    # palp.v1.Hello{protocol_version=1, role=OBSERVER, client_name=name} in ClientMessage.hello
    n = name.encode()
    h = b"\x08\x01\x10\x01\x22" + varint(len(n)) + n
    return frame(b"\x0a" + varint(len(h)) + h)


def stall(host, port, seconds):
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    s.connect((host, port))
    s.sendall(hello("bench-stalled"))
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        time.sleep(0.2)
    s.close()
    print(json.dumps({"mode": "stall", "seconds": seconds}))


def garbage(host, port, seconds, max_messages=200000):
    rng = random.Random(7)
    end = time.monotonic() + seconds
    sent = connections = refused = 0
    while time.monotonic() < end and sent < max_messages:
        try:
            s = socket.create_connection((host, port), timeout=1.0)
        except OSError:
            refused += 1
            time.sleep(0.05)
            continue
        connections += 1
        s.setblocking(False)
        kind = connections % 3
        try:
            if kind == 0:  # noise before any Hello: the server refuses and closes
                s.send(bytes(rng.getrandbits(8) for _ in range(64)))
                sent += 1
            else:  # a Hello, then undecodable messages (not fatal) ...
                s.send(hello("bench-garbage"))
                for _ in range(200):
                    if time.monotonic() >= end:
                        break
                    body = bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 40)))
                    s.send(frame(body))
                    sent += 1
                    try:
                        while s.recv(65536):
                            pass
                    except BlockingIOError:
                        pass
                    time.sleep(0.001)
                if kind == 2:  # ... and finally a bad length prefix (fatal)
                    s.send(b"\xff" * 11)
                    sent += 1
        except OSError:
            pass
        s.close()
    print(json.dumps({"mode": "garbage", "messages": sent, "connections": connections,
                      "refused": refused}))


TUNSETIFF = 0x400454CA
IFF_TUN = 0x0001
IFF_NO_PI = 0x1000


def open_tun(name):
    fd = os.open("/dev/net/tun", os.O_RDWR | os.O_NONBLOCK)
    fcntl.ioctl(fd, TUNSETIFF, struct.pack("16sH22x", name.encode(), IFF_TUN | IFF_NO_PI))
    return fd


def link(tun_a, tun_b, seconds, delay_ms, loss_pct, seed=1):
    rng = random.Random(seed)
    fa, fb = open_tun(tun_a), open_tun(tun_b)
    delay = delay_ms * 1e-3
    loss = loss_pct / 100.0
    # per direction: the fd to write to and (due time, packet) in arrival order
    queues = {fa: (fb, deque()), fb: (fa, deque())}
    counts = {"a_to_b": [0, 0], "b_to_a": [0, 0]}  # [forwarded, dropped]
    print("ready", flush=True)
    end = time.monotonic() + seconds
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))  # report the counts, then exit
    while not stop:
        now = time.monotonic()
        if now >= end:
            break
        due = min((q[0][0] for _, q in queues.values() if q), default=now + 0.05)
        readable, _, _ = select.select([fa, fb], [], [], max(0.0, min(due, end) - now))
        now = time.monotonic()
        for fd in readable:
            key = "a_to_b" if fd == fa else "b_to_a"
            while True:
                try:
                    packet = os.read(fd, 65536)
                except BlockingIOError:
                    break
                if rng.random() < loss:
                    counts[key][1] += 1
                else:
                    queues[fd][1].append((now + delay, packet))
        for src, (dst, q) in queues.items():
            while q and q[0][0] <= now:
                _, packet = q.popleft()
                try:
                    os.write(dst, packet)
                    counts["a_to_b" if src == fa else "b_to_a"][0] += 1
                except OSError:
                    pass
    print(json.dumps({"mode": "link", "delay_ms": delay_ms, "loss_pct": loss_pct,
                      "forwarded_dropped": counts}), flush=True)


def last_json(path):
    line = "{}"
    with open(path) as f:
        for text in f:
            if text.startswith("{"):
                line = text
    return json.loads(line)


def summary(name, stats_path, probe_paths):
    st = json.load(open(stats_path))
    probes = [last_json(p) for p in probe_paths]
    ok = [p for p in probes if p.get("frames")]
    lat = [p["latency_us"]["p99"] for p in ok if p["latency_us"]["p99"] is not None]
    row = {
        "scenario": name,
        "rate_hz": st["rate_hz"],
        "ticks": st["ticks"],
        "overruns": st["overruns"],
        "miss_pct": 100.0 * st["deadline_miss_fraction"],
        "faults": st["faults"],
        "late_p99_us_at_most": st["lateness_us"]["p99_at_most"],
        "late_max_us": st["lateness_us"]["max"],
        "observers": len(probes),
        "observers_ok": sum(1 for p in probes if p.get("ok")),
        "latency_p99_us_max": max(lat) if lat else None,
        "latency_p99_us_median": sorted(lat)[len(lat) // 2] if lat else None,
        "delivered_min": min((p.get("delivered", 0.0) for p in probes), default=0.0),
        "frames_per_s_min": min((p.get("frames_per_s", 0.0) for p in probes), default=0.0),
        "max_interval_ms": max((p.get("max_interval_ms") or 0.0 for p in probes), default=0.0),
        "frames_dropped": st["frames_dropped"],
        "protocol_errors": st["protocol_errors"],
        "clients_rejected": st["clients_rejected"],
        "timeouts": st["timeouts"],
    }
    wake = st.get("wake")
    if wake:  # palpd with the wake-up counters (issue 18)
        elapsed = st["elapsed_s"] or 1.0
        row.update({
            "wake_mode": wake["mode"],
            "spin_window_us": wake["spin_window_us"],
            "spin_cpu_pct": 100.0 * wake["spin_cpu_fraction"],
            "loop_cpu_pct": 100.0 * wake["loop_cpu_fraction"],
            "wake_p99_us_at_most": wake["latency_p99_us_at_most"],
            "wake_max_us": wake["latency_max_us"],
            "palpd_cpu_pct": 100.0 * st.get("process_cpu_s", 0.0) / elapsed,
            "net_signals": st.get("net_signals"),
            "net_wakeups": st.get("net_wakeups"),
        })
    print(json.dumps(row))


def hog(seconds):
    end = time.monotonic() + seconds
    n = 0
    while time.monotonic() < end:
        n += 1
    print(json.dumps({"mode": "hog", "seconds": seconds, "loops": n}))


def wake_table(path):
    rows = [json.loads(line) for line in open(path) if line.strip()]
    groups = {}
    for r in rows:
        groups.setdefault((r["case"], r["variant"]), []).append(r)

    def med(v):
        v = sorted(x for x in v if x is not None)
        if not v:
            return None
        n = len(v)
        return v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2])

    def worst(v):
        v = [x for x in v if x is not None]
        return max(v) if v else None

    def f(v, d=1):
        return "n/a" if v is None else f"{v:.{d}f}"

    def mw(rs, key, d=1):
        v = [r.get(key) for r in rs]
        return f"{f(med(v), d)} ({f(worst(v), d)})"

    print("| case | variant | runs | misses % median (worst) | faults | lateness max us median "
          "(worst) | wake-up p99 us | latency p99 us median (worst observer, worst run) | "
          "min delivered | palpd CPU % | loop thread CPU % (spinning) | spin window us | "
          "load |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for (case, variant), rs in groups.items():
        print(f"| {case} | {variant} | {len(rs)} | {mw(rs, 'miss_pct', 3)} | "
              f"{sum(r['faults'] for r in rs)} | {mw(rs, 'late_max_us', 0)} | "
              f"<= {f(med([r.get('wake_p99_us_at_most') for r in rs]), 0)} | "
              f"{mw(rs, 'latency_p99_us_max', 0)} | "
              f"{f(min(r['delivered_min'] for r in rs), 4)} | "
              f"{f(med([r.get('palpd_cpu_pct') for r in rs]))} | "
              f"{f(med([r.get('loop_cpu_pct') for r in rs]))} "
              f"({f(med([r.get('spin_cpu_pct') for r in rs]))}) | "
              f"{f(med([r.get('spin_window_us') for r in rs]), 0)} | "
              f"{f(med([r.get('load1') for r in rs]), 2)} |")


def main(argv):
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    mode = argv[1]
    if mode == "stall":
        stall(argv[2], int(argv[3]), float(argv[4]))
    elif mode == "garbage":
        garbage(argv[2], int(argv[3]), float(argv[4]))
    elif mode == "link":
        link(argv[2], argv[3], float(argv[4]), float(argv[5]), float(argv[6]),
             int(argv[7]) if len(argv) > 7 else 1)
    elif mode == "summary":
        summary(argv[2], argv[3], argv[4:])
    elif mode == "hog":
        hog(float(argv[2]))
    elif mode == "wake-table":
        wake_table(argv[2])
    else:
        print(__doc__, file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
