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

__all__ = ["Simulation", "SceneError", "load_scene", "__version__"]

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
        out.append((key, text))
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


def load_scene(path=None, overrides=None):
    """Loads and checks a scene without running it (no OpenGL). Returns a dict: name, file, timestep,
    duration, steps (the run's step count), bodies ([{name, static, bump_map: resolution or None}]),
    cameras and joints (names). Raises SceneError as Simulation does. path None: the built-in default scene."""
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

    def __init__(self, path=None, overrides=None, *, gpu=None, threads=None):
        if gpu is not None and (not isinstance(gpu, int) or gpu < 0):
            raise ValueError(f"gpu must be a device number >= 0, got {gpu!r}")
        if threads is not None and (not isinstance(threads, int) or isinstance(threads, bool) or not 0 <= threads <= 256):
            raise ValueError(f"threads must be an int in [0, 256], got {threads!r}")
        super().__init__(None if path is None else _path("Simulation", "path", path), _overrides(overrides),
                         -1 if gpu is None else gpu, -1 if threads is None else threads)
        self._scene = _json.loads(self._scene_json)

    def _info(self):
        # The scene as loaded; an object made by __new__ without __init__ has none (the C++ side says so).
        scene = self.__dict__.get("_scene")
        return scene if scene is not None else _json.loads(self._scene_json)

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
        return f"<crumple.Simulation {self.name!r} t={self.time:.4f} s, {self.steps} steps>"
