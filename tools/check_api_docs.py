#!/usr/bin/env python3
"""Check that the façade module `holosym` documents its whole public API: every name it
re-exports (the local names of its `use ..., only:` lists) must appear in its leading
doc comment, as `name`, [[name]] or [[module:name]]. Run by `make docs`."""
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
candidates = [p for p in (ROOT / "src").rglob("holosym.f90")]
if len(candidates) != 1:
    sys.exit(f"check_api_docs: expected one src/**/holosym.f90, found {candidates}")
text = candidates[0].read_text()
lines = text.split("\n")
doc = "\n".join(l for l in lines[:next(i for i, l in enumerate(lines)
                                        if not l.startswith("!"))])
# Join continuation lines, then read the only-lists.
code = re.sub(r"&\s*\n\s*", " ", text)
exported = []
for match in re.finditer(r"^\s*use\s+\w+\s*,\s*only\s*:\s*(.*)$", code, flags=re.M | re.I):
    for item in match.group(1).split(","):
        item = item.split("!")[0].strip()
        if item:
            exported.append(item.split("=>")[0].strip())
missing = [name for name in exported
           if not re.search(r"(`|\[\[|:)" + re.escape(name) + r"(`|\]\])", doc, flags=re.I)]
if missing:
    print(f"check_api_docs: {candidates[0].relative_to(ROOT)} re-exports names its doc "
          f"comment does not list: {', '.join(missing)}")
    sys.exit(1)
print(f"check_api_docs: all {len(exported)} re-exported names are documented")
