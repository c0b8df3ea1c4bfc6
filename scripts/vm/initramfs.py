"""The test VM's initramfs: busybox, the kernel modules, the test binaries and
the shared libraries they load, and an /init that runs them and powers off.

The archive is written directly in the kernel's "newc" cpio format (a few
lines of Python: no cpio binary, no staging tree, no root needed for the
/dev/console node).

Executables and libraries go in without their debug sections (objcopy
--strip-debug): the guest unpacks the whole archive into RAM, and the debug
information of an optimised build is most of its size (the `vm` image fell
from 159 MB to about a third; at 512 MB of guest RAM the unstripped image had
reached "Initramfs unpacking failed: write error"). Symbols stay, so a crash
or a sanitizer report in the guest still names functions.

Two extensions for tests that need more than their own binary:
  with_paths  files or directories copied to the SAME absolute path in the
              guest (ELF files bring the shared libraries `ldd` names), so a
              test can use paths baked in at build time (sculptd, test data);
  udevd       start systemd-udevd with the host's (Debian's) rules, trigger
              and settle, so devices carry udev properties (ID_INPUT_JOYSTICK)
              and libudev's monitor works, as on a desktop.

What /init prints on the serial console, one marker per line, is the whole
protocol with the host (qemu exits 0 whatever happened inside):
    @@SCULPT-VM kernel <uname -r>
    @@SCULPT-VM begin <test name>
    ... the test's own gtest output ...
    @@SCULPT-VM end <test name> <exit status>
    @@SCULPT-VM done
    @@SCULPT-VM udevd <running|failed ...>
    @@SCULPT-VM error <what went wrong>
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import stat
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

MARK = "@@SCULPT-VM"
# Modules without which no test can run: the boot stops. The others (the HID
# stack for tests/vm/uhid) only log their failure here, in the guest.
REQUIRED_MODULES = ("evdev", "uinput")
INSMOD_LOG = "/lib/sculpt/insmod-failures"
BUSYBOX_CANDIDATES = ("/bin/busybox", "/usr/bin/busybox")
UDEVADM_CANDIDATES = ("/usr/bin/udevadm", "/bin/udevadm")
UDEV_RULE_DIRS = ("/usr/lib/udev/rules.d", "/lib/udev/rules.d", "/etc/udev/rules.d")
WITH_LIMIT_BYTES = 400 * 1000 * 1000   # what --with may add: the guest holds it all in RAM


class ImageError(RuntimeError):
    pass


def find_program(candidates: tuple[str, ...], name: str) -> Path | None:
    """The first of the known paths that exists, else `name` on $PATH."""
    for c in candidates:
        p = Path(c)
        if p.is_file():
            return p
    found = shutil.which(name)
    return Path(found) if found else None


def find_busybox() -> Path | None:
    """A statically linked busybox (the guest has no libc of its own for it)."""
    return find_program(BUSYBOX_CANDIDATES, "busybox")


def find_udevadm() -> Path | None:
    """systemd's udevadm (systemd-udevd is the same binary under another name)."""
    return find_program(UDEVADM_CANDIDATES, "udevadm")


def is_elf(path: Path) -> bool:
    try:
        with open(path, "rb") as f:
            return f.read(4) == b"\x7fELF"
    except OSError:
        return False


def shared_libraries(binary: Path) -> list[Path]:
    """The files `ldd` says the binary loads, the dynamic loader included."""
    p = subprocess.run(["ldd", str(binary)], capture_output=True, text=True, stdin=subprocess.DEVNULL)
    out = p.stdout + p.stderr
    if re.search(r"not a dynamic executable|statically linked", out):
        return []
    if p.returncode != 0:
        raise ImageError(f"ldd {binary} failed: {out.strip()}")
    libs = []
    for line in out.splitlines():
        line = line.strip()
        if "not found" in line:
            raise ImageError(f"{binary}: a shared library is missing on the host: {line}")
        m = re.search(r"=>\s*(/\S+)\s*\(", line) or re.match(r"(/\S+)\s*\(", line)
        if m:
            libs.append(Path(m.group(1)))
    return libs


class Cpio:
    """A newc cpio archive built in memory."""

    def __init__(self) -> None:
        self._parts: list[bytes] = []
        self._ino = 1
        self._dirs: set[str] = set()
        self._names: set[str] = set()

    def _entry(self, name: str, mode: int, data: bytes = b"", rdev: tuple[int, int] = (0, 0)) -> None:
        name = name.lstrip("/")
        fields = [self._ino, mode, 0, 0, 1, 0, len(data), 0, 0, rdev[0], rdev[1], len(name) + 1, 0]
        self._ino += 1
        header = b"070701" + b"".join(b"%08X" % f for f in fields)
        blob = header + name.encode() + b"\0"
        blob += b"\0" * (-len(blob) % 4)
        blob += data + b"\0" * (-len(data) % 4)
        self._parts.append(blob)
        self._names.add(name)

    def dir(self, path: str) -> None:
        path = path.strip("/")
        if not path or path in self._dirs:
            return
        self.dir(os.path.dirname(path))
        self._dirs.add(path)
        self._entry(path, stat.S_IFDIR | 0o755)

    def file(self, path: str, data: bytes, mode: int = 0o755) -> None:
        if path.lstrip("/") in self._names:
            return
        self.dir(os.path.dirname(path.strip("/")))
        self._entry(path, stat.S_IFREG | mode, data)

    def symlink(self, path: str, target: str) -> None:
        self.dir(os.path.dirname(path.strip("/")))
        self._entry(path, stat.S_IFLNK | 0o777, target.encode())

    def chardev(self, path: str, major: int, minor: int) -> None:
        self.dir(os.path.dirname(path.strip("/")))
        self._entry(path, stat.S_IFCHR | 0o600, rdev=(major, minor))

    def has(self, path: str) -> bool:
        return path.lstrip("/") in self._names

    def bytes(self) -> bytes:
        trailer = Cpio()
        trailer._entry("TRAILER!!!", 0)
        return b"".join(self._parts + trailer._parts)


@dataclass
class GuestTest:
    name: str                    # shown in the log and the markers
    binary: Path                 # on the host
    args: list[str] = field(default_factory=list)
    timeout_s: int | None = None  # killed after this; None: init_script's test_timeout_s


def init_script(release: str, tests: list[GuestTest], env: dict[str, str], test_timeout_s: int,
                modules: list[str], probe_only: bool, udevd: bool = False) -> str:
    q = shlex.quote
    lines = [
        "#!/bin/busybox sh",
        "/bin/busybox --install -s /bin",
        "export PATH=/bin HOME=/root TMPDIR=/tmp",
        "mount -t proc proc /proc",
        "mount -t sysfs sysfs /sys",
        "mount -t devtmpfs devtmpfs /dev",
        "dmesg -n 1  # keep kernel chatter off the console the host parses",
        f'echo "{MARK} kernel $(uname -r)"',
        f'die() {{ echo "{MARK} error $*"; poweroff -f; }}',
    ]
    if not probe_only:
        for m in modules:
            if m in REQUIRED_MODULES:
                lines.append(f"insmod /lib/sculpt/{m}.ko || die 'insmod {m}.ko failed'")
            else:
                # The HID stack for the uhid tests: a failure is theirs alone.
                # They read INSMOD_LOG to say why their driver is missing.
                lines.append(f"insmod /lib/sculpt/{m}.ko 2>/tmp/insmod.err "
                             f"|| echo \"insmod {m}.ko failed: $(cat /tmp/insmod.err)\" >>{INSMOD_LOG}")
        lines += [
            "[ -c /dev/uinput ] || die '/dev/uinput missing after insmod uinput.ko'",
            "mkdir -p /run && mount -t tmpfs tmpfs /run",
        ]
        if udevd:
            lines += [
                # udevd as on a desktop: rules from the host, names never
                # resolved over the network, every existing device replayed.
                "/lib/systemd/systemd-udevd --daemon --resolve-names=never >/tmp/udevd.log 2>&1 "
                "|| die \"systemd-udevd did not start: $(cat /tmp/udevd.log)\"",
                "/usr/bin/udevadm trigger --action=add >/dev/null 2>&1",
                "/usr/bin/udevadm settle --timeout=30 || die 'udevadm settle timed out'",
                "[ -e /run/udev/control ] || die 'udevd is not listening (/run/udev/control missing)'",
                f'echo "{MARK} udevd running"',
            ]
        lines.append("cd /tmp")
        for k, v in sorted(env.items()):
            lines.append(f"export {k}={q(v)}")
        for t in tests:
            cmd = " ".join(q(a) for a in [f"/tests/{t.binary.name}", *t.args])
            lines += [
                f'echo "{MARK} begin {t.name}"',
                # A hung test is killed here, so the rest of the suite still runs.
                f"timeout -s KILL {t.timeout_s or test_timeout_s} {cmd} </dev/null 2>&1",
                f'echo "{MARK} end {t.name} $?"',
            ]
    lines += [f'echo "{MARK} done"', "sync", "poweroff -f", ""]
    return "\n".join(lines)


def elf_without_debug(path: Path) -> bytes:
    """The ELF file's bytes without its debug sections (symbols kept)."""
    objcopy = shutil.which("objcopy")
    if not objcopy:
        return path.read_bytes()
    fd, tmp = tempfile.mkstemp(prefix="sculpt-vm-strip-")
    os.close(fd)
    try:
        p = subprocess.run([objcopy, "--strip-debug", str(path), tmp], capture_output=True, text=True,
                           stdin=subprocess.DEVNULL)
        if p.returncode != 0:
            raise ImageError(f"objcopy --strip-debug {path} failed: {(p.stderr or p.stdout).strip()}")
        return Path(tmp).read_bytes()
    finally:
        os.unlink(tmp)


def add_binary(a: Cpio, path: Path, at: str | None = None) -> None:
    """An executable at `at` (default: its own path) and every library it loads."""
    a.file(at or str(path), elf_without_debug(path), 0o755)
    for lib in shared_libraries(path):
        # At the path ldd printed (the loader resolves exactly those),
        # with the content of whatever symlink chain it names.
        if not a.has(str(lib)):
            a.file(str(lib), elf_without_debug(lib.resolve()))


def add_with_path(a: Cpio, path: Path) -> int:
    """A --with path at the same absolute path in the guest; returns the bytes added."""
    path = Path(os.path.abspath(path))
    if not path.exists():
        raise ImageError(f"--with {path}: no such file or directory")
    files = [path] if not path.is_dir() else sorted(p for p in path.rglob("*") if p.is_file())
    if path.is_dir():
        a.dir(str(path))
    total = 0
    for f in files:
        if a.has(str(f)):
            continue
        mode = stat.S_IMODE(f.stat().st_mode)
        if is_elf(f) and mode & 0o111:
            add_binary(a, f)
        else:
            a.file(str(f), f.read_bytes(), mode)
        total += f.stat().st_size
    return total


def add_udevd(a: Cpio) -> None:
    """systemd-udevd, udevadm, the host's rules and the users/groups they name."""
    udevadm = find_udevadm()
    if not udevadm:
        raise ImageError("--udevd: udevadm is not installed (Debian: apt-get install udev)")
    add_binary(a, udevadm, "/usr/bin/udevadm")
    a.symlink("lib/systemd/systemd-udevd", "/usr/bin/udevadm")
    for d in UDEV_RULE_DIRS:
        p = Path(d)
        if not p.is_dir():
            continue
        for rule in sorted(p.glob("*.rules")):
            a.file(f"{d}/{rule.name}", rule.read_bytes(), 0o644)
    conf = Path("/etc/udev/udev.conf")
    if conf.is_file():
        a.file("etc/udev/udev.conf", conf.read_bytes(), 0o644)
    # GROUP="input" and friends resolve against these (the rest just warn).
    a.file("etc/passwd", b"root:x:0:0:root:/root:/bin/sh\n", 0o644)
    groups = ["root:x:0:", "tty:x:5:", "disk:x:6:", "kmem:x:15:", "dialout:x:20:", "video:x:44:",
              "audio:x:29:", "input:x:101:", "render:x:102:", "kvm:x:103:", "sgx:x:104:"]
    a.file("etc/group", ("\n".join(groups) + "\n").encode(), 0o644)


def build(output: Path, release: str, module_files: dict[str, Path], tests: list[GuestTest],
          env: dict[str, str] | None = None, test_timeout_s: int = 60, probe_only: bool = False,
          with_paths: list[Path] | None = None, udevd: bool = False) -> Path:
    """Writes the initramfs to `output` and returns it."""
    busybox = find_busybox()
    if not busybox:
        raise ImageError("busybox is not installed (Debian: apt-get install busybox-static)")
    ldd = subprocess.run(["ldd", str(busybox)], capture_output=True, text=True, stdin=subprocess.DEVNULL)
    if not re.search(r"not a dynamic executable|statically linked", ldd.stdout + ldd.stderr):
        raise ImageError(f"{busybox} is dynamically linked; the guest needs busybox-static")
    a = Cpio()
    for d in ("bin", "dev", "proc", "sys", "tmp", "root", "tests", "lib/sculpt"):
        a.dir(d)
    a.chardev("dev/console", 5, 1)   # the kernel opens it for /init's stdio
    a.chardev("dev/null", 1, 3)
    a.file("bin/busybox", busybox.read_bytes())
    a.symlink("bin/sh", "busybox")
    if not probe_only:
        for name, path in module_files.items():
            a.file(f"lib/sculpt/{name}.ko", path.read_bytes(), 0o644)
        for t in tests:
            if a.has(f"tests/{t.binary.name}"):
                continue
            add_binary(a, t.binary, f"tests/{t.binary.name}")
        added = 0
        for p in with_paths or []:
            added += add_with_path(a, p)
            if added > WITH_LIMIT_BYTES:
                raise ImageError(f"--with paths add more than {WITH_LIMIT_BYTES // 1000000} MB "
                                 f"(at {p}): the guest holds the image in RAM")
        if udevd:
            add_udevd(a)
    a.file("init", init_script(release, tests, env or {}, test_timeout_s, list(module_files),
                               probe_only, udevd).encode())
    output.parent.mkdir(parents=True, exist_ok=True)
    tmp = output.with_suffix(".tmp")
    tmp.write_bytes(a.bytes())
    tmp.rename(output)
    return output
