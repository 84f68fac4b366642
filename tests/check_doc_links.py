#!/usr/bin/env python3
"""Checks the relative links and images of crumple's Markdown documentation.

Usage: tests/check_doc_links.py [REPO_ROOT] [FILE.md ...]

Walks README.md, CHANGELOG.md, docs/**/*.md and apps/examples/README.md (or the files given), finds every link
and image whose target is a path in the repository ([text](docs/foo.md#anchor), ![alt](images/x.png),
[text](#anchor), reference definitions [ref]: target) outside code, and fails when one does not resolve:

- the file or folder does not exist, or lies outside the repository (../shared is not shipped);
- the anchor names no heading of the Markdown file it points into, by GitHub's rules: the heading's text
  lower-cased, without the characters that are not letters, digits, spaces, '-' or '_', spaces made '-',
  and "-1", "-2", ... appended to repeats.

Links to web addresses (http:, https:, mailto:, //...) are not followed. Exit status 0 when every link
resolves, 1 otherwise (each broken link printed as FILE:LINE: TARGET: why), 2 for bad usage.
Python 3 only, no other packages; ctest runs it as the test `doc_links`.
"""
import os
import re
import sys
import unicodedata
import urllib.parse

DEFAULT_FILES = ["README.md", "CHANGELOG.md", "apps/examples/README.md"]
FENCE = re.compile(r"^ {0,3}(`{3,}|~{3,})")
ATX = re.compile(r"^ {0,3}(#{1,6})(?:[ \t]+(.*?))?(?:[ \t]+#+)?[ \t]*$")
SETEXT = re.compile(r"^ {0,3}(=+|-+)[ \t]*$")
REFERENCE = re.compile(r"^ {0,3}\[([^\]]+)\]:[ \t]*(\S+)")
HTML_ANCHOR = re.compile(r"<a\s[^>]*(?:name|id)\s*=\s*[\"']([^\"']+)[\"']", re.IGNORECASE)
SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*:")


def doc_files(root):
    files = [f for f in DEFAULT_FILES if os.path.isfile(os.path.join(root, f))]
    docs = os.path.join(root, "docs")
    for folder, dirs, names in os.walk(docs):
        dirs.sort()
        for name in sorted(names):
            if name.endswith(".md"):
                files.append(os.path.relpath(os.path.join(folder, name), root))
    return files


def prose_lines(text):
    """Yields (line number, line) for the lines outside fenced code blocks."""
    fence = None
    for number, line in enumerate(text.split("\n"), 1):
        m = FENCE.match(line)
        if fence:
            if m and m.group(1)[0] == fence[0] and len(m.group(1)) >= len(fence) and not line.strip()[len(m.group(1)):]:
                fence = None
            continue
        if m:
            fence = m.group(1)
            continue
        yield number, line


def without_code_spans(line):
    """The line with its code spans (`...`, ``...``) blanked out."""
    out, i = [], 0
    while i < len(line):
        if line[i] == "`":
            j = i
            while j < len(line) and line[j] == "`":
                j += 1
            ticks = line[i:j]
            end = line.find(ticks, j)
            while end != -1 and end + len(ticks) < len(line) and line[end + len(ticks)] == "`":
                end = line.find(ticks, end + len(ticks) + 1)
            if end == -1:
                out.append(ticks)
                i = j
                continue
            out.append(" " * (end + len(ticks) - i))
            i = end + len(ticks)
        else:
            out.append(line[i])
            i += 1
    return "".join(out)


def heading_text(raw):
    """A heading's text as GitHub renders it: code spans kept as their content, links as their text,
    emphasis markers and HTML tags dropped."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", raw)  # links and images: their text
    text = re.sub(r"<[^>]+>", "", text)  # HTML tags
    text = text.replace("`", "")
    text = re.sub(r"(\*+|(?<!\w)_+|_+(?!\w))", "", text)  # emphasis (not the underscores inside words)
    return text.strip()


def slug(text):
    """GitHub's anchor for a heading's rendered text."""
    text = text.lower()
    kept = []
    for ch in text:
        cat = unicodedata.category(ch)
        if ch in "-_" or ch == " " or cat[0] in "LN" or cat == "Mn":
            kept.append(ch)
    return "".join(kept).replace(" ", "-")


def anchors_of(path, cache):
    if path in cache:
        return cache[path]
    with open(path, encoding="utf-8") as f:
        text = f.read()
    anchors, seen = set(), {}
    previous = None
    for _, line in prose_lines(text):
        for m in HTML_ANCHOR.finditer(line):
            anchors.add(m.group(1))
        title = None
        m = ATX.match(line)
        if m:
            title = m.group(2) or ""
        elif previous is not None and previous.strip() and SETEXT.match(line) and not ATX.match(previous):
            # A setext heading: the text line above underlined by === or --- (not a table's --- | --- row).
            if "|" not in line and not previous.lstrip().startswith(("-", "*", "|", ">")):
                title = previous.strip()
        previous = line
        if title is None:
            continue
        base = slug(heading_text(title))
        n = seen.get(base, 0)
        seen[base] = n + 1
        anchors.add(base if n == 0 else f"{base}-{n}")
    cache[path] = anchors
    return anchors


def link_targets(line):
    """The targets of the inline links and images of one line (code spans already blanked)."""
    i = 0
    while True:
        i = line.find("](", i)
        if i == -1:
            return
        j, depth = i + 2, 1
        while j < len(line) and line[j] in " \t":
            j += 1
        if j < len(line) and line[j] == "<":  # <target with spaces>
            end = line.find(">", j)
            if end != -1:
                yield line[j + 1:end]
            i = j
            continue
        start = j
        while j < len(line):
            if line[j] == "(":
                depth += 1
            elif line[j] == ")":
                depth -= 1
                if depth == 0:
                    break
            elif line[j] in " \t":  # a title follows
                break
            j += 1
        if j > start:
            yield line[start:j]
        i = j


def check_target(root, source, target, cache):
    """None when `target` (a link in file `source`) resolves, else why not."""
    if SCHEME.match(target) or target.startswith("//"):
        return None
    path_part, _, anchor = target.partition("#")
    path_part = urllib.parse.unquote(path_part.split("?", 1)[0])
    anchor = urllib.parse.unquote(anchor)
    if path_part:
        resolved = os.path.normpath(os.path.join(root, os.path.dirname(source), path_part))
    else:
        resolved = os.path.join(root, source)
    if os.path.relpath(resolved, root).startswith(".."):
        return "outside the repository"
    if not os.path.exists(resolved):
        return "no such file or folder"
    # The exact spelling (a case-insensitive file system would accept another).
    rel = os.path.relpath(resolved, root)
    here = root
    for part in rel.split(os.sep):
        if part in (".", ""):
            continue
        if part not in os.listdir(here):
            return f"no such file or folder (case: {part})"
        here = os.path.join(here, part)
    if anchor and resolved.endswith(".md") and os.path.isfile(resolved):
        if anchor not in anchors_of(resolved, cache):
            return f"no heading with the anchor #{anchor} in {os.path.relpath(resolved, root)}"
    return None


def check(root, files):
    cache, broken, links = {}, [], 0
    for source in files:
        with open(os.path.join(root, source), encoding="utf-8") as f:
            text = f.read()
        for number, line in prose_lines(text):
            targets = []
            m = REFERENCE.match(line)
            if m:
                targets.append(m.group(2).strip("<>"))
            targets.extend(link_targets(without_code_spans(line)))
            for target in targets:
                if SCHEME.match(target) or target.startswith("//"):
                    continue
                links += 1
                why = check_target(root, source, target, cache)
                if why:
                    broken.append(f"{source}:{number}: {target}: {why}")
    return links, broken


def main(argv):
    if any(a in ("-h", "--help") for a in argv[1:]):
        print(__doc__.strip())
        return 0
    root = os.path.abspath(argv[1]) if len(argv) > 1 else os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    if not os.path.isdir(root):
        print(f"check_doc_links: {root}: not a folder", file=sys.stderr)
        return 2
    files = argv[2:] or doc_files(root)
    for f in files:
        if not os.path.isfile(os.path.join(root, f)):
            print(f"check_doc_links: {f}: no such file under {root}", file=sys.stderr)
            return 2
    links, broken = check(root, files)
    for b in broken:
        print(b)
    print(f"check_doc_links: {len(files)} files, {links} relative links and images checked, {len(broken)} broken")
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
