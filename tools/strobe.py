#!/usr/bin/env python3
"""Strobe picture of frames from one fixed camera: what moves is drawn at each frame's place over the still
background (each pixel's median over the frames). strobe.py OUT FRAME... (8-bit RGB or RGBA PNGs, one size;
later frames drawn over earlier ones)."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scenegen import png  # noqa: E402

THRESHOLD = 30  # summed |r g b| difference from the background that counts as moving


def main():
    out_path, frames = png.pictures_from_command_line(__doc__, 2)
    w, h = frames[0][0], frames[0][1]
    if any(f[0] != w or f[1] != h for f in frames):
        sys.exit("the frames differ in size")
    middle = len(frames) // 2
    out = []
    for y in range(h):
        rows = [f[2][y] for f in frames]
        row = bytearray(w * 3)
        for x in range(w):
            pixels = [r[3 * x:3 * x + 3] for r in rows]
            background = sorted(pixels, key=sum)[middle]
            pick = background
            for p in pixels:
                if sum(abs(a - b) for a, b in zip(p, background)) > THRESHOLD:
                    pick = p
            row[3 * x:3 * x + 3] = pick
        out.append(bytes(row))
    png.write_rgb(out_path, w, h, out)


main()
