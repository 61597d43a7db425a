"""The README's Python lines (its first python block under "### Python") run as written."""
import pathlib

import numpy as np


def test_the_readme_python_example_runs():
    readme = (pathlib.Path(__file__).resolve().parents[2] / "README.md").read_text()
    block = readme.split("\n### Python\n", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    names = {}
    exec(compile(block, "README.md (Python)", "exec"), names)
    x = names["x"]
    assert x.dtype == np.float32 and x.shape == (names["scene"].particle_count(), 3)
    assert isinstance(names["state"], bytes)
