"""Environment steps per second of the gymnasium environments (mpm_bullet.envs): one
environment, a SceneBatch vector of 16, and 2 Ray RLlib env runners of 8, each the median of
`--repeats` runs with random actions. Writes a Markdown table (bench/run_env_throughput.sh
puts it in this machine's results folder)."""

import argparse
import os
import platform
import statistics
import sys
import time

import gymnasium as gym
import numpy as np

import mpm_bullet.envs  # noqa: F401 (registers the tasks)

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "demos", "python"))
from ray_env_runners import collect  # noqa: E402


def single(task, steps):
    env = gym.make(f"mpm_bullet/{task}").unwrapped
    env.reset(seed=0)
    env.action_space.seed(0)
    t = time.perf_counter()
    for _ in range(steps):
        *_, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - t)


def vector(task, n, steps, threads):
    vec = gym.make_vec(f"mpm_bullet/{task}", num_envs=n, vectorization_mode="vector_entry_point", threads=threads)
    vec.reset(seed=0)
    vec.action_space.seed(0)
    t = time.perf_counter()
    for _ in range(steps):
        vec.step(vec.action_space.sample())
    return n * steps / (time.perf_counter() - t)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", required=True)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--idle", default="", help="the CPU's idle percentage before the run")
    args = parser.parse_args()
    threads = os.cpu_count()
    rows = []
    for task in sorted(mpm_bullet.envs.TASKS):
        env = gym.make(f"mpm_bullet/{task}").unwrapped
        particles = sum(env.scene.particle_count(o) for o in env.scene.objects())
        med = [statistics.median(f() for _ in range(args.repeats)) for f in (
            lambda: single(task, 60),
            lambda: vector(task, 16, 20, threads),
            lambda: (lambda s, sec, *_: s / sec)(*collect(task, 2, 8, 40)))]
        rows.append(f"| {task} | {particles} | {env.scene.dx * 1e3:g} | {med[0]:.1f} | {med[1]:.1f} | {med[2]:.1f} |")
        print(rows[-1], flush=True)
    idle = args.idle.split(",")[-1]  # top's field may come as "ni,99.5"
    with open(args.out, "w") as f:
        f.write(f"# Environment steps per second\n\nMachine: {platform.processor() or platform.machine()}, "
                f"{threads} hardware threads ({idle or '?'} % idle before the run); `bench/run_env_throughput.sh`. "
                f"One step: one action, {1 / 30:.4f} s simulated. Medians of {args.repeats} runs, random actions.\n\n"
                "| task | particles | dx [mm] | 1 env | vector of 16 (SceneBatch, "
                f"{threads} threads) | 2 Ray env runners x 8 |\n|---|---|---|---|---|---|\n" + "\n".join(rows) + "\n")


if __name__ == "__main__":
    main()
