#!/usr/bin/env python3
"""Checks sculptd's systemd files the way systemd reads them.

- `systemd-analyze verify` on sculptd.service (with the built binary's path
  in ExecStart, which verify requires to exist) and sculptd.socket: exit 0
  and not one warning (verify only warns about unknown keys, so any output
  counts as a failure);
- the same on a copy with a misspelt key, which must be flagged (the check
  itself works);
- `systemd-analyze security --offline=yes`: the exposure stays "OK" (< 2.0);
- `systemd-sysusers --dry-run` accepts the sysusers.d file;
- `systemd-analyze verify --man=yes` finds the man page the units name
  (Documentation=man:sculptd(8)) among the project's (MANPATH=--man-dir),
  and every page there renders without a warning (`man --warnings`).
"""
import argparse
import os
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile


def run(cmd, cwd):
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=60)


def verify(d):
    r = run(["systemd-analyze", "verify", "--man=no", "sculptd.service", "sculptd.socket"], d)
    return r.returncode, (r.stdout + r.stderr).strip()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--service-in", required=True)
    ap.add_argument("--socket", required=True)
    ap.add_argument("--sysusers", required=True)
    ap.add_argument("--sculptd", required=True)
    ap.add_argument("--man-dir", required=True, help="the project's man pages (man1/, man8/)")
    ap.add_argument("--max-exposure", type=float, default=2.0)
    a = ap.parse_args()
    if not shutil.which("systemd-analyze"):
        print("systemd-analyze not found (apt-get install systemd)", file=sys.stderr)
        return 1
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        d = pathlib.Path(tmp)
        service = pathlib.Path(a.service_in).read_text().replace("@SCULPTD@", str(pathlib.Path(a.sculptd).resolve()))
        if re.search(r"@[A-Z_]+@", service):
            failures.append("sculptd.service.in: a @VARIABLE@ is left unsubstituted")
        (d / "sculptd.service").write_text(service)
        shutil.copy(a.socket, d / "sculptd.socket")

        rc, out = verify(d)
        print(f"systemd-analyze verify: exit {rc}" + (f"\n{out}" if out else ", no warnings"))
        if rc != 0 or out:
            failures.append("systemd-analyze verify complained about the units")

        (d / "sculptd.service").write_text(service.replace("ProtectHome=yes", "ProtectHome=yes\nProtectHoem=yes"))
        rc, out = verify(d)
        if "ProtectHoem" not in out:
            failures.append("a misspelt key went unnoticed: the verify check is blind")
        (d / "sculptd.service").write_text(service)

        r = run(["systemd-analyze", "security", "--offline=yes", "sculptd.service"], d)
        m = re.search(r"Overall exposure level for sculptd\.service: ([0-9.]+)", r.stdout + r.stderr)
        if not m:
            failures.append("systemd-analyze security gave no exposure level:\n" + r.stdout + r.stderr)
        else:
            exposure = float(m.group(1))
            print(f"systemd-analyze security --offline=yes: exposure {exposure}")
            if exposure >= a.max_exposure:
                failures.append(f"exposure {exposure} >= {a.max_exposure}")

        man_dir = pathlib.Path(a.man_dir).resolve()
        env = dict(os.environ, MANPATH=str(man_dir), LC_ALL="C.UTF-8")
        r = subprocess.run(["systemd-analyze", "verify", "--man=yes", "sculptd.service", "sculptd.socket"], cwd=d,
                           capture_output=True, text=True, timeout=60, env=env)
        out = (r.stdout + r.stderr).strip()
        print("systemd-analyze verify --man=yes:", out or "no warnings")
        if r.returncode != 0 or out:
            failures.append("the units' Documentation= names a man page that is not shipped (or verify complained)")
        pages = sorted(man_dir.glob("man*/*.[0-9]"))
        if not pages:
            failures.append(f"no man pages in {man_dir}")
        for page in pages:
            r = subprocess.run(["man", "--warnings", "-E", "UTF-8", "-l", str(page)], capture_output=True, text=True,
                               timeout=60, env=dict(env, MANWIDTH="80"))
            if r.returncode != 0 or r.stderr.strip():
                failures.append(f"{page.name} does not render cleanly: {r.stderr.strip()}")
            else:
                print(f"{page.name}: renders cleanly, {len(r.stdout.splitlines())} lines")

        root = d / "root"
        root.mkdir()
        r = run(["systemd-sysusers", "--dry-run", f"--root={root}", str(pathlib.Path(a.sysusers).resolve())], d)
        print("systemd-sysusers --dry-run:", (r.stdout + r.stderr).strip().replace("\n", "; "))
        if r.returncode != 0 or "Creating user 'sculptd'" not in r.stdout + r.stderr:
            failures.append("systemd-sysusers rejected the sysusers.d file")
    for f in failures:
        print("FAIL:", f, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
