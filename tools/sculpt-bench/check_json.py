#!/usr/bin/env python3
"""Run `sculpt-bench throughput` on a tiny mesh and check its JSON line has the
fields issue 3 asks for (behaviour only: no timing is judged)."""
import json
import subprocess
import sys

bench = sys.argv[1]
cases = [
    ["--mesh", "builtin:icosphere:2"],
    ["--mesh", "builtin:torus:0.1:0.03:24:12", "--model", "linear", "--precision", "double", "--tool", "none"],
    ["--mesh", "builtin:box:4", "--impl", "fast"],
    ["--mesh", "builtin:icosphere:2", "--impl", "baseline"],
]
required = ["vertices", "springs", "steps", "substeps", "ns_per_vertex_step", "ms_per_step"]
for args in cases:
    out = subprocess.run([bench, "throughput", *args, "--steps", "5", "--repeats", "1", "--json"],
                         check=True, capture_output=True, text=True).stdout
    lines = [l for l in out.splitlines() if l.strip()]
    assert len(lines) == 1, f"{args}: expected one JSON line, got {len(lines)}"
    d = json.loads(lines[0])
    for k in required:
        assert k in d, f"{args}: missing {k}"
        assert d[k] is not None and (not isinstance(d[k], float) or d[k] == d[k]), f"{args}: bad {k}"
    if "--impl" not in args:
        for k in ["baseline", "speedup_vs_baseline", "idle", "sculpting_with_sleep", "peak_memory_bytes",
                  "peak_memory_bytes_per_vertex", "bytes_per_vertex"]:
            assert k in d, f"{args}: missing {k}"
    assert d["vertices"] > 0 and d["springs"] > 0 and d["steps"] == 5

bad = subprocess.run([bench, "throughput", "--mesh", "builtin:nothing"], capture_output=True, text=True)
assert bad.returncode != 0 and "builtin:nothing" in bad.stderr, "a bad --mesh must fail with a message naming it"
print("ok")
