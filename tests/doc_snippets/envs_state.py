import gymnasium as gym
import mpm_bullet.envs

env = gym.make("mpm_bullet/NeedleInsertion-v0", render_mode="rgb_array")
obs, info = env.reset(seed=0)
obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
image = env.render()                         # (160, 240, 3) uint8, a side view
saved = env.unwrapped.save_state()           # the whole environment as bytes
env.unwrapped.load_state(saved)              # continues bit for bit

envs = gym.make_vec("mpm_bullet/NeedleInsertion-v0", num_envs=16, vectorization_mode="vector_entry_point")
