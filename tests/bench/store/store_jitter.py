#!/usr/bin/env python3
"""The real-time loop with the store on and off, side by side (issue 21).

Runs sculptd on a scene replaying a recording, alternating --no-store and
--state-dir (a fresh directory each round), and prints per run and the
medians of: the wake-up jitter p50/p99/max, overruns, and with the store the
keeper's journal bytes and commits (from its exit line). Numbers, no verdict.

  store_jitter.py SCULPTD SCENE RECORDING [--rounds 4] [--seconds 20] [--realtime]
"""
import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import tempfile


def run(sculptd, scene, recording, seconds, store_dir, realtime, tmp, name):
    stats = os.path.join(tmp, name + ".json")
    args = [sculptd, "--scene", scene, "--input", "replay:" + recording, "--duration", str(seconds),
            "--stats-json", stats, "--socket", os.path.join(tmp, name + ".sock")]
    args += ["--state-dir", store_dir] if store_dir else ["--no-store"]
    if realtime:
        args.append("--realtime")
    p = subprocess.run(args, stderr=subprocess.PIPE, text=True, timeout=seconds * 10 + 120)
    if p.returncode != 0:
        raise SystemExit(f"sculptd failed ({p.returncode}):\n{p.stderr}")
    with open(stats) as f:
        s = json.load(f)
    out = {"p50": s["jitter_us"]["p50"], "p99": s["jitter_us"]["p99"], "max": s["jitter_us"]["max"],
           "overruns": s["overruns"]}
    m = re.search(r"keeper: (\d+) journal entries \((\d+) bytes\) in (\d+) commits, the longest gap between two "
                  r"(\d+) ms; (\d+) snapshots, the last of (\d+) bytes of state \((\d+) stored\) in (\d+) ms", p.stderr)
    if m:
        out.update(journal_bytes=int(m[2]), commits=int(m[3]), longest_gap_ms=int(m[4]), snapshots=int(m[5]),
                   snapshot_ms=int(m[8]))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("sculptd")
    ap.add_argument("scene")
    ap.add_argument("recording")
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--seconds", type=float, default=20)
    ap.add_argument("--realtime", action="store_true")
    a = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="store-jitter-")
    results = {"off": [], "on": []}
    try:
        for r in range(a.rounds):
            for mode in ("off", "on"):
                store = os.path.join(tmp, f"state-{r}") if mode == "on" else None
                res = run(a.sculptd, a.scene, a.recording, a.seconds, store, a.realtime, tmp, f"{mode}-{r}")
                results[mode].append(res)
                print(f"round {r} store {mode}: " + ", ".join(f"{k} {v}" for k, v in res.items()), flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    for mode in ("off", "on"):
        rs = results[mode]
        med = {k: statistics.median(x[k] for x in rs) for k in rs[0]}
        print(f"median, store {mode}: " + ", ".join(f"{k} {v:g}" for k, v in med.items()))
    for k in ("p50", "p99", "max", "overruns"):
        ratios = [on[k] / off[k] for on, off in zip(results["on"], results["off"]) if off[k]]
        if ratios:
            print(f"on/off per round, {k}: median {statistics.median(ratios):.2f} "
                  f"(range {min(ratios):.2f}-{max(ratios):.2f})")


if __name__ == "__main__":
    main()
