"""docs/api.md's "Python on pybullet" example (tests/doc_snippets/pybullet_coupler.py, shown there
verbatim) runs from the repository's root, where its URDF path points: the tissue cube ends
resting on the ground under the open gripper."""

import os

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")


def test_the_docs_pybullet_example_runs():
    snippet = os.path.join(ROOT, "tests", "doc_snippets", "pybullet_coupler.py")
    code = open(snippet, encoding="utf-8").read()
    doc = open(os.path.join(ROOT, "docs", "api.md"), encoding="utf-8").read()
    assert code in doc, "docs/api.md must show tests/doc_snippets/pybullet_coupler.py verbatim"
    here = os.getcwd()
    os.chdir(ROOT)
    try:
        names = {}
        exec(compile(code, snippet, "exec"), names)
    finally:
        os.chdir(here)
    x, scene, cube, p = names["x"], names["scene"], names["cube"], names["p"]
    assert x.shape == (scene.particle_count(cube), 3) and x.dtype == np.float32
    # 1 s later the 4 cm cube lies where it was put, its centre 2 cm above the ground (its own
    # weight compresses it by rho g h^2 / 2E = 0.3 mm), within half a cell
    z = scene.summary(cube)["center_of_mass"][2]
    assert abs(z - 0.0205) < 0.5 * 0.01, z
    p.disconnect(names["client"])
