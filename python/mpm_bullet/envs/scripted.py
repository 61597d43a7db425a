"""Scripted policies that solve each task from its observation alone: a floor under the
rewards (a learner should do at least this well) and the tests' proof that the rewards are
not vacuous. policy(env, obs) -> action."""

import numpy as np


def retract(env, obs):
    """Moves the grasper by the flap end's offset from the target."""
    edge, target = obs[9:12], obs[6:9]
    return np.clip((target - edge) / (env.speed * env.action_dt), -1.0, 1.0)


def incise(env, obs):
    """Over the line, down to 8 mm, then along it."""
    p, line, depth = obs[0:3], obs[6:9], obs[9]
    a = np.zeros(3)
    a[2] = np.clip((line[2] - p[2]) / (env.speed * env.action_dt), -1.0, 1.0)
    a[1] = np.clip((depth - 0.008) / (env.speed * env.action_dt), -1.0, 1.0)
    if depth > 0.006 and abs(line[2] - p[2]) < 0.002:
        a[0] = 1.0
    return a


def insert(env, obs):
    """Puts the needle's centre where its circle passes through the target (at its start
    height, or lower where the target is deeper than the circle reaches), then turns the tip
    in to it."""
    c, turn, target = obs[0:3], np.arctan2(obs[4], obs[3]), obs[8:11]
    r = env.radius
    cy = min(env.top + 0.004, target[1] + 0.95 * r)
    s = (cy - target[1]) / r
    move = np.array([target[0] + r * np.sqrt(1.0 - s * s) - c[0], cy - c[1]])
    if np.linalg.norm(move) > 2e-4:
        return np.r_[np.clip(move / (0.02 * env.action_dt), -1.0, 1.0), 0.0]
    return np.array([0.0, 0.0, np.clip((np.arcsin(s) - turn) / (2.0 * env.action_dt), -1.0, 1.0)])


POLICIES = {"TissueRetraction-v0": retract, "Incision-v0": incise, "NeedleInsertion-v0": insert}
