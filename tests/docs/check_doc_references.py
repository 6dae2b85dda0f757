#!/usr/bin/python3
"""Every reference to the manual from the source tree names a page and a section that exist.

Scanned: the source, build, IDL / proto, script and configuration files of services/, core/,
comm/, config/, deploy/, tools/, idl/, proto/, scripts/, bench/, device/, firmware/, recording/
(comments, --help texts, messages; not tests/, whose fixtures name pages that do not exist),
and the manual itself (docs/**/*.md, README.md and each folder's README.md). Two forms are
checked:

  docs/<page>.md                      the page must exist (under docs/)
  <page>.md "<Heading>"               the page must exist and have that heading
  <page>.md, "<Heading>"              (also with docs/ or docs/measurements/ before the page)

A page named without a folder is looked up under docs/ and docs/measurements/. A section is a
Markdown heading (#, ##, ...) of the page or a paragraph's bold lead ("**Governance** (one per
deployment ...)"); the reference matches it when it is its text (backticks removed) or its
short title, the part before a colon, a parenthesis or a dash ("Cost" names "### Cost:
connections, memory, CPU", "Lockstep" names "### Lockstep (the default)"). A reference may run over two comment lines, and in a C++
string its quotes are escaped (\\"). Prints each broken reference as FILE:LINE: REFERENCE: WHY;
exit status 1 if any.

--self-test runs the checker on a small tree of its own: a good reference passes, a missing page
and a missing heading are reported.
"""
import bisect
import os
import re
import sys
import tempfile

FOLDERS = ["services", "core", "comm", "config", "deploy", "tools", "idl", "proto", "scripts",
           "bench", "device", "firmware", "recording"]
SUFFIXES = (".cpp", ".hpp", ".h", ".c", ".cc", ".py", ".sh", ".txt", ".cmake", ".idl", ".proto",
            ".textproto", ".mjs", ".js", ".xml", ".json", ".service", ".in")
NAMES = ("CMakeLists.txt", "postinst", "prerm", "postrm", "control")
SKIP_DIRS = {"build", "node_modules", ".git", "__pycache__"}
# Files a session writes that share a name with no page of the manual: `report.md "Recording"`
# names a section of a session's report (hexa_recorder report), not of docs/.
NOT_THE_MANUAL = {"report.md"}

# A page: a path ending in .md, not part of a URL or a longer word.
PAGE = r"(?<![\w/.:-])((?:docs/)?(?:[\w.-]+/)*[\w.-]+\.md)"
# `<page>.md "<Heading>"` or `<page>.md, "<Heading>"`: a heading starts with a letter or digit.
WITH_HEADING = re.compile(PAGE + r",? \"([A-Za-z0-9][^\"\n]*)\"")
DOCS_PAGE = re.compile(r"(?<![\w/.-])(docs/(?:[\w.-]+/)*[\w.-]+\.md)")
# An escaped quote; a line break between two string literals of a C++ text; a line break and
# the next line's comment leader (//, #, *, --, ;).
JOIN = re.compile(r'\\"|"\n[ \t]*"|\n[ \t]*(?://+|#+|\*|--|;)?[ \t]*')


def titles(text):
    """A heading's text (backticks removed) and its short title: the part before a colon, a
    parenthesis or a dash."""
    text = text.replace("`", "").strip().rstrip(".:").strip()
    return {text, re.split(r" \(|:| \u2014 ", text, maxsplit=1)[0].strip()}


def headings_of(path):
    """The sections of a page: its Markdown headings and its paragraphs' bold leads
    ("**Re-asks back off.** A leg that ...", "- **Calibration.** f_req ...")."""
    found = set()
    in_fence = False
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.lstrip().startswith("```"):
                in_fence = not in_fence
            if in_fence:
                continue
            m = re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line) or re.match(r"\s*(?:[-*]\s+)?\*\*(.+?)\*\*", line)
            if m:
                found |= titles(m.group(1))
    return found


class Manual:
    def __init__(self, root):
        self.root = root
        self.cache = {}

    def resolve(self, page):
        """The page's path, or None."""
        candidates = [page] if page.startswith("docs/") else [
            os.path.join("docs", page), os.path.join("docs", "measurements", page), page]
        for c in candidates:
            path = os.path.join(self.root, c)
            if os.path.isfile(path):
                return path
        return None

    def headings(self, path):
        if path not in self.cache:
            self.cache[path] = headings_of(path)
        return self.cache[path]


def joined(text):
    """The text with escaped quotes unescaped, two adjacent C++ string literals on two lines made
    one, and every other line break, with the next line's comment leader, made one space; and
    where each line of the text starts in the result (for line_at)."""
    out, starts = [], [0]
    size, k = 0, 0
    for m in JOIN.finditer(text):
        out.append(text[k:m.start()])
        size += m.start() - k
        token = m.group(0)
        if token == '\\"':
            out.append('"')
            size += 1
        else:
            if not token.startswith('"'):
                out.append(" ")
                size += 1
            starts.append(size)
        k = m.end()
    out.append(text[k:])
    return "".join(out), starts


def line_at(starts, offset):
    return bisect.bisect_right(starts, offset)


def check_file(manual, path, rel):
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except (UnicodeDecodeError, OSError):
        return []
    if ".md" not in text:
        return []
    flat, starts = joined(text)
    broken = []
    seen = set()
    for m in WITH_HEADING.finditer(flat):
        page, heading = m.group(1), m.group(2).strip()
        where = line_at(starts, m.start())
        seen.add(m.start(1))
        if page in NOT_THE_MANUAL:
            continue
        resolved = manual.resolve(page)
        if resolved is None:
            broken.append(f"{rel}:{where}: {page} \"{heading}\": no such page")
        elif heading not in manual.headings(resolved):
            broken.append(f"{rel}:{where}: {page} \"{heading}\": no such heading in "
                          f"{os.path.relpath(resolved, manual.root)}")
    for m in DOCS_PAGE.finditer(flat):
        if m.start(1) in seen:
            continue
        if manual.resolve(m.group(1)) is None:
            broken.append(f"{rel}:{line_at(starts, m.start())}: {m.group(1)}: no such page")
    return broken


def source_files(root):
    if os.path.isfile(os.path.join(root, "README.md")):
        yield os.path.join(root, "README.md")
    for dirpath, dirnames, filenames in os.walk(os.path.join(root, "docs")):
        dirnames[:] = sorted(dirnames)
        for name in sorted(filenames):
            if name.endswith(".md"):
                yield os.path.join(dirpath, name)
    for folder in FOLDERS:
        if os.path.isfile(os.path.join(root, folder, "README.md")):
            yield os.path.join(root, folder, "README.md")
        base = os.path.join(root, folder)
        for dirpath, dirnames, filenames in os.walk(base):
            dirnames[:] = sorted(d for d in dirnames if d not in SKIP_DIRS)
            for name in sorted(filenames):
                if name.endswith(SUFFIXES) or name in NAMES:
                    yield os.path.join(dirpath, name)


def check_tree(root):
    manual = Manual(root)
    broken = []
    count = 0
    for path in source_files(root):
        count += 1
        broken += check_file(manual, path, os.path.relpath(path, root))
    return count, broken


def self_test():
    with tempfile.TemporaryDirectory() as root:
        os.makedirs(os.path.join(root, "docs", "measurements"))
        os.makedirs(os.path.join(root, "core"))
        with open(os.path.join(root, "docs", "faults.md"), "w") as f:
            f.write("# Faults\n\n## Hardware lifecycle\n\n### Cost: memory, CPU\n\n## `Lockstep` (the default)\n\n"
                    "**Re-asks back off.** A leg ...\n\n- **Calibration.** The ...\n\n"
                    "```\n## Not a heading\n```\n")
        with open(os.path.join(root, "docs", "measurements", "plant.md"), "w") as f:
            f.write("# Plant\n\n## Speed\n")
        good = ('// docs/faults.md, "Hardware lifecycle"; plant.md "Speed"; docs/faults.md "Cost"\n'
                '// docs/faults.md "Lockstep", docs/faults.md, "Lockstep (the default)"\n'
                '// docs/faults.md, "Re-asks back off"; docs/faults.md "Calibration"\n'
                '// see docs/faults.md\n'
                '// the e-stop (docs/faults.md,\n//   "Hardware lifecycle")\n'
                'cli.Add("x", "as in docs/faults.md, \\"Hardware lifecycle\\"");\n'
                '# README.md "${CMAKE_BINARY_DIR}/x"\n')
        bad = ('// docs/faults.md "Physical limits"\n'
               '// controller.md "Dither"\n'
               '// docs/config.md\n'
               '// docs/faults.md "Not a heading"\n'
               'cli.Add("x", "docs/faults.md, \\"Hardware "\n    "lifecycles\\"");\n')
        with open(os.path.join(root, "core", "good.cpp"), "w") as f:
            f.write(good)
        count, broken = check_tree(root)
        ok = count == 3 and not broken  # the two pages and good.cpp
        print(f"self-test, good references: {len(broken)} reported {broken}")
        with open(os.path.join(root, "core", "bad.cpp"), "w") as f:
            f.write(bad)
        count, broken = check_tree(root)
        want = ['core/bad.cpp:1: docs/faults.md "Physical limits": no such heading in docs/faults.md',
                'core/bad.cpp:2: controller.md "Dither": no such page',
                'core/bad.cpp:4: docs/faults.md "Not a heading": no such heading in docs/faults.md',
                'core/bad.cpp:5: docs/faults.md "Hardware lifecycles": no such heading in docs/faults.md',
                'core/bad.cpp:3: docs/config.md: no such page']
        print("self-test, stale references reported:\n  " + "\n  ".join(broken))
        ok = ok and sorted(broken) == sorted(want)
        print("self-test " + ("passed" if ok else "FAILED: wanted\n  " + "\n  ".join(want)))
        return 0 if ok else 1


def main():
    if "--self-test" in sys.argv[1:]:
        return self_test()
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    root = args[0] if args else os.path.join(os.path.dirname(__file__), "..", "..")
    count, broken = check_tree(root)
    for b in broken:
        print(b)
    print("%d files scanned, %d broken references to the manual" % (count, len(broken)))
    return 1 if broken or count == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
