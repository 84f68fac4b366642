#!/usr/bin/env python3
"""Writes scenes/assets/crate.gltf, a wooden crate as a self-contained glTF 2.0 file (tools/scenegen/crate.py; --help says more)."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scenegen import crate  # noqa: E402

if __name__ == "__main__":
    crate.main()
