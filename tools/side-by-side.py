#!/usr/bin/env python3
"""Puts PNG pictures (8-bit RGB or RGBA, same height) side by side into one RGB PNG: side-by-side.py OUT IN..."""
import os
import struct
import sys
import zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import png_decode  # noqa: E402


def read_png(path):
    w, h, depth, colour, raw = png_decode.decode(path)
    if depth != 8 or colour not in (2, 6):
        sys.exit(path + ": only 8-bit RGB or RGBA")
    bpp = 3 if colour == 2 else 4
    rows = [b"".join(bytes(line[i:i + 3]) for i in range(0, w * bpp, bpp)) for line in raw]
    return w, h, rows


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    pictures = [read_png(p) for p in sys.argv[2:]]
    height = pictures[0][1]
    if any(p[1] != height for p in pictures):
        sys.exit("the pictures differ in height")
    raw = b"".join(b"\x00" + b"".join(p[2][y] for p in pictures) for y in range(height))
    width = sum(p[0] for p in pictures)

    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

    with open(sys.argv[1], "wb") as out:
        out.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)) +
                  chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


main()
