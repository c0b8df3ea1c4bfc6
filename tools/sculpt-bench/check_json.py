#!/usr/bin/env python3
"""Run every `sculpt-bench` subcommand on tiny inputs and check its JSON lines
carry the fields issues 3 and 8 ask for, that --out writes CSV (and PNG when
gnuplot is installed), and that bad input fails with a message naming it.
Behaviour only: no timing is judged."""
import json
import os
import shutil
import subprocess
import sys
import tempfile

bench = sys.argv[1]


def run(args, **kw):
    return subprocess.run([bench, *args], check=True, capture_output=True, text=True, **kw).stdout


def lines(out):
    return [json.loads(l) for l in out.splitlines() if l.strip()]


def finite(d, keys, what):
    for k in keys:
        assert k in d, f"{what}: missing {k}"
        assert d[k] is not None and (not isinstance(d[k], float) or d[k] == d[k]), f"{what}: bad {k}: {d[k]}"


# --- throughput (issue 3) --------------------------------------------------------
cases = [
    ["--mesh", "builtin:icosphere:2"],
    ["--mesh", "builtin:torus:0.1:0.03:24:12", "--model", "linear", "--precision", "double", "--tool", "none"],
    ["--mesh", "builtin:box:4", "--impl", "fast"],
    ["--mesh", "builtin:icosphere:2", "--impl", "baseline"],
]
required = ["vertices", "springs", "steps", "substeps", "ns_per_vertex_step", "ms_per_step"]
for args in cases:
    out = run(["throughput", *args, "--steps", "5", "--repeats", "1", "--json"])
    rows = lines(out)
    assert len(rows) == 1, f"{args}: expected one JSON line, got {len(rows)}"
    d = rows[0]
    finite(d, required, args)
    if "--impl" not in args:
        for k in ["baseline", "speedup_vs_baseline", "idle", "sculpting_with_sleep", "peak_memory_bytes",
                  "peak_memory_bytes_per_vertex", "bytes_per_vertex", "huge_page_bytes"]:
            assert k in d, f"{args}: missing {k}"
    assert d["vertices"] > 0 and d["springs"] > 0 and d["steps"] == 5

# --records picks the layout, and says which it asked for ("on" needs AVX2, so only "off" is checked).
d = lines(run(["throughput", "--mesh", "builtin:icosphere:2", "--records", "off", "--impl", "fast",
               "--steps", "5", "--repeats", "1", "--json"]))[0]
assert d["records"] == "off" and d["kernel"] in ("avx2-ring", "portable-arrays"), d  # no AVX2: no ring
assert d["path"] == d["kernel"].split("-", 1)[1], d
d = lines(run(["throughput", "--mesh", "builtin:icosphere:2", "--records", "off", "--ring", "off", "--impl", "fast",
               "--steps", "5", "--repeats", "1", "--json"]))[0]
assert d["ring"] == "off" and d["kernel"] in ("avx2-arrays", "portable-arrays"), d

for args, word in [(["--mesh", "builtin:nothing"], "builtin:nothing"), (["--model", "foam"], "--model"),
                   (["--steps", "0"], "--steps"), (["--records", "on", "--precision", "double"], "--records"),
                   (["--ring", "off", "--precision", "double"], "--ring")]:
    bad = subprocess.run([bench, "throughput", *args], capture_output=True, text=True)
    assert bad.returncode != 0 and word in bad.stderr, f"throughput {args}: must fail naming {word}: {bad.stderr}"

# --- accuracy (issue 8): the documented command works alone, one line per case ---
rows = lines(run(["accuracy", "--problem", "chain", "--integrator", "verlet", "--json", "--quiet"]))
assert len(rows) >= 8, f"accuracy: expected a default sweep, got {len(rows)} lines"
for d in rows:
    finite(d, ["problem", "integrator", "precision", "dt", "substeps", "seconds", "error_max", "error_rms",
               "energy_error", "spring_passes"], "accuracy chain verlet")
    assert d["problem"] == "chain" and d["integrator"] == "verlet"
assert {d["precision"] for d in rows} == {"float", "double"}
rows = lines(run(["accuracy", "--problem", "oscillator,mesh", "--integrator", "implicit_euler,xpbd",
                  "--precision", "double", "--dt", "0.004,0.002", "--substeps", "2", "--json", "--quiet"]))
assert len(rows) == 8, f"accuracy: 2 problems x 2 integrators x 2 dt, got {len(rows)}"
for d in rows:
    assert d["substeps"] == 2 and d["precision"] == "double"
    assert "error_max" in d and "seconds" in d
for args, word in [(["--problem", "pendulum"], "pendulum"), (["--integrator", "rk5"], "rk5"),
                   (["--dt", "0.1,x"], "--dt")]:
    bad = subprocess.run([bench, "accuracy", *args, "--quiet"], capture_output=True, text=True)
    assert bad.returncode != 0 and word in bad.stderr, f"accuracy {args}: must fail naming {word}: {bad.stderr}"

# --- stability -------------------------------------------------------------------
rows = lines(run(["stability", "--mesh", "builtin:icosphere:1", "--material", "rubber", "--scene", "none",
                  "--ticks", "300", "--json", "--quiet"]))
assert len(rows) == 2, f"stability: damped and undamped, got {len(rows)}"
for d in rows:
    finite(d, ["mesh", "material", "damping", "dt_critical_measured", "dt_bound_gershgorin", "dt_power_iteration"],
           "stability")
    # The Gershgorin bound never promises more than the measured limit.
    assert d["dt_bound_gershgorin"] <= d["dt_critical_measured"] * 1.01, d
rows = lines(run(["stability", "--mesh", "none", "--scene", "builtin:default", "--ticks", "300", "--json", "--quiet"]))
assert len(rows) == 3, f"stability: the default scene has 3 meshes, got {len(rows)}"
for d in rows:
    finite(d, ["scene", "mesh", "substeps", "substep_dt", "dt_critical_measured", "margin", "margin_ok"], "scenes")
bad = subprocess.run([bench, "stability", "--material", "steel", "--scene", "none", "--mesh", "builtin:icosphere:1"],
                     capture_output=True, text=True)
assert bad.returncode != 0 and "steel" in bad.stderr

# --- skip ------------------------------------------------------------------------
rows = lines(run(["skip", "--ticks", "200", "--tolerance", "1e-4", "--sleep-speed", "1e-4", "--json", "--quiet"]))
assert len(rows) == 1, f"skip: one default case, got {len(rows)}"
finite(rows[0], ["scene", "ms_per_tick_all", "ms_per_tick_skipping", "bytes_idle", "bytes_active"], "skip")
assert rows[0]["bytes_active"] > rows[0]["bytes_idle"] > 0

# --- --out: CSV always, PNG through gnuplot ---------------------------------------
with tempfile.TemporaryDirectory() as tmp:
    args = ["accuracy", "--problem", "oscillator", "--integrator", "verlet", "--precision", "double",
            "--dt", "0.01,0.005", "--out", tmp, "--quiet"]
    done = subprocess.run([bench, *args], capture_output=True, text=True)
    assert os.path.exists(os.path.join(tmp, "accuracy.csv")), done.stderr
    with open(os.path.join(tmp, "accuracy.csv")) as f:
        assert f.readline().startswith("problem,integrator,precision"), "CSV header"
        assert len(f.readlines()) == 2
    if shutil.which("gnuplot"):
        assert done.returncode == 0, done.stderr
        assert os.path.getsize(os.path.join(tmp, "accuracy_oscillator.png")) > 1000
    else:
        assert done.returncode != 0 and "gnuplot" in done.stderr, "without gnuplot: a clear error"
print("ok")
