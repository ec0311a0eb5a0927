#!/usr/bin/env python3
"""Offline link check of README.md and the user guide (docs/src, an mdBook).

Checks, without network or mdbook:
- every relative link and image in README.md and docs/src/**/*.md points to an existing
  file, and, when it has a #fragment, to a heading of that Markdown file whose anchor is
  the fragment (mdBook's and GitHub's slug rule: lower case, spaces to '-', characters
  other than letters, digits, '-' and '_' dropped; repeated headings get -1, -2, ...);
- every page of docs/src is listed in docs/src/SUMMARY.md and linked from README.md.

Prints each broken item and exits 1 when there is one; exits 0 otherwise.
Usage: scripts/check-links.py [ROOT] (default: the repository holding this script).
"""
import pathlib
import re
import sys

LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")


def strip_code(text):
    """The text with fenced code blocks blanked (line numbers kept) and inline code kept
    as text only where it cannot hold a link (links are not looked for inside it)."""
    out, fenced = [], False
    for line in text.split("\n"):
        if re.match(r"^\s*(```|~~~)", line):
            fenced = not fenced
            out.append("")
            continue
        out.append("" if fenced else line)
    return out


def slug(heading):
    """The anchor mdBook (and GitHub) gives a heading's text."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # links: their text
    text = text.replace("`", "").replace("*", "")
    chars = []
    for ch in text:
        if ch.isalnum() or ch in "-_":
            chars.append(ch.lower() if ch.isascii() else ch)
        elif ch.isspace():
            chars.append("-")
    return "".join(chars)


def anchors(path, cache={}):
    """Every heading anchor of a Markdown file (repeats numbered as mdBook does)."""
    if path not in cache:
        seen, result = {}, set()
        for line in strip_code(path.read_text(encoding="utf-8")):
            m = HEADING.match(line)
            if not m:
                continue
            base = slug(m.group(2))
            n = seen.get(base, 0)
            seen[base] = n + 1
            result.add(base if n == 0 else f"{base}-{n}")
        cache[path] = result
    return cache[path]


def links(path):
    """(line number, target) of every inline link and image outside code."""
    for number, line in enumerate(strip_code(path.read_text(encoding="utf-8")), 1):
        line = re.sub(r"`[^`]*`", "", line)
        for m in LINK.finditer(line):
            yield number, m.group(1)


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parent.parent)
    readme = root / "README.md"
    src = root / "docs" / "src"
    summary = src / "SUMMARY.md"
    pages = sorted(src.rglob("*.md"))
    problems = []
    linked = {readme: set(), summary: set()}
    for page in [readme] + pages:
        for number, target in links(page):
            if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
                continue
            where = f"{page.relative_to(root)}:{number}: {target}"
            file_part, _, fragment = target.partition("#")
            dest = (page.parent / file_part).resolve() if file_part else page
            if not dest.exists():
                problems.append(f"{where}: no such file")
                continue
            if page in linked:
                linked[page].add(dest)
            if fragment and dest.suffix == ".md" and fragment not in anchors(dest):
                problems.append(f"{where}: no heading with anchor #{fragment} in {dest.relative_to(root)}")
    for page in pages:
        if page == summary:
            continue
        rel = page.relative_to(root)
        if page.resolve() not in linked[summary]:
            problems.append(f"{rel}: not listed in docs/src/SUMMARY.md")
        if page.resolve() not in linked[readme]:
            problems.append(f"{rel}: not linked from README.md")
    for problem in problems:
        print(problem)
    if problems:
        print(f"check-links: {len(problems)} broken (fix the links or the pages above)", file=sys.stderr)
        return 1
    print(f"check-links: README.md and {len(pages)} guide pages: every link, image and page ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
