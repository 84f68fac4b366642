"""Writes the scenes that show joints, into scenes/:

  wrecking-ball.json  a 3-tonne steel ball on a 6 m cable (a distance joint, a rope)
                      swings into a clay wall and dents it, swing after swing
  ragdoll.json        a 10-part ragdoll (ball joints, hinges with limits) thrown
                      against a dentable wall; it folds up and drops
  chain-bridge.json   16 planks hinged edge to edge, sagging between two piers;
                      crates dropped on it make it swing
  car-doors.json      the sedan with its front doors as bodies of their own, on
                      hinges, held shut by breakable latches, hits a concrete post:
                      the latches break, the doors swing open, the front is dented

Rerun on purpose after changing it; the scene files are committed."""
import argparse
import math
import os

from . import assets
from .scene import SCENES, material, write_scene


def base(name, duration, materials):
    return {"format": "crumple-scene/1", "name": name, "timestep": 0.0041666667, "duration": duration,
            "materials": materials,
            "deformation": {"enabled": True, "bump_depth": 0.2, "bump_depth_collide": 0.02, "address_map": 512,
                            "path": "gather"}}


def wrecking_ball():
    pivot = [0.0, 9.0, 0.0]
    r, L, angle = 0.45, 6.0, math.radians(55)
    d = [-math.sin(angle), -math.cos(angle)]
    top = [pivot[0] + L * d[0], pivot[1] + L * d[1], 0.0]
    centre = [pivot[0] + (L + r) * d[0], pivot[1] + (L + r) * d[1], 0.0]
    s = base("wrecking-ball", 4.0, {
        "ground": material(2400, 0.1, 0.9, 0.0, 0.2, [0.35, 0.34, 0.32], 0, 0.95, "concrete"),
        "clay": material(1800, 0.2, 0.8, 0.00003, 0.05, [0.72, 0.5, 0.36], 0, 0.75, "clay"),
        "steel": material(7800, 0.95, 0.4, 0.00001, 0.01, [0.3, 0.31, 0.33], 1, 0.3),
        "crane": material(7800, 0.5, 0.5, 0.0, 0.05, [0.85, 0.6, 0.1], 0.3, 0.45)})
    s["bodies"] = [
        {"name": "ground", "shape": {"type": "box", "size": [30, 0.4, 20]}, "material": "ground", "static": True,
         "position": [0, -0.2, 0]},
        {"name": "wall", "shape": {"type": "box", "size": [0.6, 4.0, 5.0]}, "material": "clay", "static": True,
         "position": [0.75, 2.0, 0], "bump_map": {"resolution": 1024}},
        {"name": "jib", "shape": {"type": "box", "size": [1.0, 0.3, 0.3]}, "material": "crane", "static": True,
         "position": [0, 9.15, 0]},
        {"name": "ball", "shape": {"type": "sphere", "radius": r}, "material": "steel", "position": centre,
         "bump_map": {"resolution": 256}},
    ]
    s["joints"] = [{"name": "cable", "type": "distance", "a": "jib", "b": "ball", "anchor_a": pivot, "anchor_b": top,
                    "min": 0, "max": L}]
    s["cameras"] = [{"name": "main", "position": [-2.5, 5.0, 11.0], "target": [-0.8, 4.6, 0], "fov": 50},
                    {"name": "wall", "position": [-1.6, 2.9, -2.6], "target": [0.45, 2.45, 0.15], "fov": 40}]
    return s


def ragdoll_bodies(at, material, velocity=None, spin=None):
    """The ragdoll of tests/test_physics_joints.cpp: (name, size, centre) boxes and its joints."""
    parts = [("pelvis", [0.35, 0.2, 0.2], [0, 1.0, 0]), ("torso", [0.4, 0.45, 0.22], [0, 1.33, 0]),
             ("head", [0.2, 0.22, 0.2], [0, 1.7, 0]),
             ("upper_arm_l", [0.3, 0.1, 0.1], [-0.38, 1.48, 0]), ("lower_arm_l", [0.3, 0.09, 0.09], [-0.7, 1.48, 0]),
             ("upper_arm_r", [0.3, 0.1, 0.1], [0.38, 1.48, 0]), ("lower_arm_r", [0.3, 0.09, 0.09], [0.7, 1.48, 0]),
             ("upper_leg_l", [0.14, 0.4, 0.14], [-0.1, 0.68, 0]), ("lower_leg_l", [0.12, 0.4, 0.12], [-0.1, 0.26, 0]),
             ("upper_leg_r", [0.14, 0.4, 0.14], [0.1, 0.68, 0]), ("lower_leg_r", [0.12, 0.4, 0.12], [0.1, 0.26, 0])]
    bodies = []
    for name, size, c in parts:
        b = {"name": name, "shape": {"type": "box", "size": size}, "material": material, "group": "ragdoll",
             "position": [at[0] + c[0], at[1] + c[1], at[2] + c[2]]}
        if velocity: b["velocity"] = velocity
        if spin: b["angular_velocity"] = spin
        bodies.append(b)

    def p(x, y, z):
        return [at[0] + x, at[1] + y, at[2] + z]
    joints = [
        {"name": "waist", "type": "hinge", "a": "pelvis", "b": "torso", "anchor": p(0, 1.1, 0), "axis": [1, 0, 0],
         "limits": [-30, 60]},
        {"name": "neck", "type": "ball", "a": "torso", "b": "head", "anchor": p(0, 1.58, 0)},
        {"name": "shoulder_l", "type": "ball", "a": "torso", "b": "upper_arm_l", "anchor": p(-0.22, 1.48, 0)},
        {"name": "elbow_l", "type": "hinge", "a": "upper_arm_l", "b": "lower_arm_l", "anchor": p(-0.54, 1.48, 0),
         "axis": [0, 1, 0], "limits": [0, 140]},
        {"name": "shoulder_r", "type": "ball", "a": "torso", "b": "upper_arm_r", "anchor": p(0.22, 1.48, 0)},
        {"name": "elbow_r", "type": "hinge", "a": "upper_arm_r", "b": "lower_arm_r", "anchor": p(0.54, 1.48, 0),
         "axis": [0, 1, 0], "limits": [-140, 0]},
        {"name": "hip_l", "type": "ball", "a": "pelvis", "b": "upper_leg_l", "anchor": p(-0.1, 0.9, 0)},
        {"name": "knee_l", "type": "hinge", "a": "upper_leg_l", "b": "lower_leg_l", "anchor": p(-0.1, 0.47, 0),
         "axis": [1, 0, 0], "limits": [0, 150]},
        {"name": "hip_r", "type": "ball", "a": "pelvis", "b": "upper_leg_r", "anchor": p(0.1, 0.9, 0)},
        {"name": "knee_r", "type": "hinge", "a": "upper_leg_r", "b": "lower_leg_r", "anchor": p(0.1, 0.47, 0),
         "axis": [1, 0, 0], "limits": [0, 150]},
    ]
    return bodies, joints


def ragdoll():
    s = base("ragdoll", 3.0, {
        "ground": material(2400, 0.1, 0.9, 0.0, 0.2, [0.35, 0.36, 0.33], 0, 0.95, "concrete"),
        "plaster": material(1200, 0.1, 0.7, 0.003, 0.05, [0.85, 0.83, 0.78], 0, 0.9),
        "dummy": material(1000, 0.1, 0.6, 0.0, 0.05, [0.9, 0.55, 0.15], 0, 0.6)})
    # Thrown along +z at a wall, tumbling forward.
    bodies, joints = ragdoll_bodies([0, 0.3, 0], "dummy", velocity=[0, 2.5, 9.0], spin=[3.0, 0, 0.5])
    s["bodies"] = [
        {"name": "ground", "shape": {"type": "box", "size": [12, 0.4, 14]}, "material": "ground", "static": True,
         "position": [0, -0.2, 2]},
        {"name": "wall", "shape": {"type": "box", "size": [4, 3, 0.3]}, "material": "plaster", "static": True,
         "position": [0, 1.5, 3.2], "bump_map": {"resolution": 1024}},
    ] + bodies
    s["joints"] = joints
    s["cameras"] = [{"name": "main", "position": [4.5, 2.2, -0.5], "target": [0, 1.0, 2.2], "fov": 50},
                    {"name": "wall", "position": [0.9, 1.4, 0.6], "target": [0, 1.2, 3.05], "fov": 50}]
    return s


def chain_bridge():
    # 16 planks hinged edge to edge, hung between two piers 7 m apart: the chain is
    # 7.2 m long, so it sags. Its vertices lie on a circular arc with equal edges
    # (the plank pitch), found by bisection on the arc's angle.
    planks, pitch, span, y = 16, 0.45, 7.0, 2.0
    lo, hi = 1e-6, 2 * math.pi / planks
    for _ in range(200):  # theta: each edge's angle at the centre; the chord of the whole arc must be `span`
        th = 0.5 * (lo + hi)
        R = pitch / (2 * math.sin(th / 2))
        if 2 * R * math.sin(planks * th / 2) > span:
            lo = th
        else:
            hi = th
    th = 0.5 * (lo + hi)
    R = pitch / (2 * math.sin(th / 2))
    cy = y + R * math.cos(planks * th / 2)  # the arc's centre, above the deck
    verts = []
    for i in range(planks + 1):
        a = -planks * th / 2 + i * th
        verts.append((R * math.sin(a), cy - R * math.cos(a)))
    s = base("chain-bridge", 4.0, {
        "ground": material(2400, 0.1, 0.9, 0.0, 0.2, [0.3, 0.42, 0.28], 0, 0.95, "clay"),
        "stone": material(2600, 0.2, 0.8, 0.0, 0.2, [0.55, 0.54, 0.5], 0, 0.8),
        "wood": material(600, 0.3, 0.7, 0.0002, 0.04, [0.6, 0.42, 0.25], 0, 0.7),
        "crate": material(500, 0.3, 0.6, 0.0, 0.03, [0.75, 0.6, 0.35], 0, 0.75)})
    x0 = -span / 2
    bodies = [
        {"name": "ground", "shape": {"type": "box", "size": [20, 0.4, 10]}, "material": "ground", "static": True,
         "position": [0, -0.2, 0]},
        {"name": "pier_west", "shape": {"type": "box", "size": [1.0, y, 2.0]}, "material": "stone", "static": True,
         "position": [x0 - 0.5, y / 2, 0]},
        {"name": "pier_east", "shape": {"type": "box", "size": [1.0, y, 2.0]}, "material": "stone", "static": True,
         "position": [-x0 + 0.5, y / 2, 0]},
    ]
    joints = []
    for i in range(planks):
        (xa, ya), (xb, yb) = verts[i], verts[i + 1]
        tilt = math.degrees(math.atan2(yb - ya, xb - xa))
        bodies.append({"name": "plank_%02d" % i, "shape": {"type": "box", "size": [pitch - 0.02, 0.06, 1.4]},
                       "material": "wood", "group": "bridge", "position": [(xa + xb) / 2, (ya + yb) / 2, 0],
                       "orientation": [0, 0, tilt], "bump_map": {"resolution": 128}})
    for i in range(planks + 1):
        if i == 0:
            a, b = "pier_west", "plank_00"
        elif i == planks:
            a, b = "pier_east", "plank_%02d" % (planks - 1)
        else:
            a, b = "plank_%02d" % (i - 1), "plank_%02d" % i
        joints.append({"name": "link_%02d" % i, "type": "hinge", "a": a, "b": b,
                       "anchor": [verts[i][0], verts[i][1], 0], "axis": [0, 0, 1]})
    crates = [(-1.2, 3.5, 0.4), (0.3, 4.5, 0.5), (1.5, 5.5, 0.35)]
    for k, (x, h, size) in enumerate(crates):
        bodies.append({"name": "crate_%d" % k, "shape": {"type": "box", "size": [size] * 3}, "material": "crate",
                       "position": [x, h, 0.1 * k], "orientation": [0, 20 * k, 10]})
    s["bodies"] = bodies
    s["joints"] = joints
    s["cameras"] = [{"name": "main", "position": [2.5, 3.2, 7.0], "target": [0, 1.3, 0], "fov": 55}]
    return s


def car_doors():
    # The sedan with its front doors as bodies of their own (sedan-body.obj, sedan-door-*.obj
    # from tools/make-assets.py). Each door hangs on a hinge at its front edge: a vertical axis
    # inboard of the door's centre of mass, 0 to 75 degrees outwards, a little friction (a motor
    # holding speed 0 with a small torque); a latch at its rear edge, a weld that breaks, holds
    # it shut. The car hits a concrete post with the front, a little left of centre. Stopped in
    # one step, it asks more of the latches than they bear; unlatched, each door's momentum turns
    # it about its inboard hinge and it swings open to its stop.
    c = CAR_DOORS
    hx, hy, hz = assets.DOOR_HINGE
    a = math.radians(c["heading"])  # to the left of +x
    head, left = (math.cos(a), 0.0, math.sin(a)), (-math.sin(a), 0.0, math.cos(a))
    post = c["post"]
    # The car's centre line passes the post's centre `offset` to its right; its centre starts
    # `run` metres before the post.
    car_pos = [post[0] - c["run"] * head[0] - c["offset"] * left[0], 0.68,
               post[2] - c["run"] * head[2] - c["offset"] * left[2]]

    def at(local):  # a point of the car's frame, in the world at the start
        return [round(car_pos[i] + local[0] * head[i] + local[1] * (i == 1) + local[2] * left[i], 6)
                for i in range(3)]
    velocity = [round(c["speed"] * head[0], 6), 0, round(c["speed"] * head[2], 6)]
    yaw = [0, -c["heading"] + 0.0, 0]
    s = base("car-doors", c["duration"], {
        "asphalt": material(2400, 0.1, 1.0, 0.0, 0.2, [0.23, 0.23, 0.25], 0, 0.9, "asphalt"),
        "concrete": material(2400, 0.2, 0.7, 0.0, 0.3, [0.62, 0.61, 0.58], 0, 0.85, "concrete"),
        "car_body": material(300, 0.05, 0.5, 0.0002, 0.12, [1.0, 1.0, 1.0], 0.5, 0.3)})
    s["deformation"] = {"enabled": True, "impulse_floor": 200, "bump_depth": 0.1, "bump_depth_collide": 0.02,
                        "address_map": 512, "path": "gather"}
    car = {"name": "car", "shape": {"type": "mesh", "file": "assets/sedan-body.obj"}, "material": "car_body",
           "mass": c["car_mass"], "position": [round(v, 6) for v in car_pos], "orientation": yaw,
           "velocity": velocity, "bump_map": {"resolution": 2048, "bump_depth": 0.2},
           "vehicle": {"wheels": [[1.3, -0.17, 0.8], [1.3, -0.17, -0.8], [-1.3, -0.17, 0.8], [-1.3, -0.17, -0.8]],
                       "wheel_radius": 0.33, "wheel_width": 0.22, "suspension_rest": 0.25,
                       "suspension_stiffness": 45000, "suspension_damping": 4500, "engine_force": 6000,
                       "brake_force": 9000, "max_steer": 30, "tyre_grip": 0.9, "script": c["script"]}}
    bodies = [
        {"name": "ground", "shape": {"type": "box", "size": [60, 0.4, 30]}, "material": "asphalt", "static": True,
         "position": [5, -0.2, 0]},
        {"name": "post", "shape": {"type": "cylinder", "radius": c["post_radius"], "height": 1.2},
         "material": "concrete", "static": True, "position": post},
        car]
    joints = []
    for side, sign in (("left", 1), ("right", -1)):
        door = "door_" + side
        hinge = at((hx, hy, sign * hz))
        bodies.append({"name": door, "shape": {"type": "mesh", "file": "assets/sedan-door-%s.obj" % side},
                       "material": "car_body", "mass": c["door_mass"], "position": hinge, "orientation": yaw,
                       "velocity": velocity, "bump_map": {"resolution": 1024, "bump_depth": 0.2}})
        # Positive angles swing the door's rear edge outwards: B (the door) turns right-handed
        # about the axis relative to A (the car), up on the left side, down on the right.
        joints.append({"name": "hinge_" + side, "type": "hinge", "a": "car", "b": door, "anchor": hinge,
                       "axis": [0, sign, 0], "limits": [0, 75],
                       "motor": {"speed": 0, "max_torque": c["hinge_friction"]}})
        joints.append({"name": "latch_" + side, "type": "fixed", "a": "car", "b": door,
                       "anchor": at((assets.DOOR_REAR + 0.03, 0.1, sign * c["latch_z"])),
                       "break_impulse": c["latch_break"]})
    s["bodies"] = bodies
    s["joints"] = joints
    s["cameras"] = c["cameras"]
    return s


CAR_DOORS = {
    "speed": 18.0, "heading": 0.0, "post": [0.0, 0.6, 0.0], "post_radius": 0.3, "offset": 0.2, "run": 7.0,
    "duration": 3.0, "car_mass": 1250, "door_mass": 25, "hinge_friction": 10.0,
    "latch_z": 0.85,  # the latch: in the door's rear edge, mid thickness
    # N s. Driving and braking ask at most 0.1 of a latch; the crash 64 (left) and 18 (right) in its step.
    "latch_break": 8.0,
    # The driver brakes a moment too late.
    "script": [{"t": 0.0, "throttle": 0.2}, {"t": 0.12, "throttle": 0.0, "brake": 1.0}],
    "cameras": [
        {"name": "main", "position": [1.6, 2.7, 3.4], "target": [-2.1, 0.35, -0.5], "fov": 50},
        {"name": "side", "position": [-3.0, 1.7, 5.5], "target": [-2.6, 0.4, -0.2], "fov": 50},
        {"name": "chase", "follow": "car", "position": [-6.0, 2.4, 3.0], "target": [1.0, 0.3, 0], "fov": 55},
    ]}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=SCENES, help="folder to write the scenes into (default: scenes/)")
    args = ap.parse_args()
    for fn, scene in (("wrecking-ball.json", wrecking_ball()), ("ragdoll.json", ragdoll()),
                      ("chain-bridge.json", chain_bridge()), ("car-doors.json", car_doors())):
        path = os.path.join(args.out, fn)
        write_scene(path, scene)
        print("wrote", path)

