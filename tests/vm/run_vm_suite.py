#!/usr/bin/env python3
"""Runs the vm test suite and reports every gtest case as a TAP line.

    run_vm_suite.py [options] TEST_BINARY...

Where /dev/uinput is usable on this host the binaries run directly. Otherwise
all of them run in ONE boot of Debian's kernel under qemu (scripts/vm/): the
guest loads evdev and uinput, runs each binary, and reports on the serial
console. One meson test with TAP output, rather than one meson test per VM
test, because a boot costs seconds and the suite should pay for it once; TAP
still gives meson (and the log) one result per gtest case.

--with PATH (repeatable) copies a file or directory to the same absolute path
in the guest (ELF files with their shared libraries), so tests can use paths
baked in at build time. --udevd starts systemd-udevd in the guest with the
host's rules (udevadm trigger + settle) before the tests: the udev path of
device discovery, as on a desktop, instead of the bare devtmpfs one.

Environment:
  SCULPTD_SKIP_VM=1          skip the suite (reported as skipped, never run)
  SCULPTD_VM_MODE=auto|host|vm   force where the tests run (default auto)
  SCULPTD_VM_ACCEL=kvm|tcg   bypass the cached KVM probe
  SCULPTD_VM_TEST_TIMEOUT=S  seconds one test binary may take (default 60,
                             times --slowdown); the guest kills it after that
  SCULPTD_VM_SUITE_TIMEOUT=S seconds the whole boot may take before qemu is
                             killed (default: 60 x slowdown for the boot plus
                             each binary's allowance)
  SCULPTD_VM_REFRESH_KERNEL=1  look for a newer Debian kernel package
  SCULPT_VM_SLOWDOWN         set for the tests to --slowdown (unless already set):
                             tests scale their own long waits by it
  XDG_CACHE_HOME             the kernel cache lives in $XDG_CACHE_HOME/sculptd
Sanitizer (ASAN_OPTIONS, ...) and GTEST_* variables are passed to the guest.
"""

from __future__ import annotations

import argparse
import os
import platform
import re
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "scripts" / "vm"))
import guest_kernel  # noqa: E402
import initramfs  # noqa: E402
import qemu_boot  # noqa: E402

MARK = initramfs.MARK
FORWARDED_ENV = re.compile(r"^(ASAN|UBSAN|LSAN|MSAN|TSAN)_OPTIONS$|^GTEST_|^SCULPT_")

RUN_RE = re.compile(r"^\[ RUN      \] (\S+)")
RESULT_RE = re.compile(r"^\[ +(OK|FAILED|SKIPPED) +\] (\S+?),? .*\(\d+ ms\)$")


def log(msg: str) -> None:
    """Human-readable progress: stderr, which meson keeps in the test log."""
    print(f"vm: {msg}", file=sys.stderr, flush=True)


def tap(line: str) -> None:
    print(line, flush=True)


@dataclass
class Binary:
    name: str
    path: Path
    tests: list[str]
    timeout_s: int = 60        # the guest kills it after this (already times --slowdown)
    reported: set[str] = field(default_factory=set)


class Reporter:
    """Turns the gtest output of each binary into TAP lines as it streams."""

    def __init__(self, binaries: list[Binary]):
        self.binaries = {b.name: b for b in binaries}
        self.order = binaries
        self.number = 0
        self.failures = 0
        self.current: Binary | None = None
        self.running: str | None = None   # the gtest case between [ RUN ] and its result
        self.output: list[str] = []       # that case's output, shown when it fails
        self.kernel: str | None = None
        self.done = False
        self.guest_error: str | None = None
        self.ended: set[str] = set()
        self.began = 0.0  # when the current binary began (host clock): its time goes to the log
        # (name, why, output) of every failed result, repeated at the very end:
        # meson prints only the tail of a long log, and that is what CI shows.
        self.failed: list[tuple[str, str, list[str]]] = []
        tap(f"1..{sum(len(b.tests) + 1 for b in binaries)}")

    def result(self, ok: bool, name: str, directive: str = "", detail: list[str] | None = None) -> None:
        self.number += 1
        if not ok:
            self.failures += 1
            self.failed.append((name, directive, list(detail or [])))
        tap(f"{'ok' if ok else 'not ok'} {self.number} - {name}{' # ' + directive if directive else ''}")
        for line in detail or []:
            tap(f"# {line}")

    def begin(self, name: str) -> None:
        self.current = self.binaries.get(name)
        self.running = None
        self.began = time.monotonic()
        log(f"running {name}")

    def line(self, text: str) -> None:
        """One line of a test binary's output."""
        if self.running:
            self.output.append(text)
        m = RUN_RE.match(text)
        if m:
            self.running, self.output = m.group(1), []
            return
        m = RESULT_RE.match(text)
        if m and self.current and m.group(2) == self.running:
            status, case = m.group(1), m.group(2)
            self.current.reported.add(case)
            label = f"{self.current.name} {case}"
            if status == "OK":
                self.result(True, label)
            elif status == "SKIPPED":
                self.result(True, label, "SKIP skipped by the test")
            else:
                self.result(False, label, detail=self.output[-60:])
            self.running, self.output = None, []

    def end(self, name: str, status: int | None, why: str = "") -> None:
        b = self.binaries.get(name) or self.current
        if b is None:
            return
        if self.running:
            # The binary died inside a test: that test failed, and says how.
            how = why or describe(status)
            if "while running" not in how:
                how += " while running it"
            self.result(False, f"{b.name} {self.running}", how, self.output[-60:])
            b.reported.add(self.running)
            self.running = None
        missing = [t for t in b.tests if t not in b.reported]
        for t in missing:
            self.result(False, f"{b.name} {t}", f"never ran{': ' + why if why else ''}")
        ok = status == 0 and not missing
        reason = why or ("" if status == 0 else describe(status))
        self.result(ok, f"{b.name} (whole binary: exit status, sanitizer reports)", reason if not ok else "")
        if self.current is b:
            # What each binary takes is what its timeout must leave room for (docs/testing.md).
            log(f"{b.name} took {time.monotonic() - self.began:.1f} s (limit {b.timeout_s} s)")
        self.current = None
        self.ended.add(b.name)

    def finish(self, why: str) -> None:
        """Whatever has no result yet failed, for the reason given."""
        if self.current:
            self.end(self.current.name, None, why)
        for b in self.order:
            if b.name not in self.ended:
                self.end(b.name, None, why)


def print_failure_digest(rep: Reporter, budget: int = 70) -> None:
    """Each failure again, with the last lines of its output, within `budget`
    lines in all: the end of the log is the part everyone gets to see."""
    if not rep.failed:
        return
    log(f"--- {len(rep.failed)} failed results ---")
    for name, why, output in rep.failed:
        log(f"FAILED {name}{': ' + why if why else ''}")
        keep = max(0, min(len(output), budget // len(rep.failed)))
        shown = output[len(output) - keep:]
        for line in shown:
            print(f"  | {line}", file=sys.stderr)
        budget -= len(shown) + 1
    sys.stderr.flush()


def describe(status: int | None) -> str:
    """An exit status in words: the shell's 128+N and Python's -N both mean signal N."""
    if status is None:
        return "no exit status"
    if status < 0:
        return f"killed by signal {-status}"
    if status > 128:
        return f"killed by signal {status - 128}"
    return f"exit status {status}"


def list_tests(path: Path) -> list[str]:
    """The gtest cases a binary holds (GTEST_FILTER applies), asked on the host."""
    p = subprocess.run([str(path), "--gtest_list_tests"], capture_output=True, text=True,
                       stdin=subprocess.DEVNULL, timeout=60)
    if p.returncode != 0:
        raise RuntimeError(f"{path} --gtest_list_tests failed ({p.returncode}): {p.stderr.strip()}")
    tests, suite = [], None
    for line in p.stdout.splitlines():
        if not line.strip():
            continue
        if not line.startswith(" "):
            suite = line.split("#")[0].strip()
        elif suite:
            tests.append(suite + line.split("#")[0].strip())
    return tests


def uinput_usable() -> str | None:
    """None when this host can create uinput devices, else why not."""
    try:
        fd = os.open("/dev/uinput", os.O_RDWR | os.O_CLOEXEC)
    except OSError as e:
        return f"/dev/uinput: {e.strerror}"
    os.close(fd)
    return None


def forwarded_env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if FORWARDED_ENV.match(k)}


def run_on_host(binaries: list[Binary]) -> Reporter:
    rep = Reporter(binaries)
    for b in binaries:
        rep.begin(b.name)
        res = qemu_boot.run_streaming([str(b.path), "--gtest_color=no"],
                                      lambda l: (print(l, file=sys.stderr), rep.line(l)), b.timeout_s)
        rep.end(b.name, res.exit_status if not res.timed_out else None,
                f"killed after {b.timeout_s} s" if res.timed_out else "")
    return rep


def run_in_vm(binaries: list[Binary], args, qemu: str) -> Reporter:
    t0 = time.monotonic()
    kernel = guest_kernel.fetch(log=log)
    log(f"guest kernel {kernel.release} ({kernel.package}), from {kernel.directory} "
        f"[{time.monotonic() - t0:.1f} s]")
    work = Path(args.work_dir)
    tests = [initramfs.GuestTest(b.name, b.path, ["--gtest_color=no"], b.timeout_s) for b in binaries]
    t1 = time.monotonic()
    image = initramfs.build(work / ("initramfs-udev.cpio" if args.udevd else "initramfs.cpio"),
                            kernel.release, kernel.modules, tests,
                            env=forwarded_env(),
                            with_paths=args.with_paths, udevd=args.udevd)
    log(f"initramfs {image} ({image.stat().st_size / 1e6:.1f} MB) [{time.monotonic() - t1:.1f} s]")

    def probe_image() -> Path:
        return initramfs.build(work / "probe.cpio", kernel.release, {}, [], probe_only=True)

    with guest_kernel.cache_lock("kvm-probe"):
        accel, cpu, why = qemu_boot.choose_accel(guest_kernel.cache_root(), qemu, kernel.vmlinux, probe_image, log)
    log(f"accelerator: {accel} ({why})")
    tap(f"# vm: accel {accel}; {why}")

    rep = Reporter(binaries)
    boot_deadline = 60 * args.slowdown
    total = float(os.environ.get("SCULPTD_VM_SUITE_TIMEOUT") or
                  boot_deadline + sum(b.timeout_s + 5 for b in binaries))
    limits = {b.name: b.timeout_s for b in binaries}

    def on_line(line: str) -> None:
        print(line, file=sys.stderr, flush=True)
        if not line.startswith(MARK):
            # Markers can land mid-line after unterminated output.
            if MARK not in line:
                rep.line(line)
                return
            before, line = line.split(MARK, 1)
            rep.line(before)
            line = MARK + line
        words = line[len(MARK):].split()
        if not words:
            return
        kind = words[0]
        if kind == "kernel" and len(words) > 1:
            rep.kernel = words[1]
            log(f"guest booted: kernel {rep.kernel}")
            tap(f"# vm: guest kernel {rep.kernel}")
        elif kind == "begin" and len(words) > 1:
            rep.begin(words[1])
        elif kind == "end" and len(words) > 2:
            status = int(words[2]) if words[2].isdigit() else None
            why = f"killed after {limits.get(words[1], 0)} s in the guest (hung?)" if status == 137 else ""
            rep.end(words[1], status, why)
        elif kind == "udevd":
            log(f"guest udevd: {' '.join(words[1:])}")
            tap(f"# vm: udevd {' '.join(words[1:])}")
        elif kind == "done":
            rep.done = True
        elif kind == "error":
            rep.guest_error = " ".join(words[1:])

    cmd = qemu_boot.qemu_command(qemu, accel, kernel.vmlinux, image, args.memory, cpu)
    log(f"$ {' '.join(cmd)}")
    res = qemu_boot.run_streaming(cmd, on_line, total)
    log(f"qemu ran {res.seconds:.1f} s ({accel}), "
        + ("killed at the deadline" if res.timed_out else f"exit status {res.exit_status}"))
    if res.timed_out:
        where = f"while running {rep.current.name} {rep.running or ''}".rstrip() if rep.current else \
            ("before the guest booted" if not rep.kernel else "between tests")
        log(f"TIMEOUT: the guest did not finish within {total:.0f} s; {where}")
        rep.finish(f"guest timed out after {total:.0f} s {where}")
    elif not rep.done:
        why = rep.guest_error or ("the guest kernel never booted (see the console log above)" if not rep.kernel
                                  else "the guest stopped before finishing (crash or panic: see the log above)")
        log(f"FAILED: {why}")
        rep.finish(why)
    return rep


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--work-dir", required=True, help="where the initramfs is built (in the build tree)")
    ap.add_argument("--when-unavailable", choices=("fail", "skip"), default="fail",
                    help="neither uinput nor qemu usable: fail (default) or skip")
    ap.add_argument("--memory", type=int, default=512, help="guest RAM in MiB")
    ap.add_argument("--slowdown", type=float, default=1.0, help="timeout multiplier (sanitized builds)")
    ap.add_argument("--with", dest="with_paths", action="append", type=Path, default=[], metavar="PATH",
                    help="file or directory the guest needs at the same absolute path (repeatable)")
    ap.add_argument("--timeout", dest="timeouts", action="append", default=[], metavar="BINARY=SECONDS",
                    help="seconds that binary may take, before --slowdown (default 60; repeatable)")
    ap.add_argument("--udevd", action="store_true",
                    help="run systemd-udevd (with the host's rules) in the guest before the tests")
    ap.add_argument("binaries", nargs="+", type=Path)
    args = ap.parse_args()
    # Tests that wait on something long (a whole replayed recording) scale their
    # own deadlines by this; it reaches the guest like every SCULPT_* variable.
    os.environ.setdefault("SCULPT_VM_SLOWDOWN", f"{args.slowdown:g}")
    for p in args.with_paths:
        if not p.exists():
            tap(f"Bail out! --with {p}: no such file or directory")
            return 1

    if os.environ.get("SCULPTD_SKIP_VM") == "1":
        tap("1..0 # SKIP SCULPTD_SKIP_VM=1 is set: the uinput tests did not run")
        return 0

    mode = os.environ.get("SCULPTD_VM_MODE", "auto")
    no_uinput = uinput_usable()
    qemu = qemu_boot.find_qemu()
    missing = []
    if mode == "host" and no_uinput:
        missing.append(f"SCULPTD_VM_MODE=host but {no_uinput}")
    use_host = mode == "host" or (mode == "auto" and not no_uinput)
    if use_host and args.udevd and not os.path.exists("/run/udev/control"):
        if mode == "host":
            missing.append("--udevd with SCULPTD_VM_MODE=host but no udevd runs here (/run/udev/control)")
        else:
            use_host = False   # the host has uinput but no udevd: the VM brings its own
    if not use_host:
        if args.udevd and not initramfs.find_udevadm():
            missing.append("udevadm is not installed (Debian: apt-get install udev)")
        if not qemu:
            missing.append(f"{qemu_boot.QEMU} is not installed (Debian: apt-get install qemu-system-x86)")
        if not initramfs.find_busybox():
            missing.append("busybox is not installed (Debian: apt-get install busybox-static)")
        if missing and mode == "auto":
            missing.insert(0, f"this host cannot create uinput devices ({no_uinput}, "
                              f"kernel {platform.release()})")
    if missing:
        msg = "; ".join(missing)
        if args.when_unavailable == "skip":
            tap(f"1..0 # SKIP vm suite unavailable: {msg}")
            return 0
        log(f"FAILED: the vm suite cannot run: {msg}. Install what is missing, or set SCULPTD_SKIP_VM=1 "
            "to skip it explicitly.")
        tap(f"Bail out! vm suite cannot run: {msg} (SCULPTD_SKIP_VM=1 skips it)")
        return 1

    try:
        binaries = [Binary(p.name, p.resolve(), list_tests(p.resolve())) for p in args.binaries]
    except (OSError, RuntimeError, subprocess.TimeoutExpired) as e:
        tap(f"Bail out! cannot list the tests: {e}")
        return 1

    # Each binary's limit: SCULPTD_VM_TEST_TIMEOUT for all, as given; else its
    # --timeout (or 60 s), times --slowdown.
    try:
        own = {name: float(s) for name, s in (t.split("=", 1) for t in args.timeouts)}
    except ValueError:
        tap(f"Bail out! --timeout takes BINARY=SECONDS, not {args.timeouts}")
        return 1
    env_timeout = os.environ.get("SCULPTD_VM_TEST_TIMEOUT")
    for b in binaries:
        b.timeout_s = int(float(env_timeout)) if env_timeout else int(own.get(b.name, 60) * args.slowdown)
    start = time.monotonic()
    try:
        if use_host:
            log(f"/dev/uinput is usable here: running {len(binaries)} binaries on the host")
            tap("# vm: running on the host (/dev/uinput usable), no VM")
            rep = run_on_host(binaries)
        else:
            rep = run_in_vm(binaries, args, qemu)
    except (guest_kernel.KernelError, initramfs.ImageError, OSError) as e:
        log(f"FAILED: {e}")
        tap(f"Bail out! {str(e).splitlines()[0]}")
        return 1
    ran = sum(len(b.reported) for b in binaries)
    print_failure_digest(rep)
    log(f"{ran} tests in {len(binaries)} binaries, {rep.failures} failed results, "
        f"{time.monotonic() - start:.1f} s in all")
    return 1 if rep.failures else 0


if __name__ == "__main__":
    sys.exit(main())
