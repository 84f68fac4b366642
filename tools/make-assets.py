#!/usr/bin/env python3
"""Writes the procedural meshes and bump maps of scenes/assets/ (tools/scenegen/assets.py; --help says more)."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scenegen import assets  # noqa: E402

if __name__ == "__main__":
    assets.main()
