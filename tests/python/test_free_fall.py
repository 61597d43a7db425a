"""A block of tissue falling freely for 0.1 s, as tests/test_free_fall.cpp sets it up (dx 0.05,
box of half 0.1 m, E 1e5 Pa, 50 fixed substeps of 2e-4 s per 0.01 s step): its centre of mass,
from the positions array, follows the solver's symplectic Euler exactly to float rounding,
and the parabola -g t^2 / 2 within that scheme's drift."""
import numpy as np

import mpm_bullet as mb

G = 9.81
SUBSTEP = 2e-4


def test_centre_of_mass_follows_the_parabola():
    scene = mb.Scene({"domain": {"lower": [-0.5, -2.5, -0.5], "upper": [0.5, 0.5, 0.5]}, "dx": 0.05,
                      "gravity": [0.0, -G, 0.0], "substeps": {"fixedSubsteps": 50}})
    obj = scene.add_object({"primitive": "Box", "center": [0.0, 0.2, 0.0], "halfExtents": [0.1, 0.1, 0.1],
                            "material": {"youngsModulus": 1e5}})
    y0 = scene.positions(obj)[:, 1].astype(np.float64).mean()
    x = np.empty((scene.particle_count(obj), 3), dtype=np.float32)
    for frame in range(1, 11):
        scene.step(0.01)
        t = frame * 0.01
        com = scene.positions(obj, out=x).astype(np.float64).mean(axis=0)
        # symplectic Euler (velocity first, then position): y0 - g (t^2 + t dt) / 2, i.e. the
        # parabola plus a drift of dt / t of the fall (2e-3 at 0.1 s)
        stepped = y0 - 0.5 * G * (t * t + t * SUBSTEP)
        parabola = y0 - 0.5 * G * t * t
        fall = 0.5 * G * t * t
        assert abs(com[1] - stepped) < 1e-4 * fall, (t, com[1], stepped)  # measured 4.6e-5
        assert abs(com[1] - parabola) < (SUBSTEP / t + 1e-4) * fall, (t, com[1], parabola)
        np.testing.assert_allclose(com[[0, 2]], 0.0, atol=1e-6)
