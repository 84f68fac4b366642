#!/usr/bin/env python3
"""Writes the render mesh of a crumple primitive (box, sphere, cylinder, capsule) with crumple's texture
atlas, as an OBJ file, so that the height maps and normal maps crumple-sim writes into DIR/heightmaps/ and
DIR/normalmaps/ can be put on the same surface in another program (Blender, a glTF pipeline, your own code).

The mesh, its charts and their packing are computed exactly as crumple builds them (engine/primitives.cpp,
engine/atlas.cpp; docs/maps.md explains them); the atlas depends on the map's resolution (the gutters between
charts are 3 texels wide), so pass the body's bump_map resolution.

  python3 docs/examples/primitive_atlas.py box 2 0.2 2 --resolution 512 --obj plate.obj
  python3 docs/examples/primitive_atlas.py sphere 0.25 --resolution 256 --obj ball.obj
  python3 docs/examples/primitive_atlas.py cylinder 0.2 0.5 --resolution 256 --obj can.obj
  python3 docs/examples/primitive_atlas.py capsule 0.12 0.5 --resolution 256 --obj capsule.obj

OBJ's texture v points up the image, crumple's down the rows: the file holds vt u (1 - v), so that any OBJ
reader puts row r of crumple's PNG where crumple does. Vertex positions are in the shape frame (the frame whose
origin a scene's "position" places). Standard library only."""
import argparse, math

# --- charts: triangles with flat coordinates in metres, grouped by chart -------------------------------------


class Charts:
    def __init__(self):
        self.tris = []  # (chart, [p0, p1, p2], [n0, n1, n2], [uv0, uv1, uv2])

    def add(self, chart, p, n, uv):
        self.tris.append((chart, p, n, uv))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def normalize(a):
    l = math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
    return (a[0] / l, a[1] / l, a[2] / l)


def add_quad(ch, chart, corner, i, j):
    c = [corner(i, j), corner(i + 1, j), corner(i + 1, j + 1), corner(i, j + 1)]
    for k in ((0, 1, 2), (0, 2, 3)):
        ch.add(chart, [c[t][0] for t in k], [c[t][1] for t in k], [c[t][2] for t in k])


def add_rings(ch, chart, corner, segments, rings):
    for j in range(rings):
        for i in range(segments):
            if j < rings - 1:
                add_quad(ch, chart, corner, i, j)
            else:
                c = [corner(i, j), corner(i + 1, j), corner(i, j + 1)]
                ch.add(chart, [x[0] for x in c], [x[1] for x in c], [x[2] for x in c])


def cube_face(f):
    """Face f = 0..5 is +x, -x, +y, -y, +z, -z: its normal, u axis and v axis (u x v = normal)."""
    axis, s = f // 2, (-1.0 if f % 2 else 1.0)
    n = [0.0, 0.0, 0.0]
    n[axis] = s
    u = [0.0, 0.0, 0.0]
    u[(axis + 1) % 3] = 1.0
    return tuple(n), tuple(u), cross(n, u)


def box_charts(size, cells=4):
    ch = Charts()
    h = [s * 0.5 for s in size]
    for f in range(6):
        n, u, v = cube_face(f)
        hu = sum(abs(u[k]) * h[k] for k in range(3))
        hv = sum(abs(v[k]) * h[k] for k in range(3))
        hn = sum(abs(n[k]) * h[k] for k in range(3))

        def corner(i, j, n=n, u=u, v=v, hu=hu, hv=hv, hn=hn):
            a, b = -hu + 2 * hu * i / cells, -hv + 2 * hv * j / cells
            return tuple(n[k] * hn + u[k] * a + v[k] * b for k in range(3)), n, (a, b)

        for j in range(cells):
            for i in range(cells):
                add_quad(ch, f, corner, i, j)
    return ch


def sphere_charts(r, segments=16):
    ch = Charts()
    q = math.pi / 4
    for f in range(6):
        n, u, v = cube_face(f)

        def corner(i, j, n=n, u=u, v=v):  # equi-angular cube map
            a, b = -q + 2 * q * i / segments, -q + 2 * q * j / segments
            nn = normalize(tuple(n[k] + u[k] * math.tan(a) + v[k] * math.tan(b) for k in range(3)))
            return tuple(c * r for c in nn), nn, (a * r, b * r)

        for j in range(segments):
            for i in range(segments):
                add_quad(ch, f, corner, i, j)
    return ch


def add_tube(ch, chart, r, y0, y1, segments, rows):
    def corner(i, j):
        a = 2 * math.pi * i / segments
        y = y0 + (y1 - y0) * j / rows
        nn = (math.cos(a), 0.0, -math.sin(a))
        return (nn[0] * r, y, nn[2] * r), nn, (a * r, y)

    for j in range(rows):
        for i in range(segments):
            add_quad(ch, chart, corner, i, j)


def add_disc(ch, chart, r, y, up, segments, rings=4):
    n = (0.0, 1.0 if up else -1.0, 0.0)

    def corner(i, j):
        a = 2 * math.pi * i / segments * (-1.0 if up else 1.0)
        rr = r * (rings - j) / rings
        p = (rr * math.cos(a), y, rr * math.sin(a))
        return p, n, (p[0], -p[2] if up else p[2])

    add_rings(ch, chart, corner, segments, rings)


def add_cap(ch, chart, r, yc, up, segments, rings):
    def corner(i, j):  # azimuthal equidistant projection about the pole
        a = 2 * math.pi * i / segments * (1.0 if up else -1.0)
        polar = math.pi / 2 * (rings - j) / rings
        s, c = math.sin(polar), math.cos(polar)
        nn = (s * math.cos(a), c if up else -c, -s * math.sin(a))
        uv = (math.cos(a) * polar * r, math.sin(a) * polar * r)
        if not up:
            uv = (uv[0], -uv[1])
        return (nn[0] * r, nn[1] * r + yc, nn[2] * r), nn, uv

    add_rings(ch, chart, corner, segments, rings)


def tube_rows(radius, height):
    return max(1, math.ceil(height / (radius * 0.5)))


def cylinder_charts(radius, height, segments=48):
    ch = Charts()
    hh = height / 2
    add_tube(ch, 0, radius, -hh, hh, segments, tube_rows(radius, height))
    add_disc(ch, 1, radius, hh, True, segments)
    add_disc(ch, 2, radius, -hh, False, segments)
    return ch


def capsule_charts(radius, height, segments=48, rings=12):
    ch = Charts()
    hh = height / 2
    if height > 0:
        add_tube(ch, 0, radius, -hh, hh, segments, tube_rows(radius, height))
    add_cap(ch, 1, radius, hh, True, segments, rings)
    add_cap(ch, 2, radius, -hh, False, segments, rings)
    return ch


# --- packing: every chart at one common scale (uniform texel size), shelves, 3-texel gutters ----------------


def shelf_pack(rects, scale, gutter):
    x = y = gutter
    shelf = 0.0
    for r in rects:
        w, h = (r["size"][1], r["size"][0]) if r["rotated"] else r["size"]
        w, h = w * scale, h * scale
        if w + 2 * gutter > 1 or h + 2 * gutter > 1:
            return False
        if x + w + gutter > 1:
            x, y, shelf = gutter, y + shelf + gutter, 0.0
        if y + h + gutter > 1:
            return False
        r["at"] = (x, y)
        x += w + gutter
        shelf = max(shelf, h)
    return True


def pack(ch, resolution, gutter_texels=3):
    """Returns (positions, normals, uvs, triangles), corners welded where position, normal and uv agree."""
    n_charts = max(t[0] for t in ch.tris) + 1
    lo = [[1e30, 1e30] for _ in range(n_charts)]
    hi = [[-1e30, -1e30] for _ in range(n_charts)]
    for c, _, _, uv in ch.tris:
        for a in uv:
            for k in range(2):
                lo[c][k] = min(lo[c][k], a[k])
                hi[c][k] = max(hi[c][k], a[k])
    rects, area = [], 0.0
    for c in range(n_charts):
        size = (max(hi[c][0] - lo[c][0], 1e-6), max(hi[c][1] - lo[c][1], 1e-6))
        rects.append({"chart": c, "lo": lo[c], "size": size, "rotated": size[1] > size[0], "at": (0.0, 0.0)})
        area += size[0] * size[1]
    order = sorted(rects, key=lambda r: -min(r["size"]))  # stable: ties keep chart order
    gutter = gutter_texels / resolution
    bad = 1.0 / math.sqrt(max(area, 1e-12))
    while shelf_pack(order, bad, gutter):
        bad *= 2
    good = bad / 2
    while not shelf_pack(order, good, gutter) and good > 1e-12:
        good /= 2
    for _ in range(30):
        mid = 0.5 * (good + bad)
        if shelf_pack(order, mid, gutter):
            good = mid
        else:
            bad = mid
    shelf_pack(order, good, gutter)
    layout = [(r["chart"], r["at"], (r["size"][1], r["size"][0]) if r["rotated"] else r["size"], r["rotated"])
              for r in rects]
    positions, normals, uvs, triangles, weld = [], [], [], [], {}
    for c, p, n, uv in ch.tris:
        r = rects[c]
        idx = []
        for k in range(3):
            local = (uv[k][0] - r["lo"][0], uv[k][1] - r["lo"][1])
            if r["rotated"]:  # a quarter turn: long charts lie flat
                local = (r["size"][1] - local[1], local[0])
            t = (r["at"][0] + local[0] * good, r["at"][1] + local[1] * good)
            key = tuple(p[k]) + tuple(n[k]) + t
            if key not in weld:
                weld[key] = len(positions)
                positions.append(p[k])
                normals.append(n[k])
                uvs.append(t)
            idx.append(weld[key])
        triangles.append(tuple(idx))
    return (positions, normals, uvs, triangles), (good, layout)


CHART_NAMES = {"box": ["+x face", "-x face", "+y face", "-y face", "+z face", "-z face"],
               "sphere": ["+x face", "-x face", "+y face", "-y face", "+z face", "-z face"],
               "cylinder": ["side", "top disc (+y)", "bottom disc (-y)"],
               "capsule": ["side", "top cap (+y)", "bottom cap (-y)"]}


def primitive(kind, dims, resolution):
    """The mesh: (positions, normals, uvs, triangles), uvs in crumple's convention (v down the rows)."""
    return primitive_with_layout(kind, dims, resolution)[0]


def primitive_with_layout(kind, dims, resolution):
    charts = {"box": lambda: box_charts(dims[:3]), "sphere": lambda: sphere_charts(dims[0]),
              "cylinder": lambda: cylinder_charts(dims[0], dims[1]),
              "capsule": lambda: capsule_charts(dims[0], dims[1])}[kind]()
    return pack(charts, resolution)


def write_obj(path, mesh):
    positions, normals, uvs, triangles = mesh
    with open(path, "w") as f:
        f.write("# crumple primitive with crumple's atlas; vt v = 1 - crumple's v\n")
        for p in positions:
            f.write("v %.9g %.9g %.9g\n" % p)
        for n in normals:
            f.write("vn %.9g %.9g %.9g\n" % n)
        for u, v in uvs:
            f.write("vt %.9g %.9g\n" % (u, 1.0 - v))
        for t in triangles:
            f.write("f %s\n" % " ".join("%d/%d/%d" % (i + 1, i + 1, i + 1) for i in t))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("kind", choices=["box", "sphere", "cylinder", "capsule"])
    ap.add_argument("dims", type=float, nargs="+",
                    help="box: size x y z (full sides); sphere: radius; cylinder: radius height; "
                         "capsule: radius height (of the straight part), as in the scene file")
    ap.add_argument("--resolution", type=int, default=256, help="the body's bump_map resolution (default 256)")
    ap.add_argument("--obj", help="the OBJ file to write")
    ap.add_argument("--charts", action="store_true", help="print where each chart lies in the map, in texels")
    a = ap.parse_args()
    need = {"box": 3, "sphere": 1, "cylinder": 2, "capsule": 2}[a.kind]
    if len(a.dims) != need:
        ap.error("%s takes %d dimension(s)" % (a.kind, need))
    if not a.obj and not a.charts:
        ap.error("nothing to do: give --obj FILE and/or --charts")
    mesh, (scale, layout) = primitive_with_layout(a.kind, a.dims, a.resolution)
    if a.charts:
        n = a.resolution
        print("%s, map %d: %.6g texels per metre (texel %.6g m)" % (a.kind, n, scale * n, 1 / (scale * n)))
        for chart, at, size, rotated in layout:
            print("  chart %d %-17s columns %8.2f..%8.2f  rows %8.2f..%8.2f%s" % (
                chart, CHART_NAMES[a.kind][chart], at[0] * n, (at[0] + size[0] * scale) * n, at[1] * n,
                (at[1] + size[1] * scale) * n, "  (turned a quarter)" if rotated else ""))
    if a.obj:
        write_obj(a.obj, mesh)
        print("wrote %s: %d vertices, %d triangles" % (a.obj, len(mesh[0]), len(mesh[3])))


if __name__ == "__main__":
    main()
