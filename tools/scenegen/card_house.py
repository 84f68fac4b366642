"""Writes scenes/card-house.json: a house of cards of three storeys (three A-frames on the ground, a flat card on
each two neighbours' apexes, two A-frames on those, a flat card, one A-frame on top: fifteen cards 0.3 x 0.2 m,
1 cm thick, 700 kg/m^3, friction 0.6, leaning 20 degrees from upright) that stands on friction alone.
tests/test_physics_stacks.cpp builds the same houses of two and three storeys and holds them to 1 cm over 10 s;
tests/test_sim_app.cpp runs this scene.

Each card's load goes sideways through the cards it leans on, so the contact step's few passes leave the lower
A-frames creeping apart; the world's resting solve (islands holding a plate) holds them.
"""
import math
import os

from .scene import SCENES, material, no_options, scene_of, write_scene

T, L, D, TILT, STOREYS = 0.01, 0.3, 0.2, 20.0, 3


def r6(x):
    return round(x, 6)


def cards():
    tilt = math.radians(TILT)
    span = 2 * (L * math.sin(tilt) + T * math.cos(tilt)) + 0.02  # an A-frame's footprint and a gap
    out = []

    def card(name, size, at, z_degrees):
        out.append({"name": name, "shape": {"type": "box", "size": [r6(s) for s in size]}, "material": "card",
                    "position": [r6(at[0]), r6(at[1]), 0], "orientation": [0, 0, z_degrees]})

    y = 0.0
    for s in range(STOREYS):
        frames = STOREYS - s
        x0 = -(frames - 1) * span / 2
        for f in range(frames):
            x = x0 + f * span
            cy = y + L / 2 * math.cos(tilt) + T / 2 * math.sin(tilt) + 0.0005
            cx = L / 2 * math.sin(tilt) + T / 2 * math.cos(tilt)
            card("card_%d_%d_left" % (s, f), (T, L, D), (x - cx, cy), -TILT)
            card("card_%d_%d_right" % (s, f), (T, L, D), (x + cx, cy), TILT)
        y += L * math.cos(tilt) + T * math.sin(tilt) + 0.001
        if s + 1 == STOREYS:
            break
        for f in range(frames - 1):
            card("card_%d_%d_flat" % (s, f), (span + 0.01, T, D), (x0 + (f + 0.5) * span, y + T / 2), 0)
        y += T + 0.001
    return out


def scene():
    bodies = [{"name": "table", "shape": {"type": "box", "size": [3, 0.1, 2]}, "material": "table", "static": True,
               "position": [0, -0.05, 0]}]
    bodies += cards()
    materials = {
        "table": material(700, 0.0, 0.6, 0.0, 0.05, [0.35, 0.22, 0.13], 0, 0.6),
        "card": material(700, 0.0, 0.6, 0.0, 0.01, [0.92, 0.9, 0.85], 0, 0.7),
    }
    cameras = [{"name": "main", "position": [0.55, 0.6, 2.0], "target": [0, 0.4, 0], "fov": 36}]
    return scene_of("card-house", 10.0, materials, bodies, cameras)


def main():
    no_options(__doc__)
    write_scene(os.path.join(SCENES, "card-house.json"), scene())
    print("wrote scenes/card-house.json")
