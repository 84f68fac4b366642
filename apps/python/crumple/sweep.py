"""crumple-sweep: the variants of a sweep file, each a crumple-sim run, as tasks of Dask distributed.

    crumple-sweep SWEEP --out DIR [--scheduler local[:N] | tcp://HOST:PORT | FILE.json] [--gpu N[,N...]]
                  [--set KEY=VALUE]... [--timeout S] [--grace S] [--max-variants N] [--scheduler-timeout S]
                  [--sim PATH] [-- CRUMPLE-SIM OPTIONS]

A sweep file (docs/sweeps.md):

    {"format": "crumple-sweep/1", "scene": "drop.json",
     "vary": {"bodies[ball].velocity": [[0,-2,0], [0,-4,0]], "materials.clay.kappa": [0.05, 0.1]},
     "mode": "grid"}

Every variant is checked with crumple.load_scene before anything runs (one that does not load is bad input,
exit 2). Each task runs crumple-sim with --set for each key into DIR/runs/<id>/ and returns its row of
DIR/results.csv. The task itself needs only the standard library and crumple-sim: it travels to the workers by
value, so a dask-worker on another machine needs python3-distributed and crumple-sim at the same path (or
--sim), and DIR and the scene on a filesystem it shares.

SIGINT, SIGTERM and SIGHUP stop the sweep: every running crumple-sim gets SIGTERM (it removes its partial output),
SIGKILL after --grace seconds, results.csv is written, and crumple-sweep exits 128 + the signal's number.
"""

import argparse
import csv
import glob
import itertools
import json
import math
import os
import re
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import uuid

SWEEP_FORMAT = "crumple-sweep/1"
RECORD_FORMAT = "crumple-sweep-variants/1"
MARKER = ".crumple-output"
MAX_VARIANTS = 100000  # --max-variants
MAX_LOCAL_WORKERS = 1024  # --scheduler local:N
SCHEDULER_TIMEOUT = 60.0  # --scheduler-timeout, seconds
GRACE = 10.0  # --grace, seconds
MAX_SWEEP_BYTES = 64 << 20  # a sweep file larger than this is refused unread
POLL = 0.25  # seconds between looks at a running crumple-sim (its stop file, its timeout)
STOP_PREFIX = ".crumple-sweep-stop-"  # DIR/.crumple-sweep-stop-<token>: the running tasks stop their runs


class SweepError(Exception):
    """Bad input: the sweep file, an option or a variant that does not load (exit 2)."""


class Interrupted(BaseException):
    """SIGINT, SIGTERM or SIGHUP reached crumple-sweep (raised by its handler in the main thread)."""

    def __init__(self, signum):
        super().__init__(signum)
        self.signum = signum


# ---------------------------------------------------------------------------------------------------------------
# What runs on the workers: standard library only.


def value_text(value):
    """A value as --set takes it (JSON) and as results.csv shows it: compact JSON, a string as it is."""
    if isinstance(value, str):
        return value
    return json.dumps(value, separators=(",", ":"))


def read_run(out_dir):
    """collisions, deformations, {body: max_dent} and {body: saturated} of a complete crumple-sim output folder.

    max_dent.<body> is the largest `max_dent` (m) of the body's sides over the collision lines of events.jsonl
    (the deepest drop of one texel in one collision), for every body with a bump map (heightmaps/<body>.png);
    0.0 for one that was never dented. saturated.<body>: whether some dent of it reached the map's floor (its
    depth was cut off there: max_dent is then a lower bound)."""
    with open(os.path.join(out_dir, "summary.json")) as f:
        summary = json.load(f)
    bodies = []
    maps = os.path.join(out_dir, "heightmaps")
    if os.path.isdir(maps):
        names = {n[:-4] for n in os.listdir(maps) if n.endswith(".png")}
        bodies = [b["name"] for b in summary.get("bodies", []) if b["name"] in names]
    dents = {name: 0.0 for name in bodies}
    saturated = {name: False for name in bodies}
    events = os.path.join(out_dir, "events.jsonl")
    if os.path.exists(events):
        with open(events) as f:
            for line in f:
                if not line.strip():
                    continue
                e = json.loads(line)
                if e.get("type", "collision") != "collision":
                    continue
                for body, side in ((e["a"], e["a_side"]), (e["b"], e["b_side"])):
                    if body in dents and side.get("max_dent") is not None:
                        dents[body] = max(dents[body], float(side["max_dent"]))
                    if body in saturated and side.get("saturated"):
                        saturated[body] = True
    return {"collisions": summary.get("collisions"), "deformations": summary.get("deformations"), "max_dent": dents,
            "saturated": saturated}


def is_complete(out_dir):
    """Whether crumple-sim finished this folder: its marker and summary.json are there."""
    return os.path.isfile(os.path.join(out_dir, MARKER)) and os.path.isfile(os.path.join(out_dir, "summary.json"))


def signal_text(number):
    """`signal 11 (SIGSEGV)`: how results.csv's status names a run that a signal ended."""
    try:
        return f"signal {number} ({signal.Signals(number).name})"
    except ValueError:
        return f"signal {number}"


def _pick_gpu(gpus):
    if not gpus:
        return None
    if len(gpus) == 1:
        return gpus[0]
    # A list: one GPU per worker of a local cluster (their names are 0, 1, ...).
    try:
        from distributed import get_worker

        name = get_worker().name
        return gpus[int(name) % len(gpus)]
    except Exception:
        return gpus[0]


def _death_signal():
    """A preexec_fn giving the child SIGTERM when the thread that started it ends (Linux's PR_SET_PDEATHSIG), so
    that a worker or a crumple-sweep that dies, even by SIGKILL, takes its crumple-sim runs with it; None where
    that cannot be had. The thread waits on the child until it exits, so it never ends first on its own."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        import ctypes

        prctl = ctypes.CDLL(None, use_errno=True).prctl
        prctl.argtypes = [ctypes.c_int, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong]
        prctl.restype = ctypes.c_int
    except (ImportError, OSError, AttributeError):
        return None
    parent = os.getpid()

    def preexec():
        prctl(1, int(signal.SIGTERM), 0, 0, 0)  # PR_SET_PDEATHSIG
        if os.getppid() != parent:  # the parent died before that: go now
            os.kill(os.getpid(), signal.SIGTERM)

    return preexec


def _signal_group(proc, sig):
    """sig to the child's process group (it leads its own: crumple-sim and whatever it started)."""
    if proc.poll() is not None:
        return
    try:
        os.killpg(proc.pid, sig)
    except ProcessLookupError:
        pass
    except OSError:
        proc.send_signal(sig)


def _stop_child(proc, grace):
    """SIGTERM (crumple-sim removes its partial output and exits 130), SIGKILL after grace s; True if killed."""
    _signal_group(proc, signal.SIGTERM)
    try:
        proc.wait(timeout=grace)
        return False
    except subprocess.TimeoutExpired:
        _signal_group(proc, signal.SIGKILL)
        proc.wait()
        return True


def _remove_partial(out_dir, pid):
    """The staging folders a crumple-sim of this pid left beside out_dir when it did not end on its own."""
    for path in glob.glob(glob.escape(out_dir) + f".partial-{pid}-*"):
        shutil.rmtree(path, ignore_errors=True)


def run_child(cmd, env, out_dir, timeout=None, stop=None, grace=GRACE):
    """Runs cmd (a crumple-sim writing out_dir) in its own process group until it exits; stops it when timeout s
    have passed or the file stop exists. Returns (returncode, output, how, killed): how is None, "timeout" or
    "stopped"; killed when it was still running grace s after SIGTERM. A run that did not succeed leaves no staging
    folder beside out_dir."""
    with tempfile.TemporaryFile() as capture:
        proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=capture, stderr=subprocess.STDOUT, env=env,
                                start_new_session=True, preexec_fn=_death_signal())
        how = None
        killed = False
        try:
            deadline = None if timeout is None else time.monotonic() + timeout
            while True:
                try:
                    proc.wait(timeout=POLL)
                    break
                except subprocess.TimeoutExpired:
                    pass
                if stop is not None and os.path.exists(stop):
                    how = "stopped"
                elif deadline is not None and time.monotonic() >= deadline:
                    how = "timeout"
                if how:
                    killed = _stop_child(proc, grace)
                    break
            if how is None and proc.returncode != 0 and stop is not None and os.path.exists(stop):
                how = "stopped"  # killed by crumple-sweep itself before this saw the stop
        except BaseException:  # Interrupted in the main thread: the child goes first
            _stop_child(proc, grace)
            raise
        finally:
            if proc.returncode is not None and proc.returncode != 0:
                _remove_partial(out_dir, proc.pid)
        capture.seek(0)
        output = capture.read().decode("utf-8", errors="replace")
    return proc.returncode, output, how, killed


def run_variant(spec):
    """Runs one variant with crumple-sim; returns its row: exit, status, collisions, deformations, max_dent, error.

    spec: sim, scene, out (DIR/runs/<id>), log (DIR/logs/<id>.log), overrides [(key, JSON text)], args,
    gpus (list or None), timeout (s or None), grace (s), stop (a file whose existence stops the run, or None)."""
    row = {"exit": None, "status": "not run", "collisions": None, "deformations": None, "max_dent": {}, "error": ""}
    stop = spec.get("stop")
    if stop is not None and os.path.exists(stop):
        return row  # the sweep was interrupted before this one started
    cmd = [spec["sim"], spec["scene"], "--out", spec["out"], "--quiet"]
    for key, text in spec["overrides"]:
        cmd += ["--set", f"{key}={text}"]
    cmd += list(spec.get("args") or [])
    env = dict(os.environ)
    gpu = _pick_gpu(spec.get("gpus"))
    if gpu is not None:
        env["CRUMPLE_EGL_DEVICE"] = str(gpu)
    grace = spec.get("grace", GRACE)
    started = time.time()
    output = ""
    try:
        rc, output, how, killed = run_child(cmd, env, spec["out"], spec.get("timeout"), stop, grace)
        row["exit"] = rc if rc >= 0 else 128 - rc
        how_killed = f" (killed: still running {grace:g} s after SIGTERM)" if killed else (
            " (killed)" if rc == -signal.SIGKILL else "")
        if how == "timeout":
            row["exit"], row["status"] = 124, "timed out"
            row["error"] = f"timed out after {spec['timeout']:g} s{how_killed}"
        elif how == "stopped":
            row["status"] = "interrupted"
            row["error"] = f"stopped: crumple-sweep was interrupted{how_killed}"
        elif rc < 0:
            row["status"] = signal_text(-rc)
            row["error"] = f"crumple-sim was killed by {signal_text(-rc)}"
        elif rc == 0:
            row["status"] = "ok"
        else:
            row["status"] = f"exit {rc}"
    except OSError as e:
        row["exit"], row["status"] = 127, "not started"
        row["error"] = f"cannot run {spec['sim']} on {socket.gethostname()}: {e}"
    elapsed = time.time() - started
    if row["exit"] == 0:
        try:
            row.update(read_run(spec["out"]))
        except (OSError, ValueError, KeyError, TypeError) as e:
            row["exit"], row["status"] = 1, "unreadable output"
            row["error"] = f"unreadable output: {e}"
    elif not row["error"]:
        lines = [ln for ln in output.splitlines() if ln.strip()]
        row["error"] = lines[-1] if lines else f"crumple-sim exited with status {row['exit']}"
    try:
        os.makedirs(os.path.dirname(spec["log"]), exist_ok=True)
        with open(spec["log"], "w") as f:
            f.write(f"# host {socket.gethostname()}, {elapsed:.1f} s, {row['status']} (exit {row['exit']})"
                    f"{'' if gpu is None else f', CRUMPLE_EGL_DEVICE={gpu}'}\n# {shlex.join(cmd)}\n{output}")
    except OSError:
        pass
    return row


# ---------------------------------------------------------------------------------------------------------------
# The client: the sweep file, the variants, the scheduler, results.csv.


def one_line(message):
    """A message as one line of stderr: line breaks (a key path may hold one) written as \\n."""
    return str(message).replace("\r", "\\r").replace("\n", "\\n")


def _is_utf16(data):
    """Whether data is UTF-16 text: a byte order mark, or ASCII characters each beside a zero byte."""
    if data[:2] in (b"\xff\xfe", b"\xfe\xff"):
        encoding = "utf-16"
    elif len(data) >= 4 and data[0] and data[2] and not data[1] and not data[3]:
        encoding = "utf-16-le"
    elif len(data) >= 4 and data[1] and data[3] and not data[0] and not data[2]:
        encoding = "utf-16-be"
    else:
        return False
    try:
        data.decode(encoding)
        return True
    except UnicodeDecodeError:
        return False


def _read_json_text(path, fail):
    """The sweep file's JSON document: UTF-8 text (a UTF-8 BOM is allowed) of at most MAX_SWEEP_BYTES."""
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_SWEEP_BYTES + 1)
    except OSError as e:
        fail("", e.strerror or str(e))
    if len(data) > MAX_SWEEP_BYTES:
        fail("", f"larger than {MAX_SWEEP_BYTES >> 20} MiB: not a sweep file")
    if _is_utf16(data):
        fail("", "UTF-16 text: a sweep file is JSON in UTF-8 (save it as UTF-8)")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        fail("", f"not UTF-8 text (byte 0x{data[e.start]:02x} at offset {e.start}): a sweep file is JSON in UTF-8")

    def constant(name):
        raise ValueError(f"{name} is not a JSON value")

    def number(text):
        value = float(text)
        if not math.isfinite(value):
            raise ValueError(f"the number {text} is out of range")
        return value

    try:
        return json.loads(text, parse_constant=constant, parse_float=number)
    except RecursionError:
        fail("", "malformed JSON: nested too deeply")
    except ValueError as e:
        fail("", f"malformed JSON: {e}")


def _json_kind(value):
    return {dict: "an object", list: "an array", str: "a string", bool: "true or false", type(None): "null"}.get(
        type(value), "a number")


def load_sweep(path, max_variants=MAX_VARIANTS):
    """The sweep file, checked: (absolute scene path, [(key, values)], mode, {key: value} fixed overrides).

    A sweep of more than max_variants variants is refused before any is made (their count is the product of the
    lists' lengths, or their one length with zip)."""
    def fail(key, why):
        raise SweepError(f"{path}: {key + ': ' if key else ''}{why}")

    doc = _read_json_text(path, fail)
    if not isinstance(doc, dict):
        fail("", f"the top level must be an object, got {_json_kind(doc)}")
    for key in doc:
        if key not in ("format", "scene", "vary", "mode", "set"):
            fail(key, "unknown key (expected format, scene, vary, mode, set)")
    if doc.get("format", SWEEP_FORMAT) != SWEEP_FORMAT:
        fail("format", f"unsupported format {doc['format']!r} (expected {SWEEP_FORMAT})")
    scene = doc.get("scene")
    if not isinstance(scene, str) or not scene or "\0" in scene:
        fail("scene", "is required: the scene file, relative to the sweep file's folder")
    scene = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(path)), scene))
    vary = doc.get("vary")
    if not isinstance(vary, dict) or not vary:
        fail("vary", "is required: an object of key path -> list of values")
    axes = []
    for key, values in vary.items():
        if not isinstance(values, list) or not values:
            fail(f"vary.{key}", "must be a non-empty list of values")
        axes.append((key, values))
    mode = doc.get("mode", "grid")
    if mode not in ("grid", "zip"):
        fail("mode", f"must be \"grid\" or \"zip\", got {mode!r}")
    if mode == "zip" and len({len(v) for _, v in axes}) > 1:
        fail("vary", "mode zip needs lists of one length, got " + ", ".join(f"{k}: {len(v)}" for k, v in axes))
    count = len(axes[0][1]) if mode == "zip" else math.prod(len(v) for _, v in axes)
    if count > max_variants:
        shape = f"zip of {count}" if mode == "zip" else "grid of " + " x ".join(str(len(v)) for _, v in axes)
        fail("vary", f"{count} variants ({shape}): more than --max-variants {max_variants} allows")
    fixed = doc.get("set", {})
    if not isinstance(fixed, dict):
        fail("set", "must be an object of key path -> value")
    return scene, axes, mode, fixed


def expand(axes, mode):
    """The variants, in order: grid (every combination, the last key fastest) or zip (the i-th values)."""
    keys = [k for k, _ in axes]
    if mode == "zip":
        combos = zip(*[v for _, v in axes])
    else:
        combos = itertools.product(*[v for _, v in axes])
    return [dict(zip(keys, c)) for c in combos]


def variant_ids(n):
    width = max(3, len(str(n - 1)))
    return [f"{i:0{width}d}" for i in range(n)]


ADDRESS = re.compile(r"(tcp|tls|ws|wss|ucx)://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):([0-9]{1,5})/?")


def parse_scheduler(text):
    """("local", N or None), ("address", URL) or ("file", path); SweepError for anything else."""
    if text == "local" or text.startswith("local:"):
        n = text[6:] if text.startswith("local:") else ""
        if n and (not n.isdigit() or not 1 <= int(n) <= MAX_LOCAL_WORKERS):
            raise SweepError(f"--scheduler: local:N needs a number of workers from 1 to {MAX_LOCAL_WORKERS}, "
                             f"got {text!r}")
        return ("local", int(n) if n else None)
    if "://" in text:
        m = ADDRESS.fullmatch(text)
        if not m or not 1 <= int(m.group(3)) <= 65535:
            raise SweepError(f"--scheduler: expected a scheduler address tcp://HOST:PORT (or tls://, ws://, wss://, "
                             f"ucx://) with a port from 1 to 65535, got {text!r}")
        return ("address", text)
    if os.path.isdir(text):
        raise SweepError(f"--scheduler: {text} is a folder, not a scheduler file")
    if text.endswith(".json") or os.path.isfile(text):
        return ("file", text)
    hint = " (a scheduler address starts with tcp://)" if re.fullmatch(r"[^/\s]+:[0-9]+", text) else ""
    raise SweepError(f"--scheduler: expected local[:N], tcp://HOST:PORT or a scheduler file (.json), "
                     f"got {text!r}{hint}")


def parse_gpus(text):
    if text is None:
        return None
    try:
        gpus = [int(p) for p in text.split(",")]
    except ValueError:
        gpus = [-1]
    if not gpus or any(g < 0 for g in gpus):
        raise SweepError(f"--gpu: expected N or N,M,... (EGL device numbers from 0), got {text!r}")
    return gpus


# Options after -- that crumple-sweep refuses itself: (option, why).
OWN_OPTIONS = [("--out", "crumple-sweep sets it itself"), ("--set", "crumple-sweep sets it itself: use --set "
               "before --"), ("--trace", "every variant would write that one file"),
               ("--video", "every variant would write that one file")]


def check_own_options(sim_args):
    for a in sim_args:
        name = a.partition("=")[0]
        if a == "-o" or (a.startswith("-o") and not a.startswith("--")):
            name = "--out"
        for option, why in OWN_OPTIONS:
            if name == option:
                raise SweepError(f"{a} after --: {why}")


def _one_step(sim_args):
    """The options after -- with one step: --steps N becomes --steps 1 (an N crumple-sim refuses stays)."""
    args = list(sim_args)
    for i, a in enumerate(args):
        if a == "--steps" and i + 1 < len(args) and args[i + 1].isdigit() and int(args[i + 1]) >= 1:
            args[i + 1] = "1"
            return args
        if a.startswith("--steps=") and a[8:].isdigit() and int(a[8:]) >= 1:
            args[i] = "--steps=1"
            return args
        if a == "--steps" or a.startswith("--steps="):
            return args
    return args + ["--steps", "1"]


def check_sim_args(sim, scene, overrides, sim_args, gpus, grace):
    """Runs crumple-sim once with the options after -- (the first variant, one step, into a temporary folder):
    None when it accepts them (or cannot be run here, so cannot tell), else its refusal in one line."""
    env = dict(os.environ)
    if gpus:
        env["CRUMPLE_EGL_DEVICE"] = str(gpus[0])
    with tempfile.TemporaryDirectory(prefix="crumple-sweep-check-") as tmp:
        out = os.path.join(tmp, "run")
        cmd = [sim, scene, "--out", out, "--quiet"]
        for key, text in overrides:
            cmd += ["--set", f"{key}={text}"]
        cmd += _one_step(sim_args)
        try:
            rc, output, how, _ = run_child(cmd, env, out, timeout=120, grace=grace)
        except OSError:
            return None
        lines = [ln.strip() for ln in output.splitlines()
                 if ln.strip() and not ln.startswith("Run with --help")]
        if rc == 2 and how is None:
            said = next((ln for ln in lines if "error" in ln), lines[0] if lines else "exit 2")
            for prefix in ("crumple-sim: ", "error: "):
                said = said[len(prefix):] if said.startswith(prefix) else said
            return f"options after -- ({shlex.join(sim_args)}): crumple-sim refuses them: {said}"
        if rc == 0 and not os.path.isfile(os.path.join(out, "summary.json")):
            said = lines[0] if lines else ""
            said = said if len(said) <= 80 else said[:77] + "..."
            return f"options after -- ({shlex.join(sim_args)}): crumple-sim runs nothing with them" + (
                f" (it printed: {said})" if said else "")
    return None


def _executable(sim):
    if os.sep in sim:
        return os.path.isfile(sim) and os.access(sim, os.X_OK)
    return shutil.which(sim) is not None


def _vector_length(variants, key):
    """n when every variant's value of key is a list of n numbers (2 <= n <= 4), else 0."""
    lengths = set()
    for v in variants:
        value = v[key]
        if not isinstance(value, list) or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                  for x in value):
            return 0
        lengths.add(len(value))
    return lengths.pop() if len(lengths) == 1 and 2 <= next(iter(lengths)) <= 4 else 0


VECTOR_PARTS = {2: "xy", 3: "xyz", 4: "wxyz"}  # 4: a quaternion, as the scene writes orientations


def write_csv(path, keys, bodies, ids, variants, rows):
    """results.csv, whole, through a temporary file renamed over it. A key whose values are all vectors of the
    same length has a column per component (key.x, key.y, key.z; a quaternion key.w ... key.z)."""
    split = {k: _vector_length(variants, k) for k in keys}
    key_columns = []
    for k in keys:
        key_columns += [f"{k}.{c}" for c in VECTOR_PARTS[split[k]]] if split[k] else [k]
    tmp = path + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["id", *key_columns, "exit", "status", "collisions", "deformations",
                    *[f"max_dent.{b}" for b in bodies], *[f"saturated.{b}" for b in bodies], "error"])
        for vid, variant in zip(ids, variants):
            row = rows.get(vid)
            cells = [vid]
            for k in keys:
                cells += [value_text(x) for x in variant[k]] if split[k] else [value_text(variant[k])]
            if row is None:
                cells += ["", "not run"] + [""] * (2 + 2 * len(bodies)) + [""]
            else:
                dents = row.get("max_dent") or {}
                full = row.get("saturated") or {}
                cells += [row["exit"], row.get("status", ""),
                          "" if row.get("collisions") is None else row["collisions"],
                          "" if row.get("deformations") is None else row["deformations"],
                          *[repr(dents[b]) if b in dents else "" for b in bodies],
                          *[("true" if full[b] else "false") if b in full else "" for b in bodies],
                          row.get("error", "")]
            w.writerow(cells)
    os.replace(tmp, path)


def wait_scheduler_file(path, deadline, timeout):
    """The scheduler's address from its scheduler file, waiting until deadline (time.monotonic()) for it to
    appear and hold one."""
    why = None
    while True:
        try:
            with open(path) as f:
                doc = json.load(f)
            address = doc.get("address") if isinstance(doc, dict) else None
            if isinstance(address, str) and address:
                return address
            why = "no \"address\""
        except FileNotFoundError:
            why = None
        except IsADirectoryError:
            raise SweepError(f"--scheduler: {path} is a folder, not a scheduler file")
        except (OSError, ValueError, RecursionError) as e:  # being written, or not one
            why = e.strerror if isinstance(e, OSError) and e.strerror else str(e).splitlines()[0]
        if time.monotonic() >= deadline:
            if why is None:
                raise SweepError(f"--scheduler: {path}: no scheduler file after {timeout:g} s (--scheduler-timeout):"
                                 f" is dask-scheduler --scheduler-file {path} running?")
            raise SweepError(f"--scheduler: {path}: not a Dask scheduler file after {timeout:g} s ({why})")
        time.sleep(min(0.1, max(0.0, deadline - time.monotonic())))


def connect(scheduler, gpus, timeout):
    """A Dask client (and the local cluster it owns, or None); SweepError when the scheduler does not answer
    within timeout s."""
    import logging

    from distributed import Client, LocalCluster

    kind, arg = scheduler
    if kind == "local":
        n = arg or (len(gpus) if gpus and len(gpus) > 1 else os.cpu_count() or 1)
        # Threads, not processes: each task waits on its own crumple-sim process.
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=False, dashboard_address=None,
                               silence_logs=logging.ERROR)
        return Client(cluster), cluster
    deadline = time.monotonic() + timeout
    address = wait_scheduler_file(arg, deadline, timeout) if kind == "file" else arg
    left = max(1.0, deadline - time.monotonic())
    try:
        return Client(address, timeout=f"{left}s"), None
    except (OSError, TimeoutError, ValueError) as e:
        what = f"{arg} ({address})" if kind == "file" else arg
        why = re.sub(r" after [0-9.]+ ?s$", "", " ".join(str(e).split())) or type(e).__name__
        raise SweepError(f"--scheduler: {what}: no answer within {timeout:g} s (--scheduler-timeout): {why}")


class Parser(argparse.ArgumentParser):
    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (crumple-sweep --help for usage)\n")


def build_parser():
    p = Parser(
        prog="crumple-sweep",
        description="Run the variants of a crumple sweep file as tasks of Dask distributed: each variant is a "
        "crumple-sim run into DIR/runs/<id>/, one row of DIR/results.csv (docs/sweeps.md).",
        epilog="Options after -- go to every crumple-sim run (e.g. -- --render --size 480x270). "
        "crumple-sweep plot DIR --x COLUMN --y COLUMN draws results.csv's columns (crumple-sweep plot --help).")
    try:
        from . import __version__ as version
    except ImportError:  # the package's compiled module missing: the sweep itself needs only crumple-sim
        version = "unknown"
    p.add_argument("--version", action="version", version=f"crumple-sweep {version}")
    p.add_argument("sweep", help="the sweep file (JSON, format crumple-sweep/1)")
    p.add_argument("--out", "-o", required=True, help="output folder: runs/<id>/, logs/<id>.log, results.csv")
    p.add_argument("--scheduler", default="local",
                   help="local[:N] (a local cluster of N workers; default: one per CPU core, or one per --gpu "
                   "listed), tcp://HOST:PORT (a running dask-scheduler) or a scheduler file (dask-scheduler "
                   "--scheduler-file)")
    p.add_argument("--scheduler-timeout", type=float, default=SCHEDULER_TIMEOUT, metavar="S",
                   help=f"seconds to wait for the scheduler file to appear and the scheduler to answer (default "
                   f"{SCHEDULER_TIMEOUT:g}); then exit 2")
    p.add_argument("--gpu", help="EGL device for every run (N), or one per local worker (N,M,...): sets "
                   "CRUMPLE_EGL_DEVICE")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="a fixed override for every variant (as crumple-sim --set; repeatable)")
    p.add_argument("--timeout", type=float, metavar="S",
                   help="seconds a run may take before it is stopped (exit 124)")
    p.add_argument("--grace", type=float, default=GRACE, metavar="S",
                   help=f"seconds a stopped run (--timeout, or crumple-sweep interrupted) gets to remove its "
                   f"partial output before it is killed (default {GRACE:g})")
    p.add_argument("--max-variants", type=int, default=MAX_VARIANTS, metavar="N",
                   help=f"refuse a sweep of more variants than this (default {MAX_VARIANTS})")
    p.add_argument("--sim", help="the crumple-sim to run (default: the one built or installed with this)")
    p.add_argument("--dry-run", action="store_true", help="check the variants and list them; run nothing")
    p.add_argument("--quiet", "-q", action="store_true", help="only errors")
    return p


def _direct_children():
    """The pids of this process's children (Linux: /proc)."""
    me, kids = os.getpid(), []
    try:
        names = os.listdir("/proc")
    except OSError:
        return kids
    for name in names:
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat", "rb") as f:
                stat = f.read()
            if int(stat[stat.rindex(b")") + 2:].split()[1]) == me:
                kids.append(int(name))
        except (OSError, ValueError, IndexError):
            continue
    return kids


def _kill_children(sig):
    """sig to every child of this process and its process group: the runs of a local cluster's workers."""
    for pid in _direct_children():
        try:
            if os.getpgid(pid) == pid:
                os.killpg(pid, sig)
            else:
                os.kill(pid, sig)
        except OSError:
            pass


def _signal_name(signum):
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


STOP_SIGNALS = [signal.SIGINT, signal.SIGTERM] + ([signal.SIGHUP] if hasattr(signal, "SIGHUP") else [])


def console_main():
    """crumple-sweep as pip installs it: crumple-sim from the package (crumple/bin/), else from PATH."""
    packaged = os.path.join(os.path.dirname(os.path.abspath(__file__)), "bin", "crumple-sim")
    sim = packaged if os.access(packaged, os.X_OK) else "crumple-sim"
    return main(sys.argv[1:], default_sim=sim)


def main(argv=None, default_sim="crumple-sim"):
    """crumple-sweep's command line; returns the exit status. In the main thread, SIGINT, SIGTERM and SIGHUP stop
    the sweep (128 + the signal's number)."""
    caught = []

    def on_signal(signum, frame):
        caught.append(signum)
        if len(caught) == 1:
            raise Interrupted(signum)

    previous = {}
    if threading.current_thread() is threading.main_thread():
        for sig in STOP_SIGNALS:
            previous[sig] = signal.signal(sig, on_signal)
    try:
        return _main(argv, default_sim, caught)
    except Interrupted as e:
        # Before the runs (or between them and here): a check run may be going.
        _kill_children(signal.SIGTERM)
        print(f"crumple-sweep: interrupted ({_signal_name(e.signum)})", file=sys.stderr)
        return 128 + e.signum
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def plot(argv):
    """crumple-sweep plot DIR --x COLUMN --y COLUMN [--out PNG]: a column of DIR/results.csv against another, one
    point per complete variant, written as a PNG with matplotlib. Returns the exit status."""
    p = Parser(prog="crumple-sweep plot",
               description="Plot one column of a sweep's results.csv against another (a point per complete "
               "variant; where y is max_dent.<body>, variants whose dent reached the map's floor are marked: "
               "their depth is a lower bound). docs/sweeps.md.")
    p.add_argument("dir", help="the sweep's output folder (crumple-sweep --out): its results.csv")
    p.add_argument("--x", required=True, help="the x column, e.g. bodies[ball].velocity.y")
    p.add_argument("--y", required=True, help="the y column, e.g. max_dent.plate")
    p.add_argument("--out", "-o", help="the PNG to write (default: DIR/plot.png)")
    args = p.parse_args(argv)
    csv_path = os.path.join(args.dir, "results.csv")
    try:
        with open(csv_path, newline="") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        print(f"crumple-sweep: error: {csv_path}: {e.strerror or e}", file=sys.stderr)
        return 2
    columns = list(rows[0].keys()) if rows else []
    for which, name in (("--x", args.x), ("--y", args.y)):
        if name not in columns:
            print(f"crumple-sweep: error: {which} {name}: no such column in {csv_path} (columns: "
                  f"{', '.join(columns)})", file=sys.stderr)
            return 2
    saturated = "saturated." + args.y[len("max_dent."):] if args.y.startswith("max_dent.") else None
    points, failed = [], 0
    for row in rows:
        if row.get("exit") != "0":
            failed += 1
            continue
        try:
            x, y = float(row[args.x]), float(row[args.y])
        except ValueError:
            print(f"crumple-sweep: error: variant {row['id']}: {args.x} = {row[args.x]!r}, {args.y} = "
                  f"{row[args.y]!r}: not numbers (a vector key has a column per component: {args.x}.x ...)",
                  file=sys.stderr)
            return 2
        points.append((x, y, saturated is not None and row.get(saturated) == "true"))
    if not points:
        print(f"crumple-sweep: error: {csv_path}: no complete variant to plot", file=sys.stderr)
        return 1
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:
        print(f"crumple-sweep: error: plot needs matplotlib (python3-matplotlib): {e}", file=sys.stderr)
        return 2
    points.sort()
    scale, unit = (1000.0, " (mm)") if args.y.startswith("max_dent.") else (1.0, "")
    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=100)
    ax.plot([x for x, _, _ in points], [y * scale for _, y, _ in points], "o-", color="#3566a8", label=args.y)
    full = [(x, y * scale) for x, y, s in points if s]
    if full:
        ax.plot([x for x, _ in full], [y for _, y in full], "x", color="#c0392b", markersize=11, mew=2,
                label="dent reached the map's floor (a lower bound)")
    ax.set_xlabel(args.x)
    ax.set_ylabel(args.y + unit)
    title = os.path.basename(os.path.normpath(os.path.abspath(args.dir)))
    ax.set_title(title + (f" ({failed} failed variant{'s' if failed != 1 else ''} left out)" if failed else ""))
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    out = args.out or os.path.join(args.dir, "plot.png")
    tmp = out + ".tmp.png"
    try:
        fig.savefig(tmp)
        os.replace(tmp, out)
    except OSError as e:
        print(f"crumple-sweep: error: {out}: {e.strerror or e}", file=sys.stderr)
        return 2
    finally:
        plt.close(fig)
        if os.path.exists(tmp):
            os.remove(tmp)
    print(f"crumple-sweep: wrote {out}: {len(points)} variants")
    return 0


def _main(argv, default_sim, caught):
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["plot"]:
        return plot(argv[1:])
    sim_args = []
    if "--" in argv:
        i = argv.index("--")
        argv, sim_args = argv[:i], argv[i + 1:]
    args = build_parser().parse_args(argv)

    def say(msg):
        if not args.quiet:
            print(f"crumple-sweep: {msg}", flush=True)

    try:
        import crumple

        check_own_options(sim_args)
        if args.max_variants < 1:
            raise SweepError(f"--max-variants must be at least 1, got {args.max_variants}")
        for name, value, least in (("--timeout", args.timeout, None), ("--grace", args.grace, 0.0),
                                   ("--scheduler-timeout", args.scheduler_timeout, None)):
            if value is not None and not (math.isfinite(value) and (value > 0 if least is None else value >= least)):
                raise SweepError(f"{name} must be a {'positive' if least is None else 'non-negative'} number of "
                                 f"seconds, got {value:g}")
        scene, axes, mode, fixed = load_sweep(args.sweep, args.max_variants)
        scheduler = parse_scheduler(args.scheduler)
        gpus = parse_gpus(args.gpu)
        if gpus and len(gpus) > 1 and scheduler[0] != "local":
            raise SweepError("--gpu N,M,...: one GPU per worker needs --scheduler local[:N]; on a cluster, start "
                             "each dask-worker with CRUMPLE_EGL_DEVICE=N in its environment")
        sim = os.path.abspath(args.sim) if args.sim else default_sim
        if scheduler[0] == "local" and not _executable(sim):
            raise SweepError(f"--sim: {sim}: not an executable file")
        fixed_overrides = []
        for s in args.set:
            key, eq, value = s.partition("=")
            if not eq or not key:
                raise SweepError(f"--set: expected KEY=VALUE, got {s!r}")
            fixed_overrides.append((key, value))
        try:
            fixed_overrides = [(k, json.dumps(v)) for k, v in fixed.items()] + fixed_overrides
        except RecursionError:
            raise SweepError(f"{args.sweep}: set: nested too deeply") from None
        variants = expand(axes, mode)
        keys = [k for k, _ in axes]
        ids = variant_ids(len(variants))
        # Every variant must load: a typo in a key path stops the sweep before anything runs.
        bodies = []
        bad = []
        overrides = {}
        for vid, variant in zip(ids, variants):
            try:
                overrides[vid] = fixed_overrides + [(k, json.dumps(v)) for k, v in variant.items()]
            except RecursionError:
                bad.append((vid, f"variant {vid}: a value is nested too deeply"))
                continue
            try:
                info = crumple._crumple._load_scene(scene, overrides[vid])
            except crumple.SceneError as e:
                values = ", ".join(f"{k}={value_text(v)}" for k, v in variant.items())
                bad.append((vid, f"variant {vid} ({values}): {e}"))
                continue
            for b in json.loads(info)["bodies"]:
                if b["bump_map"] is not None and b["name"] not in bodies:
                    bodies.append(b["name"])
        if bad:
            more = [vid for vid, _ in bad[1:]]
            raise SweepError(bad[0][1] + (f"; {len(more)} more of {len(variants)} variants do not load ("
                                          f"{', '.join(more[:10])}{', ...' if len(more) > 10 else ''})"
                                          if more else ""))
        # What crumple-sim does with the options after --, once, before any variant runs.
        if sim_args:
            refused = check_sim_args(sim, scene, overrides[ids[0]], sim_args, gpus, args.grace)
            if refused:
                raise SweepError(refused)
    except SweepError as e:
        print(f"crumple-sweep: error: {one_line(e)}", file=sys.stderr)
        return 2

    out = os.path.abspath(args.out)
    if os.path.exists(out) and not os.path.isdir(out):
        print(f"crumple-sweep: error: --out: {out} exists and is not a folder", file=sys.stderr)
        return 2
    specs = {}
    for vid, variant in zip(ids, variants):
        specs[vid] = {
            "sim": sim, "scene": scene, "out": os.path.join(out, "runs", vid),
            "log": os.path.join(out, "logs", vid + ".log"), "overrides": overrides[vid],
            "args": sim_args, "gpus": gpus, "timeout": args.timeout, "grace": args.grace,
        }
    if args.dry_run:
        for vid, variant in zip(ids, variants):
            print(vid, " ".join(f"{k}={value_text(v)}" for k, v in variant.items()))
        say(f"{len(variants)} variants ({mode}), every one loads; bump-mapped bodies: {', '.join(bodies) or 'none'}")
        return 0

    # What a variant ran with: a rerun skips a variant only when its output is complete and it ran the same.
    def signature(spec):
        return {"scene": spec["scene"], "overrides": [list(o) for o in spec["overrides"]], "args": spec["args"]}

    record_path = os.path.join(out, "variants.json")
    previous = {}
    try:
        if os.path.exists(record_path):
            with open(record_path) as f:
                record = json.load(f)
            previous = record.get("variants") if isinstance(record, dict) else None
            if not isinstance(previous, dict):
                raise ValueError("not a crumple-sweep record (remove it to run every variant again)")
    except (OSError, ValueError, RecursionError) as e:
        print(f"crumple-sweep: error: {record_path}: {e}", file=sys.stderr)
        return 2
    rows = {}
    todo = []
    for vid in ids:
        spec = specs[vid]
        before = previous.get(vid)
        if is_complete(spec["out"]) and isinstance(before, dict) and before.get("signature") == signature(spec):
            try:
                rows[vid] = {"exit": 0, "status": "ok", "error": "", **read_run(spec["out"])}
                continue
            except (OSError, ValueError, KeyError, TypeError):
                pass
        todo.append(vid)
    csv_path = os.path.join(out, "results.csv")
    client = cluster = None
    try:
        if todo:
            try:
                import cloudpickle

                # The task goes to the workers by value: they need not import crumple (only crumple-sim).
                cloudpickle.register_pickle_by_value(sys.modules[__name__])
            except (ImportError, AttributeError, ValueError):
                pass
            try:
                client, cluster = connect(scheduler, gpus, args.scheduler_timeout)
            except SweepError as e:
                print(f"crumple-sweep: error: {one_line(e)}", file=sys.stderr)
                return 2
        try:
            os.makedirs(os.path.join(out, "runs"), exist_ok=True)
            with open(record_path + ".tmp", "w") as f:
                json.dump({"format": RECORD_FORMAT, "sweep": os.path.abspath(args.sweep), "mode": mode,
                           "variants": {vid: {"values": variants[i], "signature": signature(specs[vid])}
                                        for i, vid in enumerate(ids)}}, f, indent=1)
            os.replace(record_path + ".tmp", record_path)
            write_csv(csv_path, keys, bodies, ids, variants, rows)
        except OSError as e:
            print(f"crumple-sweep: error: --out {out}: cannot write {e.filename or out}: {e.strerror or e}",
                  file=sys.stderr)
            return 2
        if len(todo) < len(ids):
            say(f"{len(ids) - len(todo)} of {len(ids)} variants already complete in {out}: skipped")
        if todo:
            code = _run(client, cluster, specs, todo, rows, caught, say, args,
                        lambda: write_csv(csv_path, keys, bodies, ids, variants, rows))
            if code:
                return code
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()

    failed = [vid for vid in ids if rows.get(vid, {}).get("exit") != 0]
    say(f"wrote {csv_path}: {len(ids)} variants, {len(ids) - len(failed)} complete"
        + (f", {len(failed)} failed (logs in {os.path.join(out, 'logs')})" if failed else ""))
    return 1 if failed else 0


def _clock(seconds):
    """h:mm:ss or m:ss."""
    s = int(round(seconds))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


def _run(client, cluster, specs, todo, rows, caught, say, args, write):
    """Runs the variants todo on the cluster, rows as they come; on a signal, stops them and returns
    128 + its number (else None)."""
    from distributed import as_completed

    out = os.path.dirname(os.path.dirname(specs[todo[0]]["out"]))
    token = uuid.uuid4().hex[:8]
    stop = os.path.join(out, STOP_PREFIX + token)
    workers = len(client.scheduler_info().get("workers", {}))
    say(f"running {len(todo)} variants on {workers} worker{'s' if workers != 1 else ''} ({args.scheduler})")
    futures = {}
    done = set()

    def record(fut):
        vid = futures[fut]
        done.add(fut)
        try:
            row = fut.result()
        except Exception as e:  # the task was lost (its worker died too often), never the sweep
            row = {"exit": -1, "status": "lost", "error": f"task lost: {type(e).__name__}: {e}"}
        if row.get("exit") is not None:
            rows[vid] = row
        return vid, row

    try:
        for vid in todo:
            fut = client.submit(run_variant, dict(specs[vid], stop=stop), key=f"crumple-variant-{vid}-{token}",
                                pure=False)
            futures[fut] = vid
        started = time.monotonic()
        for fut in as_completed(list(futures)):
            vid, r = record(fut)
            write()
            # The time left at the pace so far (the variants share the workers alike).
            left = (time.monotonic() - started) / len(done) * (len(todo) - len(done))
            eta = f" (about {_clock(left)} left)" if len(done) < len(todo) else ""
            say(f"[{len(done)}/{len(todo)}] {vid}: {r['status']}" + (f": {r['error']}" if r.get("error") else "") + eta)
        return None
    except Interrupted as e:
        # Every running task sees the stop file within POLL s and stops its crumple-sim (SIGKILL after --grace);
        # a task not started yet runs nothing. A second signal stops the waiting.
        name = _signal_name(e.signum)
        print(f"crumple-sweep: {name}: stopping the running variants", file=sys.stderr, flush=True)
        try:
            with open(stop, "w"):
                pass
        except OSError:
            pass
        left = [f for f in futures if futures[f] not in rows]

        def collect(seconds, until_signal):
            end = time.monotonic() + seconds
            while left and time.monotonic() < end and not (until_signal and len(caught) > 1):
                for f in [f for f in left if f.done()]:
                    record(f)
                    left.remove(f)
                time.sleep(0.05)

        collect(args.grace + 5 * POLL + 2, True)
        if left and cluster is not None:
            # A second signal, or runs that outlived the grace: what this process started is killed now.
            _kill_children(signal.SIGKILL)
            collect(5 * POLL + 1, False)
        if left:
            try:
                client.cancel(left)
            except Exception:  # the scheduler is gone: nothing left to cancel there
                pass
        else:
            try:
                os.remove(stop)
            except OSError:
                pass
        try:
            write()
        except OSError:
            pass
        complete = sum(1 for r in rows.values() if r.get("exit") == 0)
        print(f"crumple-sweep: interrupted ({name}): {complete} of {len(specs)} variants complete in {out}; run the "
              f"same command again to finish", file=sys.stderr)
        return 128 + e.signum
