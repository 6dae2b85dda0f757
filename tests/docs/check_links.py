#!/usr/bin/python3
"""Every relative link of the manual resolves: docs/**/*.md, README.md and each top-level
folder's README.md; a link [text](path) or [text](path#anchor) whose path is not a URL must
name a file or folder that exists (code blocks, fenced or indented by four spaces, are not
text and are skipped). Prints each broken link as FILE:LINE: TARGET; exit status 1 if any."""
import glob
import os
import re
import sys

LINK = re.compile(r"\]\(([^)\s]+)\)")


def broken_links(root):
    files = sorted(glob.glob(os.path.join(root, "docs", "**", "*.md"), recursive=True))
    files += [os.path.join(root, "README.md")] + sorted(glob.glob(os.path.join(root, "*", "README.md")))
    broken = []
    for path in files:
        in_fence = False
        with open(path, encoding="utf-8") as f:
            for number, line in enumerate(f, 1):
                if line.lstrip().startswith("```"):
                    in_fence = not in_fence
                    continue
                if in_fence or line.startswith("    ") or line.startswith("\t"):
                    continue
                for match in LINK.finditer(line):
                    target = match.group(1)
                    if re.match(r"[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
                        continue
                    resolved = os.path.normpath(os.path.join(os.path.dirname(path), target.split("#")[0]))
                    if not os.path.exists(resolved):
                        broken.append("%s:%d: %s" % (os.path.relpath(path, root), number, target))
    return files, broken


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "..")
    files, broken = broken_links(root)
    for b in broken:
        print(b)
    print("%d pages, %d broken links" % (len(files), len(broken)))
    return 1 if broken or not files else 0


if __name__ == "__main__":
    sys.exit(main())
