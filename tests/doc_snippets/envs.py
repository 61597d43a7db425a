import gymnasium as gym
import mpm_bullet.envs                       # registers the surgical tasks
env = gym.make("mpm_bullet/NeedleInsertion-v0", render_mode="rgb_array")
obs, info = env.reset(seed=0)                # the same seed, the same episode, bit for bit
obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
envs = gym.make_vec("mpm_bullet/NeedleInsertion-v0", num_envs=16, vectorization_mode="vector_entry_point")
