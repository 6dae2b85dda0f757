#!/usr/bin/python3
"""The repository's shape: the largest source files and the longest functions of the product
folders (services/, deploy/, comm/ by default), and the longest guide and reference pages of
docs/ (dated measurements in docs/measurements/ are not counted).

    scripts/shape_report.py                 # report (exit 0)
    scripts/shape_report.py --check         # also exit 1 when a limit is exceeded
    scripts/shape_report.py --folders config bench --top 5

Limits (docs/style.md, "Shape (checked)"): a source file at most 600 lines, a function at most 120, a
guide or reference page at most 400. A function is counted from its first header line to its
closing brace (C and C++, by brace matching after comments, strings and preprocessor lines are
removed) or to its last indented line (Python `def`). Lambdas and local classes count as part
of the function that holds them. Pure standard library: runs with /usr/bin/python3 anywhere.
"""
import argparse
import os
import re
import subprocess
import sys

CPP_SUFFIXES = (".cpp", ".cc", ".cxx", ".c", ".hpp", ".hh", ".h")
SOURCE_SUFFIXES = CPP_SUFFIXES + (".py", ".sh")
DEFAULT_FOLDERS = ("services", "deploy", "comm")


def list_files(root, folders):
    """Tracked and untracked-but-not-ignored files below `folders` (git), else a walk."""
    try:
        out = subprocess.run(
            ["git", "-C", root, "ls-files", "--cached", "--others", "--exclude-standard", "--", *folders],
            check=True, capture_output=True, text=True).stdout
        files = [f for f in out.splitlines() if os.path.isfile(os.path.join(root, f))]
    except (OSError, subprocess.CalledProcessError):
        files = []
        for folder in folders:
            for dirpath, _, names in os.walk(os.path.join(root, folder)):
                files += [os.path.relpath(os.path.join(dirpath, n), root) for n in names]
    return sorted(set(files))


def count_lines(text):
    return text.count("\n") + (0 if text.endswith("\n") or not text else 1)


# --- C and C++ -------------------------------------------------------------------------------

def blank_cpp(text):
    """`text` with comments, string and character literals and preprocessor lines replaced by
    spaces (newlines kept, so that offsets map to the same lines)."""
    out = list(text)
    i, n = 0, len(text)

    def blank(a, b):
        for k in range(a, b):
            if out[k] != "\n":
                out[k] = " "

    at_line_start = True
    while i < n:
        c = text[i]
        if at_line_start and c in " \t":
            i += 1
            continue
        if at_line_start and c == "#":  # preprocessor line, with its continuations
            j = i
            while j < n and not (text[j] == "\n" and text[j - 1] != "\\"):
                j += 1
            blank(i, j)
            i = j
            continue
        at_line_start = c == "\n"
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            blank(i, j)
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            blank(i, j)
            i = j
        elif c == "R" and i + 1 < n and text[i + 1] == '"' and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^(\s]{0,16})\(', text[i:])
            if not m:
                i += 1
                continue
            end = text.find(")" + m.group(1) + '"', i + m.end())
            end = n if end < 0 else end + len(m.group(1)) + 2
            blank(i, end)
            i = end
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum() and i + 1 < n and text[i + 1].isalnum():
                i += 1  # digit separator: 1'000'000
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            blank(i, min(j + 1, n))
            i = j + 1
        else:
            i += 1
    return "".join(out)


_SCOPE_KEYWORDS = re.compile(r"^(?:template\s*<.*>\s*)?(?:namespace|class|struct|union|extern\s*$|extern\b)", re.S)
_ENUM = re.compile(r"^(?:typedef\s+)?enum\b")
_ACCESS = re.compile(r"^(?:\s*(?:public|private|protected)\s*:)+")


def _top_level_assignment(head):
    """True when `head` has an `=` outside parentheses and template brackets (an initialiser,
    not a function), ignoring `operator=` and comparison operators."""
    if re.search(r"\boperator\b", head):
        return False
    depth = 0
    for k, c in enumerate(head):
        if c in "([<":
            depth += 1
        elif c in ")]>" and depth > 0:
            depth -= 1
        elif c == "=" and depth == 0:
            before = head[k - 1] if k > 0 else ""
            after = head[k + 1] if k + 1 < len(head) else ""
            if before not in "=!<>" and after != "=":
                return True
    return False


def _init_list_brace(head):
    """True when the `{` after `head` opens a member's brace initialiser in a constructor's
    initialiser list (`Foo::Foo(int a) : a_{a}`), not the constructor's body."""
    stripped = head.rstrip()
    if not stripped or not (stripped[-1].isalnum() or stripped[-1] in "_>"):
        return False
    depth = 0
    for k, c in enumerate(head):
        if c == "(":
            depth += 1
        elif c == ")":
            depth -= 1
            if depth == 0 and re.match(r"\s*(?:noexcept\s*)?:(?!:)", head[k + 1:]):
                return True
    return False


def _match_brace(code, i):
    depth = 0
    for k in range(i, len(code)):
        if code[k] == "{":
            depth += 1
        elif code[k] == "}":
            depth -= 1
            if depth == 0:
                return k
    return len(code) - 1


def cpp_functions(text):
    """[(name, first_line, line_count)] of the functions defined in C or C++ `text`."""
    code = blank_cpp(text)
    line_of = [0] * (len(code) + 1)
    line = 1
    for k, c in enumerate(code):
        line_of[k] = line
        if c == "\n":
            line += 1
    line_of[len(code)] = line
    found = []

    def scan(start, end):
        head_start = start
        i = start
        while i < end:
            c = code[i]
            if c in ";}":
                head_start = i + 1
            elif c == "{":
                head = code[head_start:i]
                text_head = _ACCESS.sub("", head).strip()
                close = _match_brace(code, i)
                if _init_list_brace(head):
                    i = close + 1
                    continue
                if _SCOPE_KEYWORDS.match(text_head) and not re.match(r"^(?:template\s*<.*>\s*)?\w[\w\s:<>,*&]*\(", text_head):
                    scan(i + 1, close)  # namespace, class, struct, extern "C": look inside
                elif "(" in text_head and not _ENUM.match(text_head) and not _top_level_assignment(text_head):
                    first = head_start + (len(head) - len(_ACCESS.sub("", head).lstrip()))
                    name = re.findall(r"([~\w:]+(?:operator\s*\S+?)?)\s*\(", text_head)
                    found.append((name[0] if name else "?", line_of[first], line_of[close] - line_of[first] + 1))
                head_start = close + 1
                i = close + 1
                continue
            i += 1

    scan(0, len(code))
    return found


# --- Python ----------------------------------------------------------------------------------

def python_functions(text):
    lines = text.split("\n")
    found = []
    for k, line in enumerate(lines):
        m = re.match(r"^(\s*)(?:async\s+)?def\s+(\w+)", line)
        if not m:
            continue
        indent = len(m.group(1))
        last = k
        for j in range(k + 1, len(lines)):
            s = lines[j]
            if not s.strip():
                continue
            if len(s) - len(s.lstrip()) <= indent and not s.lstrip().startswith(("#", ")", "]", "}")):
                break
            last = j
        found.append((m.group(2), k + 1, last - k + 1))
    return found


def functions_of(path, text):
    if path.endswith(CPP_SUFFIXES):
        return cpp_functions(text)
    if path.endswith(".py"):
        return python_functions(text)
    return []


def doc_pages(root):
    pages = []
    docs = os.path.join(root, "docs")
    for dirpath, dirnames, names in os.walk(docs):
        dirnames[:] = [d for d in dirnames if d != "measurements"]
        pages += [os.path.relpath(os.path.join(dirpath, n), root) for n in names if n.endswith(".md")]
    return sorted(pages)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--root", default=os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                    help="the repository (default: this script's)")
    ap.add_argument("--folders", nargs="+", default=list(DEFAULT_FOLDERS),
                    help="source folders to measure (default: %(default)s)")
    ap.add_argument("--max-file-lines", type=int, default=600)
    ap.add_argument("--max-function-lines", type=int, default=120)
    ap.add_argument("--max-page-lines", type=int, default=400,
                    help="docs/ guide and reference pages (docs/measurements/ not counted)")
    ap.add_argument("--no-docs", action="store_true", help="do not measure docs/")
    ap.add_argument("--top", type=int, default=8, help="rows per table")
    ap.add_argument("--check", action="store_true", help="exit 1 when a limit is exceeded")
    args = ap.parse_args(argv)

    files, functions = [], []
    for rel in list_files(args.root, args.folders):
        if not rel.endswith(SOURCE_SUFFIXES):
            continue
        with open(os.path.join(args.root, rel), encoding="utf-8", errors="replace") as f:
            text = f.read()
        files.append((count_lines(text), rel))
        functions += [(n, rel, first, name) for name, first, n in functions_of(rel, text)]
    pages = []
    if not args.no_docs:
        for rel in doc_pages(args.root):
            with open(os.path.join(args.root, rel), encoding="utf-8", errors="replace") as f:
                pages.append((count_lines(f.read()), rel))
    files.sort(reverse=True)
    functions.sort(reverse=True)
    pages.sort(reverse=True)

    where = ", ".join(f + "/" for f in args.folders)
    print(f"{len(files)} source files and {len(functions)} functions in {where}")
    print(f"\nlargest files (limit {args.max_file_lines} lines):")
    for n, rel in files[:args.top]:
        print(f"  {n:6d}  {rel}")
    print(f"\nlongest functions (limit {args.max_function_lines} lines):")
    for n, rel, first, name in functions[:args.top]:
        print(f"  {n:6d}  {rel}:{first}  {name}")
    if pages:
        print(f"\nlongest docs/ pages, measurements/ not counted (limit {args.max_page_lines} lines):")
        for n, rel in pages[:args.top]:
            print(f"  {n:6d}  {rel}")

    over = [f"file {rel}: {n} lines (limit {args.max_file_lines})"
            for n, rel in files if n > args.max_file_lines]
    over += [f"function {name} at {rel}:{first}: {n} lines (limit {args.max_function_lines})"
             for n, rel, first, name in functions if n > args.max_function_lines]
    over += [f"page {rel}: {n} lines (limit {args.max_page_lines})"
             for n, rel in pages if n > args.max_page_lines]
    print()
    for o in over:
        print("over the limit: " + o)
    print(f"{len(over)} over the limits")
    return 1 if args.check and over else 0


if __name__ == "__main__":
    sys.exit(main())
