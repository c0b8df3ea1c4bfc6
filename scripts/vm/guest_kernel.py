"""Debian's own kernel for the test VM, fetched once and cached.

This machine's kernel has no uinput; Debian's does, as a module. We take the
package `linux-image-amd64` points at, and keep from it only what the VM needs:
the uncompressed vmlinux (it carries a PVH note, so qemu boots it directly,
about twice as fast as vmlinuz under TCG) and the modules in MODULES: evdev
and uinput (the uinput tests, no dependencies), and the HID stack the uhid
tests bind the kernel's own gamepad drivers with. MODULES is in dependency
order (`depends=` of each .ko's .modinfo, checked on 6.1.0-56): the guest
insmods them in that order.

Cache layout (${XDG_CACHE_HOME:-~/.cache}/sculptd/kernel/):
    current                    name of the entry in use
    <package>_<version>/       linux-image-*.deb, vmlinux, one .ko per MODULES
                               entry, release (uname -r of the guest)
A warm cache needs neither network nor apt. `modules` in an entry names the
MODULES it was unpacked for: an entry written before a module was added to
MODULES is completed from the .deb it holds (no network). A module the
package lacks is left out (only evdev and uinput must be there: the uhid
tests fail on their own, saying which is missing). SCULPTD_VM_REFRESH_KERNEL=1 (or
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
# name -> where it lives under /lib/modules/<release>/kernel/, in insmod order.
MODULES = {
    "evdev": "drivers/input/evdev.ko",
    "uinput": "drivers/input/misc/uinput.ko",
    # The uhid gamepads (tests/vm/uhid): depends= hid (none), uhid (hid),
    # ff-memless (none), led-class-multicolor (none; led-class is built in),
    # usb-common (none), usbcore (usb-common), usbhid (hid, usbcore),
    # hid-playstation (hid, led-class-multicolor, ff-memless),
    # hid-sony (hid, usbcore, usbhid, ff-memless), hid-microsoft (hid, ff-memless).
    # hidraw is part of hid.ko (CONFIG_HIDRAW=y).
    "hid": "drivers/hid/hid.ko",
    "uhid": "drivers/hid/uhid.ko",
    "ff-memless": "drivers/input/ff-memless.ko",
    "led-class-multicolor": "drivers/leds/led-class-multicolor.ko",
    "usb-common": "drivers/usb/common/usb-common.ko",
    "usbcore": "drivers/usb/core/usbcore.ko",
    "usbhid": "drivers/hid/usbhid/usbhid.ko",
    "hid-playstation": "drivers/hid/hid-playstation.ko",
    "hid-sony": "drivers/hid/hid-sony.ko",
    "hid-microsoft": "drivers/hid/hid-microsoft.ko",
}
# Without these the guest does not boot its tests; the others only fail the
# uhid tests (initramfs.py).
REQUIRED_MODULES = ("evdev", "uinput")
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
    """The entry in `directory` if it is complete (vmlinux and every module)."""
    try:
        release = (directory / "release").read_text().strip()
        package = (directory / "package").read_text().strip()
    except OSError:
        return None
    try:
        looked_for = set((directory / "modules").read_text().split())
    except OSError:
        looked_for = set()
    if not set(MODULES) <= looked_for:
        return None   # unpacked for fewer modules: _complete_from_deb
    vmlinux = directory / "vmlinux"
    modules = {m: directory / f"{m}.ko" for m in MODULES if (directory / f"{m}.ko").is_file()}
    if not vmlinux.is_file() or not all(m in modules for m in REQUIRED_MODULES):
        return None
    return GuestKernel(directory, vmlinux, modules, release, package)


def _current_dir() -> Path | None:
    current = cache_root() / "kernel" / "current"
    try:
        name = current.read_text().strip()
    except OSError:
        return None
    return current.parent / name if name else None


def cached() -> GuestKernel | None:
    """The cached kernel, or None. Never touches the network."""
    d = _current_dir()
    return _load(d) if d else None


def _complete_from_deb(log) -> GuestKernel | None:
    """The current entry, missing modules added from the .deb it keeps (an
    entry from before MODULES grew). None when there is no such entry or .deb.
    Call with the cache lock held."""
    d = _current_dir()
    if not d or not d.is_dir() or not (d / "release").is_file():
        return None
    debs = sorted(d.glob("linux-image-*.deb"))
    if not debs:
        return None
    staging = Path(tempfile.mkdtemp(dir=d.parent, prefix=".complete-"))
    try:
        _unpack(debs[-1], staging, log, vmlinux=False)
        for ko in sorted(staging.glob("*.ko")):
            # Each file appears atomically: a reader of the entry (another
            # build's run) sees a module whole or not at all.
            ko.rename(d / ko.name)
        (staging / "modules").rename(d / "modules")   # last: the entry is complete
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return _load(d)


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


def _unpack(deb: Path, dest: Path, log, vmlinux: bool = True) -> str | None:
    """Streams the package's data tarball, keeping vmlinuz and the modules only."""
    log(f"extracting {'vmlinux, ' if vmlinux else ''}{', '.join(MODULES)} from {deb.name}")
    wanted = {f"/kernel/{rel}": m for m, rel in MODULES.items()}
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
                if vmlinux:
                    vmlinuz = tar.extractfile(member).read()
                continue
            if "/kernel/drivers/" not in path:
                continue
            for suffix in ("", ".xz"):
                for tail, mod in wanted.items():
                    if path.endswith(tail + suffix):
                        data = tar.extractfile(member).read()
                        found[mod] = lzma.decompress(data) if suffix else data
    if proc.wait() != 0:
        raise KernelError(f"dpkg-deb --fsys-tarfile {deb} failed with status {proc.returncode}")
    if release is None or (vmlinux and vmlinuz is None):
        raise KernelError(f"{deb.name} holds no /boot/vmlinuz-*")
    missing = [m for m in REQUIRED_MODULES if m not in found]
    if missing:
        raise KernelError(f"{deb.name} holds no {', '.join(m + '.ko' for m in missing)} "
                          "(built in? then the VM needs no insmod for it: adapt scripts/vm/initramfs.py)")
    if vmlinux:
        (dest / "vmlinux").write_bytes(_extract_vmlinux(vmlinuz))
    for mod, data in found.items():
        (dest / f"{mod}.ko").write_bytes(data)
    absent = [m for m in MODULES if m not in found]
    if absent:
        log(f"{deb.name} holds no {', '.join(absent)} (the uhid tests that need them will fail)")
    (dest / "modules").write_text("\n".join(MODULES) + "\n")
    return release


def fetch(log=print, refresh: bool = False) -> GuestKernel:
    """The guest kernel: from the cache when it is there, else downloaded."""
    refresh = refresh or os.environ.get("SCULPTD_VM_REFRESH_KERNEL") == "1"
    if not refresh and (k := cached()):
        return k
    with cache_lock():
        if not refresh and (k := cached()):   # another run filled it meanwhile
            return k
        if not refresh and (k := _complete_from_deb(log)):
            log(f"guest kernel {k.release}: modules added to {k.directory} from its .deb")
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
