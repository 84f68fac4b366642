#!/usr/bin/env python3
"""Writes the scenes that show joints (wrecking-ball, ragdoll, chain-bridge, car-doors) (tools/scenegen/joints.py; --help says more)."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scenegen import joints  # noqa: E402

if __name__ == "__main__":
    joints.main()
