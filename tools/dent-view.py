#!/usr/bin/env python3
"""Measures and shows the dents of a crumple height map (a 16-bit PNG written by
crumple-sim into DIR/heightmaps/): how many texels are dented, the deepest dent,
the dent's continuity (over the dented texels, the mean fraction of their four
neighbours that are dented too: a continuous dent scores about 0.95, a screen
door about 0.5) and its holes (flat texels between two dented neighbours, as a
fraction of dented texels plus holes). With --png it writes an 8-bit picture of
the dented region, darker where deeper, optionally beside a second map's
(--compare) at the same crop, so two runs can be seen side by side.

  tools/dent-view.py out/highway/heightmaps/car.png --k 0.2
  tools/dent-view.py A/car.png --compare B/car.png --png side-by-side.png

Standard library only."""
import argparse, os, struct, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scenegen import png  # noqa: E402


def read_png16(path):
    w, h, depth, ctype, raw = png.decode(path)
    if depth != 16 or ctype != 0:
        sys.exit("%s: not a 16-bit grey height map" % path)
    rows = [[struct.unpack(">H", bytes(line[2 * x:2 * x + 2]))[0] / 65535 for x in range(w)] for line in raw]
    return w, h, rows


def measure(w, h, H, eps):
    dented = lambda x, y: 0 <= x < w and 0 <= y < h and H[y][x] < 0.5 - eps
    cells = [(x, y) for y in range(h) for x in range(w) if dented(x, y)]
    if not cells:
        return cells, 0.0, 0, 0.0
    cont = sum(sum(dented(x + a, y + b) for a, b in ((1, 0), (-1, 0), (0, 1), (0, -1))) / 4 for x, y in cells) / len(cells)
    x0, x1 = min(c[0] for c in cells), max(c[0] for c in cells)
    y0, y1 = min(c[1] for c in cells), max(c[1] for c in cells)
    holes = sum(1 for y in range(y0, y1 + 1) for x in range(x0, x1 + 1)
                if not dented(x, y) and ((dented(x - 1, y) and dented(x + 1, y)) or (dented(x, y - 1) and dented(x, y + 1))))
    return cells, cont, holes, min(H[y][x] for x, y in cells)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("map", help="a height map PNG (16-bit grey, 0.5 = flat)")
    ap.add_argument("--compare", help="a second map of the same surface, shown beside the first")
    ap.add_argument("--k", type=float, default=0.1, help="the map's bump depth k in metres (default 0.1)")
    ap.add_argument("--eps", type=float, default=1e-4, help="a texel is dented below 0.5 - eps (default 1e-4)")
    ap.add_argument("--png", help="write the dented region (8-bit grey) here")
    ap.add_argument("--margin", type=int, default=8, help="texels around the dented region in --png (default 8)")
    ap.add_argument("--max-width", type=int, default=900, help="crop --png to at most this many texels wide")
    ap.add_argument("--crop", help="X0,Y0,X1,Y1: show these texels (inclusive) instead of the dented region")
    ap.add_argument("--scale", type=int, default=1, help="magnify --png by this whole factor (default 1)")
    args = ap.parse_args()
    maps = [args.map] + ([args.compare] if args.compare else [])
    loaded, box = [], None
    for path in maps:
        w, h, H = read_png16(path)
        cells, cont, holes, low = measure(w, h, H, args.eps)
        print("%s: %d texels dented, deepest %.4f m, continuity %.3f, holes %.2f%%"
              % (path, len(cells), (0.5 - low) * args.k if cells else 0.0, cont,
                 100.0 * holes / (len(cells) + holes) if cells else 0.0))
        loaded.append((w, h, H))
        if cells:
            b = (min(c[0] for c in cells), min(c[1] for c in cells), max(c[0] for c in cells), max(c[1] for c in cells))
            box = b if box is None else (min(box[0], b[0]), min(box[1], b[1]), max(box[2], b[2]), max(box[3], b[3]))
    if args.png:
        if box is None:
            sys.exit("no dent to show")
        w, h, _ = loaded[0]
        if args.crop:
            try:
                x0, y0, x1, y1 = (int(v) for v in args.crop.split(","))
            except ValueError:
                sys.exit("--crop: expected X0,Y0,X1,Y1, got '%s'" % args.crop)
            if not (0 <= x0 <= x1 < w and 0 <= y0 <= y1 < h):
                sys.exit("--crop: %s is not inside the %dx%d map" % (args.crop, w, h))
        else:
            x0, y0 = max(0, box[0] - args.margin), max(0, box[1] - args.margin)
            x1, y1 = min(w - 1, box[2] + args.margin), min(h - 1, box[3] + args.margin)
            x1 = min(x1, x0 + args.max_width - 1)
        low = min(min(H[y][x] for y in range(y0, y1 + 1) for x in range(x0, x1 + 1)) for _, _, H in loaded)
        rows = [[] for _ in range(y0, y1 + 1)]
        for n, (_, _, H) in enumerate(loaded):
            for j, y in enumerate(range(y0, y1 + 1)):
                if n:
                    rows[j] += [128] * 6
                rows[j] += [255 if H[y][x] >= 0.5 else int(255 * (H[y][x] - low) / (0.5 - low + 1e-9)) for x in range(x0, x1 + 1)]
        if args.scale < 1 or args.scale > 16:
            sys.exit("--scale must be in [1, 16]")
        rows = [[v for v in r for _ in range(args.scale)] for r in rows for _ in range(args.scale)]
        png.write_grey8(args.png, rows)
        print("wrote %s (texels x %d-%d, y %d-%d)" % (args.png, x0, x1, y0, y1))


if __name__ == "__main__":
    main()
