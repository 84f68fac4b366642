"""Writes scenes/assets/crate.gltf: a 0.6 m wooden crate as a self-contained glTF 2.0 file.

A closed box (24 vertices: positions, outward normals, TEXCOORD_0; 36 indices, counter-clockwise seen from
outside) with a metallic-roughness material whose two textures are drawn here and embedded as PNG data URIs:
the base colour (horizontal planks with grain and dark gaps, a darker frame, a dark diagonal cross brace, a
stencilled red arrow, steel corner brackets) and the metallicRoughness map (rough wood, smooth metal brackets).
Standard library only; the output is the same byte for byte on every run.
"""
import argparse
import base64
import json
import math
import os
import struct

from . import png as pngio
from .scene import ASSETS

N = 256  # texels a side


def png(width, height, rows):
    """PNG bytes of an 8-bit RGB image; rows: list of bytes, 3*width each."""
    return pngio.encode(width, height, 8, 2, rows)


def hash01(*k):
    """A deterministic value in [0, 1) from integers."""
    h = 2166136261
    for v in k:
        h = ((h ^ (v & 0xFFFFFFFF)) * 16777619) & 0xFFFFFFFF
    h ^= h >> 13
    h = (h * 0x5BD1E995) & 0xFFFFFFFF
    h ^= h >> 15
    return h / 2**32


def in_arrow(x, y):
    """A stencilled 'this side up' arrow in the upper-right plank field."""
    cx, top = 172, 44
    if top <= y < top + 22 and abs(x - cx) <= (y - top) * 0.9:  # the head
        return True
    return top + 22 <= y < top + 56 and abs(x - cx) <= 6  # the shaft


def texel(x, y):
    """(base colour rgb, roughness, metallic) of texel (x, y), y down."""
    frame = 20
    corner = 34
    # Steel corner brackets: an L over each corner of the frame.
    cxd, cyd = min(x, N - 1 - x), min(y, N - 1 - y)
    if cxd < corner and cyd < corner and (cxd < frame - 4 or cyd < frame - 4):
        rivet = any(math.hypot(cxd - a, cyd - b) < 3.0 for a, b in ((8, 26), (26, 8), (8, 8)))
        g = 0.30 if rivet else 0.52 + 0.06 * hash01(x // 2, y // 2, 7)
        return (g, g * 1.02, g * 1.06), 0.35, 1.0
    # Wood: planks 36 texels high between the frame; the frame boards run along the edges.
    edge = x < frame or x >= N - frame or y < frame or y >= N - frame
    d = (x - y) / math.sqrt(2.0)  # distance across the diagonal brace (top-left to bottom-right)
    brace = abs(d) < 13 and not edge
    if edge:
        along, across, board = (y, x, 100 + (x >= N - frame)) if (x < frame or x >= N - frame) else (x, y, 102 + (y >= N - frame))
        tone = (0.42, 0.27, 0.14)
    elif brace:
        along, across, board = (x + y), d, 200
        tone = (0.20, 0.12, 0.06)
    else:
        board = (y - frame) // 36
        along, across = x, (y - frame) % 36
        shade = 0.9 + 0.2 * hash01(board, 3)
        tone = (0.74 * shade, 0.52 * shade, 0.30 * shade)
        if across < 2:  # the dark gap between planks
            tone = (0.16, 0.10, 0.05)
    # Grain: streaks along the board, a knot now and then.
    grain = 0.85 + 0.15 * math.sin(across * 1.7 + 3.0 * math.sin(along * 0.045 + board) + board)
    grain *= 0.95 + 0.1 * hash01(along // 3, int(across), board)
    r, g, b = (c * grain for c in tone)
    if not edge and not brace and in_arrow(x, y):
        r, g, b = 0.55, 0.08, 0.06
    # Nails where the brace crosses the plank gaps and along the frame.
    if brace and abs(d) < 3 and ((y - frame) % 36) in (17, 18, 19):
        r, g, b = 0.12, 0.12, 0.12
    return (r, g, b), 0.85 + 0.1 * hash01(x // 4, y // 4, 11), 0.0


def textures():
    base, mr = [], []
    for y in range(N):
        brow, mrow = bytearray(), bytearray()
        for x in range(N):
            (r, g, b), rough, metal = texel(x, y)
            brow += bytes(max(0, min(255, round(255 * c))) for c in (r, g, b))
            mrow += bytes((255, round(255 * rough), round(255 * metal)))  # R unused (occlusion), G rough, B metal
        base.append(bytes(brow))
        mr.append(bytes(mrow))
    return png(N, N, base), png(N, N, mr)


def box(half):
    """24 vertices (4 a face) and 36 indices of a box, outward normals, counter-clockwise from outside."""
    pos, nrm, uv, idx = [], [], [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = [0.0, 0.0, 0.0]
            n[axis] = sign
            # Two tangents with u x v = n.
            u = [0.0, 0.0, 0.0]
            v = [0.0, 0.0, 0.0]
            u[(axis + 1) % 3] = 1.0
            v[(axis + 2) % 3] = 1.0
            if sign < 0:
                u, v = v, u
            base = len(pos)
            for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                pos.append([half * (n[i] + su * u[i] + sv * v[i]) for i in range(3)])
                nrm.append(n)
                uv.append([(su + 1) / 2, (1 - sv) / 2])
            idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    return pos, nrm, uv, idx


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(ASSETS, "crate.gltf"))
    ap.add_argument("--size", type=float, default=0.6, help="edge length in metres (default 0.6)")
    args = ap.parse_args()
    pos, nrm, uv, idx = box(args.size / 2)
    data = b"".join(struct.pack("<3f", *p) for p in pos) + b"".join(struct.pack("<3f", *n) for n in nrm)
    data += b"".join(struct.pack("<2f", *t) for t in uv) + b"".join(struct.pack("<H", i) for i in idx)
    nv = len(pos)
    base_png, mr_png = textures()
    uri = "data:application/octet-stream;base64,"
    h = args.size / 2
    gltf = {
        "asset": {"version": "2.0", "generator": "crumple tools/make-gltf-crate.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "crate", "mesh": 0}],
        "meshes": [{"name": "crate", "primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}]}],
        "materials": [{"name": "wood", "pbrMetallicRoughness": {
            "baseColorTexture": {"index": 0}, "metallicRoughnessTexture": {"index": 1},
            "metallicFactor": 1.0, "roughnessFactor": 1.0}}],
        "textures": [{"source": 0, "sampler": 0}, {"source": 1, "sampler": 0}],
        "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 33071, "wrapT": 33071}],
        "images": [{"uri": "data:image/png;base64," + base64.b64encode(base_png).decode()},
                   {"uri": "data:image/png;base64," + base64.b64encode(mr_png).decode()}],
        "buffers": [{"byteLength": len(data), "uri": uri + base64.b64encode(data).decode()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 12 * nv, "target": 34962},
            {"buffer": 0, "byteOffset": 12 * nv, "byteLength": 12 * nv, "target": 34962},
            {"buffer": 0, "byteOffset": 24 * nv, "byteLength": 8 * nv, "target": 34962},
            {"buffer": 0, "byteOffset": 32 * nv, "byteLength": 2 * len(idx), "target": 34963}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": nv, "type": "VEC3", "min": [-h] * 3, "max": [h] * 3},
            {"bufferView": 1, "componentType": 5126, "count": nv, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": nv, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": len(idx), "type": "SCALAR"}],
    }
    with open(args.out, "w") as f:
        json.dump(gltf, f, indent=1)
        f.write("\n")
