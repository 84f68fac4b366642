#!/usr/bin/env python3
"""Writes scenes/highway.json, the flagship crash (tools/scenegen/highway.py; --help says more)."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scenegen import highway  # noqa: E402

if __name__ == "__main__":
    highway.main()
