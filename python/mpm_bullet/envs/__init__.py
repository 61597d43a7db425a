"""Gymnasium environments of surgical tasks on MPM tissue, registered on import:

    import gymnasium as gym
    import mpm_bullet.envs
    env = gym.make("mpm_bullet/NeedleInsertion-v0")
    envs = gym.make_vec("mpm_bullet/NeedleInsertion-v0", num_envs=16, vectorization_mode="vector_entry_point")

mpm_bullet/TissueRetraction-v0 (TissueRetractionEnv), mpm_bullet/Incision-v0 (IncisionEnv),
mpm_bullet/NeedleInsertion-v0 (NeedleInsertionEnv). The vector entry point is a
SurgicalVectorEnv: the environments' scenes stepped together by an mpm_bullet.SceneBatch.
gymnasium comes from PyPI; the C++ library does not need it.
"""
import functools

import gymnasium as gym

from .base import SurgicalEnv
from .tasks import IncisionEnv, NeedleInsertionEnv, TissueRetractionEnv
from .vector import SurgicalVectorEnv

TASKS = {"TissueRetraction-v0": TissueRetractionEnv, "Incision-v0": IncisionEnv,
         "NeedleInsertion-v0": NeedleInsertionEnv}


def make_vector(env_class, num_envs, max_episode_steps=None, **kwargs):
    """The vector entry point: episodes end at the task's own max_steps (truncated)."""
    return SurgicalVectorEnv(env_class, num_envs, **kwargs)


for _name, _cls in TASKS.items():
    if f"mpm_bullet/{_name}" not in gym.registry:
        gym.register(f"mpm_bullet/{_name}", entry_point=_cls, max_episode_steps=_cls.max_steps,
                     vector_entry_point=functools.partial(make_vector, _cls))

__all__ = ["IncisionEnv", "NeedleInsertionEnv", "SurgicalEnv", "SurgicalVectorEnv", "TissueRetractionEnv", "TASKS"]
