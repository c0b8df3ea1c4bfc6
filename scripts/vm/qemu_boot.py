"""Booting the test VM under qemu: KVM when it works, else TCG, always under a
deadline.

The flags are the ones measured here (DESIGN.md, "Testing tiers"): `-M pc`
with the uncompressed vmlinux (PVH boot) booted in ~2.7 s under TCG with no
hang in 20 runs; `-M microvm` hung 2 in 12.

Whether KVM works is probed once per host kernel with a tiny guest and a short
deadline, and the verdict cached: on this machine /dev/kvm exists but a KVM
guest never finishes booting, and a failed attempt must not cost every run.
"""

from __future__ import annotations

import os
import platform
import re
import selectors
import shutil
import signal
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

QEMU = "qemu-system-x86_64"
KVM_PROBE_TIMEOUT_S = 15.0


def find_qemu() -> str | None:
    return shutil.which(QEMU)


def qemu_command(qemu: str, accel: str, vmlinux: Path, initrd: Path, memory_mb: int,
                 cpu: str | None = None) -> list[str]:
    cmd = [qemu, "-accel", accel, "-M", "pc", "-m", f"{memory_mb}M", "-smp", "1",
           "-nographic", "-no-reboot", "-nodefaults", "-serial", "stdio",
           "-kernel", str(vmlinux), "-initrd", str(initrd), "-append", "console=ttyS0 quiet panic=-1"]
    if cpu:
        cmd[3:3] = ["-cpu", cpu]
    return cmd


@dataclass
class BootResult:
    timed_out: bool
    exit_status: int | None     # qemu's own, None when we killed it
    seconds: float


def run_streaming(cmd: list[str], on_line: Callable[[str], None], timeout_s: float) -> BootResult:
    """Runs cmd (qemu, or a test binary on a host with uinput), feeding each
    output line (without CR/LF) to on_line as it arrives. At the deadline the
    whole process group is killed."""
    start = time.monotonic()
    proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, start_new_session=True)
    assert proc.stdout is not None
    os.set_blocking(proc.stdout.fileno(), False)
    sel = selectors.DefaultSelector()
    sel.register(proc.stdout, selectors.EVENT_READ)
    buf = b""
    timed_out = False
    try:
        while True:
            left = timeout_s - (time.monotonic() - start)
            if left <= 0:
                timed_out = True
                break
            if not sel.select(timeout=min(left, 1.0)):
                if proc.poll() is not None:
                    break
                continue
            chunk = proc.stdout.read(65536)
            if not chunk:          # EOF: qemu exited
                break
            buf += chunk
            *lines, buf = buf.split(b"\n")
            for raw in lines:
                on_line(raw.decode("utf-8", "replace").rstrip("\r"))
        if buf:
            on_line(buf.decode("utf-8", "replace").rstrip("\r"))
    finally:
        sel.close()
        if proc.poll() is None:
            # Let an orderly poweroff finish; a hung guest gets killed.
            try:
                proc.wait(timeout=0 if timed_out else 5)
            except subprocess.TimeoutExpired:
                pass
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
                return BootResult(timed_out, None, time.monotonic() - start)
    return BootResult(timed_out, proc.returncode, time.monotonic() - start)


def kvm_usable_device() -> str | None:
    """None when /dev/kvm can be opened read-write, else why not."""
    try:
        fd = os.open("/dev/kvm", os.O_RDWR | os.O_CLOEXEC)
    except OSError as e:
        return f"/dev/kvm: {e.strerror}"
    os.close(fd)
    return None


def _verdict_file(cache_root: Path) -> Path:
    return cache_root / f"kvm-verdict-{platform.release()}"


def choose_accel(cache_root: Path, qemu: str, vmlinux: Path, probe_initrd: Callable[[], Path],
                 log: Callable[[str], None]) -> tuple[str, str | None, str]:
    """(accel, cpu model or None, why). SCULPTD_VM_ACCEL=kvm|tcg overrides the probe."""
    forced = os.environ.get("SCULPTD_VM_ACCEL")
    if forced in ("kvm", "tcg"):
        return forced, ("host" if forced == "kvm" else None), "forced by SCULPTD_VM_ACCEL"
    why_not = kvm_usable_device()
    if why_not:
        return "tcg", None, why_not
    verdict_path = _verdict_file(cache_root)
    try:
        verdict = verdict_path.read_text().strip()
    except OSError:
        verdict = ""
    if not verdict:
        log(f"probing KVM (short boots, verdict cached in {verdict_path})")
        failures = []
        # -cpu host is fastest; some nested set-ups only take qemu's default model.
        for cpu in ("host", "qemu64"):
            seen: list[str] = []
            res = run_streaming(qemu_command(qemu, "kvm", vmlinux, probe_initrd(), 128, cpu),
                                seen.append, KVM_PROBE_TIMEOUT_S)
            if any("@@SCULPT-VM done" in line for line in seen):
                verdict = f"kvm cpu={cpu}: probe booted in {res.seconds:.1f} s"
                break
            if res.timed_out:
                failures.append(f"-cpu {cpu}: guest did not finish booting within {KVM_PROBE_TIMEOUT_S:.0f} s")
            else:
                tail = " | ".join(l for l in seen[-2:] if l.strip())
                failures.append(f"-cpu {cpu}: qemu failed (status {res.exit_status}): {tail}")
        else:
            verdict = "tcg: KVM unusable: " + "; ".join(failures)
        verdict_path.parent.mkdir(parents=True, exist_ok=True)
        verdict_path.write_text(verdict + "\n")
    about = f"KVM verdict for host kernel {platform.release()} (cached in {verdict_path}): {verdict}"
    m = re.match(r"kvm cpu=(\S+):", verdict)
    if m:
        return "kvm", m.group(1), about
    return "tcg", None, about


def forget_verdict(cache_root: Path) -> None:
    _verdict_file(cache_root).unlink(missing_ok=True)
