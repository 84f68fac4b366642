"""The pieces crumple's scene files share: where they live, a material, writing a scene."""
import argparse
import json
import os

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENES = os.path.join(ROOT, "scenes")
ASSETS = os.path.join(SCENES, "assets")


def material(density, restitution, friction, kappa, thickness, color, metallic, roughness, texture=None):
    """A scene's material (docs/scene-format.md), its keys in the order the scene files write them."""
    m = {"density": density, "restitution": restitution, "friction": friction, "kappa": kappa,
         "thickness": thickness, "color": color, "metallic": metallic, "roughness": roughness}
    if texture is not None:
        m["texture"] = texture
    return m


def scene_of(name, duration, materials, bodies, cameras):
    """A scene file's top level: its name and duration, materials, bodies and cameras (in the files' key order)."""
    return {"format": "crumple-scene/1", "name": name, "duration": duration, "materials": materials,
            "bodies": bodies, "cameras": cameras}


def write_scene(path, scene):
    """Writes a scene as JSON, indented one space a level, with a final newline."""
    with open(path, "w") as f:
        json.dump(scene, f, indent=1)
        f.write("\n")


def no_options(doc):
    """The command line of a generator that takes no options: --help prints `doc`."""
    argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
