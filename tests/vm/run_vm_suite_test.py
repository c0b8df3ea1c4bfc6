#!/usr/bin/env python3
"""Unit tests of the vm runner itself, with no VM and no uinput: the gtest
output parser, the TAP it writes, deadlines on a hung binary, and the
initramfs archive format. (The vm suite is the integration test.)"""

import contextlib
import io
import os
import stat
import subprocess
import sys
import tempfile
import textwrap
import unittest
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import run_vm_suite as runner  # noqa: E402
import initramfs  # noqa: E402  (put on sys.path by run_vm_suite)

FAKE_GTEST = textwrap.dedent("""\
    #!/bin/sh
    # Mimics a gtest binary: lists two cases, then behaves as $FAKE says.
    if [ "$1" = --gtest_list_tests ]; then
      printf 'Suite.\\n  First\\n  Second\\nParam/P.\\n  Case/0  # GetParam() = 1\\n'
      exit 0
    fi
    echo '[ RUN      ] Suite.First'
    echo '[       OK ] Suite.First (1 ms)'
    echo '[ RUN      ] Suite.Second'
    case "$FAKE" in
      hang) exec sleep 1000 ;;
      crash) kill -SEGV $$ ;;
      fail) echo 'x.cpp:3: Failure'; echo '[  FAILED  ] Suite.Second (2 ms)' ;;
      *) echo '[       OK ] Suite.Second (0 ms)' ;;
    esac
    echo '[ RUN      ] Param/P.Case/0'
    echo '[       OK ] Param/P.Case/0, where GetParam() = 1 (0 ms)'
    echo '[  FAILED  ] Suite.Second'
    [ "$FAKE" = fail ] && exit 1
    exit 0
    """)


class RunnerTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.fake = Path(self.tmp.name) / "fake_test"
        self.fake.write_text(FAKE_GTEST)
        self.fake.chmod(self.fake.stat().st_mode | stat.S_IEXEC)

    def tearDown(self):
        self.tmp.cleanup()
        os.environ.pop("FAKE", None)

    def run_host(self, scenario, timeout_s=30):
        os.environ["FAKE"] = scenario
        b = runner.Binary("fake_test", self.fake, runner.list_tests(self.fake), timeout_s)
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            rep = runner.run_on_host([b])
        return rep, out.getvalue().splitlines()

    def test_lists_cases_including_parameterised_ones(self):
        self.assertEqual(runner.list_tests(self.fake), ["Suite.First", "Suite.Second", "Param/P.Case/0"])

    def test_all_passing_gives_one_ok_per_case_plus_the_binary(self):
        rep, tap = self.run_host("pass")
        self.assertEqual(tap[0], "1..4")
        self.assertEqual([l.split(" - ")[0] for l in tap[1:] if not l.startswith("#")],
                         ["ok 1", "ok 2", "ok 3", "ok 4"])
        self.assertEqual(rep.failures, 0)

    def test_a_failure_is_reported_once_with_its_output(self):
        rep, tap = self.run_host("fail")
        self.assertIn("not ok 2 - fake_test Suite.Second", tap)
        self.assertIn("# x.cpp:3: Failure", tap)
        # gtest's closing summary repeats the name: not a second result.
        self.assertEqual(sum(l.startswith(("ok", "not ok")) for l in tap), 4)
        self.assertEqual(rep.failures, 2)   # the case and the binary's exit status

    def test_failures_are_repeated_at_the_end_where_a_short_log_shows_them(self):
        rep, _ = self.run_host("fail")
        err = io.StringIO()
        with contextlib.redirect_stderr(err):
            runner.print_failure_digest(rep, budget=10)
        lines = err.getvalue().splitlines()
        self.assertIn("vm: FAILED fake_test Suite.Second", lines)
        self.assertIn("  | x.cpp:3: Failure", lines)
        self.assertLessEqual(len(lines), 1 + 10 + len(rep.failed))

    def test_a_crash_names_the_running_case_and_fails_the_rest(self):
        rep, tap = self.run_host("crash")
        self.assertIn("not ok 2 - fake_test Suite.Second # killed by signal 11 while running it", tap)
        self.assertTrue(any(l.startswith("not ok 3 - fake_test Param/P.Case/0 # never ran") for l in tap), tap)
        self.assertEqual(rep.failures, 3)

    def test_a_hung_binary_is_killed_at_the_deadline(self):
        # Seconds: the first case must pass before the deadline on a busy machine.
        rep, tap = self.run_host("hang", timeout_s=5)
        self.assertIn("not ok 2 - fake_test Suite.Second # killed after 5 s while running it", tap)
        self.assertGreaterEqual(rep.failures, 2)


class InitramfsTest(unittest.TestCase):
    def test_archive_lists_with_busybox_cpio(self):
        busybox = initramfs.find_busybox()
        if not busybox:
            self.fail("busybox is not installed (apt-get install busybox-static)")
        a = initramfs.Cpio()
        a.file("tests/odd_size", b"12345")
        a.symlink("bin/sh", "busybox")
        a.chardev("dev/console", 5, 1)
        with tempfile.NamedTemporaryFile() as f:
            f.write(a.bytes())
            f.flush()
            listing = subprocess.run([str(busybox), "cpio", "-t", "-v", "-F", f.name],
                                     capture_output=True, text=True, check=True).stdout
        names = [line.split()[-1] if "->" not in line else line.split()[-3] for line in listing.splitlines()]
        self.assertEqual(names, ["tests", "tests/odd_size", "bin", "bin/sh", "dev", "dev/console"])
        self.assertIn("crw", listing)

    def test_init_runs_every_test_under_a_timeout_with_quoted_env(self):
        tests = [initramfs.GuestTest("a_test", Path("/x/a_test"), ["--gtest_color=no"]),
                 initramfs.GuestTest("long_test", Path("/x/long_test"), [], 180)]
        script = initramfs.init_script("6.1.0", tests, {"ASAN_OPTIONS": "a=1:b='2'"}, 42,
                                       ["evdev", "uinput"], probe_only=False)
        self.assertIn("insmod /lib/sculpt/evdev.ko", script)
        self.assertIn("insmod /lib/sculpt/uinput.ko", script)
        self.assertIn("timeout -s KILL 42 /tests/a_test --gtest_color=no", script)
        self.assertIn("timeout -s KILL 180 /tests/long_test", script)  # its own limit
        self.assertIn("export ASAN_OPTIONS='a=1:b='\"'\"'2'\"'\"''", script)
        self.assertLess(script.index("begin a_test"), script.index("end a_test"))
        self.assertTrue(script.rstrip().endswith("poweroff -f"))

    def test_only_evdev_and_uinput_stop_the_boot(self):
        script = initramfs.init_script("6.1.0", [], {}, 60, ["evdev", "uinput", "hid", "uhid", "hid-sony"],
                                       probe_only=False)
        self.assertIn("insmod /lib/sculpt/uinput.ko || die", script)
        for m in ("hid", "uhid", "hid-sony"):
            line = next(l for l in script.splitlines() if l.startswith(f"insmod /lib/sculpt/{m}.ko"))
            self.assertNotIn("die", line)
            self.assertIn(initramfs.INSMOD_LOG, line)   # the uhid tests report it
        # In the order given (guest_kernel.MODULES is in dependency order).
        self.assertLess(script.index("/hid.ko"), script.index("/uhid.ko"))
        self.assertLess(script.index("/uhid.ko"), script.index("/hid-sony.ko"))


class GuestKernelCacheTest(unittest.TestCase):
    """An entry unpacked before MODULES grew is completed from its own .deb."""

    def test_entry_without_the_new_modules_is_incomplete(self):
        import guest_kernel
        with tempfile.TemporaryDirectory() as d:
            entry = Path(d)
            for name, text in (("release", "6.1.0-56-amd64"), ("package", "linux-image-6.1.0-56-amd64 1")):
                (entry / name).write_text(text + "\n")
            for f in ("vmlinux", "evdev.ko", "uinput.ko"):
                (entry / f).write_bytes(b"x")
            self.assertIsNone(guest_kernel._load(entry))   # no `modules`: an old entry
            (entry / "modules").write_text("evdev\nuinput\n")
            self.assertIsNone(guest_kernel._load(entry))   # unpacked for fewer modules
            (entry / "modules").write_text("\n".join(guest_kernel.MODULES) + "\n")
            k = guest_kernel._load(entry)                  # complete; the package lacked the rest
            self.assertIsNotNone(k)
            self.assertEqual(list(k.modules), ["evdev", "uinput"])
            (entry / "hid.ko").write_bytes(b"x")
            self.assertEqual(list(guest_kernel._load(entry).modules), ["evdev", "uinput", "hid"])


class WithAndUdevdTest(unittest.TestCase):
    """--with copies paths to the same absolute path (ELF files with their
    libraries); --udevd brings udevd, its rules and starts it in /init."""

    def listing(self, archive: "initramfs.Cpio") -> list[str]:
        busybox = initramfs.find_busybox()
        if not busybox:
            self.fail("busybox is not installed (apt-get install busybox-static)")
        with tempfile.NamedTemporaryFile() as f:
            f.write(archive.bytes())
            f.flush()
            out = subprocess.run([str(busybox), "cpio", "-t", "-F", f.name],
                                 capture_output=True, text=True, check=True).stdout
        return out.split()

    def test_with_copies_files_and_directories_at_their_absolute_paths(self):
        with tempfile.TemporaryDirectory() as tmp:
            d = Path(tmp) / "data"
            (d / "sub").mkdir(parents=True)
            (d / "a.txt").write_text("a")
            (d / "sub" / "b.jsonl").write_text("b")
            single = Path(tmp) / "single.toml"
            single.write_text("x = 1")
            a = initramfs.Cpio()
            added = initramfs.add_with_path(a, d) + initramfs.add_with_path(a, single)
            names = self.listing(a)
        self.assertEqual(added, len("a") + len("b") + len("x = 1"))  # bytes added
        for p in (d / "a.txt", d / "sub" / "b.jsonl", single):
            self.assertIn(str(p).lstrip("/"), names)

    def test_with_an_elf_brings_its_shared_libraries(self):
        a = initramfs.Cpio()
        initramfs.add_with_path(a, Path(sys.executable).resolve())
        names = self.listing(a)
        self.assertIn(str(Path(sys.executable).resolve()).lstrip("/"), names)
        self.assertTrue(any("libc.so" in n for n in names), names[:20])

    def test_executables_go_in_without_debug_sections_but_with_symbols(self):
        with tempfile.TemporaryDirectory() as tmp:
            src, exe = Path(tmp) / "t.c", Path(tmp) / "t"
            src.write_text("int debug_me(int x) { return x * 2; }\nint main(void) { return debug_me(0); }\n")
            subprocess.run(["cc", "-g", "-O0", str(src), "-o", str(exe)], check=True)
            stripped = Path(tmp) / "stripped"
            stripped.write_bytes(initramfs.elf_without_debug(exe))
            sections = subprocess.run(["objdump", "-h", str(stripped)], capture_output=True, text=True,
                                      check=True).stdout
            symbols = subprocess.run(["nm", str(stripped)], capture_output=True, text=True, check=True).stdout
            self.assertLess(stripped.stat().st_size, exe.stat().st_size)
        self.assertNotIn(".debug_info", sections)
        self.assertIn("debug_me", symbols)  # a crash in the guest still names the function

    def test_with_a_missing_path_is_a_clear_error(self):
        with self.assertRaisesRegex(initramfs.ImageError, "no such file"):
            initramfs.add_with_path(initramfs.Cpio(), Path("/nonexistent/sculpt/path"))

    def test_udevd_init_starts_udevd_after_the_modules_and_settles(self):
        tests = [initramfs.GuestTest("a_test", Path("/x/a_test"), [])]
        script = initramfs.init_script("6.1.0", tests, {}, 42, ["evdev", "uinput"], probe_only=False, udevd=True)
        self.assertLess(script.index("insmod /lib/sculpt/uinput.ko"), script.index("systemd-udevd --daemon"))
        self.assertLess(script.index("udevadm trigger"), script.index("udevadm settle"))
        self.assertLess(script.index("udevadm settle"), script.index("begin a_test"))
        self.assertIn("udevd running", script)
        plain = initramfs.init_script("6.1.0", tests, {}, 42, ["evdev", "uinput"], probe_only=False)
        self.assertNotIn("udevd", plain)

    def test_udevd_image_has_udevadm_rules_and_groups(self):
        if not initramfs.find_udevadm():
            self.fail("udevadm is not installed (apt-get install udev)")
        a = initramfs.Cpio()
        initramfs.add_udevd(a)
        names = self.listing(a)
        self.assertIn("usr/bin/udevadm", names)
        self.assertIn("lib/systemd/systemd-udevd", names)
        self.assertTrue(any(n.endswith("60-input-id.rules") for n in names))
        self.assertIn("etc/group", names)

    def test_runner_bails_out_on_a_missing_with_path(self):
        p = subprocess.run([sys.executable, str(Path(runner.__file__)), "--work-dir", "/tmp/x",
                            "--with", "/nonexistent/sculpt/path", "/bin/true"],
                           capture_output=True, text=True, env={**os.environ, "SCULPTD_SKIP_VM": ""})
        self.assertEqual(p.returncode, 1)
        self.assertIn("Bail out! --with /nonexistent/sculpt/path", p.stdout)


if __name__ == "__main__":
    unittest.main(verbosity=2)
