"""docs/python.md's notebook runs as written, on the quick range set, and prints what it shows."""
import contextlib
import io
import json
import os
import re
import tempfile
import unittest

from svms_test_data import need

DOC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "docs", "python.md")


def notebook():
    """The python blocks of the doc's notebook section, each with the output block after it."""
    text = open(DOC).read()
    section = text.split("## A notebook", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```(python)?\n(.*?)```", section, re.S)
    cells = []
    for kind, body in blocks:
        if kind == "python":
            cells.append([body, None])
        elif cells and cells[-1][1] is None:
            cells[-1][1] = body
    return cells


class DocsTest(unittest.TestCase):
    def test_notebook_runs(self):
        data = os.path.join(need("SVMS_TEST_DATA"), "range")
        cells = notebook()
        self.assertGreaterEqual(len(cells), 3)
        os.environ.setdefault("MPLBACKEND", "Agg")
        namespace = {}
        cwd = os.getcwd()
        with tempfile.TemporaryDirectory() as d:
            os.chdir(d)
            try:
                for code, shown in cells:
                    out = io.StringIO()
                    with contextlib.redirect_stdout(out):
                        exec(compile(code.replace("out/demo/range", data), DOC, "exec"), namespace)
                    if shown:
                        self.check_output(out.getvalue(), shown)
                self.assertTrue(os.path.getsize("detections.png") > 0)
                if namespace.get("plt"):
                    self.assertTrue(os.path.getsize("range_error.png") > 0)
            finally:
                os.chdir(cwd)

    def check_output(self, printed, shown):
        """Each line the doc shows (but '...') is printed, its numbers within 0.01 of them."""
        printed = printed.splitlines()
        number = re.compile(r"[-+]?\d+\.?\d*(?:e[-+]?\d+)?")
        for line in shown.splitlines():
            if line.strip() == "...":
                continue
            matches = [p for p in printed if number.sub("#", p) == number.sub("#", line)]
            self.assertTrue(matches, f"the doc shows {line!r}; printed:\n" + "\n".join(printed))
            want = [float(x) for x in number.findall(line)]
            best = min(max((abs(float(a) - b) for a, b in zip(number.findall(p), want)), default=0)
                       for p in matches)
            self.assertLess(best, 0.011, f"the doc shows {line!r}; printed:\n" + "\n".join(printed))


if __name__ == "__main__":
    unittest.main()
