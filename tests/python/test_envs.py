"""The gymnasium environments (mpm_bullet.envs): gymnasium's own checks, deterministic
resets, whole-environment save and restore, and the SceneBatch vector against single
environments, bit for bit."""

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")
envs = pytest.importorskip("mpm_bullet.envs")
from gymnasium.utils.env_checker import check_env  # noqa: E402

TASKS = sorted(envs.TASKS)


def actions(space, n, seed):
    space.seed(seed)
    return [space.sample() for _ in range(n)]


def rollout(env, seed, plan):
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for a in plan:
        obs, r, terminated, truncated, _ = env.step(a)
        out.append(np.append(obs, r))
        if terminated or truncated:
            break
    return out


@pytest.mark.parametrize("task", TASKS)
def test_gymnasium_checks_pass(task):
    env = gym.make(f"mpm_bullet/{task}", render_mode="rgb_array")
    check_env(env.unwrapped)
    env.reset(seed=0)
    image = env.render()
    assert image.shape == (160, 240, 3) and image.dtype == np.uint8
    assert (image != 245).any(axis=2).mean() > 0.02  # the tissue is in the picture


@pytest.mark.parametrize("task", TASKS)
def test_a_seed_repeats_its_episode_bit_for_bit(task):
    env = gym.make(f"mpm_bullet/{task}").unwrapped
    plan = actions(env.action_space, 20, 3)
    first, second = rollout(env, 7, plan), rollout(env, 7, plan)
    assert len(first) == len(second) == 21
    for a, b in zip(first, second):
        assert np.array_equal(a, b)
    other = rollout(env, 8, plan)  # another seed: another target
    assert not np.array_equal(first[0], other[0])


@pytest.mark.parametrize("task", TASKS)
def test_a_restored_environment_continues_bit_for_bit(task):
    env = gym.make(f"mpm_bullet/{task}").unwrapped
    plan = actions(env.action_space, 12, 5)
    env.reset(seed=11)
    for a in plan[:6]:
        env.step(a)
    saved = env.save_state()
    later = [env.step(a) for a in plan[6:]]
    env.reset(seed=99)  # somewhere else entirely
    env.load_state(saved)
    again = [env.step(a) for a in plan[6:]]
    for (o1, r1, *_), (o2, r2, *_) in zip(later, again):
        assert np.array_equal(o1, o2) and r1 == r2


@pytest.mark.parametrize("task,n", [("TissueRetraction-v0", 16), ("Incision-v0", 4), ("NeedleInsertion-v0", 4)])
def test_the_vector_steps_as_single_environments_do(task, n):
    steps = 8
    vec = gym.make_vec(f"mpm_bullet/{task}", num_envs=n, vectorization_mode="vector_entry_point", threads=1)
    plans = [actions(vec.single_action_space, steps, 100 + i) for i in range(n)]
    obs, _ = vec.reset(seed=[20 + i for i in range(n)])
    got = [[obs[i]] for i in range(n)]
    for k in range(steps):
        obs, rewards, *_ = vec.step(np.stack([plans[i][k] for i in range(n)]))
        for i in range(n):
            got[i].append(np.append(obs[i], rewards[i]))
    single = gym.make(f"mpm_bullet/{task}").unwrapped
    for i in range(n):
        want = rollout(single, 20 + i, plans[i])
        assert len(want) == steps + 1
        for a, b in zip(want, got[i]):
            assert np.array_equal(a, b), f"environment {i}"


def test_the_vector_resets_and_restores_one_environment():
    vec = gym.make_vec("mpm_bullet/TissueRetraction-v0", num_envs=3, vectorization_mode="vector_entry_point")
    obs0, _ = vec.reset(seed=1)
    up = np.tile([0.0, 1.0, 0.0], (3, 1))
    for _ in range(3):
        obs, *_ = vec.step(up)
    saved = vec.save_state(1)
    after, *_ = vec.step(up)
    obs, _ = vec.reset(seed=[None, 2, None], options={"reset_mask": [False, True, False]})
    assert np.array_equal(obs[1], obs0[1])  # its first episode had seed 1 + 1: the same start
    assert np.array_equal(obs[0], after[0]) and np.array_equal(obs[2], after[2])
    vec.load_state(1, saved)
    again, *_ = vec.step(up)
    assert np.array_equal(again[1], after[1])


def test_the_grasper_feels_the_flap_it_lifts():
    """Lifted 1 cm, the jaws carry the flap's weight and its bending: the tissue pulls them
    down (force y < 0), by less than the flap's stretch could (E A strain, 20 kPa x 4 cm x
    2 cm x 1/4 = 4 N), and not sideways across the symmetric flap (a sanity check of the
    force's sign and size, not a measurement)."""
    env = gym.make("mpm_bullet/TissueRetraction-v0").unwrapped
    env.reset(seed=0)
    for _ in range(6):  # 6 x 1/30 s at 5 cm/s: 1 cm up
        obs, *_ = env.step(np.array([0.0, 1.0, 0.0]))
    force = obs[12:15]
    assert -4.0 < force[1] < -0.01 and abs(force[2]) < 0.05 * abs(force[1])  # symmetric about z = 0


@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize("seed", [0, 1])
def test_a_scripted_policy_solves_the_task(task, seed):
    """Within the step budget: the flap's end reaches its target (within 5 mm), the blade
    reaches the line's end having cut along it (while at least 5 mm deep, never more than
    2 dx off the line), the needle's tip reaches its target (within 2 mm)."""
    from mpm_bullet.envs.scripted import POLICIES
    env = gym.make(f"mpm_bullet/{task}").unwrapped
    obs, _ = env.reset(seed=seed)
    off = 0.0
    for _ in range(env.max_steps):
        obs, reward, terminated, truncated, _ = env.step(POLICIES[task](env, obs))
        if task == "Incision-v0" and obs[9] >= 0.005:
            off = max(off, abs(obs[2] - obs[8]))
        if terminated or truncated:
            break
    assert terminated and not truncated
    if task == "TissueRetraction-v0":
        assert env.task["distance"] < 0.005 and obs[10] > 0.03  # lifted by more than 1.5 cm
    elif task == "Incision-v0":
        assert env.task["progress"] >= 0.04 and off <= 2 * env.scene.dx
    else:
        assert env.task["distance"] < 0.002
