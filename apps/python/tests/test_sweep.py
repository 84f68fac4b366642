"""crumple-sweep on a local Dask cluster (local:2): a 3-variant sweep of drop.json writes results.csv, a failed
variant is a row with its exit status, and a rerun runs only what is not complete. Bad input (sweep files, options,
a scheduler that is not there) is one line and exit 2; SIGTERM, SIGINT and SIGKILL of crumple-sweep end its
crumple-sim runs; a run that a signal ended is recorded as such.

Run by ctest; by hand (from apps/python/tests/):
    PYTHONPATH=build/python CRUMPLE_SWEEP=build/apps/crumple-sweep python3 -m unittest -v test_sweep"""

import csv
import json
import os
import signal
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
SWEEP = os.environ.get("CRUMPLE_SWEEP", "crumple-sweep")

try:
    import distributed  # noqa: F401
    HAVE_DASK = True
except ImportError:
    HAVE_DASK = False


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def processes_naming(text):
    """The pids of the processes whose command line holds text."""
    pids = []
    for name in os.listdir("/proc"):
        if not name.isdigit() or int(name) == os.getpid():
            continue
        try:
            with open(f"/proc/{name}/cmdline", "rb") as f:
                if text.encode() in f.read():
                    pids.append(int(name))
        except OSError:
            pass
    return pids


def wait_for(predicate, timeout):
    """Whether predicate() came true within timeout s (looked at every 0.1 s)."""
    end = time.monotonic() + timeout
    while True:
        if predicate():
            return True
        if time.monotonic() >= end:
            return False
        time.sleep(0.1)


@unittest.skipUnless(HAVE_DASK, "python3-distributed is not installed")
class Sweep(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="crumple-sweep-")
        shutil.copy(os.path.join(HERE, "drop.json"), self.tmp)
        self.sweep = os.path.join(self.tmp, "speeds.json")
        with open(self.sweep, "w") as f:
            json.dump({"format": "crumple-sweep/1", "scene": "drop.json",
                       "vary": {"bodies[ball].velocity": [[0, -2, 0], [0, -5, 0], [0, -9, 0]],
                                "deformation.path": ["gather", "scatter", "gather"]},
                       "mode": "zip", "set": {"duration": 0.05}}, f)
        self.out = os.path.join(self.tmp, "out")

    def tearDown(self):
        for pid in processes_naming(self.tmp):  # a failed signal test must not leave its runs behind
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
        shutil.rmtree(self.tmp, ignore_errors=True)

    def run_sweep(self, *extra, timeout=300):
        return subprocess.run([SWEEP, self.sweep, "--out", self.out, "--scheduler", "local:2", *extra],
                              capture_output=True, text=True, timeout=timeout)

    def write_sweep(self, doc):
        with open(self.sweep, "w") as f:
            json.dump(doc, f)

    def fake_sim(self, name, body):
        """An executable Python script standing in for crumple-sim (--sim)."""
        path = os.path.join(self.tmp, name)
        with open(path, "w") as f:
            f.write(f"#!{sys.executable}\nimport os, resource, signal, sys, time\n{body}\n")
        os.chmod(path, 0o755)
        return path

    def assert_one_line_error(self, r, *fragments):
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
        self.assertEqual(len(r.stderr.splitlines()), 1, r.stderr)
        self.assertTrue(r.stderr.startswith("crumple-sweep: error: "), r.stderr)
        for fragment in fragments:
            self.assertIn(fragment, r.stderr)

    def test_three_variants_then_a_failure_then_a_rerun(self):
        # Variant 001's folder holds a file crumple did not write: crumple-sim refuses it (exit 2).
        os.makedirs(os.path.join(self.out, "runs", "001"))
        with open(os.path.join(self.out, "runs", "001", "notes.txt"), "w") as f:
            f.write("mine\n")
        r = self.run_sweep()
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        rows = read_csv(os.path.join(self.out, "results.csv"))
        self.assertEqual(list(rows[0].keys()),
                         ["id", "bodies[ball].velocity.x", "bodies[ball].velocity.y", "bodies[ball].velocity.z",
                          "deformation.path", "exit", "status", "collisions", "deformations", "max_dent.plate",
                          "max_dent.ball", "saturated.plate", "saturated.ball", "error"])
        self.assertEqual([row["id"] for row in rows], ["000", "001", "002"])
        self.assertEqual([row["bodies[ball].velocity.y"] for row in rows], ["-2", "-5", "-9"])
        self.assertEqual([row["bodies[ball].velocity.x"] for row in rows], ["0", "0", "0"])
        self.assertEqual([row["saturated.plate"] for row in rows], ["false", "", "false"])
        self.assertEqual([row["deformation.path"] for row in rows], ["gather", "scatter", "gather"])
        self.assertEqual([row["exit"] for row in rows], ["0", "2", "0"])
        self.assertEqual([row["status"] for row in rows], ["ok", "exit 2", "ok"])
        self.assertIn("not written by crumple", rows[1]["error"])
        self.assertEqual(rows[1]["max_dent.plate"], "")
        for row in (rows[0], rows[2]):
            self.assertGreaterEqual(int(row["collisions"]), 1)
            self.assertGreaterEqual(int(row["deformations"]), 1)
            self.assertEqual(row["error"], "")
        # A faster ball dents deeper.
        self.assertGreater(float(rows[0]["max_dent.plate"]), 0)
        self.assertGreater(float(rows[2]["max_dent.plate"]), float(rows[0]["max_dent.plate"]))
        self.assertTrue(os.path.isfile(os.path.join(self.out, "runs", "000", "summary.json")))
        self.assertTrue(os.path.isfile(os.path.join(self.out, "logs", "001.log")))

        # The rerun skips the complete variants and runs the failed one.
        os.remove(os.path.join(self.out, "runs", "001", "notes.txt"))
        before = os.stat(os.path.join(self.out, "runs", "000", "summary.json")).st_mtime_ns
        r = self.run_sweep()
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertIn("2 of 3 variants already complete", r.stdout)
        self.assertIn("running 1 variants on 2 workers", r.stdout)
        self.assertEqual(os.stat(os.path.join(self.out, "runs", "000", "summary.json")).st_mtime_ns, before)
        again = read_csv(os.path.join(self.out, "results.csv"))
        self.assertEqual([row["exit"] for row in again], ["0", "0", "0"])
        self.assertEqual(again[0], rows[0])
        self.assertGreater(float(again[1]["max_dent.plate"]), float(again[0]["max_dent.plate"]))

        # The dents against the speed, as a picture.
        picture = os.path.join(self.tmp, "dents.png")
        r = subprocess.run([SWEEP, "plot", self.out, "--x", "bodies[ball].velocity.y", "--y", "max_dent.plate",
                            "--out", picture], capture_output=True, text=True, timeout=120)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertIn("3 variants", r.stdout)
        with open(picture, "rb") as f:
            self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")
        if os.environ.get("CRUMPLE_KEEP_PLOT"):
            shutil.copy(picture, os.environ["CRUMPLE_KEEP_PLOT"])
        r = subprocess.run([SWEEP, "plot", self.out, "--x", "speed", "--y", "max_dent.plate"],
                           capture_output=True, text=True, timeout=120)
        self.assert_one_line_error(r, "--x speed: no such column", "bodies[ball].velocity.y")
        r = subprocess.run([SWEEP, "plot", self.out, "--x", "deformation.path", "--y", "max_dent.plate"],
                           capture_output=True, text=True, timeout=120)
        self.assert_one_line_error(r, "not numbers")

    def test_a_variant_that_does_not_load_stops_the_sweep(self):
        with open(self.sweep, "w") as f:
            json.dump({"format": "crumple-sweep/1", "scene": "drop.json",
                       "vary": {"materials.clay.restitution": [0.5, 1.5]}}, f)
        r = self.run_sweep("--dry-run")
        self.assertEqual(r.returncode, 2)
        self.assertIn("variant 001 (materials.clay.restitution=1.5): ", r.stderr)
        self.assertIn("materials.clay.restitution: must be in [0, 1], got 1.5", r.stderr)
        self.assertFalse(os.path.exists(self.out))
        with open(self.sweep, "w") as f:
            json.dump({"scene": "drop.json", "vary": {"bodies[bal].velocity": [[0, -1, 0]]}}, f)
        r = self.run_sweep()
        self.assertEqual(r.returncode, 2)
        self.assertIn("bodies[bal].velocity: no body is named 'bal'", r.stderr)

    def test_version(self):
        import crumple
        r = subprocess.run([SWEEP, "--version"], capture_output=True, text=True, timeout=60)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(r.stdout.strip(), f"crumple-sweep {crumple.__version__}")

    def test_grid_dry_run(self):
        with open(self.sweep, "w") as f:
            json.dump({"scene": "drop.json", "vary": {"bodies[ball].velocity": [[0, -2, 0], [0, -4, 0]],
                                                      "materials.clay.kappa": [0.05, 0.1, 0.2]}}, f)
        r = self.run_sweep("--dry-run")
        self.assertEqual(r.returncode, 0, r.stderr)
        lines = r.stdout.splitlines()
        self.assertEqual(lines[0], "000 bodies[ball].velocity=[0,-2,0] materials.clay.kappa=0.05")
        self.assertEqual(lines[5], "005 bodies[ball].velocity=[0,-4,0] materials.clay.kappa=0.2")
        self.assertIn("6 variants (grid)", r.stdout)

    def test_a_sweep_of_too_many_variants_is_refused_before_they_are_made(self):
        # 10^12 combinations: refused from the lists' lengths alone (making them would never end).
        self.write_sweep({"scene": "drop.json", "vary": {f"set.k{i}": list(range(10)) for i in range(12)}})
        started = time.monotonic()
        r = self.run_sweep(timeout=60)
        self.assert_one_line_error(r, self.sweep, "vary: 1000000000000 variants (grid of 10 x 10 x",
                                   "more than --max-variants 100000")
        self.assertLess(time.monotonic() - started, 20)
        self.assertFalse(os.path.exists(self.out))
        self.write_sweep({"scene": "drop.json", "vary": {f"set.k{i}": list(range(10)) for i in range(6)}})
        r = self.run_sweep("--dry-run", timeout=60)
        self.assert_one_line_error(r, self.sweep, "vary: 1000000 variants")
        self.assertEqual(r.stdout, "")
        # zip counts its one length; --max-variants moves the cap.
        self.write_sweep({"scene": "drop.json", "mode": "zip", "vary": {"duration": [0.01, 0.02, 0.03]}})
        self.assert_one_line_error(self.run_sweep("--dry-run", "--max-variants", "2"),
                                   "vary: 3 variants (zip of 3): more than --max-variants 2")
        r = self.run_sweep("--dry-run", "--max-variants", "3")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("3 variants (zip)", r.stdout)
        self.assert_one_line_error(self.run_sweep("--dry-run", "--max-variants", "0"), "--max-variants")

    def test_a_bad_sweep_file_is_one_line_and_exit_2(self):
        ok = json.dumps({"scene": "drop.json", "vary": {"duration": [0.05]}})
        cases = [
            ("binary", bytes(range(256)) * 4, "not UTF-8 text (byte 0x80 at offset 128)"),
            ("UTF-16", ok.encode("utf-16"), "UTF-16 text"),
            ("UTF-16 without a byte order mark", ok.encode("utf-16-le"), "UTF-16 text"),
            ("nested", b"[" * 100000 + b"]" * 100000, "malformed JSON: nested too deeply"),
            ("a nested value", b'{"scene": "drop.json", "vary": {"duration": [' + b"[" * 100000 + b"]" * 100000
             + b"]}}", "malformed JSON: nested too deeply"),
            ("an array", b"[1, 2]", "the top level must be an object, got an array"),
            ("a string", b'"drop.json"', "the top level must be an object, got a string"),
            ("empty", b"", "malformed JSON"),
            ("NaN", b'{"scene": "drop.json", "vary": {"duration": [NaN]}}', "NaN is not a JSON value"),
            ("1e999", b'{"scene": "drop.json", "vary": {"duration": [1e999]}}', "the number 1e999 is out of range"),
        ]
        for name, data, why in cases:
            with self.subTest(name):
                with open(self.sweep, "wb") as f:
                    f.write(data)
                r = self.run_sweep(timeout=60)
                self.assert_one_line_error(r, self.sweep, why)
                self.assertNotIn("Traceback", r.stderr)
                self.assertFalse(os.path.exists(self.out))
        # Several variants that do not load: the first, and which others.
        self.write_sweep({"scene": "drop.json", "vary": {"materials.clay.restitution": [1.5, 2, 0.5, 3]}})
        self.assert_one_line_error(self.run_sweep("--dry-run"), "variant 000 (materials.clay.restitution=1.5): ",
                                   "must be in [0, 1], got 1.5", "; 2 more of 4 variants do not load (001, 003)")
        # A key path holding a line break is still one line.
        with open(self.sweep, "wb") as f:
            f.write(b'{"scene": "drop.json", "vary": {"dura\\ntion": [1]}}')
        self.assert_one_line_error(self.run_sweep("--dry-run"), "variant 000 (dura\\ntion=1): ",
                                   "dura\\ntion: unknown key")
        os.remove(self.sweep)
        os.mkdir(self.sweep)
        self.assert_one_line_error(self.run_sweep("--dry-run"), self.sweep, "Is a directory")

    def test_a_bad_option_is_one_line_and_exit_2(self):
        cases = [
            (["--scheduler", "local:0"], "local:N needs a number of workers from 1 to 1024"),
            (["--scheduler", "local:lots"], "local:N needs a number of workers"),
            (["--scheduler", "udp://head:8786"], "expected a scheduler address tcp://HOST:PORT"),
            (["--scheduler", "tcp://head"], "with a port from 1 to 65535, got 'tcp://head'"),
            (["--scheduler", "tcp://head:99999"], "with a port from 1 to 65535"),
            (["--scheduler", "head:8786"], "(a scheduler address starts with tcp://)"),
            (["--scheduler", "no-such-scheduler"], "expected local[:N], tcp://HOST:PORT or a scheduler file"),
            (["--scheduler", self.tmp], "is a folder, not a scheduler file"),
            (["--scheduler-timeout", "0"], "--scheduler-timeout must be a positive number of seconds"),
            (["--timeout", "nan"], "--timeout must be a positive number of seconds, got nan"),
            (["--grace", "-1"], "--grace must be a non-negative number of seconds"),
            (["--gpu", "one"], "--gpu: expected N or N,M,..."),
            (["--bogus"], "unrecognized arguments: --bogus"),
            (["--timeout", "soon"], "argument --timeout: invalid float value: 'soon'"),
            (["--", "--out", "elsewhere"], "--out after --: crumple-sweep sets it itself"),
            (["--", "-oelsewhere"], "-oelsewhere after --: crumple-sweep sets it itself"),
            (["--", "--trace=t.csv"], "--trace=t.csv after --: every variant would write that one file"),
            # Refused by crumple-sim itself, which crumple-sweep runs once with them before any variant.
            (["--", "--bogus"], "options after -- (--bogus): crumple-sim refuses them: The following argument "
             "was not expected: --bogus"),
            (["--", "--steps", "0"], "crumple-sim refuses them: --steps: Value 0 not in range"),
            (["--", "--size", "3x3"], "crumple-sim refuses them: --size must be WxH"),
            (["--", "--video-camera", "main"], "crumple-sim refuses them: --video-camera needs --video"),
            (["--", "--version"], "options after -- (--version): crumple-sim runs nothing with them"),
        ]
        for extra, why in cases:
            with self.subTest(" ".join(extra)):
                r = self.run_sweep(*extra, timeout=60)
                self.assert_one_line_error(r, why)
                self.assertFalse(os.path.exists(self.out))
        r = self.run_sweep("--dry-run", "--", "--steps", "20", "--deform-path", "scatter", timeout=60)
        self.assertEqual(r.returncode, 0, r.stderr)

    def test_a_scheduler_that_is_not_there_is_waited_for_at_most_the_timeout(self):
        # No scheduler file ever appears.
        missing = os.path.join(self.tmp, "dask", "scheduler.json")
        started = time.monotonic()
        r = self.run_sweep("--scheduler", missing, "--scheduler-timeout", "1", timeout=60)
        self.assert_one_line_error(r, f"{missing}: no scheduler file after 1 s (--scheduler-timeout)")
        self.assertLess(time.monotonic() - started, 20)
        self.assertFalse(os.path.exists(self.out))
        # A scheduler that accepts connections and never answers: named by a scheduler file that appears late,
        # then by its address.
        silent = socket.socket()
        silent.bind(("127.0.0.1", 0))
        silent.listen(8)
        address = "tcp://127.0.0.1:%d" % silent.getsockname()[1]
        try:
            os.makedirs(os.path.dirname(missing))

            def appear():
                with open(missing + ".tmp", "w") as f:
                    json.dump({"type": "Scheduler", "address": address}, f)
                os.replace(missing + ".tmp", missing)

            later = threading.Timer(0.5, appear)
            later.start()
            r = self.run_sweep("--scheduler", missing, "--scheduler-timeout", "3", timeout=60)
            later.join()
            self.assert_one_line_error(r, f"{missing} ({address}): no answer within 3 s")
            started = time.monotonic()
            r = self.run_sweep("--scheduler", address, "--scheduler-timeout", "2", timeout=60)
            self.assert_one_line_error(r, f"{address}: no answer within 2 s (--scheduler-timeout)")
            self.assertLess(time.monotonic() - started, 20)
        finally:
            silent.close()
        # A scheduler file that is not one.
        with open(missing, "w") as f:
            f.write("{\"addr")
        self.assert_one_line_error(self.run_sweep("--scheduler", missing, "--scheduler-timeout", "0.5"),
                                   f"{missing}: not a Dask scheduler file after 0.5 s")
        self.assertFalse(os.path.exists(self.out))

    def start_slow_sweep(self, *extra):
        """crumple-sweep on two variants that would run for minutes; returns it once both runs have started."""
        self.write_sweep({"scene": "drop.json", "vary": {"bodies[ball].velocity": [[0, -2, 0], [0, -5, 0]]},
                          "set": {"duration": 100000}})
        sweep = subprocess.Popen([SWEEP, self.sweep, "--out", self.out, "--scheduler", "local:2", *extra],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        runs = os.path.join(self.out, "runs") + os.sep
        if not wait_for(lambda: len(processes_naming(runs)) == 2 or sweep.poll() is not None, 120):
            sweep.kill()
        if len(processes_naming(runs)) != 2:
            sweep.kill()
            self.fail(f"the runs did not start: {sweep.communicate()}")
        return sweep, runs

    @unittest.skipUnless(sys.platform.startswith("linux"), "looks for processes in /proc")
    def test_sigterm_stops_the_runs_and_a_rerun_redoes_them(self):
        sweep, runs = self.start_slow_sweep()
        time.sleep(0.5)  # into their steps
        sweep.send_signal(signal.SIGTERM)
        _, err = sweep.communicate(timeout=60)
        self.assertEqual(sweep.returncode, 143, err)
        self.assertIn("interrupted (SIGTERM): 0 of 2 variants complete", err)
        self.assertEqual(processes_naming(runs), [])
        # crumple-sim removed its partial output: nothing in runs/, no marker a rerun would trust.
        self.assertEqual(os.listdir(os.path.join(self.out, "runs")), [])
        rows = read_csv(os.path.join(self.out, "results.csv"))
        self.assertEqual([(row["exit"], row["status"]) for row in rows], [("130", "interrupted")] * 2)
        self.assertIn("crumple-sweep was interrupted", rows[0]["error"])
        # The same sweep, shorter: both run again into the same folders.
        self.write_sweep({"scene": "drop.json", "vary": {"bodies[ball].velocity": [[0, -2, 0], [0, -5, 0]]},
                          "set": {"duration": 0.05}})
        r = self.run_sweep()
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertIn("running 2 variants", r.stdout)
        self.assertEqual([row["status"] for row in read_csv(os.path.join(self.out, "results.csv"))], ["ok", "ok"])

    @unittest.skipUnless(sys.platform.startswith("linux"), "looks for processes in /proc")
    def test_sigint_kills_a_run_that_ignores_sigterm_after_the_grace(self):
        sim = self.fake_sim("stubborn-sim", "signal.signal(signal.SIGTERM, signal.SIG_IGN)\n"
                                            "signal.signal(signal.SIGINT, signal.SIG_IGN)\ntime.sleep(60)")
        sweep, runs = self.start_slow_sweep("--sim", sim, "--grace", "1")
        started = time.monotonic()
        sweep.send_signal(signal.SIGINT)
        _, err = sweep.communicate(timeout=60)
        self.assertEqual(sweep.returncode, 130, err)
        self.assertLess(time.monotonic() - started, 15)
        self.assertEqual(processes_naming(runs), [])
        rows = read_csv(os.path.join(self.out, "results.csv"))
        self.assertEqual([(row["exit"], row["status"]) for row in rows], [("137", "interrupted")] * 2)
        self.assertIn("killed: still running 1 s after SIGTERM", rows[1]["error"])

    @unittest.skipUnless(sys.platform.startswith("linux"), "looks for processes in /proc")
    def test_sigkill_of_the_sweep_ends_its_runs(self):
        # Nothing of crumple-sweep runs after SIGKILL: its runs end by the death signal they were started with.
        sim = self.fake_sim("slow-sim", "time.sleep(60)")
        sweep, runs = self.start_slow_sweep("--sim", sim)
        sweep.kill()
        sweep.communicate(timeout=60)
        self.assertTrue(wait_for(lambda: not processes_naming(runs), 5), processes_naming(runs))

    def test_a_run_that_a_signal_ended_says_which(self):
        sim = self.fake_sim("crashing-sim", "resource.setrlimit(resource.RLIMIT_CORE, (0, 0))\n"
                                            "print('step 1')\n"
                                            "if 'bodies[ball].velocity=[0, -5, 0]' in sys.argv:\n"
                                            "    os.kill(os.getpid(), signal.SIGSEGV)\n"
                                            "sys.exit(3)")
        r = self.run_sweep("--sim", sim)
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        rows = read_csv(os.path.join(self.out, "results.csv"))
        self.assertEqual([(row["exit"], row["status"]) for row in rows],
                         [("3", "exit 3"), ("139", "signal 11 (SIGSEGV)"), ("3", "exit 3")])
        self.assertEqual(rows[1]["error"], "crumple-sim was killed by signal 11 (SIGSEGV)")
        self.assertIn("001: signal 11 (SIGSEGV)", r.stdout)
        with open(os.path.join(self.out, "logs", "001.log")) as f:
            self.assertIn("signal 11 (SIGSEGV) (exit 139)", f.readline())

    def test_a_run_past_its_timeout_is_stopped_then_killed(self):
        sim = self.fake_sim("stubborn-sim", "if 'bodies[ball].velocity=[0, -5, 0]' in sys.argv:\n"
                                            "    signal.signal(signal.SIGTERM, signal.SIG_IGN)\ntime.sleep(60)")
        started = time.monotonic()
        r = self.run_sweep("--sim", sim, "--timeout", "0.5", "--grace", "0.5", timeout=60)
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        self.assertLess(time.monotonic() - started, 30)
        rows = read_csv(os.path.join(self.out, "results.csv"))
        self.assertEqual([(row["exit"], row["status"]) for row in rows], [("124", "timed out")] * 3)
        self.assertEqual([row["error"] for row in rows],
                         ["timed out after 0.5 s", "timed out after 0.5 s (killed: still running 0.5 s after SIGTERM)",
                          "timed out after 0.5 s"])
        self.assertEqual(processes_naming(os.path.join(self.out, "runs") + os.sep), [])


if __name__ == "__main__":
    unittest.main()
