#!/usr/bin/python3
"""scripts/shape_report.py on small synthetic trees: what it counts as a function, and that
--check fails on a file, a function or a page over its limit (and passes at the limit)."""
import os
import subprocess
import sys
import tempfile
import unittest

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts", "shape_report.py")
sys.path.insert(0, os.path.dirname(SCRIPT))
import shape_report  # noqa: E402


def body(n):
    """A function body of n lines in all: header, n - 2 statements, closing brace."""
    return "void F() {\n" + "  x();\n" * (n - 2) + "}\n"


class CppFunctions(unittest.TestCase):
    def test_free_functions_methods_and_namespaces(self):
        text = ("namespace a {\nnamespace {\nint G(int v) {\n  return v;\n}\n}  // namespace\n"
                "class C {\n public:\n  int M() const {\n    return 1;\n  }\n};\n"
                "void C::N() {\n  if (x) {\n    y();\n  }\n}\n}  // namespace a\n")
        self.assertEqual(shape_report.cpp_functions(text),
                         [("G", 3, 3), ("M", 9, 3), ("C::N", 13, 5)])

    def test_braces_in_comments_strings_and_preprocessor_are_not_code(self):
        text = ('// a comment { with a brace\n#define X {\nvoid F() {\n  s = "}";\n  c = \'{\';\n'
                '  r = R"x(})x";\n  /* } */\n  n = 1\'000;\n}\n')
        self.assertEqual(shape_report.cpp_functions(text), [("F", 3, 7)])

    def test_initialisers_and_types_are_not_functions(self):
        text = ("const std::vector<int> kList = {1, 2};\nstruct S {\n  int a{0};\n};\n"
                "enum class E : int { kA, kB };\nint v{3};\nvoid F(int d = 2) {\n}\n")
        self.assertEqual(shape_report.cpp_functions(text), [("F", 7, 2)])

    def test_constructor_with_brace_initialisers_counts_from_its_header(self):
        text = "Foo::Foo(int a)\n    : a_{a},\n      b_(2) {\n  Start();\n}\n"
        self.assertEqual(shape_report.cpp_functions(text), [("Foo::Foo", 1, 5)])


class PythonFunctions(unittest.TestCase):
    def test_def_until_its_last_indented_line(self):
        text = "def f(a):\n    x = 1\n\n    return x\n\n\ndef g():\n    pass\n"
        self.assertEqual(shape_report.python_functions(text), [("f", 1, 4), ("g", 7, 2)])


class Check(unittest.TestCase):
    def run_check(self, files):
        with tempfile.TemporaryDirectory() as root:
            for rel, text in files.items():
                path = os.path.join(root, rel)
                os.makedirs(os.path.dirname(path), exist_ok=True)
                with open(path, "w") as f:
                    f.write(text)
            r = subprocess.run([sys.executable, SCRIPT, "--root", root, "--check"],
                               capture_output=True, text=True)
            return r.returncode, r.stdout

    def test_at_the_limits_passes(self):
        rc, out = self.run_check({"services/a.cpp": body(120) + "\n" * 478,
                                  "docs/guide.md": "x\n" * 400,
                                  "docs/measurements/log.md": "x\n" * 900})
        self.assertEqual(rc, 0, out)
        self.assertIn("0 over the limits", out)

    def test_a_long_file_fails(self):
        rc, out = self.run_check({"deploy/a.cpp": "int x;\n" * 601})
        self.assertEqual(rc, 1, out)
        self.assertIn("file deploy/a.cpp: 601 lines", out)

    def test_a_long_function_fails(self):
        rc, out = self.run_check({"comm/a.cpp": body(121)})
        self.assertEqual(rc, 1, out)
        self.assertIn("function F at comm/a.cpp:1: 121 lines", out)

    def test_a_long_python_function_fails(self):
        rc, out = self.run_check({"deploy/a.py": "def f():\n" + "    x = 1\n" * 120})
        self.assertEqual(rc, 1, out)
        self.assertIn("function f at deploy/a.py:1: 121 lines", out)

    def test_a_long_guide_page_fails(self):
        rc, out = self.run_check({"docs/guide.md": "x\n" * 401})
        self.assertEqual(rc, 1, out)
        self.assertIn("page docs/guide.md: 401 lines", out)


if __name__ == "__main__":
    unittest.main()
