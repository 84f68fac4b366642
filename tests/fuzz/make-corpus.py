#!/usr/bin/env python3
"""Writes the fuzzers' seed corpora, tests/fuzz/corpus/<target>/ (scene, obj, off, ply, gltf, glb), and their
dictionaries, tests/fuzz/<target>.dict (the words of each format; the scene's keys from engine/scene_loader.cpp).

Seeds: the shipped scenes (scenes/*.json) and the small shipped assets (scenes/assets/*.obj under 64 KB), small
valid files of each format (a tetrahedron in every variant the readers accept), and every hostile input the loaders
once mishandled, kept as a regression case (named hostile-*; tools/fuzz.sh replays each file once before fuzzing). Deterministic:
rerunning it rewrites the same bytes and leaves other files there alone: the inputs a fuzzer found (named fuzz-*,
copied from build-fuzz/findings/), kept as regression cases. Usage: tests/fuzz/make-corpus.py
"""
import base64
import json
import os
import re
import struct
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OUT = os.path.join(ROOT, "tests", "fuzz", "corpus")

TET = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
FACES = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def write(target, name, data):
    folder = os.path.join(OUT, target)
    os.makedirs(folder, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(folder, name), "wb") as f:
        f.write(data)


def shipped(pattern):
    """The committed files matching pattern, as HEAD has them (a working tree's edits stay out), up to 64 KB."""
    names = subprocess.run(["git", "-C", ROOT, "ls-files", pattern], check=True, capture_output=True,
                           text=True).stdout.split()
    for name in sorted(names):
        data = subprocess.run(["git", "-C", ROOT, "show", "HEAD:" + name], capture_output=True).stdout
        if 0 < len(data) <= 64 * 1024:
            yield os.path.basename(name), data


def scenes():
    for name, data in shipped("scenes/*.json"):
        write("scene", name, data)
    base = json.loads(dict(shipped("scenes/sphere-into-plate.json"))["sphere-into-plate.json"])

    def variant(name, edit):
        s = json.loads(json.dumps(base))
        edit(s)
        write("scene", name, json.dumps(s))

    # Regression cases, scene side: a 100000-deep array in a key that fails validation (the message dumped it).
    deep = json.dumps(base).replace('"gravity": [0, -9.81, 0]', '"gravity": ' + "[" * 100000 + "]" * 100000)
    write("scene", "hostile-deep-array.json", deep)
    # A 100000-character key path and a long value (messages are capped).
    variant("hostile-long-key.json", lambda s: s["bodies"][1].update({"x" * 100000: 1}))
    variant("hostile-long-name.json", lambda s: s["bodies"][1].update({"name": "n" * 100000}))
    # The physics cases parse fine; kept so the loader's side of them stays covered.
    variant("hostile-thin-capsule.json", lambda s: s["bodies"][1].update(
        {"shape": {"type": "capsule", "radius": 1e-4, "height": 1e4}}))
    variant("hostile-coincident-spheres.json", lambda s: s["bodies"].extend(
        [{"name": "s%d" % i, "shape": {"type": "sphere", "radius": 0.1}, "material": "steel",
          "position": [0, 1, 0]} for i in range(50)]))
    variant("hostile-thin-plate.json", lambda s: s["bodies"][0].update(
        {"shape": {"type": "box", "size": [2, 0.0001, 2]}}))
    variant("hostile-10km-box.json", lambda s: s["bodies"][1].update(
        {"shape": {"type": "box", "size": [1e4, 1e4, 1e4]}}))
    variant("hostile-mesh-folder-image.json", lambda s: s["bodies"][0].update(
        {"bump_map": {"image": "assets"}}))
    variant("mesh-body.json", lambda s: s["bodies"][1].update(
        {"shape": {"type": "mesh", "file": "assets/car.obj", "scale": [0.5, 0.5, 0.5]}}))


def obj():
    for name, data in shipped("scenes/assets/*.obj"):
        write("obj", name, data)
    v = "".join("v %g %g %g\n" % p for p in TET)
    f = "".join("f %d %d %d\n" % (a + 1, b + 1, c + 1) for a, b, c in FACES)
    write("obj", "tet.obj", v + f)
    write("obj", "tet-uv.obj", v + "vt 0 0\nvt 1 0\nvt 0 1\n" +
          "".join("f %d/1 %d/2 %d/3\n" % (a + 1, b + 1, c + 1) for a, b, c in FACES))
    write("obj", "tet-colours.obj", "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nv 0 0 1 0.5 0.5 0.5\n" + f)
    write("obj", "tet-relative.obj", v + "f -4 -2 -3\nf -4 -3 -1\nf -4 -1 -2\nf -3 -2 -1\n")
    write("obj", "quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1\nf 1 2 3 4\nf 1 2 5\nf 2 3 5\n"
          "f 3 4 5\nf 4 1 5\n# comment\ng group\ns off\nusemtl m\nvn 0 0 1\n")
    # Regression cases: duplicate faces (10^6 in the original input; 2000 here), NUL bytes (2 GB in the original),
    # a 1e38 coordinate.
    write("obj", "hostile-duplicate-faces.obj", v + f + "f 1 3 2\nf 3 2 1\n" * 1000)
    write("obj", "hostile-nul-bytes.obj", b"\0" * 4096)
    write("obj", "hostile-huge-coordinate.obj", v.replace("v 1 0 0", "v 1e38 0 0") + f)
    write("obj", "index-out-of-range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n")


def off():
    v = "".join("%g %g %g\n" % p for p in TET)
    f = "".join("3 %d %d %d\n" % t for t in FACES)
    write("off", "tet.off", "OFF\n4 4 6\n" + v + f)
    write("off", "tet-comments.off", "# a tetrahedron\nOFF\n\n4 4 0 # counts\n" + v + f)
    write("off", "tet-st.off", "STOFF\n4 4 0\n" + "".join("%g %g %g %g %g\n" % (p + p[:2]) for p in TET) + f)
    write("off", "tet-cn.off", "CNOFF\n4 4 0\n" + "".join("%g %g %g 0 0 1 255 0 0 255\n" % p for p in TET) +
          "".join("3 %d %d %d 1 0 0\n" % t for t in FACES))
    write("off", "pyramid.off", "OFF 5 5 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 0.5 1\n4 3 2 1 0\n3 0 1 4\n3 1 2 4\n"
          "3 2 3 4\n3 3 0 4\n")

    def binary(nv, nf, verts, faces, prefix="OFF"):
        return ((prefix + " BINARY\n").encode() + struct.pack("<3i", nv, nf, 0) +
                b"".join(struct.pack("<3f", *p) for p in verts) + faces)

    faces = b"".join(struct.pack("<4i", 3, *t) for t in FACES)
    write("off", "tet-binary.off", binary(4, 4, TET, faces))
    write("off", "tet-binary-st.off", b"STOFF BINARY\n" + struct.pack("<3i", 4, 4, 0) +
          b"".join(struct.pack("<5f", *(p + p[:2])) for p in TET) + faces)
    # Regression cases: a binary OFF with a face index out of range, with a lying face count, with a face of -3
    # vertices; an ASCII OFF with a coordinate of 1e38.
    write("off", "hostile-binary-index-out-of-range.off", binary(4, 4, TET, faces[:-4] + struct.pack("<i", 1000000)))
    write("off", "hostile-binary-lying-face-count.off", binary(4, 2000000000, TET, faces))
    write("off", "hostile-binary-face-of-minus-3.off", binary(4, 4, TET, struct.pack("<i", -3) + faces[4:]))
    write("off", "hostile-coordinate-1e38.off", "OFF\n4 4 0\n" + v.replace("1 0 0", "1e38 0 0") + f)
    write("off", "huge-count.off", "OFF\n999999999 1 0\n")


def ply():
    head = ("ply\nformat %s 1.0\ncomment a tetrahedron\nelement vertex 4\nproperty float x\nproperty float y\n"
            "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n")
    v = "".join("%g %g %g\n" % p for p in TET)
    f = "".join("3 %d %d %d\n" % t for t in FACES)
    good = head % "ascii" + v + f
    write("ply", "tet.ply", good)
    write("ply", "tet-binary.ply", (head % "binary_little_endian").encode() +
          b"".join(struct.pack("<3f", *p) for p in TET) + b"".join(struct.pack("<B3i", 3, *t) for t in FACES))
    write("ply", "tet-binary-be.ply", (head % "binary_big_endian").encode() +
          b"".join(struct.pack(">3f", *p) for p in TET) + b"".join(struct.pack(">B3i", 3, *t) for t in FACES))
    write("ply", "tet-uv.ply", good.replace("property float z\n", "property float z\nproperty float u\n"
                                            "property float v\n").replace(v, "".join(
                                                "%g %g %g %g %g\n" % (p + p[:2]) for p in TET)))
    # Regression cases: corrupted 'element' keyword and 'end_header' (OpenMesh crashed or looped), no end_header.
    write("ply", "hostile-corrupted-element.ply", good.replace("element face", "elemXnt face"))
    write("ply", "hostile-corrupted-end-header.ply", good.replace("end_header", "end_hXader"))
    write("ply", "hostile-no-end-header.ply", good.replace("end_header\n", ""))
    write("ply", "hostile-corrupted-element-line.ply", good.replace("element vertex 4", "element vertex"))
    write("ply", "index-out-of-range.ply", good.replace("3 1 2 3", "3 1 2 99"))


def gltf_parts(scale=1.0):
    pos = [tuple(c * scale for c in p) for p in TET]
    idx = [i for t in FACES for i in t]
    data = b"".join(struct.pack("<3f", *p) for p in pos) + struct.pack("<12H", *idx)
    lo = [min(p[i] for p in pos) for i in range(3)]
    hi = [max(p[i] for p in pos) for i in range(3)]
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
           "nodes": [{"mesh": 0, "translation": [0, 1, 0]}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
           "buffers": [{"byteLength": len(data)}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                           {"buffer": 0, "byteOffset": 48, "byteLength": 24}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": lo, "max": hi},
                         {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}]}
    return doc, data


def glb_bytes(doc, data):
    j = json.dumps(doc).encode()
    j += b" " * (-len(j) % 4)
    data += b"\0" * (-len(data) % 4)
    total = 12 + 8 + len(j) + 8 + len(data)
    return (b"glTF" + struct.pack("<2I", 2, total) + struct.pack("<I", len(j)) + b"JSON" + j +
            struct.pack("<I", len(data)) + b"BIN\0" + data)


def gltf():
    doc, data = gltf_parts()
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(data).decode()
    write("gltf", "tet.gltf", json.dumps(doc, indent=1))
    strip = json.loads(json.dumps(doc))
    strip["meshes"][0]["primitives"][0]["mode"] = 5
    write("gltf", "tet-strip.gltf", json.dumps(strip))
    nested = json.loads(json.dumps(doc))
    nested["nodes"] = [{"children": [1], "rotation": [0, 0.7071068, 0, 0.7071068], "scale": [2, 2, 2]},
                       {"mesh": 0, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 0, 1]}]
    write("gltf", "tet-nested.gltf", json.dumps(nested))
    missing = json.loads(json.dumps(doc))
    missing["buffers"][0]["uri"] = "missing.bin"
    write("gltf", "missing-buffer.gltf", json.dumps(missing))
    write("gltf", "hostile-nul-bytes.gltf", b"\0" * 4096)


def glb():
    def edit(name, node=None, scale=1.0, view=None):
        doc, data = gltf_parts(scale)
        doc["nodes"][0].update(node or {})
        doc["bufferViews"][0].update(view or {})
        write("glb", name, glb_bytes(doc, data))

    edit("tet.glb")
    edit("tet-rotated.glb", {"rotation": [0, 0, 0.3826834, 0.9238795], "scale": [1, 2, 0.5]})
    # Regression cases: GLB positions of 3e38, a zero node rotation, a 1e30 node scale, a negative byteOffset; a 2 GB
    # file of NUL bytes (4 KB here).
    edit("hostile-positions-3e38.glb", scale=3e38)
    edit("hostile-zero-rotation.glb", {"rotation": [0, 0, 0, 0]})
    edit("hostile-scale-1e30.glb", {"scale": [1e30, 1, 1]})
    edit("hostile-negative-byte-offset.glb", view={"byteOffset": -4})
    write("glb", "hostile-nul-bytes.glb", b"\0" * 4096)


def dictionary(target, words):
    def quoted(w):
        return "".join(c if 32 <= ord(c) < 127 and c not in '"\\' else "\\x%02x" % ord(c) for c in w)
    with open(os.path.join(ROOT, "tests", "fuzz", target + ".dict"), "w") as f:
        f.write("# libFuzzer dictionary for fuzz_%s, written by tests/fuzz/make-corpus.py\n" % target)
        for w in sorted(set(words)):
            f.write('"%s"\n' % quoted(w))


def dictionaries():
    loader = open(os.path.join(ROOT, "engine", "scene_loader.cpp")).read()
    keys = set(re.findall(r'"([a-z][a-z0-9_]{0,31})"', loader))
    dictionary("scene", ['"%s"' % k for k in keys] + ["crumple-scene/1", "[0, 0, 0]", "{", "}", "[", "]", ":",
                                                       ",", "true", "false", "null", "1e308", "-0", "assets/car.obj",
                                                       "assets/cow-bumps.png", "bodies[0]"])
    dictionary("obj", ["v ", "vt ", "vn ", "f ", "o ", "g ", "s off", "usemtl ", "mtllib ", "#", "/", "//", "-1",
                       "1e30", "nan", "inf"])
    dictionary("off", ["OFF", "STOFF", "COFF", "NOFF", "CNOFF", "STCNOFF", "4OFF", "nOFF", " BINARY\n", "#", "-1",
                       "1e30", "\xff\xff\xff\xff", "\x03\x00\x00\x00", "\x00\x00\x80\x7f"])
    dictionary("ply", ["ply\n", "format ascii 1.0\n", "format binary_little_endian 1.0\n",
                       "format binary_big_endian 1.0\n", "element vertex ", "element face ", "property float x\n",
                       "property float y\n", "property float z\n", "property float u\n", "property float v\n",
                       "property list uchar int vertex_indices\n", "property list uchar float texcoord\n",
                       "end_header\n", "comment ", "obj_info ", "char", "uchar", "short", "ushort", "int", "uint",
                       "float", "double", "int8", "uint8", "int16", "uint16", "int32", "uint32", "float32",
                       "float64", "\xff\xff\xff\xff", "\x00\x00\x80\x7f"])
    gltf = ["asset", "version", "2.0", "scene", "scenes", "nodes", "children", "mesh", "meshes", "primitives",
            "attributes", "POSITION", "NORMAL", "TEXCOORD_0", "indices", "mode", "matrix", "translation", "rotation",
            "scale", "accessors", "bufferView", "byteOffset", "componentType", "count", "type", "SCALAR", "VEC2",
            "VEC3", "VEC4", "MAT4", "min", "max", "normalized", "sparse", "bufferViews", "buffer", "byteLength",
            "byteStride", "target", "buffers", "uri", "extras", "extensions", "data:application/octet-stream;base64,"]
    words = ['"%s"' % w for w in gltf] + ["5120", "5121", "5122", "5123", "5125", "5126", "-1", "1e39", "[", "]",
                                          "{", "}", ":", ","]
    dictionary("gltf", words)
    dictionary("glb", words + ["glTF", "JSON", "BIN\x00", "\x02\x00\x00\x00"])


def main():
    if len(sys.argv) > 1:
        print(__doc__.strip())
        return 0 if sys.argv[1] in ("-h", "--help") else 2
    for target in ("scene", "obj", "off", "ply", "gltf", "glb"):
        os.makedirs(os.path.join(OUT, target), exist_ok=True)  # other files there (fuzzers' findings) stay
    scenes()
    obj()
    off()
    ply()
    gltf()
    glb()
    dictionaries()
    return 0


if __name__ == "__main__":
    sys.exit(main())
