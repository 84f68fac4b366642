"""crumple-sweep: the variants of a sweep file, each a crumple-sim run, as tasks of Dask distributed.

    crumple-sweep SWEEP --out DIR [--scheduler local[:N] | tcp://HOST:PORT | FILE.json] [--gpu N[,N...]]
                  [--set KEY=VALUE]... [--timeout S] [--sim PATH] [-- CRUMPLE-SIM OPTIONS]

A sweep file (docs/sweeps.md):

    {"format": "crumple-sweep/1", "scene": "drop.json",
     "vary": {"bodies[ball].velocity": [[0,-2,0], [0,-4,0]], "materials.clay.kappa": [0.05, 0.1]},
     "mode": "grid"}

Every variant is checked with crumple.load_scene before anything runs (one that does not load is bad input,
exit 2). Each task runs crumple-sim with --set for each key into DIR/runs/<id>/ and returns its row of
DIR/results.csv. The task itself needs only the standard library and crumple-sim: it travels to the workers by
value, so a dask-worker on another machine needs python3-distributed and crumple-sim at the same path (or
--sim), and DIR and the scene on a filesystem it shares.
"""

import argparse
import csv
import itertools
import json
import os
import shlex
import socket
import subprocess
import sys
import time
import uuid

SWEEP_FORMAT = "crumple-sweep/1"
RECORD_FORMAT = "crumple-sweep-variants/1"
MARKER = ".crumple-output"


class SweepError(Exception):
    """Bad input: the sweep file, an option or a variant that does not load (exit 2)."""


# ---------------------------------------------------------------------------------------------------------------
# What runs on the workers: standard library only.


def value_text(value):
    """A value as --set takes it (JSON) and as results.csv shows it: compact JSON, a string as it is."""
    if isinstance(value, str):
        return value
    return json.dumps(value, separators=(",", ":"))


def read_run(out_dir):
    """collisions, deformations and {body: max_dent} of a complete crumple-sim output folder.

    max_dent.<body> is the largest `max_dent` (m) of the body's sides over the collision lines of events.jsonl
    (the deepest drop of one texel in one collision), for every body with a bump map (heightmaps/<body>.png);
    0.0 for one that was never dented."""
    with open(os.path.join(out_dir, "summary.json")) as f:
        summary = json.load(f)
    bodies = []
    maps = os.path.join(out_dir, "heightmaps")
    if os.path.isdir(maps):
        names = {n[:-4] for n in os.listdir(maps) if n.endswith(".png")}
        bodies = [b["name"] for b in summary.get("bodies", []) if b["name"] in names]
    dents = {name: 0.0 for name in bodies}
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
    return {"collisions": summary.get("collisions"), "deformations": summary.get("deformations"), "max_dent": dents}


def is_complete(out_dir):
    """Whether crumple-sim finished this folder: its marker and summary.json are there."""
    return os.path.isfile(os.path.join(out_dir, MARKER)) and os.path.isfile(os.path.join(out_dir, "summary.json"))


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


def run_variant(spec):
    """Runs one variant with crumple-sim; returns its row: exit, collisions, deformations, max_dent, error.

    spec: sim, scene, out (DIR/runs/<id>), log (DIR/logs/<id>.log), overrides [(key, JSON text)], args,
    gpus (list or None), timeout (s or None)."""
    cmd = [spec["sim"], spec["scene"], "--out", spec["out"], "--quiet"]
    for key, text in spec["overrides"]:
        cmd += ["--set", f"{key}={text}"]
    cmd += list(spec.get("args") or [])
    env = dict(os.environ)
    gpu = _pick_gpu(spec.get("gpus"))
    if gpu is not None:
        env["CRUMPLE_EGL_DEVICE"] = str(gpu)
    row = {"exit": None, "collisions": None, "deformations": None, "max_dent": {}, "error": ""}
    started = time.time()
    output = ""
    try:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                                errors="replace")
        try:
            output, _ = proc.communicate(timeout=spec.get("timeout"))
            row["exit"] = proc.returncode
        except subprocess.TimeoutExpired:
            proc.terminate()  # crumple-sim removes its partial output on SIGTERM
            try:
                output, _ = proc.communicate(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                output, _ = proc.communicate()
            row["exit"] = 124
            row["error"] = f"timed out after {spec['timeout']} s"
    except OSError as e:
        row["exit"] = 127
        row["error"] = f"cannot run {spec['sim']} on {socket.gethostname()}: {e}"
    elapsed = time.time() - started
    if row["exit"] == 0:
        try:
            row.update(read_run(spec["out"]))
        except (OSError, ValueError, KeyError) as e:
            row["exit"] = 1
            row["error"] = f"unreadable output: {e}"
    elif not row["error"]:
        lines = [ln for ln in output.splitlines() if ln.strip()]
        row["error"] = lines[-1] if lines else f"crumple-sim exited with status {row['exit']}"
    try:
        os.makedirs(os.path.dirname(spec["log"]), exist_ok=True)
        with open(spec["log"], "w") as f:
            f.write(f"# host {socket.gethostname()}, {elapsed:.1f} s, exit {row['exit']}"
                    f"{'' if gpu is None else f', CRUMPLE_EGL_DEVICE={gpu}'}\n# {shlex.join(cmd)}\n{output}")
    except OSError:
        pass
    return row


# ---------------------------------------------------------------------------------------------------------------
# The client: the sweep file, the variants, the scheduler, results.csv.


def load_sweep(path):
    """The sweep file, checked: (absolute scene path, [(key, values)], mode, {key: value} fixed overrides)."""
    def fail(key, why):
        raise SweepError(f"{path}: {key + ': ' if key else ''}{why}")

    try:
        with open(path) as f:
            text = f.read()
    except OSError as e:
        fail("", e.strerror or str(e))
    try:
        doc = json.loads(text)
    except ValueError as e:
        fail("", f"malformed JSON: {e}")
    if not isinstance(doc, dict):
        fail("", "the top level must be an object")
    for key in doc:
        if key not in ("format", "scene", "vary", "mode", "set"):
            fail(key, "unknown key (expected format, scene, vary, mode, set)")
    if doc.get("format", SWEEP_FORMAT) != SWEEP_FORMAT:
        fail("format", f"unsupported format {doc['format']!r} (expected {SWEEP_FORMAT})")
    scene = doc.get("scene")
    if not isinstance(scene, str) or not scene:
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


def parse_scheduler(text):
    if text == "local" or text.startswith("local:"):
        n = text[6:] if text.startswith("local:") else ""
        if n and (not n.isdigit() or int(n) < 1):
            raise SweepError(f"--scheduler: local:N needs a number of workers >= 1, got {text!r}")
        return ("local", int(n) if n else None)
    if "://" in text:
        return ("address", text)
    if text.endswith(".json") or os.path.isfile(text):
        return ("file", text)
    raise SweepError(f"--scheduler: expected local[:N], tcp://HOST:PORT or a scheduler file, got {text!r}")


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


def write_csv(path, keys, bodies, ids, variants, rows):
    tmp = path + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["id", *keys, "exit", "collisions", "deformations", *[f"max_dent.{b}" for b in bodies], "error"])
        for vid, variant in zip(ids, variants):
            row = rows.get(vid)
            cells = [vid, *[value_text(variant[k]) for k in keys]]
            if row is None:
                cells += [""] * (3 + len(bodies)) + ["not run"]
            else:
                dents = row.get("max_dent") or {}
                cells += [row["exit"], "" if row.get("collisions") is None else row["collisions"],
                          "" if row.get("deformations") is None else row["deformations"],
                          *[repr(dents[b]) if b in dents else "" for b in bodies], row.get("error", "")]
            w.writerow(cells)
    os.replace(tmp, path)


def connect(scheduler, gpus):
    """A Dask client (and the local cluster it owns, or None)."""
    import logging

    from distributed import Client, LocalCluster

    kind, arg = scheduler
    if kind == "local":
        n = arg or (len(gpus) if gpus and len(gpus) > 1 else os.cpu_count() or 1)
        # Threads, not processes: each task waits on its own crumple-sim process.
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=False, dashboard_address=None,
                               silence_logs=logging.ERROR)
        return Client(cluster), cluster
    if kind == "file":
        return Client(scheduler_file=arg, timeout="30s"), None
    return Client(arg, timeout="30s"), None


def build_parser():
    p = argparse.ArgumentParser(
        prog="crumple-sweep",
        description="Run the variants of a crumple sweep file as tasks of Dask distributed: each variant is a "
        "crumple-sim run into DIR/runs/<id>/, one row of DIR/results.csv (docs/sweeps.md).",
        epilog="Options after -- go to every crumple-sim run (e.g. -- --render --size 480x270).")
    p.add_argument("sweep", help="the sweep file (JSON, format crumple-sweep/1)")
    p.add_argument("--out", "-o", required=True, help="output folder: runs/<id>/, logs/<id>.log, results.csv")
    p.add_argument("--scheduler", default="local",
                   help="local[:N] (a local cluster of N workers; default: one per CPU core, or one per --gpu "
                   "listed), tcp://HOST:PORT (a running dask-scheduler) or a scheduler file (dask-scheduler "
                   "--scheduler-file)")
    p.add_argument("--gpu", help="EGL device for every run (N), or one per local worker (N,M,...): sets "
                   "CRUMPLE_EGL_DEVICE")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="a fixed override for every variant (as crumple-sim --set; repeatable)")
    p.add_argument("--timeout", type=float, help="seconds a run may take before it is stopped (exit 124)")
    p.add_argument("--sim", help="the crumple-sim to run (default: the one built or installed with this)")
    p.add_argument("--dry-run", action="store_true", help="check the variants and list them; run nothing")
    p.add_argument("--quiet", "-q", action="store_true", help="only errors")
    return p


def main(argv=None, default_sim="crumple-sim"):
    argv = list(sys.argv[1:] if argv is None else argv)
    sim_args = []
    if "--" in argv:
        i = argv.index("--")
        argv, sim_args = argv[:i], argv[i + 1:]
    args = build_parser().parse_args(argv)
    for a in sim_args:
        if a in ("--out", "-o", "--set") or a.startswith("--out=") or a.startswith("--set="):
            print(f"crumple-sweep: error: {a} after -- : crumple-sweep sets it itself", file=sys.stderr)
            return 2

    def say(msg):
        if not args.quiet:
            print(f"crumple-sweep: {msg}", flush=True)

    try:
        import crumple

        scene, axes, mode, fixed = load_sweep(args.sweep)
        scheduler = parse_scheduler(args.scheduler)
        gpus = parse_gpus(args.gpu)
        if args.timeout is not None and not args.timeout > 0:
            raise SweepError(f"--timeout must be a positive number of seconds, got {args.timeout}")
        if gpus and len(gpus) > 1 and scheduler[0] != "local":
            raise SweepError("--gpu N,M,...: one GPU per worker needs --scheduler local[:N]; on a cluster, start "
                             "each dask-worker with CRUMPLE_EGL_DEVICE=N in its environment")
        sim = os.path.abspath(args.sim) if args.sim else default_sim
        fixed_overrides = []
        for s in args.set:
            key, eq, value = s.partition("=")
            if not eq or not key:
                raise SweepError(f"--set: expected KEY=VALUE, got {s!r}")
            fixed_overrides.append((key, value))
        fixed_overrides = [(k, json.dumps(v)) for k, v in fixed.items()] + fixed_overrides
        variants = expand(axes, mode)
        keys = [k for k, _ in axes]
        ids = variant_ids(len(variants))
        # Every variant must load: a typo in a key path stops the sweep before anything runs.
        bodies = []
        bad = []
        for vid, variant in zip(ids, variants):
            overrides = fixed_overrides + [(k, json.dumps(v)) for k, v in variant.items()]
            try:
                info = crumple._crumple._load_scene(scene, overrides)
            except crumple.SceneError as e:
                bad.append(f"variant {vid} ({', '.join(f'{k}={value_text(v)}' for k, v in variant.items())}): {e}")
                continue
            for b in json.loads(info)["bodies"]:
                if b["bump_map"] is not None and b["name"] not in bodies:
                    bodies.append(b["name"])
        if bad:
            for line in bad[:5]:
                print(f"crumple-sweep: error: {line}", file=sys.stderr)
            if len(bad) > 5:
                print(f"crumple-sweep: error: ... {len(bad)} of {len(variants)} variants do not load",
                      file=sys.stderr)
            return 2
    except SweepError as e:
        print(f"crumple-sweep: error: {e}", file=sys.stderr)
        return 2

    out = os.path.abspath(args.out)
    specs = {}
    for vid, variant in zip(ids, variants):
        specs[vid] = {
            "sim": sim, "scene": scene, "out": os.path.join(out, "runs", vid),
            "log": os.path.join(out, "logs", vid + ".log"),
            "overrides": fixed_overrides + [(k, json.dumps(v)) for k, v in variant.items()],
            "args": sim_args, "gpus": gpus, "timeout": args.timeout,
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
    try:
        os.makedirs(os.path.join(out, "runs"), exist_ok=True)
        previous = {}
        if os.path.exists(record_path):
            with open(record_path) as f:
                previous = json.load(f).get("variants", {})
    except (OSError, ValueError) as e:
        print(f"crumple-sweep: error: {out}: {e}", file=sys.stderr)
        return 2
    rows = {}
    todo = []
    for vid in ids:
        spec = specs[vid]
        if is_complete(spec["out"]) and previous.get(vid, {}).get("signature") == signature(spec):
            try:
                rows[vid] = {"exit": 0, "error": "", **read_run(spec["out"])}
                continue
            except (OSError, ValueError, KeyError):
                pass
        todo.append(vid)
    with open(record_path + ".tmp", "w") as f:
        json.dump({"format": RECORD_FORMAT, "sweep": os.path.abspath(args.sweep), "mode": mode,
                   "variants": {vid: {"values": variants[i], "signature": signature(specs[vid])}
                                for i, vid in enumerate(ids)}}, f, indent=1)
    os.replace(record_path + ".tmp", record_path)
    csv_path = os.path.join(out, "results.csv")
    write_csv(csv_path, keys, bodies, ids, variants, rows)
    if len(todo) < len(ids):
        say(f"{len(ids) - len(todo)} of {len(ids)} variants already complete in {out}: skipped")

    if todo:
        try:
            import cloudpickle

            # The task goes to the workers by value: they need not import crumple (only crumple-sim).
            cloudpickle.register_pickle_by_value(sys.modules[__name__])
        except (ImportError, AttributeError, ValueError):
            pass
        from distributed import as_completed

        client = cluster = None
        try:
            try:
                client, cluster = connect(scheduler, gpus)
            except (OSError, TimeoutError) as e:
                print(f"crumple-sweep: failed: cannot reach the scheduler {args.scheduler}: {e}", file=sys.stderr)
                return 1
            workers = len(client.scheduler_info().get("workers", {}))
            say(f"running {len(todo)} variants on {workers} worker{'s' if workers != 1 else ''} ({args.scheduler})")
            token = uuid.uuid4().hex[:8]
            futures = {client.submit(run_variant, specs[vid], key=f"crumple-variant-{vid}-{token}", pure=False): vid
                       for vid in todo}
            done = 0
            for fut in as_completed(list(futures)):
                vid = futures[fut]
                try:
                    rows[vid] = fut.result()
                except Exception as e:  # the task was lost (its worker died too often), never the sweep
                    rows[vid] = {"exit": -1, "error": f"task lost: {type(e).__name__}: {e}"}
                done += 1
                write_csv(csv_path, keys, bodies, ids, variants, rows)
                r = rows[vid]
                say(f"[{done}/{len(todo)}] {vid}: exit {r['exit']}" + (f": {r['error']}" if r.get("error") else ""))
        except KeyboardInterrupt:
            print("\ncrumple-sweep: interrupted: complete runs are kept; run again to finish", file=sys.stderr)
            return 130
        finally:
            if client is not None:
                client.close()
            if cluster is not None:
                cluster.close()

    failed = [vid for vid in ids if rows.get(vid, {}).get("exit") != 0]
    say(f"wrote {csv_path}: {len(ids)} variants, {len(ids) - len(failed)} complete"
        + (f", {len(failed)} failed (logs in {os.path.join(out, 'logs')})" if failed else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
