"""SurgicalVectorEnv: n environments of one task stepped together by an mpm_bullet.SceneBatch
(on the CPU each scene on one of the batch's threads, bit for bit as it would step alone),
with gymnasium's next-step autoreset, per-environment reset (options={"reset_mask": ...})
and per-environment save_state(i) / load_state(i, bytes)."""

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

import mpm_bullet as mb


class SurgicalVectorEnv(VectorEnv):
    def __init__(self, env_class, num_envs, threads=0, render_mode=None, **kwargs):
        self.envs = [env_class(render_mode=render_mode, **kwargs) for _ in range(num_envs)]
        self.num_envs = num_envs
        self.single_observation_space = self.envs[0].observation_space
        self.single_action_space = self.envs[0].action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.metadata = dict(env_class.metadata, autoreset_mode=AutoresetMode.NEXT_STEP)
        self.render_mode = render_mode
        self.threads = threads
        self._batch = mb.SceneBatch([e.scene for e in self.envs], threads=threads)
        self._ended = np.zeros(num_envs, bool)

    def reset(self, *, seed=None, options=None):
        seeds = seed if isinstance(seed, (list, tuple)) else [None if seed is None else seed + i
                                                               for i in range(self.num_envs)]
        mask = np.ones(self.num_envs, bool) if not options or "reset_mask" not in options \
            else np.asarray(options["reset_mask"], bool)
        obs, infos = [], {}
        for i, env in enumerate(self.envs):
            if mask[i]:
                o, info = env.reset(seed=seeds[i])
                self._ended[i] = False
            else:
                o, info = env._observe(), env._info()
            obs.append(o)
            infos = self._add_info(infos, info, i)
        return np.stack(obs), infos

    def step(self, actions):
        actions = np.asarray(actions)
        going = [i for i in range(self.num_envs) if not self._ended[i]]
        for i in going:
            self.envs[i].apply(actions[i])
        if len(going) == self.num_envs:
            self._batch.step(self.envs[0].action_dt)
        elif going:
            mb.SceneBatch([self.envs[i].scene for i in going], threads=self.threads).step(self.envs[0].action_dt)
        obs = []
        rewards = np.zeros(self.num_envs)
        terminated, truncated = np.zeros(self.num_envs, bool), np.zeros(self.num_envs, bool)
        infos = {}
        for i, env in enumerate(self.envs):
            if self._ended[i]:  # next-step autoreset: this step only resets it
                o, info = env.reset()
                self._ended[i] = False
            else:
                o, rewards[i], terminated[i], truncated[i], info = env.finish()
                self._ended[i] = terminated[i] or truncated[i]
            obs.append(o)
            infos = self._add_info(infos, info, i)
        return np.stack(obs), rewards, terminated, truncated, infos

    def save_state(self, i):
        """Environment i as bytes (SurgicalEnv.save_state)."""
        return self.envs[i].save_state()

    def load_state(self, i, data):
        self.envs[i].load_state(data)
        self._ended[i] = False

    def render(self):
        return tuple(e.render() for e in self.envs) if self.render_mode == "rgb_array" else None

    def close_extras(self, **kwargs):
        self._batch = None
        self.envs = []
