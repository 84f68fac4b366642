"""The Python module `crumple` (docs/python.md) and crumple-sim --set, on a small scene (drop.json).

Run by ctest with PYTHONPATH=build/python; by hand:
    PYTHONPATH=build/python CRUMPLE_SIM=build/apps/crumple-sim python3 -m unittest -v test_python
(from apps/python/tests/)."""

import json
import os
import pathlib
import subprocess
import sys
import tempfile
import threading
import unittest

import numpy as np

import crumple

HERE = os.path.dirname(os.path.abspath(__file__))
DROP = os.path.join(HERE, "drop.json")
SIM = os.environ.get("CRUMPLE_SIM", "crumple-sim")


class LoadAndStep(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.sim = crumple.Simulation(DROP)
        cls.sim.run()

    def test_runs_to_the_scene_duration(self):
        self.assertEqual(self.sim.steps, round(0.1 / self.sim.timestep))
        self.assertAlmostEqual(self.sim.time, 0.1, places=6)
        self.assertEqual(self.sim.name, "drop")
        self.assertEqual(self.sim.run(), 0)  # already there

    def test_height_map_holds_the_dent(self):
        h = self.sim.height_map("plate")
        self.assertIsInstance(h, np.ndarray)
        self.assertEqual(h.dtype, np.float32)
        self.assertEqual(h.shape, (128, 128))
        # 0.5 is flat: most of the plate is untouched, and the ball pressed in below it.
        self.assertAlmostEqual(float(np.median(h)), 0.5, places=6)
        depth_m = (0.5 - float(h.min())) * 0.1  # bump_depth k = 0.1 m
        self.assertGreater(depth_m, 0.005)
        dented = np.count_nonzero(h < 0.5 - 1e-4)
        self.assertGreater(dented, 20)
        self.assertLess(dented, h.size // 4)
        # The deepest texel matches the deepest dent the events report (to float precision).
        plate_dents = [e["a_side"]["max_dent"] if e["a"] == "plate" else e["b_side"]["max_dent"]
                       for e in self.sim.events() if e["type"] == "collision" and "plate" in (e["a"], e["b"])]
        self.assertAlmostEqual(depth_m, max(plate_dents), delta=1e-5)

    def test_normal_map_is_tilted_in_the_dent_only(self):
        n = self.sim.normal_map("plate")
        self.assertEqual(n.dtype, np.float32)
        self.assertEqual(n.shape, (128, 128, 3))
        h = self.sim.height_map("plate")
        # Texels whose neighbours are all undented too (a normal is the height map's slope around a texel).
        far = h == 0.5
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                far &= np.roll(np.roll(h, dy, 0), dx, 1) == 0.5
        flat = n[far]
        self.assertGreater(len(flat), h.size // 2)
        self.assertTrue(np.all(np.abs(flat[:, :2]) < 0.01))
        self.assertTrue(np.all(flat[:, 2] > 0.99))
        self.assertGreater(float(np.abs(n[..., :2]).max()), 0.1)

    def test_bodies_and_events(self):
        bodies = self.sim.bodies()
        self.assertEqual([b["name"] for b in bodies], ["plate", "ball", "pebble"])
        self.assertEqual(set(bodies[1]), {"name", "position", "orientation", "linear_velocity", "angular_velocity",
                                          "center_of_mass", "mass", "static", "asleep"})
        self.assertNotIn("mass", bodies[0])
        self.assertTrue(bodies[0]["static"])
        self.assertGreater(bodies[1]["position"][1], 0.2)  # bounced, above the plate
        events = self.sim.events()
        self.assertGreaterEqual(len(events), 1)
        first = events[0]
        self.assertEqual(first["type"], "collision")
        self.assertEqual({first["a"], first["b"]}, {"plate", "ball"})
        self.assertTrue(first["a_side"]["deformed"] and first["b_side"]["deformed"])

    def test_errors_for_names(self):
        with self.assertRaisesRegex(ValueError, r"no body is named 'nope'"):
            self.sim.height_map("nope")
        with self.assertRaisesRegex(ValueError, r"'pebble' has no bump_map"):
            self.sim.normal_map("pebble")
        with self.assertRaisesRegex(ValueError, r"no camera is named 'side' \(cameras: main\)"):
            self.sim.render("side")

    def test_render_returns_an_image(self):
        img = self.sim.render("main", width=160, height=90)
        self.assertEqual(img.dtype, np.uint8)
        self.assertEqual(img.shape, (90, 160, 3))
        self.assertGreater(int(img.std()), 3)  # a picture, not a blank
        self.assertEqual(self.sim.render().shape, (540, 960, 3))  # the first camera, crumple-sim's size


class Outputs(unittest.TestCase):
    def test_write_outputs_is_what_crumple_sim_writes(self):
        with tempfile.TemporaryDirectory() as tmp:
            sim = crumple.Simulation(DROP)
            sim.step(12)
            self.assertEqual(sim.steps, 12)
            out = os.path.join(tmp, "out")
            sim.write_outputs(out)
            with open(os.path.join(out, "summary.json")) as f:
                summary = json.load(f)
            self.assertEqual(summary["steps"], 12)
            self.assertEqual(summary["bodies"], sim.bodies())
            with open(os.path.join(out, "events.jsonl")) as f:
                lines = [json.loads(line) for line in f]
            self.assertEqual(lines, sim.events())
            for f in ("heightmaps/plate.png", "normalmaps/ball.png", ".crumple-output"):
                self.assertTrue(os.path.isfile(os.path.join(out, f)), f)
            # crumple-sim's run of the same steps writes the same state.
            cli = os.path.join(tmp, "cli")
            subprocess.run([SIM, DROP, "--out", cli, "--steps", "12", "-q"], check=True)
            with open(os.path.join(cli, "summary.json")) as f:
                self.assertEqual(json.load(f)["bodies"], summary["bodies"])
            # A folder crumple did not write is refused, as crumple-sim refuses it.
            foreign = os.path.join(tmp, "foreign")
            os.makedirs(foreign)
            open(os.path.join(foreign, "notes.txt"), "w").close()
            with self.assertRaisesRegex(crumple.SceneError, "not written by crumple"):
                sim.write_outputs(foreign)


class Overrides(unittest.TestCase):
    def test_overrides_change_the_run(self):
        slow = crumple.Simulation(DROP, overrides={"bodies[ball].velocity": [0, -3, 0]})
        fast = crumple.Simulation(DROP, overrides={"bodies[ball].velocity": np.array([0.0, -9.0, 0.0]),
                                                   "deformation.path": "scatter"})
        for s in (slow, fast):
            s.run()
        self.assertLess(slow.height_map("plate").min(), 0.5)
        self.assertLess(fast.height_map("plate").min(), slow.height_map("plate").min())

    def test_threads_give_the_same_run(self):
        one = crumple.Simulation(DROP, threads=1)
        two = crumple.Simulation(DROP, threads=2)
        for s in (one, two):
            s.run()
        self.assertEqual(one.bodies(), two.bodies())
        self.assertTrue(np.array_equal(one.height_map("plate"), two.height_map("plate")))
        with self.assertRaises(ValueError):
            crumple.Simulation(DROP, threads=-1)

    def test_load_scene(self):
        info = crumple.load_scene(DROP, {"bodies[pebble].bump_map": {"resolution": 32}, "duration": 0.5})
        self.assertEqual(info["name"], "drop")
        self.assertEqual(info["steps"], 120)
        self.assertEqual([(b["name"], b["bump_map"]) for b in info["bodies"]],
                         [("plate", 128), ("ball", 64), ("pebble", 32)])
        self.assertEqual(info["cameras"], ["main"])

    def test_bad_input_raises_scene_error_with_crumple_sim_message(self):
        cases = [
            ({"bodies[bal].velocity": [0, -8, 0]}, "bodies[bal].velocity", "no body is named 'bal'"),
            ({"bodies[ball].velocty": [0, -8, 0]}, "bodies[1].velocty", "unknown key"),
            ({"materials.clay.restitution": 1.5}, "materials.clay.restitution", "must be in [0, 1], got 1.5"),
            ({"materials.iron.kappa": 0.1}, "materials.iron.kappa", "no material is named 'iron'"),
        ]
        for overrides, key_path, reason in cases:
            with self.subTest(overrides=overrides):
                with self.assertRaises(crumple.SceneError) as cm:
                    crumple.Simulation(DROP, overrides=overrides)
                e = cm.exception
                self.assertIsInstance(e, ValueError)
                self.assertEqual(e.key_path, key_path)
                self.assertIn(reason, e.reason)
                self.assertEqual(e.file, DROP)
                # crumple-sim prints the same message, with exit status 2.
                (key, value), = overrides.items()
                r = subprocess.run([SIM, DROP, "--out", os.devnull + "-never", "--set", f"{key}={json.dumps(value)}"],
                                   capture_output=True, text=True)
                self.assertEqual(r.returncode, 2)
                self.assertEqual(r.stderr.strip(), f"crumple-sim: error: {e}")

    def test_bad_scene_file(self):
        with self.assertRaises(crumple.SceneError) as cm:
            crumple.Simulation(os.path.join(HERE, "no-such-scene.json"))
        self.assertIn("no such file", str(cm.exception))
        with tempfile.NamedTemporaryFile("w", suffix=".json") as f:
            f.write('{"bodies": [{"name": "b", "shape": {"type": "sphere", "radius": -1}}]}')
            f.flush()
            with self.assertRaises(crumple.SceneError) as cm:
                crumple.Simulation(f.name)
            self.assertEqual(cm.exception.key_path, "bodies[0].shape.radius")

    def test_override_types(self):
        with self.assertRaisesRegex(TypeError, "key path must be a str"):
            crumple.Simulation(DROP, overrides={3: 1})
        with self.assertRaisesRegex(TypeError, "not JSON"):
            crumple.Simulation(DROP, overrides={"duration": object()})

    def test_crumple_sim_set(self):
        with tempfile.TemporaryDirectory() as tmp:
            runs = {}
            for v in (-3, -9):
                out = os.path.join(tmp, str(v))
                subprocess.run([SIM, DROP, "--out", out, "-q", "--set", f"bodies[ball].velocity=[0,{v},0]",
                                "--set", "deformation.path=scatter", "--set", "duration=0.05"], check=True)
                with open(os.path.join(out, "summary.json")) as f:
                    runs[v] = json.load(f)
                with open(os.path.join(out, "events.jsonl")) as f:
                    runs[v]["dent"] = max(json.loads(line)["a_side"]["max_dent"] for line in f)
            self.assertEqual(runs[-3]["steps"], 12)
            self.assertGreater(runs[-9]["dent"], runs[-3]["dent"])


class Default(unittest.TestCase):
    def test_builtin_scene_and_version(self):
        sim = crumple.Simulation(overrides={"duration": 0.01})
        self.assertEqual(sim.name, "sphere-into-plate")
        self.assertEqual(sim.run(), 2)
        self.assertRegex(crumple.__version__, r"^\d+\.\d+\.\d+")
        self.assertIn("sphere-into-plate", repr(sim))


class Robustness(unittest.TestCase):
    def test_an_object_made_without_init_raises_instead_of_crashing(self):
        # In a child interpreter: it used to end in a segmentation fault.
        code = """
import crumple, tempfile
sim = crumple.Simulation.__new__(crumple.Simulation)
raw = crumple._crumple._Simulation.__new__(crumple._crumple._Simulation)
print(repr(sim))
calls = {
    "step": lambda s: s.step(1), "run": lambda s: s.run(), "time": lambda s: s.time, "steps": lambda s: s.steps,
    "total_steps": lambda s: s.total_steps, "gl": lambda s: s.gl, "bodies": lambda s: s.bodies(),
    "events": lambda s: s.events(), "height_map": lambda s: s.height_map("plate"),
    "normal_map": lambda s: s.normal_map("plate"), "render": lambda s: s.render(),
    "write_outputs": lambda s: s.write_outputs(tempfile.mkdtemp() + "/out"),
}
for name, call in calls.items():
    for obj in (sim, raw):
        try:
            call(obj)
            print(name, "no error")
        except TypeError as e:
            assert "not initialised" in str(e), (name, str(e))
for name in ("name", "timestep", "duration"):
    try:
        getattr(sim, name)
        print(name, "no error")
    except TypeError as e:
        assert "not initialised" in str(e), (name, str(e))
print("done")
"""
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(r.stdout, "<crumple.Simulation (not initialised)>\ndone\n")

    def test_a_simulation_runs_and_renders_from_any_thread(self):
        made_here = crumple.Simulation(DROP)
        made_there = {}
        errors = []

        def use(sim):
            try:
                sim.step(6)
                frame = sim.render(width=64, height=48)
                assert frame.shape == (48, 64, 3), frame.shape
                sim.height_map("plate")
                sim.bodies()
                sim.events()
                assert "EGL" in sim.gl or sim.gl.startswith("none"), sim.gl
            except Exception as e:  # reported below
                errors.append(repr(e))

        def make():
            try:
                made_there["sim"] = crumple.Simulation(DROP)
            except Exception as e:
                errors.append(repr(e))

        # Made on this thread, used on another (EGL_BAD_ACCESS before), then here again.
        t = threading.Thread(target=use, args=(made_here,))
        t.start()
        t.join()
        self.assertEqual(errors, [])
        use(made_here)
        self.assertEqual(errors, [])
        # Made on another thread, used here.
        t = threading.Thread(target=make)
        t.start()
        t.join()
        self.assertEqual(errors, [])
        use(made_there["sim"])
        self.assertEqual(errors, [])
        # Two threads taking turns on one simulation, and on their own at once: the runs of one thread's.
        shared = crumple.Simulation(DROP)
        threads = [threading.Thread(target=use, args=(shared,)) for _ in range(2)]
        threads += [threading.Thread(target=use, args=(crumple.Simulation(DROP),)) for _ in range(2)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        self.assertEqual(errors, [])
        alone = crumple.Simulation(DROP)
        alone.step(12)
        self.assertEqual(shared.steps, 12)  # 6 from each of the threads
        self.assertEqual(shared.bodies(), alone.bodies())
        shared.step(12)
        alone.step(12)
        self.assertEqual(shared.bodies(), alone.bodies())
        self.assertTrue(np.array_equal(shared.height_map("plate"), alone.height_map("plate")))

    def test_failures_at_run_time_raise_runtime_error(self):
        # The engine's own std::invalid_argument, length_error and out_of_range used to arrive as ValueError and
        # IndexError, which say the caller passed a bad value.
        for kind in ("invalid_argument", "length_error", "out_of_range", "runtime_error"):
            with self.subTest(kind=kind):
                with self.assertRaises(RuntimeError) as cm:
                    crumple._crumple._raise_for_test(kind)
                self.assertNotIsInstance(cm.exception, ValueError)
                self.assertEqual(str(cm.exception), f"{kind} from C++")
        # Bad input stays SceneError, its text UTF-8 whatever the file name's bytes.
        with self.assertRaises(crumple.SceneError) as cm:
            crumple._crumple._raise_for_test("scene_error")
        self.assertEqual(str(cm.exception), "f\\xFF.json: k: bad")
        self.assertEqual(cm.exception.file, "f\\xFF.json")
        # No such GPU: RuntimeError.
        with self.assertRaises(RuntimeError):
            crumple.Simulation(DROP, gpu=1023)

    def test_paths_are_str_bytes_or_path_like_never_empty_or_with_a_nul_byte(self):
        sim = crumple.Simulation(DROP, overrides={"duration": 0.01})
        sim.run()
        with tempfile.TemporaryDirectory() as tmp:
            with self.assertRaisesRegex(ValueError, "^write_outputs: dir must not be empty$"):
                sim.write_outputs("")
            # A NUL byte used to cut the path short: out\0side wrote to "out".
            with self.assertRaisesRegex(ValueError, "^write_outputs: dir holds a NUL byte$"):
                sim.write_outputs(os.path.join(tmp, "out\0side"))
            with self.assertRaisesRegex(ValueError, "dir must not be empty"):
                crumple._crumple._Simulation.write_outputs(sim, "")
            with self.assertRaisesRegex(ValueError, "dir holds a NUL byte"):
                crumple._crumple._Simulation.write_outputs(sim, os.path.join(tmp, "out\0side"))
            self.assertEqual(os.listdir(tmp), [])
            with self.assertRaisesRegex(TypeError, "write_outputs: dir must be a str or an os.PathLike, got int"):
                sim.write_outputs(3)
            sim.write_outputs(pathlib.Path(tmp) / "as-path")
            sim.write_outputs(os.fsencode(os.path.join(tmp, "as-bytes")))
            self.assertTrue(os.path.isfile(os.path.join(tmp, "as-path", "summary.json")))
            self.assertTrue(os.path.isfile(os.path.join(tmp, "as-bytes", "summary.json")))
            # A scene in a folder whose name is not UTF-8 loads and writes (its path escaped in summary.json).
            folder = os.path.join(os.fsencode(tmp), b"caf\xe9")
            os.mkdir(folder)
            with open(DROP, "rb") as f, open(os.path.join(folder, b"drop.json"), "wb") as g:
                g.write(f.read())
            odd = crumple.Simulation(os.fsdecode(os.path.join(folder, b"drop.json")), overrides={"duration": 0.01})
            self.assertEqual(odd.name, "drop")
            odd.write_outputs(os.path.join(tmp, "odd"))
            with open(os.path.join(tmp, "odd", "summary.json")) as f:
                self.assertTrue(json.load(f)["scene_file"].endswith("caf\\xE9/drop.json"))
        for bad, error in (("", "^Simulation: path must not be empty$"), ("a\0b", "^Simulation: path holds a NUL byte$")):
            with self.assertRaisesRegex(ValueError, error):
                crumple.Simulation(bad)
            with self.assertRaisesRegex(ValueError, error.replace("Simulation", "load_scene")):
                crumple.load_scene(bad)
        self.assertEqual(crumple.load_scene(pathlib.Path(DROP))["name"], "drop")
        with self.assertRaises(TypeError):
            crumple.Simulation(3)


class ScenesFromPython(unittest.TestCase):
    def test_from_dict_and_from_json_run_as_the_file_does(self):
        with open(DROP) as f:
            scene = json.load(f)
        files = crumple.Simulation(DROP)
        dicts = crumple.Simulation.from_dict(scene)
        texts = crumple.Simulation.from_json(json.dumps(scene).encode())
        for s in (files, dicts, texts):
            s.step(12)
        self.assertEqual(dicts.bodies(), files.bodies())
        self.assertEqual(texts.bodies(), files.bodies())
        self.assertTrue(np.array_equal(dicts.height_map("plate"), files.height_map("plate")))
        # Overrides apply as for a file; errors name the source and the key path.
        quick = crumple.Simulation.from_dict(scene, {"duration": 0.05})
        self.assertEqual(quick.total_steps, 12)
        scene["bodies"][1]["material"] = "rubber"
        with self.assertRaises(crumple.SceneError) as e:
            crumple.Simulation.from_dict(scene)
        self.assertEqual(e.exception.file, "<dict>")
        self.assertEqual(e.exception.key_path, "bodies[1].material")
        with self.assertRaises(crumple.SceneError) as e:
            crumple.Simulation.from_json("{")
        self.assertEqual(e.exception.file, "<json>")
        with self.assertRaisesRegex(TypeError, "from_dict: scene must be a dict"):
            crumple.Simulation.from_dict("drop.json")
        with self.assertRaisesRegex(TypeError, "from_json: text must be a str or bytes"):
            crumple.Simulation.from_json(3)

    def test_a_closed_simulation_raises_and_with_closes(self):
        with crumple.Simulation(DROP) as sim:
            sim.step(2)
            self.assertFalse(sim.closed)
        self.assertTrue(sim.closed)
        for call in (lambda: sim.step(1), lambda: sim.bodies(), lambda: sim.height_map("plate"), lambda: sim.time,
                     lambda: sim.poses(), lambda: sim.body("ball")):
            with self.assertRaisesRegex(RuntimeError, "closed"):
                call()
        sim.close()  # twice: nothing
        for call in (lambda: sim.name, lambda: sim.timestep, lambda: sim.cameras()):
            with self.assertRaisesRegex(RuntimeError, "closed"):
                call()
        self.assertIn("(closed)", repr(sim))

    def test_a_simulation_is_initialised_once(self):
        sim = crumple.Simulation(DROP)
        with self.assertRaisesRegex(RuntimeError, "already initialised"):
            sim.__init__(DROP)
        with self.assertRaises(AttributeError):
            sim.body("ball").name = "rock"

    def test_a_body_on_a_path_refuses_a_pose_or_velocity(self):
        # (a pose set there would be left at the next step at the speed that takes: 480 m/s for 2 m)
        scene = {"format": "crumple-scene/1", "name": "k", "duration": 1,
                 "materials": {"m": {"density": 1000, "restitution": 0.2, "friction": 0.5, "kappa": 0.0001,
                                     "thickness": 0.05}},
                 "bodies": [{"name": "pusher", "shape": {"type": "box", "size": [0.2, 0.2, 0.2]}, "material": "m",
                             "kinematic": True, "path": [{"t": 0, "position": [0, 1, 0]},
                                                         {"t": 1, "position": [1, 1, 0]}]}]}
        with crumple.Simulation.from_dict(scene) as sim:
            pusher = sim.body("pusher")
            sim.step(10)
            before = pusher.position
            for what, value in (("position", [0, 3, 0]), ("orientation", [1, 0, 0, 0]),
                                ("linear_velocity", [0, 5, 0]), ("angular_velocity", [0, 1, 0])):
                with self.assertRaisesRegex(ValueError, "follows its path"):
                    setattr(pusher, what, value)
            self.assertEqual(pusher.position, before)
            sim.step(1)
            self.assertLess(max(abs(x) for x in pusher.linear_velocity), 2)

    def test_input_that_is_not_utf8_names_where_it_is(self):
        with self.assertRaises(crumple.SceneError):
            crumple.Simulation.from_json(b'{"format": "crumple-scene/1", "name": "\xff"}')
        with self.assertRaisesRegex(crumple.SceneError, "not valid UTF-8"):
            crumple.Simulation(DROP, overrides={"na\udcffme": 1})
        with self.assertRaisesRegex(ValueError, "no body is named"):
            crumple.Simulation(DROP).body("\udcff")

    def test_arguments_of_the_wrong_type_name_the_parameter(self):
        sim = crumple.Simulation(DROP)
        with self.assertRaisesRegex(TypeError, "step: n must be an int"):
            sim.step("3")
        with self.assertRaisesRegex(TypeError, "render: width must be an int"):
            sim.render("main", 64.5, 64)
        with self.assertRaisesRegex(TypeError, "body: name must be a str"):
            sim.body(1)
        ball = sim.body("ball")
        with self.assertRaisesRegex(TypeError, "linear_velocity must be a sequence of 3 numbers"):
            ball.linear_velocity = "fast"
        with self.assertRaisesRegex(ValueError, "linear_velocity must hold 3 numbers, got 2"):
            ball.linear_velocity = [1, 2]
        with self.assertRaisesRegex(ValueError, "force must be finite"):
            ball.apply_force([0, float("nan"), 0])
        with self.assertRaisesRegex(ValueError, "no body is named 'rock' \\(bodies: plate, ball, pebble\\)"):
            sim.body("rock")
        for value in ({0: 5, 1: 6, 2: 7}, {3.0, 1.0, 2.0}):  # (a dict's keys, a set's order: not a vector)
            with self.assertRaisesRegex(TypeError, "position must be a sequence of 3 numbers"):
                ball.position = value
        with self.assertRaisesRegex(TypeError, "height_map: name must be a str"):
            sim.height_map(None)
        with self.assertRaisesRegex(TypeError, "threads must be an int"):
            crumple.Simulation(DROP, threads="2")
        with self.assertRaisesRegex(TypeError, "gpu must be an int"):
            crumple.Simulation(DROP, gpu=True)
        with self.assertRaisesRegex(TypeError, "overrides must be a dict"):
            crumple.Simulation(DROP, overrides=5)
        self.assertEqual(crumple.Simulation(DROP, threads=np.int64(2)).name, sim.name)
        with self.assertRaisesRegex(ValueError, "up must not be zero or parallel to the view direction"):
            sim.render(position=[0, 3, 0], target=[0, 0, 0], size=(32, 32))
        ball.orientation = [1e200, 1e200, 0, 0]  # normalised, not overflowed
        self.assertAlmostEqual(ball.orientation[0], 0.5 ** 0.5)


class Bodies(unittest.TestCase):
    def setUp(self):
        self.sim = crumple.Simulation(DROP)
        self.dt = self.sim.timestep

    def test_handles_read_what_bodies_reports(self):
        self.sim.step(3)
        self.assertEqual(self.sim.body_names, ["plate", "ball", "pebble"])
        poses = self.sim.poses()
        self.assertEqual(poses.shape, (3, 7))
        self.assertEqual(poses.dtype, np.float64)
        for row, b in zip(poses, self.sim.bodies()):
            handle = self.sim.body(b["name"])
            self.assertEqual(list(handle.position), b["position"])
            self.assertEqual(list(handle.orientation), b["orientation"])
            self.assertEqual(list(row), b["position"] + b["orientation"])
            self.assertEqual(handle.static, b["static"])
        pebble = self.sim.body("pebble")
        self.assertEqual(list(pebble.linear_velocity), self.sim.bodies()[2]["linear_velocity"])
        self.assertAlmostEqual(pebble.mass, 7800 * 4 / 3 * np.pi * 0.05 ** 3, delta=1e-6 * pebble.mass)

    def test_setting_a_pose_and_velocities_moves_the_body(self):
        pebble = self.sim.body("pebble")
        pebble.position = [0.7, 2.0, -0.5]
        pebble.linear_velocity = [1.0, 0.0, 0.0]
        pebble.angular_velocity = np.array([0.0, 3.0, 0.0])
        self.assertEqual(pebble.position, (0.7, 2.0, -0.5))
        self.sim.step(1)
        # Free flight: x moves by v dt, y falls by g dt^2 (semi-implicit Euler: the velocity first).
        x, y, z = pebble.position
        self.assertAlmostEqual(x, 0.7 + self.dt, places=12)
        self.assertAlmostEqual(y, 2.0 - 9.81 * self.dt * self.dt, places=12)
        self.assertAlmostEqual(pebble.angular_velocity[1], 3.0, places=12)
        pebble.orientation = [2, 0, 0, 0]  # normalised
        self.assertEqual(pebble.orientation, (1.0, 0.0, 0.0, 0.0))
        with self.assertRaisesRegex(ValueError, "is static"):
            self.sim.body("plate").linear_velocity = [0, 1, 0]

    def test_an_impulse_changes_momentum_by_itself_and_a_force_acts_one_step(self):
        pebble = self.sim.body("pebble")
        m = pebble.mass
        v0 = np.array(pebble.linear_velocity)
        pebble.apply_impulse([m * 2.0, 0.0, 0.0])
        self.assertTrue(np.allclose(np.array(pebble.linear_velocity) - v0, [2.0, 0, 0], atol=1e-12))
        self.assertEqual(pebble.angular_velocity, (0.0, 0.0, 0.0))  # through the centre: no turn
        # Off the centre: the same change of momentum, and a turn about r x J (a sphere: L = I w, I = 2/5 m r^2).
        com = np.array(pebble.position)  # a sphere's origin is its centre of mass
        pebble.apply_impulse([0.0, 0.0, m * 1.0], point=com + [0.05, 0.0, 0.0])
        self.assertTrue(np.allclose(np.array(pebble.linear_velocity) - v0, [2.0, 0, 1.0], atol=1e-12))
        inertia = 0.4 * m * 0.05 ** 2
        expected_w = np.cross([0.05, 0, 0], [0, 0, m]) / inertia
        self.assertTrue(np.allclose(pebble.angular_velocity, expected_w, rtol=1e-9, atol=1e-12))
        # A force that holds the weight for one step: the velocity does not change in it, and falls again after.
        v1 = np.array(pebble.linear_velocity)
        pebble.apply_force([0.0, m * 9.81, 0.0])
        self.sim.step(1)
        self.assertTrue(np.allclose(pebble.linear_velocity, v1, atol=1e-9))
        self.sim.step(1)
        self.assertAlmostEqual(pebble.linear_velocity[1] - v1[1], -9.81 * self.dt, places=9)
        with self.assertRaisesRegex(ValueError, "plate.*static"):
            self.sim.body("plate").apply_impulse([0, 1, 0])

    def test_render_from_a_camera_placed_by_hand(self):
        named = self.sim.render("main", 96, 64)
        same = self.sim.render(position=[1.6, 1.2, 1.6], target=[0, 0, 0], size=(96, 64))
        self.assertEqual(same.shape, (64, 96, 3))
        self.assertTrue(np.array_equal(named, same))  # the scene's camera "main" is placed there, fov 45
        top = self.sim.render(position=[0, 4, 0.01], target=[0, 0, 0], fov=30, width=96, height=64)
        self.assertFalse(np.array_equal(top, same))
        self.assertGreater(top.std(), 1.0)  # a picture, not a flat colour
        with self.assertRaisesRegex(ValueError, "position and target go together"):
            self.sim.render(position=[1, 1, 1])
        with self.assertRaisesRegex(ValueError, "either camera or position"):
            self.sim.render("main", position=[1, 1, 1], target=[0, 0, 0])

    def test_write_png(self):
        self.sim.run()
        with tempfile.TemporaryDirectory() as tmp:
            def header(path):
                with open(path, "rb") as f:
                    data = f.read(33)
                self.assertEqual(data[:8], b"\x89PNG\r\n\x1a\n")
                width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
                return width, height, data[24], data[25]  # bit depth, colour type
            frame = self.sim.render("main", 80, 48)
            crumple.write_png(os.path.join(tmp, "frame.png"), frame)
            self.assertEqual(header(os.path.join(tmp, "frame.png")), (80, 48, 8, 2))  # RGB
            h = self.sim.height_map("plate")
            crumple.write_png(pathlib.Path(tmp) / "h.png", h)
            self.assertEqual(header(os.path.join(tmp, "h.png")), (128, 128, 16, 0))  # grey, 16 bit
            # The height map the outputs write is the same file.
            self.sim.write_outputs(os.path.join(tmp, "out"))
            with open(os.path.join(tmp, "h.png"), "rb") as a, open(os.path.join(tmp, "out", "heightmaps", "plate.png"), "rb") as b:
                self.assertEqual(a.read(), b.read())
            with self.assertRaisesRegex(ValueError, "got shape"):
                crumple.write_png(os.path.join(tmp, "bad.png"), np.zeros((4, 4, 5)))
            with self.assertRaisesRegex(TypeError, "array must be a numpy array"):
                crumple.write_png(os.path.join(tmp, "bad.png"), [[0.5]])
            with self.assertRaises(OSError):
                crumple.write_png(os.path.join(tmp, "no", "such", "folder", "x.png"), h)
            self.assertFalse(os.path.exists(os.path.join(tmp, "bad.png")))


class Documentation(unittest.TestCase):
    def test_every_public_name_has_a_docstring_and_a_stub(self):
        import ast
        stub_path = os.path.join(os.path.dirname(crumple.__file__), "__init__.pyi")
        with open(stub_path) as f:
            stub = ast.parse(f.read())
        stubbed = {node.name: node for node in stub.body if isinstance(node, (ast.ClassDef, ast.FunctionDef))}
        for name in crumple.__all__:
            if name == "__version__":
                continue
            self.assertIn(name, stubbed, f"{name} has no stub")
            self.assertTrue((getattr(crumple, name).__doc__ or "").strip(), f"{name} has no docstring")
        for cls in (crumple.Simulation, crumple.Body):
            members = {n for n in dir(cls) if not n.startswith("_")}
            in_stub = {n.name if isinstance(n, (ast.FunctionDef, ast.ClassDef)) else n.target.id
                       for n in stubbed[cls.__name__].body if isinstance(n, (ast.FunctionDef, ast.AnnAssign))}
            in_stub = {n for n in in_stub if not n.startswith("_")}
            self.assertEqual(members - {"name"}, in_stub - {"name"}, cls.__name__)
            for n in members - {"name"}:
                self.assertTrue((getattr(cls, n).__doc__ or "").strip(), f"{cls.__name__}.{n} has no docstring")
        self.assertIn("seconds", crumple.Simulation.step.__doc__ + crumple.Simulation.time.__doc__)


class DocumentedScript(unittest.TestCase):
    def test_the_ball_driven_by_impulses_in_docs_python_md_runs(self):
        docs = pathlib.Path(HERE).parents[2] / "docs" / "python.md"
        text = docs.read_text(encoding="utf-8")
        section = text.split("### A ball driven by impulses", 1)[1]
        script = section.split("```python\n", 1)[1].split("```", 1)[0]
        self.assertLess(len(script.splitlines()), 25)
        with tempfile.TemporaryDirectory() as tmp:
            r = subprocess.run([sys.executable, "-c", script], cwd=tmp, capture_output=True, text=True, timeout=300)
            self.assertEqual(r.returncode, 0, r.stderr)
            # 2.4 m/s^2 through the centre of a ball that rolls: 5/7 of it, 1.7 m/s^2 over 1 s (rolling friction aside).
            rolled, speed = (float(x) for x in __import__("re").findall(r"[-0-9.]+(?= m)", r.stdout)[:2])
            self.assertAlmostEqual(speed, 2.4 * 5 / 7, delta=0.15)
            self.assertAlmostEqual(rolled, 0.5 * 2.4 * 5 / 7, delta=0.15)
            with open(os.path.join(tmp, "push.png"), "rb") as f:
                self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")


if __name__ == "__main__":
    unittest.main()
