"""Writes scenes/highway.json, the flagship crash (the paper's figure 1): a car at
80 km/h swerves into a guard rail at about 20 degrees and scrapes along it.
The rails are W-beam segments (scenes/assets/wbeam.obj, 4 m) on steel posts
every 2 m, on both sides of the road; the car is scenes/assets/sedan.obj, a
smooth procedural body with glass and lights in its vertex colours (both from
tools/make-assets.py). Around the impact the left rail is held by joints:
its segments are bolted (welded) to their posts and the posts are welded to the
ground by welds that break, so a hard enough hit tears posts out; verges beyond
the road's edges catch what it drags off. Cameras: a chase camera that follows
the car, a close camera at the impact, one where the torn segment lands, and one
that follows the car's dented front-left corner and side (turning with the car).
Rerun on purpose after changing it; the scene file is committed."""
import json
import os

from .scene import SCENES, material, no_options

SEGMENT = 4.0      # m, the length of wbeam.obj
RAIL_START = 0.0   # x of the first segment's start
SEGMENTS = 25      # per side: 100 m of rail
RAIL_Z = 5.0       # the beams' traffic faces stand at |z| = RAIL_Z - 0.09
BEAM_Y = 0.6       # centre height of the beam (its top at ~0.76 m)
POST_EVERY = 2.0
# Around the impact the left rail is held by joints instead of being static: its
# segments are welded to their posts and each post is welded to the ground by a
# weld that breaks above POST_BREAK N s in one step (a post torn out of the soil).
LOOSE_SEGMENTS = range(9, 10)   # rail_left_09 (x = 36 .. 40 m), where the car hits
POST_BREAK = 1000.0             # N s
RAIL_MASS, POST_MASS = 60.0, 25.0
ROAD_WIDTH, VERGE_WIDTH = 14.0, 20.0   # m


def scene():
    joints = []
    bodies = [{"name": "road", "shape": {"type": "box", "size": [240, 0.4, ROAD_WIDTH]}, "material": "asphalt",
               "static": True, "position": [100, -0.2, 0]}]
    # Verges beyond the road's edges, flush with it: a post or segment torn out lands on ground.
    for side, sign in (("left", -1), ("right", 1)):
        bodies.append({"name": "verge_" + side, "shape": {"type": "box", "size": [240, 0.4, VERGE_WIDTH]},
                       "material": "verge", "static": True,
                       "position": [100, -0.2, sign * (ROAD_WIDTH + VERGE_WIDTH) / 2]})
    for side, z, yaw in (("left", -RAIL_Z, 180), ("right", RAIL_Z, 0)):
        # wbeam.obj's traffic face looks along -z: the right rail as it is, the left one turned about y.
        loose = LOOSE_SEGMENTS if side == "left" else []
        for i in range(SEGMENTS):
            x = RAIL_START + SEGMENT * (i + 0.5)
            rail = {"name": "rail_%s_%02d" % (side, i), "shape": {"type": "mesh", "file": "assets/wbeam.obj"},
                    "material": "rail", "static": i not in loose, "position": [x, BEAM_Y, z],
                    "orientation": [0, yaw, 0], "bump_map": {"resolution": 1024}, "group": "rail"}
            if i in loose:
                rail["mass"] = RAIL_MASS
            bodies.append(rail)
        posts = int(SEGMENTS * SEGMENT / POST_EVERY) + 1
        for i in range(posts):
            x = RAIL_START + POST_EVERY * i
            pz = z + (0.17 if z > 0 else -0.17)
            # A post under a loose segment is loose too (the ones at its ends included).
            held = [k for k in loose if SEGMENT * k <= x - RAIL_START <= SEGMENT * (k + 1)]
            post = {"name": "post_%s_%02d" % (side, i), "shape": {"type": "box", "size": [0.1, 0.8, 0.12]},
                    "material": "post", "static": not held, "position": [x, 0.4, pz]}
            if held:
                post.update({"mass": POST_MASS, "group": "rail"})
                joints.append({"name": "footing_%s_%02d" % (side, i), "type": "fixed", "b": post["name"],
                               "anchor": [x, 0.0, pz], "break_impulse": POST_BREAK})
                for k in held:
                    joints.append({"name": "bolt_%s_%02d_%02d" % (side, k, i), "type": "fixed",
                                   "a": post["name"], "b": "rail_%s_%02d" % (side, k), "anchor": [x, BEAM_Y, pz]})
            bodies.append(post)
    car = {"name": "car", "shape": {"type": "mesh", "file": "assets/sedan.obj"}, "material": "car_body",
           "mass": 1300, "position": [0, 0.68, 3.0], "velocity": [22.2, 0, 0], "bump_map": {"resolution": 2048, "bump_depth": 0.2},
           "vehicle": {"wheels": [[1.3, -0.17, 0.8], [1.3, -0.17, -0.8], [-1.3, -0.17, 0.8], [-1.3, -0.17, -0.8]],
                       "wheel_radius": 0.33, "wheel_width": 0.22, "suspension_rest": 0.25,
                       "suspension_stiffness": 45000, "suspension_damping": 4500, "engine_force": 6000,
                       "brake_force": 9000, "max_steer": 30, "tyre_grip": 0.9,
                       # Swerve left into the rail at ~20 degrees, steer away after the hit, brake.
                       "script": [{"t": 0.0, "throttle": 0.3},
                                  {"t": 0.3, "throttle": 0.3, "steer": 0.8},
                                  {"t": 1.45, "throttle": 0.2, "steer": 0.0},
                                  {"t": 1.95, "throttle": 0.0, "steer": -0.6},
                                  {"t": 2.45, "throttle": 0.0, "steer": 0.3, "brake": 0.6},
                                  {"t": 2.75, "throttle": 0.0, "steer": 0.0, "brake": 0.6}]}}
    bodies.append(car)
    return {
        "format": "crumple-scene/1",
        "name": "highway",
        "timestep": 0.0041666667,
        "duration": 4.5,
        "materials": {
            "asphalt": material(2400, 0.1, 1.0, 0.0, 0.2, [0.23, 0.23, 0.25], 0, 0.9, "asphalt"),
            "verge": material(1800, 0.1, 0.8, 0.0, 0.2, [0.30, 0.36, 0.20], 0, 0.95, "clay"),
            "rail": material(7800, 0.4, 0.4, 0.00006, 0.08, [0.58, 0.6, 0.62], 1, 0.35),
            "post": material(7800, 0.4, 0.5, 0.0, 0.1, [0.35, 0.36, 0.38], 0.8, 0.5),
            "car_body": material(300, 0.3, 0.5, 0.0002, 0.12, [1.0, 1.0, 1.0], 0.5, 0.3),
        },
        "deformation": {"enabled": True, "impulse_floor": 300, "bump_depth": 0.1, "bump_depth_collide": 0.02,
                        "address_map": 512, "path": "gather"},
        "bodies": bodies,
        "joints": joints,
        # Rail segments abut: a loose one swings out past its neighbours' ends.
        "no_collide": [["rail", "rail"]],
        "cameras": [
            {"name": "chase", "follow": "car", "follow_heading": True, "position": [-8.5, 3.2, 2.5],
             "target": [2.5, 0.4, 0], "fov": 50},
            {"name": "impact", "position": [36.0, 1.25, -3.1], "target": [39.0, 0.55, -4.9], "fov": 45},
            {"name": "torn", "position": [46.4, 2.4, -9.4], "target": [41.8, 0.2, -5.0], "fov": 45},
            {"name": "side", "follow": "car", "follow_heading": True, "position": [3.3, 0.7, -2.6],
             "target": [0.3, -0.05, -0.7], "fov": 45, "displace": True},
        ],
    }


def main():
    no_options(__doc__)
    text = json.dumps(scene(), separators=(", ", ": "))
    # One body per line: readable diffs.
    text = text.replace("}, {\"name\"", "},\n    {\"name\"")
    path = os.path.join(SCENES, "highway.json")
    with open(path, "w") as f:
        f.write(text + "\n")
    print("wrote", path)
