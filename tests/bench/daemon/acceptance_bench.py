#!/usr/bin/env python3
"""The acceptance benchmark of issue 5: a 50k-vertex scene sculpted by a
replayed recording for 30 s at 1 kHz, stats from sculptd's own --stats-json.

    acceptance_bench.py --sculptd BIN --scene S --recording R [--duration 30]
                        [--repeats 3] [--realtime both|on|off] [--config FILE]

Runs `sculptd --scene S --input replay:R --duration D --stats-json F`
(and the same with --realtime), `repeats` times each, and prints per run and
the medians: overruns, jitter p50/p99/max, stage times, vertices awake. Per
run it also prints why the overruns happened (the stats' overrun_causes, the
sim thread's faults and preemptions, the last overruns tick by tick) and the host's steal over the run: the `steal` column
of /proc/stat's `cpu` line (column 9, in USER_HZ ticks: 1/100 s) read before
and after, with the load average at the start. It prints numbers and asserts
nothing (timings are not tests); it fails only if sculptd fails or the replay
is not deterministic (same recording, different final mesh hash).
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile


def cpu_times():
    """/proc/stat's `cpu` line: every column by name (steal is column 9)."""
    with open("/proc/stat") as f:
        for l in f:
            if l.startswith("cpu "):
                cols = l.split()
                names = ["user", "nice", "system", "idle", "iowait", "irq", "softirq", "steal"]
                return {n: int(v) for n, v in zip(names, cols[1:])}
    return {}


def loadavg():
    with open("/proc/loadavg") as f:
        return f.read().split()[0]


def run(a, realtime, tmp, i):
    stats = os.path.join(tmp, f"stats-{realtime}-{i}.json")
    hash_out = os.path.join(tmp, f"hash-{realtime}-{i}")
    cmd = [a.sculptd, "--config", a.config, "--scene", a.scene, "--input", "replay:" + a.recording,
           "--duration", str(a.duration), "--stats-json", stats, "--hash-out", hash_out, "--log-level", "warning"]
    if realtime:
        cmd.append("--realtime")
    load = loadavg()
    before = cpu_times()
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=a.duration * 4 + 120)
    after = cpu_times()
    if r.returncode != 0:
        print(f"sculptd failed ({r.returncode}): {' '.join(cmd)}\n{r.stderr}", file=sys.stderr)
        sys.exit(1)
    with open(stats) as f:
        s = json.load(f)
    with open(hash_out) as f:
        s["hash"] = f.read().strip()
    s["warnings"] = [l for l in r.stderr.splitlines() if l.strip()]
    s["host"] = {"load": load, **{k: after.get(k, 0) - before.get(k, 0) for k in ("steal", "idle", "user", "system")}}
    return s


def line(s):
    st = s["stage_us"]
    return (f"ticks {s['ticks']} overruns {s['overruns']} jitter_us p50 {s['jitter_us']['p50']:.1f} "
            f"p99 {s['jitter_us']['p99']:.1f} max {s['jitter_us']['max']:.1f} | stage p50/p99/max us: "
            + " ".join(f"{k} {v['p50']:.1f}/{v['p99']:.1f}/{v['max']:.0f}" for k, v in st.items())
            + f" | vertices {s['vertices_total']} awake at end {s['vertices_awake']} blowups {s['blowups']}")


def attribution(s):
    """Why the run's overruns happened (older daemons lack the keys: say so)."""
    h = s["host"]
    host = (f"host: load {h['load']} at start; /proc/stat over the run (1/100 s, both CPUs): steal {h['steal']} "
            f"idle {h['idle']} user {h['user']} system {h['system']}")
    if "overrun_causes" not in s:
        return [host, "no overrun attribution in this sculptd's stats"]
    c, t = s["overrun_causes"], s["sim_thread"]
    out = [host,
           "overrun causes: " + " ".join(f"{k} {v}" for k, v in c.items())
           + f" | sim thread: minflt {t['minflt']} majflt {t['majflt']} nivcsw {t['nivcsw']}"
           + f" waits mid-tick {t.get('work_nvcsw', '?')}"
           + f" (without a page fault {t.get('work_nvcsw_no_fault', '?')})"]
    for r in s["recent_overruns"]:
        st = r["stage_us"]
        cause = r["cause"] + (" (off cpu)" if r["off_cpu"] else "")
        out.append(f"  tick {r['tick']} cpu {r['cpu']} {cause}: late {r['late_us']:.0f} us, "
                   + " ".join(f"{k} {v:.0f}" for k, v in st.items())
                   + f" us; on-cpu {r['work_cpu_us']:.0f} us, "
                   f"minflt {r['minflt']} majflt {r['majflt']} nivcsw {r['nivcsw']} "
                   f"waits {r.get('work_nvcsw', '?')} (without a page fault {r.get('work_nvcsw_no_fault', '?')})")
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sculptd", required=True)
    ap.add_argument("--scene", required=True)
    ap.add_argument("--recording", required=True)
    ap.add_argument("--duration", type=float, default=30.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--realtime", choices=["both", "on", "off"], default="both")
    ap.add_argument("--config", default=os.devnull, help="sculptd config file (default: none, every default)")
    a = ap.parse_args()
    modes = {"both": [False, True], "on": [True], "off": [False]}[a.realtime]
    print(f"# sculptd acceptance: {a.scene}, replay:{a.recording}, {a.duration} s, {a.repeats} run(s) per mode")
    hashes = set()
    with tempfile.TemporaryDirectory() as tmp:
        for rt in modes:
            runs = [run(a, rt, tmp, i) for i in range(a.repeats)]
            label = "--realtime" if rt else "plain"
            for i, s in enumerate(runs):
                print(f"{label} run {i + 1}: {line(s)}")
                for l in attribution(s):
                    print(f"  {l}")
                for w in s["warnings"]:
                    print(f"  {w}")
                hashes.add(s["hash"])
            med = lambda f: statistics.median(f(s) for s in runs)
            print(f"{label} median: overruns {med(lambda s: s['overruns']):.0f}, jitter_us p50 "
                  f"{med(lambda s: s['jitter_us']['p50']):.1f} p99 {med(lambda s: s['jitter_us']['p99']):.1f} "
                  f"max {med(lambda s: s['jitter_us']['max']):.1f}; step (integration) p50 "
                  f"{med(lambda s: s['stage_us']['integration']['p50']):.1f} us p99 "
                  f"{med(lambda s: s['stage_us']['integration']['p99']):.1f} us")
    print(f"final mesh hash: {', '.join(sorted(hashes))}")
    if len(hashes) != 1:
        print("FAIL: the same recording gave different meshes", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
