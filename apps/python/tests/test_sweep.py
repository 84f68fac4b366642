"""crumple-sweep on a local Dask cluster (local:2): a 3-variant sweep of drop.json writes results.csv, a failed
variant is a row with its exit status, and a rerun runs only what is not complete.

Run by ctest; by hand (from apps/python/tests/):
    PYTHONPATH=build/python CRUMPLE_SWEEP=build/apps/crumple-sweep python3 -m unittest -v test_sweep"""

import csv
import json
import os
import shutil
import subprocess
import tempfile
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
        shutil.rmtree(self.tmp, ignore_errors=True)

    def run_sweep(self, *extra):
        return subprocess.run([SWEEP, self.sweep, "--out", self.out, "--scheduler", "local:2", *extra],
                              capture_output=True, text=True, timeout=300)

    def test_three_variants_then_a_failure_then_a_rerun(self):
        # Variant 001's folder holds a file crumple did not write: crumple-sim refuses it (exit 2).
        os.makedirs(os.path.join(self.out, "runs", "001"))
        with open(os.path.join(self.out, "runs", "001", "notes.txt"), "w") as f:
            f.write("mine\n")
        r = self.run_sweep()
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        rows = read_csv(os.path.join(self.out, "results.csv"))
        self.assertEqual(list(rows[0].keys()),
                         ["id", "bodies[ball].velocity", "deformation.path", "exit", "collisions", "deformations",
                          "max_dent.plate", "max_dent.ball", "error"])
        self.assertEqual([row["id"] for row in rows], ["000", "001", "002"])
        self.assertEqual([row["bodies[ball].velocity"] for row in rows], ["[0,-2,0]", "[0,-5,0]", "[0,-9,0]"])
        self.assertEqual([row["deformation.path"] for row in rows], ["gather", "scatter", "gather"])
        self.assertEqual([row["exit"] for row in rows], ["0", "2", "0"])
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


if __name__ == "__main__":
    unittest.main()
