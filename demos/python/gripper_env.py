"""The gripper scene of gripper_lift.py as a Gymnasium-style environment, the shape a learning
user needs: reset() puts the tissue and the robot back from checkpoints taken once (the
scene's bytes and pybullet's saveState), step(action) drives the joints for a few ticks and
returns observations as numpy arrays. It follows gymnasium.Env's calls and return values
without importing gymnasium (wrap it in gymnasium.Env to register it).

    env = GripperLiftEnv()
    obs, info = env.reset()
    obs, reward, terminated, truncated, info = env.step(np.array([0.0, 1.0]))  # close

    python demos/python/gripper_env.py     # scripted episodes; checks that reset repeats them
"""

import os

import numpy as np
import pybullet as p

import mpm_bullet as mb
from mpm_bullet.pybullet import Coupler

HERE = os.path.dirname(os.path.abspath(__file__))


class GripperLiftEnv:
    """Lift a 4 cm tissue cube with the two-finger gripper. Action (2,) in [-1, 1]: the palm's
    vertical speed (times 0.1 m/s) and the fingers' closing (-1 open, 1 closed). Observation:
    dict of "tissue" (N, 3) particle positions, "tissue_velocity" (N, 3), "joints" (3,) lift
    and finger positions [m]. Reward: the cube's centre of mass above its start [m]."""

    def __init__(self, dx=0.01, ticks_per_action=8, max_actions=60, palm_start=0.1):
        self.ticks_per_action, self.max_actions = ticks_per_action, max_actions
        self.client = p.connect(p.DIRECT)
        p.setGravity(0, 0, -9.81, physicsClientId=self.client)
        p.setPhysicsEngineParameter(fixedTimeStep=1.0 / 240, numSubSteps=0, physicsClientId=self.client)
        ground = p.createMultiBody(0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=self.client),
                                   physicsClientId=self.client)
        self.robot = p.loadURDF(os.path.join(HERE, "gripper.urdf"), [0, 0, palm_start], useFixedBase=True,
                                physicsClientId=self.client)
        self.scene = mb.Scene({"domain": {"lower": [-0.1, -0.1, -0.02], "upper": [0.1, 0.1, 0.2]}, "dx": dx,
                               "gravity": [0, 0, -9.81]})
        self.cube = self.scene.add_object({"primitive": "Box", "center": [0, 0, 0.0205],
                                           "halfExtents": [0.02, 0.02, 0.02],
                                           "material": {"model": "NeoHookeanDecoupled", "youngsModulus": 3e4,
                                                        "poissonRatio": 0.4, "density": 1000}})
        self.coupler = Coupler(self.client, self.scene)
        self.coupler.add_body(ground)
        self.coupler.add_body(self.robot, contact={"friction": 1.0})
        self.lift_target = 0.0
        # the start, taken once: reset() returns here
        self._tissue_start = self.scene.save_bytes()
        self._world_start = p.saveState(physicsClientId=self.client)
        self._z0 = self.scene.summary(self.cube)["center_of_mass"][2]
        n = self.scene.particle_count(self.cube)
        self._x, self._v = np.empty((n, 3), np.float32), np.empty((n, 3), np.float32)

    def _observation(self):
        joints = [s[0] for s in p.getJointStates(self.robot, range(3), physicsClientId=self.client)]
        return {"tissue": self.scene.positions(self.cube, out=self._x).copy(),
                "tissue_velocity": self.scene.velocities(self.cube, out=self._v).copy(),
                "joints": np.array(joints)}

    def reset(self, seed=None, options=None):
        self.scene.load_bytes(self._tissue_start)
        p.restoreState(self._world_start, physicsClientId=self.client)
        self.lift_target, self.actions = 0.0, 0
        return self._observation(), {}

    def step(self, action):
        a = np.clip(np.asarray(action, float), -1, 1)
        dt = self.ticks_per_action / 240
        self.lift_target = float(np.clip(self.lift_target + 0.1 * a[0] * dt, -0.3, 0.3))
        finger = 0.0125 * (a[1] + 1)  # 0 (open) to 0.025 (inner faces 1 cm off the axis)
        c = self.client
        p.setJointMotorControl2(self.robot, 0, p.POSITION_CONTROL, targetPosition=self.lift_target, force=40,
                                physicsClientId=c)
        for j in (1, 2):
            p.setJointMotorControl2(self.robot, j, p.POSITION_CONTROL, targetPosition=finger, force=10,
                                    maxVelocity=0.1, physicsClientId=c)
        for _ in range(self.ticks_per_action):
            self.coupler.step()
        self.actions += 1
        rise = self.scene.summary(self.cube)["center_of_mass"][2] - self._z0
        obs = self._observation()
        return obs, rise, bool(rise > 0.03), self.actions >= self.max_actions, {"time": self.scene.time}

    def close(self):
        p.disconnect(self.client)


def scripted(env):
    """Open, close, lift: (last observation, rewards)."""
    obs, _ = env.reset()
    rewards = []
    plan = [(0.0, -1.0)] * 2 + [(0.0, 1.0)] * 12 + [(1.0, 1.0)] * 20
    for a in plan:
        obs, r, terminated, truncated, _ = env.step(a)
        rewards.append(r)
        if terminated or truncated:
            break
    return obs, rewards


if __name__ == "__main__":
    env = GripperLiftEnv()
    first, rewards = scripted(env)
    print(f"episode 1: {len(rewards)} actions, cube rose {1e3 * rewards[-1]:.1f} mm; "
          f"observation: tissue {first['tissue'].shape}, joints {np.round(first['joints'], 4)}")
    again, rewards2 = scripted(env)
    same = all(np.array_equal(first[k], again[k]) for k in first)
    print(f"episode 2 after reset: cube rose {1e3 * rewards2[-1]:.1f} mm; observations bit-identical: {same}")
    env.close()
