"""Debian's own kernel for the test VM, fetched once and cached.

This machine's kernel has no uinput; Debian's does, as a module. We take the
package `linux-image-amd64` points at, and keep from it only what the VM needs:
the uncompressed vmlinux (it carries a PVH note, so qemu boots it directly,
about twice as fast as vmlinuz under TCG) and the evdev and uinput modules
(plain .ko files with no dependencies between them).

Cache layout (${XDG_CACHE_HOME:-~/.cache}/sculptd/kernel/):
    current                    name of the entry in use
    <package>_<version>/       linux-image-*.deb, vmlinux, evdev.ko, uinput.ko,
                               release (uname -r of the guest)
A warm cache needs neither network nor apt. SCULPTD_VM_REFRESH_KERNEL=1 (or
`sculpt-vm kernel --refresh`) looks for a newer package.
"""

from __future__ import annotations

import contextlib
import fcntl
import lzma
import os
import re
import shutil
import subprocess
import tarfile
import tempfile
from dataclasses import dataclass
from pathlib import Path

META_PACKAGE = "linux-image-amd64"
MODULES = ("evdev", "uinput")
XZ_MAGIC = b"\xfd7zXZ\x00"


class KernelError(RuntimeError):
    """The guest kernel could not be fetched or prepared; the message says why."""


@dataclass(frozen=True)
class GuestKernel:
    directory: Path
    vmlinux: Path
    modules: dict[str, Path]   # module name -> .ko
    release: str               # e.g. 6.1.0-41-amd64
    package: str               # e.g. linux-image-6.1.0-41-amd64 6.1.158-1


def cache_root() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "sculptd"


@contextlib.contextmanager
def cache_lock(name: str = "lock"):
    """Serialises cache writers (a plain and an asan build may run at once)."""
    root = cache_root()
    root.mkdir(parents=True, exist_ok=True)
    with open(root / f".{name}", "w") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def _load(directory: Path) -> GuestKernel | None:
    try:
        release = (directory / "release").read_text().strip()
        package = (directory / "package").read_text().strip()
    except OSError:
        return None
    vmlinux = directory / "vmlinux"
    modules = {m: directory / f"{m}.ko" for m in MODULES}
    if not vmlinux.is_file() or not all(p.is_file() for p in modules.values()):
        return None
    return GuestKernel(directory, vmlinux, modules, release, package)


def cached() -> GuestKernel | None:
    """The cached kernel, or None. Never touches the network."""
    current = cache_root() / "kernel" / "current"
    try:
        name = current.read_text().strip()
    except OSError:
        return None
    return _load(current.parent / name) if name else None


def _run(cmd: list[str], cwd: Path, log) -> str:
    log(f"$ {' '.join(cmd)}")
    try:
        p = subprocess.run(cmd, cwd=cwd, stdin=subprocess.DEVNULL, capture_output=True, text=True)
    except FileNotFoundError:
        raise KernelError(f"{cmd[0]} is not installed (needed to fetch the guest kernel)")
    if p.returncode != 0:
        hint = ""
        if cmd[:2] == ["apt-get", "download"]:
            hint = ("\n  (no network, or stale package lists? `apt-get update` as root, or prefill the "
                    f"cache from another machine: {cache_root() / 'kernel'})")
        raise KernelError(f"`{' '.join(cmd)}` failed with status {p.returncode}:\n"
                          f"{(p.stderr or p.stdout).strip()}{hint}")
    return p.stdout


def _download(package: str, into: Path, log) -> Path:
    _run(["apt-get", "download", package], into, log)
    name = package.split("=")[0]
    debs = sorted(into.glob(f"{name}_*.deb"))
    if not debs:
        raise KernelError(f"apt-get download {package} left no {name}_*.deb in {into}")
    return debs[-1]


def _field(deb: Path, field: str, log) -> str:
    return _run(["dpkg-deb", "-f", str(deb), field], deb.parent, log).strip()


def _extract_vmlinux(vmlinuz: bytes) -> bytes:
    # vmlinuz = setup code + an xz-compressed ELF vmlinux; the decompressor
    # stops at the end of the xz stream and ignores what follows.
    start = vmlinuz.find(XZ_MAGIC)
    while start >= 0:
        try:
            elf = lzma.LZMADecompressor(format=lzma.FORMAT_XZ).decompress(vmlinuz[start:])
            if elf.startswith(b"\x7fELF"):
                return elf
        except lzma.LZMAError:
            pass
        start = vmlinuz.find(XZ_MAGIC, start + 1)
    raise KernelError("no xz-compressed ELF vmlinux found inside vmlinuz "
                      "(Debian changed the kernel compression?)")


def _unpack(deb: Path, dest: Path, log) -> str:
    """Streams the package's data tarball, keeping vmlinuz and the modules only."""
    log(f"extracting vmlinux, {', '.join(MODULES)} from {deb.name}")
    wanted = {f"/{m}.ko": m for m in MODULES}
    found: dict[str, bytes] = {}
    vmlinuz = None
    release = None
    proc = subprocess.Popen(["dpkg-deb", "--fsys-tarfile", str(deb)], stdout=subprocess.PIPE,
                            stdin=subprocess.DEVNULL)
    assert proc.stdout is not None
    with tarfile.open(fileobj=proc.stdout, mode="r|*") as tar:
        for member in tar:
            if not member.isfile():
                continue
            path = member.name.lstrip(".")
            m = re.fullmatch(r"/boot/vmlinuz-(.+)", path)
            if m:
                release = m.group(1)
                vmlinuz = tar.extractfile(member).read()
                continue
            if "/kernel/drivers/input/" not in path:
                continue
            for suffix in ("", ".xz"):
                for tail, mod in wanted.items():
                    if path.endswith(tail + suffix):
                        data = tar.extractfile(member).read()
                        found[mod] = lzma.decompress(data) if suffix else data
    if proc.wait() != 0:
        raise KernelError(f"dpkg-deb --fsys-tarfile {deb} failed with status {proc.returncode}")
    if vmlinuz is None or release is None:
        raise KernelError(f"{deb.name} holds no /boot/vmlinuz-*")
    missing = [m for m in MODULES if m not in found]
    if missing:
        raise KernelError(f"{deb.name} holds no {', '.join(m + '.ko' for m in missing)} "
                          "(built in? then the VM needs no insmod for it: adapt scripts/vm/initramfs.py)")
    (dest / "vmlinux").write_bytes(_extract_vmlinux(vmlinuz))
    for mod, data in found.items():
        (dest / f"{mod}.ko").write_bytes(data)
    return release


def fetch(log=print, refresh: bool = False) -> GuestKernel:
    """The guest kernel: from the cache when it is there, else downloaded."""
    refresh = refresh or os.environ.get("SCULPTD_VM_REFRESH_KERNEL") == "1"
    if not refresh and (k := cached()):
        return k
    with cache_lock():
        if not refresh and (k := cached()):   # another run filled it meanwhile
            return k
        kdir = cache_root() / "kernel"
        kdir.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=kdir, prefix=".fetch-") as tmp:
            tmpdir = Path(tmp)
            os.chmod(tmpdir, 0o755)   # apt's _apt user wants to write here when run as root
            meta = _download(META_PACKAGE, tmpdir, log)
            depends = _field(meta, "Depends", log)
            m = re.search(r"(linux-image-[0-9][^\s,(]*)(?:\s*\(=\s*([^)\s]+)\))?", depends)
            if not m:
                raise KernelError(f"{meta.name} depends on no linux-image-<version> package: {depends!r}")
            package = m.group(1) + (f"={m.group(2)}" if m.group(2) else "")
            deb = _download(package, tmpdir, log)
            version = _field(deb, "Version", log)
            name = f"{m.group(1)}_{version}"
            entry = kdir / name
            if not _load(entry):
                staging = Path(tempfile.mkdtemp(dir=kdir, prefix=".entry-"))
                os.chmod(staging, 0o755)
                try:
                    release = _unpack(deb, staging, log)
                    (staging / "release").write_text(release + "\n")
                    (staging / "package").write_text(f"{m.group(1)} {version}\n")
                    shutil.move(str(deb), staging / deb.name)
                    if entry.exists():
                        shutil.rmtree(entry)
                    staging.rename(entry)
                except BaseException:
                    shutil.rmtree(staging, ignore_errors=True)
                    raise
            (kdir / "current.tmp").write_text(name + "\n")
            (kdir / "current.tmp").rename(kdir / "current")
            # Older entries are dead weight once a newer kernel is current.
            for old in kdir.iterdir():
                if old.is_dir() and old.name != name and not old.name.startswith("."):
                    shutil.rmtree(old, ignore_errors=True)
    k = cached()
    if not k:
        raise KernelError(f"kernel cache entry {name} is incomplete after fetching")
    log(f"guest kernel {k.release} ({k.package}) cached in {k.directory}")
    return k
