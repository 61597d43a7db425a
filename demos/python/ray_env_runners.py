"""The surgical environments under Ray RLlib's env runners: `runners` remote SingleAgentEnvRunner
actors, each holding `envs` environments as one SurgicalVectorEnv (the vector entry point: its
scenes stepped together by a SceneBatch), collecting experience with RLlib's default PPO
module. On a multi-node cluster the same script runs unchanged: start Ray on the nodes
(`ray start --head` on one, `ray start --address=HEAD:6379` on the others), set RAY_ADDRESS
or pass --address, and raise --runners; each runner asks Ray for `num_cpus_per_env_runner`
CPUs (1 here, the batch's threads) and, where the scene runs on CUDA, a fraction of a GPU
(`num_gpus_per_env_runner`, e.g. 0.25 to put four runners' batches on one GPU).

    python demos/python/ray_env_runners.py --task NeedleInsertion-v0 --runners 2 --envs 8

Ray, gymnasium and torch come from PyPI; the C++ library needs none of them.
"""

import argparse
import os
import time

import numpy as np


def collect(task, runners, envs, timesteps, address=None, threads=1):
    """Collects `timesteps` per runner; returns (timesteps collected, seconds, runner pids,
    episodes ended, whether every observation was finite)."""
    import ray
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.env.env_runner_group import EnvRunnerGroup

    import mpm_bullet.envs  # noqa: F401 (registers the tasks here; the runners import it by the id's module)

    started = not ray.is_initialized()
    if started:
        ray.init(address=address, num_cpus=None if address else max(2, runners), include_dashboard=False,
                 log_to_driver=False)
    try:
        config = (PPOConfig().environment(f"mpm_bullet.envs:mpm_bullet/{task}", env_config={"threads": threads})
                  .env_runners(num_env_runners=runners, num_envs_per_env_runner=envs, num_cpus_per_env_runner=threads,
                               gym_env_vectorize_mode="vector_entry_point", rollout_fragment_length=timesteps // envs))
        group = EnvRunnerGroup(config=config, local_env_runner=False)
        group.foreach_env_runner(lambda r: r.sample(num_timesteps=envs, explore=True), local_env_runner=False)  # warm
        t = time.perf_counter()
        episodes = group.foreach_env_runner(lambda r: r.sample(num_timesteps=timesteps, explore=True),
                                            local_env_runner=False)
        seconds = time.perf_counter() - t
        pids = group.foreach_env_runner(lambda r: os.getpid(), local_env_runner=False)
        steps = sum(len(e) for runner in episodes for e in runner)
        ended = sum(e.is_done for runner in episodes for e in runner)
        finite = all(np.isfinite(np.asarray(e.get_observations())).all() for runner in episodes for e in runner)
        group.stop()
        if len(pids) != runners or steps == 0:
            raise RuntimeError(f"{len(pids)} of {runners} env runners answered, {steps} steps (see Ray's log)")
        return steps, seconds, pids, ended, finite
    finally:
        if started:
            ray.shutdown()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="NeedleInsertion-v0")
    parser.add_argument("--runners", type=int, default=2)
    parser.add_argument("--envs", type=int, default=8, help="environments per runner")
    parser.add_argument("--timesteps", type=int, default=1000, help="per runner")
    parser.add_argument("--address", default=None, help="a running Ray cluster (default: a local one)")
    args = parser.parse_args()
    steps, seconds, pids, ended, finite = collect(args.task, args.runners, args.envs, args.timesteps, args.address)
    print(f"{args.task}: {args.runners} env runners (pids {pids}) x {args.envs} environments: {steps} steps in "
          f"{seconds:.2f} s, {steps / seconds:.1f} steps/s; {ended} episodes ended; observations finite: {finite}")


if __name__ == "__main__":
    main()
