"""crumple: rigid bodies whose strong collisions dent their bump maps, from Python.

    import crumple
    sim = crumple.Simulation("scenes/sphere-into-plate.json",
                             overrides={"bodies[ball].velocity": [0, -8, 0]})
    sim.run()
    dent = 0.5 - sim.height_map("plate").min()   # in units of the plate's bump_depth

The full API is in docs/python.md; scene files in docs/scene-format.md.
"""

import json as _json
import os as _os

from . import _crumple

import math as _math
import numbers as _numbers

__all__ = ["Simulation", "Body", "SceneError", "load_scene", "write_png", "__version__"]

__version__ = _crumple.__version__

SceneError = _crumple.SceneError
SceneError.__module__ = "crumple"
SceneError.__doc__ = (
    "Bad input: the scene file, a file it names, or an override. str(e) is the message crumple-sim prints "
    "after 'crumple-sim: error: ' (file, key path, reason); e.file, e.key_path and e.reason hold the parts.")


def _json_default(value):
    # numpy arrays and scalars
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def _overrides(overrides):
    """{key path: value} (or (key path, value) pairs) as (key, JSON text) pairs, in order."""
    if overrides is None:
        return []
    if isinstance(overrides, (str, bytes)) or not hasattr(overrides, "__iter__"):
        raise TypeError(f"overrides must be a dict or (key, value) pairs, got {type(overrides).__name__}")
    items = overrides.items() if hasattr(overrides, "items") else overrides
    out = []
    for item in items:
        try:
            key, value = item
        except (TypeError, ValueError):
            raise TypeError(f"overrides: expected a dict or (key, value) pairs, got {item!r}") from None
        if not isinstance(key, str):
            raise TypeError(f"overrides: a key path must be a str, got {key!r}")
        try:
            text = _json.dumps(value, default=_json_default, allow_nan=False)
        except (TypeError, ValueError) as e:
            raise TypeError(f"overrides: {key}: the value is not JSON: {e}") from None
        # (bytes: a key that is not UTF-8 reaches the loader, which names it)
        out.append((key.encode("utf-8", "surrogateescape"), text))
    return out


def _path(function, parameter, value):
    """A path argument (str, bytes or os.PathLike) as the bytes the file system takes (a name that is not UTF-8
    included): TypeError for anything else, ValueError for an empty path or one that holds a NUL byte (a C string
    would end there and name another file)."""
    try:
        text = _os.fspath(value)
    except TypeError:
        raise TypeError(f"{function}: {parameter} must be a str or an os.PathLike, got {type(value).__name__}") from None
    if isinstance(text, str):
        text = _os.fsencode(text)
    if not text:
        raise ValueError(f"{function}: {parameter} must not be empty")
    if b"\0" in text:
        raise ValueError(f"{function}: {parameter} holds a NUL byte")
    return text


def _vector(function, parameter, value, n):
    """A sequence (list, tuple, numpy array) of n finite numbers as a list of floats: TypeError naming the
    parameter for anything else, ValueError for the wrong length or a value that is not finite."""
    if isinstance(value, (str, bytes, dict, set, frozenset)) or not hasattr(value, "__len__"):
        raise TypeError(f"{function}: {parameter} must be a sequence of {n} numbers, got {type(value).__name__}")
    items = list(value.tolist() if hasattr(value, "tolist") else value)
    if len(items) != n:
        raise ValueError(f"{function}: {parameter} must hold {n} numbers, got {len(items)}")
    out = []
    for x in items:
        if isinstance(x, bool) or not isinstance(x, _numbers.Real):
            raise TypeError(f"{function}: {parameter} must hold numbers, got {type(x).__name__}")
        if not _math.isfinite(x):
            raise ValueError(f"{function}: {parameter} must be finite, got {list(items)}")
        out.append(float(x))
    return out


def _name(function, parameter, value):
    """A body's or camera's name (str) as UTF-8 bytes; a str that is not valid Unicode (lone surrogates, as
    surrogateescape decodes bytes that are not UTF-8) keeps its bytes, for the checks that name them."""
    if not isinstance(value, str):
        raise TypeError(f"{function}: {parameter} must be a str, got {type(value).__name__}")
    return value.encode("utf-8", "surrogateescape")


def _int(function, parameter, value, low, high):
    if isinstance(value, bool) or not isinstance(value, _numbers.Integral):
        raise TypeError(f"{function}: {parameter} must be an int, got {type(value).__name__}")
    if not low <= value <= high:
        raise ValueError(f"{function}: {parameter} must be in [{low}, {high}], got {value}")
    return int(value)


def write_png(path, array, bit_depth=None):
    """Writes a numpy array as a PNG file, atomically (a temporary file renamed into place).

    array: (rows, cols) grey, or (rows, cols, channels) with 1 (grey), 2 (grey, alpha), 3 (RGB) or 4 (RGBA)
    channels; row 0 is the image's top row. uint8 values are taken as 0-255, uint16 as 0-65535, bool as 0/1,
    floats as 0-1 (clamped). bit_depth: 8 or 16 (default 16 for uint16 and float arrays, 8 otherwise: a
    height map from Simulation.height_map keeps its precision). Render frames (uint8 RGB) and maps go
    straight in. Raises TypeError for a non-array, ValueError for a bad shape, OSError when the file cannot
    be written."""
    import numpy as np
    target = _path("write_png", "path", path)
    if not isinstance(array, np.ndarray):
        raise TypeError(f"write_png: array must be a numpy array, got {type(array).__name__}")
    if array.ndim == 2:
        array = array[:, :, None]
    if array.ndim != 3 or not 1 <= array.shape[2] <= 4 or array.shape[0] < 1 or array.shape[1] < 1:
        raise ValueError(f"write_png: array must be (rows, cols) or (rows, cols, 1-4), got shape {array.shape}")
    if array.dtype == np.uint8:
        pixels, depth = array.astype(np.float32) / 255.0, 8
    elif array.dtype == np.uint16:
        pixels, depth = array.astype(np.float32) / 65535.0, 16
    elif array.dtype == np.bool_:
        pixels, depth = array.astype(np.float32), 8
    elif np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer):
        pixels, depth = array.astype(np.float32), 16
    else:
        raise TypeError(f"write_png: array must hold numbers, got {array.dtype}")
    if not np.all(np.isfinite(pixels)):
        raise ValueError("write_png: array holds values that are not finite")
    if bit_depth is not None:
        if isinstance(bit_depth, bool) or not isinstance(bit_depth, _numbers.Integral):
            raise TypeError(f"write_png: bit_depth must be an int (8 or 16), got {type(bit_depth).__name__}")
        if bit_depth not in (8, 16):
            raise ValueError(f"write_png: bit_depth must be 8 or 16, got {bit_depth!r}")
        depth = int(bit_depth)
    _crumple._write_png(target, np.ascontiguousarray(pixels), depth)


def load_scene(path=None, overrides=None):
    """Loads and checks a scene without running it (no OpenGL). Returns a dict: name, file, timestep,
    duration, steps (the run's step count), bodies ([{name, static, kinematic, path (whether it follows
    keyframes), bump_map: resolution or None}]), cameras and joints (names). Raises SceneError as Simulation
    does. path None: the built-in default scene."""
    return _json.loads(_crumple._load_scene(None if path is None else _path("load_scene", "path", path),
                                            _overrides(overrides)))


class Simulation(_crumple._Simulation):
    """A scene loaded, checked and ready to step (docs/python.md).

    path: a scene file (str or os.PathLike); None runs the built-in default scene (a steel ball thrown
    onto a clay plate). overrides: {key path: value}, the key paths of crumple-sim's --set
    ("bodies[ball].velocity", "materials.clay.kappa"), values as Python objects (lists, numbers, str...).
    gpu: the EGL device, as crumple-sim --gpu (None: CRUMPLE_EGL_DEVICE, else the first GPU, else software).
    threads: the physics step's threads, as crumple-sim --threads (None: the scene's "threads", default 1;
    0: the machine's hardware threads). Every count gives the same bits.

    Raises SceneError for bad input, RuntimeError when no OpenGL context can be made for a scene with bump
    maps.
    """

    def __init__(self, path=None, overrides=None, *, gpu=None, threads=None, _text=None, _origin=""):
        if self.__dict__.get("_scene") is not None:
            raise RuntimeError("Simulation: already initialised (make a new Simulation for another scene)")
        if gpu is not None:
            gpu = _int("Simulation", "gpu", gpu, 0, 2**31 - 1)
        if threads is not None:
            threads = _int("Simulation", "threads", threads, 0, 256)
        if _text is not None:  # (bytes: a text that is not UTF-8 reaches the loader, which names where)
            _text = _text.encode("utf-8", "surrogateescape")
        super().__init__(None if path is None else _path("Simulation", "path", path), _overrides(overrides),
                         -1 if gpu is None else gpu, -1 if threads is None else threads, _text, _origin)
        self._scene = _json.loads(self._scene_json)

    @classmethod
    def from_json(cls, text, overrides=None, *, gpu=None, threads=None):
        """A simulation of the scene whose JSON text is `text` (a str or bytes; the scene format of
        docs/scene-format.md). Files it names (meshes, textures) are found from the working folder. Errors
        name the file as "<json>". Otherwise as Simulation(path, ...)."""
        if isinstance(text, (bytes, bytearray)):
            text = bytes(text).decode("utf-8", "surrogateescape")
        if not isinstance(text, str):
            raise TypeError(f"from_json: text must be a str or bytes, got {type(text).__name__}")
        return cls(None, overrides, gpu=gpu, threads=threads, _text=text, _origin="<json>")

    @classmethod
    def from_dict(cls, scene, overrides=None, *, gpu=None, threads=None):
        """A simulation of the scene held by the dict `scene` (what json.load of a scene file gives; numpy
        arrays and scalars are taken as lists and numbers). Errors name the file as "<dict>" with the key path
        into the dict. Otherwise as Simulation(path, ...)."""
        if not isinstance(scene, dict):
            raise TypeError(f"from_dict: scene must be a dict, got {type(scene).__name__}")
        try:
            text = _json.dumps(scene, default=_json_default, allow_nan=False)
        except (TypeError, ValueError) as e:
            raise TypeError(f"from_dict: the scene is not JSON: {e}") from None
        return cls(None, overrides, gpu=gpu, threads=threads, _text=text, _origin="<dict>")

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def close(self):
        """Releases the simulation and its OpenGL context now (as `with crumple.Simulation(...) as sim:` does
        at the block's end). Calls after it raise RuntimeError; closing twice does nothing."""
        return super().close()

    def step(self, n=1):
        """Runs n steps of `timestep` seconds each (Ctrl-C interrupts between two steps with
        KeyboardInterrupt). Forces given with Body.apply_force act during the next step."""
        return super().step(_int("step", "n", n, 0, 2**62))

    def body(self, name):
        """The body named `name` (a crumple.Body: its pose and velocities to read and set, forces and impulses
        to apply, its maps). ValueError naming the bodies when there is none."""
        return Body(self, name, self._body_index(_name("body", "name", name)))

    def run(self):
        """Runs on to the scene's duration (round(duration / timestep) steps in all); returns the steps it
        ran."""
        return super().run()

    def height_map(self, name):
        """The body's height map now: numpy float32 (rows, cols), 0.5 flat, 0 the deepest dent; the surface
        lies (h - 0.5) x bump_depth metres above the undented shape."""
        return super().height_map(_name("height_map", "name", name))

    def normal_map(self, name):
        """The body's tangent-space normal map now: numpy float32 (rows, cols, 3), components in [-1, 1]."""
        return super().normal_map(_name("normal_map", "name", name))

    def render(self, camera=None, width=960, height=540, *, position=None, target=None, up=(0.0, 1.0, 0.0),
               fov=45.0, size=None):
        """A frame as a numpy uint8 array (height, width, 3), RGB, row 0 at the top.

        From the scene camera named `camera` (None: the first; a scene without cameras has one named
        "default"), or, with `position` and `target` (world coordinates, metres), from a camera placed there
        looking at target, with `up` and a vertical field of view `fov` in degrees. size=(width, height) may
        stand for width and height. Each side in [16, 8192] pixels."""
        if size is not None:
            if isinstance(size, (str, bytes)) or not hasattr(size, "__len__") or len(size) != 2:
                raise TypeError(f"render: size must be (width, height), got {size!r}")
            width, height = size
        width = _int("render", "width", width, 16, 8192)
        height = _int("render", "height", height, 16, 8192)
        if position is None and target is None:
            if camera is not None and not isinstance(camera, str):
                raise TypeError(f"render: camera must be a str, got {type(camera).__name__}")
            return super().render(camera, width, height)
        if camera is not None:
            raise ValueError("render: give either camera or position and target, not both")
        if position is None or target is None:
            raise ValueError("render: position and target go together")
        p = _vector("render", "position", position, 3)
        t = _vector("render", "target", target, 3)
        u = _vector("render", "up", up, 3)
        if isinstance(fov, bool) or not isinstance(fov, _numbers.Real) or not 1 <= fov <= 179:
            raise ValueError(f"render: fov must be degrees in [1, 179], got {fov!r}")
        if p == t:
            raise ValueError("render: position and target must differ")
        return self._render_view(p, t, u, float(fov), width, height)

    def _info(self):
        # The scene as loaded; an object made by __new__ without __init__ has none, and a closed one answers
        # nothing more (the C++ side says so in both cases).
        scene = self.__dict__.get("_scene")
        if scene is None:
            return _json.loads(self._scene_json)
        if self.closed:
            raise RuntimeError("this crumple.Simulation is closed")
        return scene

    @property
    def name(self):
        """The scene's name."""
        return self._info()["name"]

    @property
    def timestep(self):
        """Seconds per step."""
        return self._info()["timestep"]

    @property
    def duration(self):
        """The scene's duration in seconds (run() runs to it)."""
        return self._info()["duration"]

    def cameras(self):
        """The scene's camera names ("default" for a scene without cameras), as render() takes them."""
        return list(self._info()["cameras"]) or ["default"]

    def write_outputs(self, dir):
        """Writes what crumple-sim --out dir writes, for the state now (docs/python.md). dir: a str, bytes or
        os.PathLike."""
        return super().write_outputs(_path("write_outputs", "dir", dir))

    def __repr__(self):
        if self.__dict__.get("_scene") is None:
            return "<crumple.Simulation (not initialised)>"
        try:
            return f"<crumple.Simulation {self.name!r} t={self.time:.4f} s, {self.steps} steps>"
        except RuntimeError:  # closed
            return f"<crumple.Simulation {self._scene['name']!r} (closed)>"


class Body:
    """One body of a Simulation (Simulation.body(name)), by its place in the scene.

    position: the shape origin's world position (m), as the scene's "position" and summary.json give it;
    orientation: the unit quaternion (w, x, y, z); linear_velocity (m/s, of the centre of mass) and
    angular_velocity (rad/s, world axes). Each reads as a tuple and can be set (a sequence of finite numbers;
    setting wakes the body; a static body's velocities cannot be set). mass (kg, 0 for a static body),
    static, kinematic and asleep read the body's state now."""

    __slots__ = ("_sim", "_name", "_k")

    def __init__(self, sim, name, k):
        self._sim = sim
        self._name = name
        self._k = k

    @property
    def name(self):
        """The body's name (read only: a scene's bodies keep their names)."""
        return self._name

    def _state(self):
        return self._sim._body_state(self._k)

    def _set(self, what, value, n):
        self._check_free(what)
        self._sim._set_body(self._k, what, _vector(f"Body.{what}", what, value, n))

    def _check_free(self, what):
        # A kinematic body on keyframes is put where its path says at every step: a pose set here would be left
        # at once, at the speed that takes (a push of hundreds of m/s on whatever lies between).
        if self._sim._info()["bodies"][self._k].get("path"):
            raise ValueError(f"Body.{what}: {self._name} follows its path, which sets its pose and velocities")

    @property
    def position(self):
        """The shape origin's world position (m)."""
        return self._state()[0]

    @position.setter
    def position(self, value):
        self._set("position", value, 3)

    @property
    def orientation(self):
        """The unit quaternion (w, x, y, z); set ones are normalised."""
        return self._state()[1]

    @orientation.setter
    def orientation(self, value):
        self._check_free("orientation")
        q = _vector("Body.orientation", "orientation", value, 4)
        if not any(q):
            raise ValueError("Body.orientation: a quaternion must not be zero")
        largest = max(abs(x) for x in q)  # (scaled first: 1e200 squared overflows, 1e-200 squared underflows)
        self._sim._set_body(self._k, "orientation", [x / largest for x in q])

    @property
    def linear_velocity(self):
        """The centre of mass' velocity (m/s)."""
        return self._state()[2]

    @linear_velocity.setter
    def linear_velocity(self, value):
        self._set("linear_velocity", value, 3)

    @property
    def angular_velocity(self):
        """The angular velocity (rad/s, world axes)."""
        return self._state()[3]

    @angular_velocity.setter
    def angular_velocity(self, value):
        self._set("angular_velocity", value, 3)

    @property
    def mass(self):
        """kg (0 for a static body)."""
        return self._state()[4]

    @property
    def static(self):
        """Whether the body is static (it never moves)."""
        return self._state()[5]

    @property
    def kinematic(self):
        """Whether the body is kinematic (it moves on its path, pushed by nothing)."""
        return self._state()[6]

    @property
    def asleep(self):
        """Whether the body is asleep (at rest; anything that touches or pushes it wakes it)."""
        return self._state()[7]

    def apply_force(self, force, point=None):
        """Applies `force` (N, world) during the next step only, through the centre of mass or at the world
        point `point` (m; a torque comes with it). Wakes the body. ValueError for a static or kinematic body."""
        f = _vector("Body.apply_force", "force", force, 3)
        at = None if point is None else _vector("Body.apply_force", "point", point, 3)
        self._sim._push(self._k, "apply_force", f, at)

    def apply_impulse(self, impulse, point=None):
        """Changes the body's momentum now by `impulse` (N s, world), through the centre of mass or at the
        world point `point` (m; its angular momentum changes too). Wakes the body. ValueError for a static or
        kinematic body."""
        j = _vector("Body.apply_impulse", "impulse", impulse, 3)
        at = None if point is None else _vector("Body.apply_impulse", "point", point, 3)
        self._sim._push(self._k, "apply_impulse", j, at)

    def height_map(self):
        """The body's height map now (Simulation.height_map)."""
        return self._sim.height_map(self.name)

    def normal_map(self):
        """The body's normal map now (Simulation.normal_map)."""
        return self._sim.normal_map(self.name)

    def __repr__(self):
        return f"<crumple.Body {self.name!r}>"
