#!/usr/bin/env python3
"""Replace one section of a Markdown page by a new text of the same section.

Usage: tools/replace_section.py PAGE SECTION_FILE

SECTION_FILE starts with the section's heading (after blank lines), e.g.
"## Model files against the built-in models"; the section of PAGE with that heading, up
to the next heading of the same or a higher level, is replaced by SECTION_FILE's text.
When PAGE has no such section, the text is appended. `make bench-models` uses it for
docs/performance.md, whose other sections come from `make bench`.
"""
import pathlib
import sys


def level(line):
    stripped = line.lstrip("#")
    return len(line) - len(stripped) if line.startswith("#") and stripped.startswith(" ") else 0


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    page = pathlib.Path(sys.argv[1])
    section = pathlib.Path(sys.argv[2]).read_text().strip("\n").split("\n")
    heading = section[0]
    depth = level(heading)
    if depth == 0:
        sys.exit(f"{sys.argv[2]}: the first line is not a heading: {heading!r}")
    lines = page.read_text().rstrip("\n").split("\n")
    fenced = False
    start = end = None
    for i, line in enumerate(lines):
        if line.startswith("```"):
            fenced = not fenced
        if fenced:
            continue
        if start is None and line == heading:
            start = i
        elif start is not None and 0 < level(line) <= depth:
            end = i
            break
    if start is None:
        lines = lines + [""] + section
    else:
        end = len(lines) if end is None else end
        lines = lines[:start] + section + [""] + lines[end:]
    page.write_text("\n".join(lines).rstrip("\n") + "\n")


if __name__ == "__main__":
    main()
