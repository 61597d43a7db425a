"""demos/python/ray_env_runners.py on a local Ray cluster the test starts: 2 RLlib env runners,
each a separate process holding 8 environments as one SceneBatch vector, collect the
experience asked of them with RLlib's default PPO module: 2,000 steps, more than an
episode (90 steps) of every environment, so episodes end, and every observation finite."""
import os
import re
import subprocess
import sys

import pytest

pytest.importorskip("ray.rllib")
pytest.importorskip("torch")

DEMO = os.path.join(os.path.dirname(__file__), "..", "..", "demos", "python", "ray_env_runners.py")
LINE = re.compile(r"(\S+): 2 env runners \(pids \[(\d+), (\d+)\]\) x 8 environments: (\d+) steps in ([\d.]+) s, "
                  r"[\d.]+ steps/s; (\d+) episodes ended; observations finite: (\w+)")


@pytest.mark.parametrize("task", ["TissueRetraction-v0", "NeedleInsertion-v0"])
def test_two_env_runners_collect_experience(task):
    out = subprocess.run([sys.executable, DEMO, "--task", task, "--runners", "2", "--envs", "8", "--timesteps", "1000"],
                         check=True, capture_output=True, text=True, timeout=600).stdout
    m = LINE.search(out)
    assert m, out
    assert m.group(1) == task
    assert m.group(2) != m.group(3)  # two processes
    assert int(m.group(4)) >= 2 * 1000  # every runner collected what it was asked (RLlib may finish an episode beyond)
    assert int(m.group(6)) >= 16  # each of the 16 environments ended an episode
    assert m.group(7) == "True"
