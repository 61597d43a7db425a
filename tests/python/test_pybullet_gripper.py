"""The Gymnasium-style gripper environment of demos/python (a fixed-base URDF whose fingers
are "held" links driven by position motors): it lifts the tissue cube by friction, and
reset() from its checkpoints repeats an episode bit for bit."""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "demos", "python"))
from gripper_env import GripperLiftEnv, scripted  # noqa: E402


# The fingers squeeze the 4 cm cube (64 g) with up to 10 N each at mu 1, fifteen times its
# weight, so it must not slip while the palm rises: the episode ends with the cube 3 cm up
# (terminated) and it rose with the lift joint to within a quarter of a cell (its elastic
# stretch under its own weight, rho g h^2 / E, is 0.5 mm; measured 1.0 mm behind).
def test_gripper_lifts_the_cube_and_reset_repeats_the_episode():
    env = GripperLiftEnv(dx=0.01)
    try:
        first, rewards = scripted(env)
        lift = first["joints"][0]
        print(f"{len(rewards)} actions: cube rose {1e3 * rewards[-1]:.1f} mm, the palm {1e3 * lift:.1f} mm")
        assert rewards[-1] > 0.03, "terminated: the cube is 3 cm up"
        assert len(rewards) < 34, "before the scripted actions ran out"
        assert abs(lift - rewards[-1]) < 0.25 * 0.01, "the cube rose with the palm"
        assert first["tissue"].shape == (env.scene.particle_count(env.cube), 3)
        again, rewards2 = scripted(env)
        assert rewards2 == rewards
        for k in first:
            assert np.array_equal(first[k], again[k]), k
    finally:
        env.close()
