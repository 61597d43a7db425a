"""mpm_bullet.SceneBatch: three small blocks (different starting speeds) stepped together on
two threads end bit for bit where each stepped alone; a scene that is not a Scene, a repeated
scene and a dt list of the wrong length are refused by name."""
import numpy as np
import pytest

import mpm_bullet as mb

SETTINGS = {"domain": {"lower": [-0.2, -0.2, -0.2], "upper": [0.2, 0.3, 0.2]}, "dx": 0.02}


def block_scene(speed):
    scene = mb.Scene(SETTINGS)
    obj = scene.add_object({"primitive": "Box", "center": [0.0, 0.0, 0.0], "halfExtents": [0.04, 0.04, 0.04],
                            "velocity": [0.0, -speed, 0.0], "material": {"youngsModulus": 2e5}})
    return scene, obj


def test_batch_ends_where_each_scene_steps_alone():
    together = [block_scene(0.5 * i) for i in range(3)]
    alone = [block_scene(0.5 * i) for i in range(3)]
    batch = mb.SceneBatch([s for s, _ in together], threads=2)
    assert len(batch) == 3 and batch.threads == 2
    for _ in range(6):
        reports = batch.step(1 / 240)
        for s, _ in alone:
            s.step(1 / 240)
    assert len(reports) == 3 and all(r.substeps >= 1 for r in reports)
    heights = []
    for (a, ia), (b, ib) in zip(together, alone):
        xa, xb = a.positions(ia), b.positions(ib)
        assert xa.tobytes() == xb.tobytes()
        heights.append(float(xa[:, 1].mean()))
    assert heights[2] < heights[1] < heights[0]  # the faster blocks fell further
    batch.step([1 / 240, 2 / 240, 3 / 240])
    assert together[2][0].time == pytest.approx(6 / 240 + 3 / 240)


def test_bad_input_is_refused_by_name():
    scene, _ = block_scene(0.0)
    with pytest.raises(mb.InvalidArgument, match=r"SceneBatch scenes\[1\]"):
        mb.SceneBatch([scene, "not a scene"])
    with pytest.raises(mb.InvalidArgument, match=r"SceneBatch scenes\[1\] = scenes\[0\]"):
        mb.SceneBatch([scene, scene])
    batch = mb.SceneBatch([scene])
    with pytest.raises(mb.InvalidArgument, match="SceneBatch::advance dt = 2 values"):
        batch.step([0.01, 0.01])
    batch.step(0.01)  # still steps
    assert np.isclose(scene.time, 0.01)
