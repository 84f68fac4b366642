#!/usr/bin/env python3
"""Puts PNG pictures (8-bit RGB, RGBA or grey, same height) side by side into one RGB PNG: side-by-side.py OUT IN..."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scenegen import png  # noqa: E402


def main():
    if len(sys.argv) > 1 and sys.argv[1] in ("-h", "--help"):
        print(__doc__)
        return
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    pictures = [png.read_rgb(p) for p in sys.argv[2:]]
    height = pictures[0][1]
    if any(p[1] != height for p in pictures):
        sys.exit("the pictures differ in height")
    rows = [b"".join(p[2][y] for p in pictures) for y in range(height)]
    png.write_rgb(sys.argv[1], sum(p[0] for p in pictures), height, rows)


main()
