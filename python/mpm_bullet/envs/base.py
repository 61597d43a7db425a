"""The shared body of the surgical environments: a gymnasium.Env over one mpm_bullet.Scene
whose tool is kinematic and driven by the action as a velocity. reset() loads the scene's
start (its checkpoint bytes, taken once), so an episode starts bit for bit where the last one
did; save_state()/load_state() hold a whole environment (the scene's checkpoint with the
task's own state as its attachment)."""

import json

import gymnasium as gym
import numpy as np

import mpm_bullet as mb

from .render import render_points


class SurgicalEnv(gym.Env):
    """A task is a subclass: _build() adds the tissue and the tool to self.scene; _restart(rng)
    draws the episode's target and places the tool; _move(action) sets the tool's velocity for
    the next action_dt; _observe() and _score() read the result. One action is one
    Scene.step(action_dt), its substeps inside it."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 30}
    action_dt = 1 / 30  # [s] simulated per action
    max_steps = 90
    view = ((-0.06, -0.01), (0.06, 0.07))  # render(): the x-y window shown [m]

    def __init__(self, render_mode=None, backend="Cpu", cpu_threads=1):
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode {render_mode!r}: must be None or 'rgb_array'")
        self.render_mode = render_mode
        self.scene = mb.Scene(dict(self.settings, backend=backend, cpuThreads=cpu_threads))
        self._build()
        self._start = self.scene.save_bytes()
        self.steps = 0
        self.task = {}

    # --- gymnasium.Env
    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.scene.load_bytes(self._start)
        self.steps = 0
        self.task = self._restart(self.np_random)
        return self._observe(), self._info()

    def step(self, action):
        self.apply(action)
        self.scene.step(self.action_dt)
        return self.finish()

    def render(self):
        return render_points(self._render_points(), 0.5 * self.scene.dx, *self.view)

    # --- the step in two halves, for vectors that advance many scenes together
    def apply(self, action):
        """Sets the tool's velocity from `action` for the next Scene.step(action_dt)."""
        a = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)
        if a.shape != self.action_space.shape or not np.all(np.isfinite(a)):
            raise ValueError(f"action {np.asarray(action)!r}: must be finite, shape {self.action_space.shape}")
        self._move(a)

    def finish(self):
        """(observation, reward, terminated, truncated, info) after the scene was stepped."""
        self.steps += 1
        obs = self._observe()
        reward, terminated = self._score()
        return obs, float(reward), bool(terminated), self.steps >= self.max_steps, self._info()

    # --- whole-environment checkpoints
    def save_state(self):
        """The environment as bytes: the scene's checkpoint, the task (target, step count) and
        the random generator as its attachment."""
        extra = {"steps": self.steps, "task": self.task, "rng": self.np_random.bit_generator.state}
        return self.scene.save_bytes(json.dumps(extra).encode())

    def load_state(self, data):
        """Puts the environment back to save_state()'s bytes; it continues bit for bit."""
        extra = json.loads(bytes(self.scene.load_bytes(data)).decode())
        self.steps, self.task = extra["steps"], extra["task"]
        self.np_random.bit_generator.state = extra["rng"]

    def _info(self):
        return {"time": self.scene.time}

    # --- helpers for the tasks
    def _force(self, impulse):
        """The mean force [N] the tissue put on a tool over the last step, from its impulse."""
        return np.asarray(impulse[0], dtype=np.float32) / np.float32(self.action_dt)


def box_space(n, low=-np.inf, high=np.inf):
    return gym.spaces.Box(low, high, shape=(n,), dtype=np.float32)
