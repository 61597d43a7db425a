"""The README's Python lines (tests/doc_snippets/scene.py, shown verbatim in README.md) run."""
import pathlib

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_the_readme_python_example_runs():
    snippet = (ROOT / "tests/doc_snippets/scene.py").read_text()
    assert snippet in (ROOT / "README.md").read_text(), "README.md must show tests/doc_snippets/scene.py verbatim"
    names = {}
    exec(compile(snippet, "tests/doc_snippets/scene.py", "exec"), names)
    x = names["x"]
    assert x.dtype == np.float32 and x.shape == (names["scene"].particle_count(), 3)
    assert isinstance(names["state"], bytes)


def test_the_readme_environment_lines_run():
    snippet = (ROOT / "tests/doc_snippets/envs.py").read_text()
    assert snippet in (ROOT / "README.md").read_text(), "README.md must show tests/doc_snippets/envs.py verbatim"
    names = {}
    exec(compile(snippet, "tests/doc_snippets/envs.py", "exec"), names)
    assert names["obs"].shape == names["env"].observation_space.shape and names["envs"].num_envs == 16


def test_the_learning_doc_lines_run():
    snippet = (ROOT / "tests/doc_snippets/envs_state.py").read_text()
    assert snippet in (ROOT / "docs/learning.md").read_text(), "docs/learning.md must show envs_state.py verbatim"
    names = {}
    exec(compile(snippet, "tests/doc_snippets/envs_state.py", "exec"), names)
    assert names["image"].shape == (160, 240, 3) and isinstance(names["saved"], bytes)
