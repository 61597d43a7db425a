"""demos/python/scene_batch.py runs and its blocks fall as it says: each block's fall equals
symplectic Euler's sum over the substeps the batch reported (to 1e-4, float positions) and
lies within 1 % of v0 t + g t^2 / 2 (the substeps' first-order error, g h t / 2 over the
fall: 0.3 % here); the faster the throw, the further the fall."""
import os
import re
import subprocess
import sys

DEMO = os.path.join(os.path.dirname(__file__), "..", "..", "demos", "python", "scene_batch.py")
LINE = re.compile(r"scene (\d+): v0 ([\d.]+) m/s fell ([\d.]+) m; substeps' sum ([\d.]+) m, closed form ([\d.]+) m")


def test_scene_batch_demo_falls_as_the_closed_form():
    out = subprocess.run([sys.executable, DEMO, "--scenes", "3", "--threads", "2"], check=True,
                         capture_output=True, text=True).stdout
    assert out.startswith("3 scenes on 2 threads"), out
    rows = [LINE.fullmatch(line) for line in out.splitlines()[1:]]
    assert len(rows) == 3 and all(rows), out
    falls = []
    for row in rows:
        fell, discrete, closed = (float(row.group(k)) for k in (3, 4, 5))
        assert abs(fell - discrete) <= 1e-4 * discrete, row.group(0)
        assert abs(fell - closed) <= 0.01 * closed, row.group(0)
        falls.append(fell)
    assert falls[0] < falls[1] < falls[2]
