#!/usr/bin/env python3
"""Puts PNG pictures (8-bit RGB, RGBA or grey, same height) side by side into one RGB PNG: side-by-side.py OUT IN..."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scenegen import png  # noqa: E402


def main():
    out_path, pictures = png.pictures_from_command_line(__doc__, 1)
    height = pictures[0][1]
    if any(p[1] != height for p in pictures):
        sys.exit("the pictures differ in height")
    rows = [b"".join(p[2][y] for p in pictures) for y in range(height)]
    png.write_rgb(out_path, sum(p[0] for p in pictures), height, rows)


main()
