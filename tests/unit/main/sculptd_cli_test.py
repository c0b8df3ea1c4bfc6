#!/usr/bin/env python3
"""sculptd as a program, without devices (unit suite): flags, errors,
--check, a replayed recording twice (same mesh hash, the stats JSON's keys),
SIGTERM and SIGHUP while running.

    sculptd_cli_test.py SCULPTD SCENES_DIR RECORDINGS_DIR
"""
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
import unittest

SCULPTD, SCENES, RECORDINGS = sys.argv[1], sys.argv[2], sys.argv[3]
# Every daemon started here listens in a private directory: never on the
# default path, where a real service or another test's daemon may listen.
_SOCKET_DIR = tempfile.TemporaryDirectory(prefix="sculptd-cli-test-")
os.environ["SCULPTD_SOCKET"] = os.path.join(_SOCKET_DIR.name, "sculptd.sock")
KEYS = sorted(["rate_hz", "ticks", "overruns", "jitter_us", "stage_us", "vertices_total", "vertices_awake",
               "viewers", "devices", "ff_uploads", "bytes_sent", "blowups",
               "overrun_causes", "recent_overruns", "sim_thread"])


def run(*args, timeout=60):
    return subprocess.run([SCULPTD, "--config", os.devnull, *args], capture_output=True, text=True, timeout=timeout)


class Cli(unittest.TestCase):
    def test_version_and_help(self):
        r = subprocess.run([SCULPTD, "--version"], capture_output=True, text=True)
        self.assertEqual(r.returncode, 0)
        self.assertRegex(r.stdout.strip(), r"^\d+\.\d+\.\d+$")
        r = subprocess.run([SCULPTD, "--help"], capture_output=True, text=True)
        self.assertEqual(r.returncode, 0)
        for flag in ["--scene", "--socket", "--rate", "--input", "--duration", "--realtime", "--stats-json",
                     "--config"]:
            self.assertIn(flag, r.stdout)

    def test_bad_input_is_named(self):
        r = run("--input", "mouse")
        self.assertNotEqual(r.returncode, 0)
        self.assertIn('--input: "mouse"', r.stderr)
        # Not the journal: the programs' one voice, no sd-daemon prefix.
        self.assertTrue(r.stderr.startswith("sculptd: error: "), r.stderr)
        r = run("--scene", "/nonexistent/scene.toml", "--duration", "1")
        self.assertEqual(r.returncode, 1)
        self.assertIn("/nonexistent/scene.toml", r.stderr)
        r = subprocess.run([SCULPTD, "--config", "/nonexistent/sculptd.conf"], capture_output=True, text=True)
        self.assertEqual(r.returncode, 1)
        self.assertIn("/nonexistent/sculptd.conf", r.stderr)

    def test_priority_prefixes_only_when_stderr_is_the_journal(self):
        with tempfile.TemporaryFile("w+") as journal:
            st = os.fstat(journal.fileno())
            env = dict(os.environ, JOURNAL_STREAM=f"{st.st_dev}:{st.st_ino}")
            r = subprocess.run([SCULPTD, "--config", os.devnull, "--input", "mouse"], stdout=subprocess.DEVNULL,
                               stderr=journal, env=env, timeout=60)
            self.assertEqual(r.returncode, 1)
            journal.seek(0)
            text = journal.read()
            self.assertTrue(text.startswith("<3>"), text)  # journald keeps the level
            # The variable inherited, but stderr is somewhere else (a pipe): plain words.
            r = subprocess.run([SCULPTD, "--config", os.devnull, "--input", "mouse"], capture_output=True,
                               text=True, env=env, timeout=60)
            self.assertTrue(r.stderr.startswith("sculptd: error: "), r.stderr)

    def test_usage_errors_are_named_with_status_2(self):
        r = subprocess.run([SCULPTD, "--frobnicate"], capture_output=True, text=True, timeout=60)
        self.assertEqual(r.returncode, 2)
        self.assertIn("sculptd: error: unknown option '--frobnicate'", r.stderr)
        self.assertIn("--scene", r.stderr)  # the valid ones are listed
        r = subprocess.run([SCULPTD, "stray"], capture_output=True, text=True, timeout=60)
        self.assertEqual(r.returncode, 2)
        self.assertIn("unexpected argument 'stray'", r.stderr)
        r = subprocess.run([SCULPTD, "--rate", "fast"], capture_output=True, text=True, timeout=60)
        self.assertEqual(r.returncode, 2)
        self.assertIn("--rate", r.stderr)

    def test_check_reports_config_errors_with_line_and_key(self):
        with tempfile.NamedTemporaryFile("w", suffix=".conf", delete=False) as f:
            f.write("[daemon]\nrate_hz = 1000\n\n[haptics]\ngain = -1\n")
        try:
            r = subprocess.run([SCULPTD, "--check", "--config", f.name], capture_output=True, text=True)
            self.assertEqual(r.returncode, 1)
            self.assertIn(f"{f.name}:5: haptics.gain", r.stderr)
        finally:
            os.unlink(f.name)
        r = subprocess.run([SCULPTD, "--check", "--config", os.devnull, "--scene",
                            os.path.join(SCENES, "sculpt_50k.toml")], capture_output=True, text=True)
        self.assertEqual(r.returncode, 0, r.stderr)


class Replay(unittest.TestCase):
    def replay(self, tmp, name):
        stats, hash_out = os.path.join(tmp, name + ".json"), os.path.join(tmp, name + ".hash")
        r = run("--scene", os.path.join(SCENES, "e2e_default_coarse.toml"), "--rate", "500",
                "--input", "replay:" + os.path.join(RECORDINGS, "push.jsonl"), "--duration", "2",
                "--stats-json", stats, "--hash-out", hash_out)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(stats) as f, open(hash_out) as h:
            return json.load(f), h.read().strip()

    def test_same_recording_same_mesh_and_the_stats_keys(self):
        with tempfile.TemporaryDirectory() as tmp:
            s1, h1 = self.replay(tmp, "a")
            s2, h2 = self.replay(tmp, "b")
        self.assertEqual(h1, h2)
        self.assertRegex(h1, r"^[0-9a-f]{16}$")
        self.assertEqual(sorted(s1.keys()), KEYS)
        self.assertEqual(s1["ticks"], 1000)
        self.assertEqual(s1["rate_hz"], 500)
        self.assertEqual(s1["devices"], 1)
        self.assertEqual(s1["viewers"], 0)
        self.assertEqual(sorted(s1["jitter_us"].keys()), ["max", "p50", "p99"])
        self.assertEqual(sorted(s1["stage_us"].keys()), ["collision", "input", "integration", "publish"])
        self.assertGreater(s1["vertices_total"], 0)


class Signals(unittest.TestCase):
    def test_sighup_reloads_sigterm_exits_zero(self):
        with tempfile.TemporaryDirectory() as tmp:
            conf = os.path.join(tmp, "sculptd.conf")
            with open(conf, "w") as f:
                f.write("[haptics]\ngain = 1000\n")
            stats = os.path.join(tmp, "s.json")
            p = subprocess.Popen([SCULPTD, "--config", conf, "--stats-json", stats,
                                  "--input", "replay:" + os.path.join(RECORDINGS, "push.jsonl"),
                                  "--scene", os.path.join(SCENES, "e2e_ball.toml")],
                                 stderr=subprocess.PIPE, text=True)
            lines = []

            def wait_for(text, limit=20):
                end = time.time() + limit
                while time.time() < end:
                    line = p.stderr.readline()
                    if not line:
                        break
                    lines.append(line)
                    if text in line:
                        return True
                return False

            try:
                self.assertTrue(wait_for("sculptd ready"), "".join(lines))
                with open(conf, "w") as f:
                    f.write("[haptics]\ngain = \"loud\"\n")
                p.send_signal(signal.SIGHUP)
                self.assertTrue(wait_for("keeping the running configuration"), "".join(lines))
                with open(conf, "w") as f:
                    f.write("[haptics]\ngain = 2000\n")
                p.send_signal(signal.SIGHUP)
                self.assertTrue(wait_for("SIGHUP: reloaded"), "".join(lines))
                p.send_signal(signal.SIGTERM)
                _, rest = p.communicate(timeout=20)
                self.assertEqual(p.returncode, 0, "".join(lines) + rest)
                with open(stats) as f:
                    self.assertGreater(json.load(f)["ticks"], 0)
            finally:
                if p.poll() is None:
                    p.kill()
                    p.wait()


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
