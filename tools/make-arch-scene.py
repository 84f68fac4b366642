#!/usr/bin/env python3
"""Writes scenes/arch.json and its voussoir mesh, a masonry arch that stands (tools/scenegen/arch.py; --help says more)."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scenegen import arch  # noqa: E402

if __name__ == "__main__":
    arch.main()
