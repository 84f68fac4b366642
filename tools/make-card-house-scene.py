#!/usr/bin/env python3
"""Writes scenes/card-house.json, a house of cards that stands on friction alone (tools/scenegen/card_house.py; --help says more)."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scenegen import card_house  # noqa: E402

if __name__ == "__main__":
    card_house.main()
