#!/usr/bin/env python3
"""The version is said in one place, project(VERSION) in CMakeLists.txt; this checks that what repeats it agrees:
the newest released heading of CHANGELOG.md is that version (or older, with an [Unreleased] section above it), and
every `find_package(crumple X.Y` in the README, docs/ and apps/examples names its major.minor.

Usage: check_version.py REPOSITORY_ROOT  (exit 1 and one line per disagreement)."""
import pathlib
import re
import sys


def main() -> int:
    if len(sys.argv) != 2 or sys.argv[1] in ("-h", "--help"):
        print(__doc__)
        return 0 if len(sys.argv) == 2 else 2
    root = pathlib.Path(sys.argv[1])
    cmake = (root / "CMakeLists.txt").read_text(encoding="utf-8")
    m = re.search(r"project\(crumple VERSION (\d+)\.(\d+)\.(\d+)", cmake)
    if not m:
        print("CMakeLists.txt: no project(crumple VERSION x.y.z)")
        return 1
    version = tuple(int(x) for x in m.groups())
    problems = []
    changelog = (root / "CHANGELOG.md").read_text(encoding="utf-8")
    released = re.findall(r"^## \[(\d+)\.(\d+)\.(\d+)\]", changelog, flags=re.M)
    if not released:
        problems.append("CHANGELOG.md: no released version heading (## [x.y.z] - date)")
    else:
        newest = tuple(int(x) for x in released[0])
        if newest > version:
            problems.append(f"CHANGELOG.md: newest release {'.'.join(map(str, newest))} is after the project's "
                            f"{'.'.join(map(str, version))}")
        if newest < version and "## [Unreleased]" not in changelog:
            problems.append(f"CHANGELOG.md: no heading for {'.'.join(map(str, version))}")
    files = [root / "README.md", *sorted((root / "docs").glob("*.md")), *sorted((root / "apps/examples").glob("*")),
             *sorted((root / "cmake").glob("*"))]
    for f in files:
        if not f.is_file():
            continue
        for n, line in enumerate(f.read_text(encoding="utf-8").splitlines(), 1):
            for major, minor in re.findall(r"find_package\(crumple (\d+)\.(\d+)", line):
                if (int(major), int(minor)) != version[:2]:
                    problems.append(f"{f.relative_to(root)}:{n}: find_package(crumple {major}.{minor}) but the "
                                    f"version is {version[0]}.{version[1]}")
    for p in problems:
        print(p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
