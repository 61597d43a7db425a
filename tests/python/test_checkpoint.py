"""Checkpoints from Python: saved to bytes or a file and restored into a fresh scene, the run
continues bit for bit (CPU backend, same thread count); refusals raise CheckpointError with
the library's reason and leave the scene as it was."""
import numpy as np
import pytest

import mpm_bullet as mb
from tissue_scenes import scene_with_block, settings


def tissue_and_sphere():
    scene, obj = scene_with_block((0.05, 0.0, 0.0))
    sphere = scene.add_shape([{"type": "sphere", "radius": 0.012}], position=(0.01, 0.1, 0.0),
                             linear_velocity=(0, -0.3, 0), mass=0.01, inertia=(6e-7, 6e-7, 6e-7),
                             gravity=(0, -9.81, 0))
    return scene, obj, sphere


def fields(scene, obj, sphere):
    return [scene.positions(obj), scene.velocities(obj), scene.deformation_gradients(obj),
            *scene.shape_state(sphere), *scene.shape_impulse(sphere)]


def run(scene, steps):
    for _ in range(steps):
        scene.step(1 / 240)


@pytest.mark.parametrize("medium", ["bytes", "file"])
def test_restored_scene_continues_bit_for_bit(medium, tmp_path):
    scene, obj, sphere = tissue_and_sphere()
    run(scene, 4)
    if medium == "bytes":
        checkpoint = scene.save_bytes(b"my own state")
    else:
        path = str(tmp_path / "scene.ckpt")
        scene.save(path, b"my own state")
    run(scene, 6)  # the uninterrupted run
    reference = fields(scene, obj, sphere)

    fresh = mb.Scene(settings())  # no objects: the checkpoint brings them, under the same handles
    attachment = fresh.load_bytes(checkpoint) if medium == "bytes" else fresh.load(path)
    assert attachment == b"my own state"
    assert fresh.time == pytest.approx(4 / 240, rel=1e-6)
    run(fresh, 6)
    assert fresh.time == scene.time
    for a, b in zip(fields(fresh, obj, sphere), reference):
        np.testing.assert_array_equal(a, b)
    assert np.abs(reference[0] - fields(tissue_and_sphere()[0], obj, sphere)[0]).max() > 1e-4  # it moved


def test_refused_checkpoints_leave_the_scene_unchanged():
    scene, obj, sphere = tissue_and_sphere()
    run(scene, 2)
    good = scene.save_bytes()
    run(scene, 2)
    before = fields(scene, obj, sphere)

    def refused(data, reason):
        with pytest.raises(mb.CheckpointError) as info:
            scene.load_bytes(data)
        assert info.value.reason == reason, str(info.value)
        assert str(info.value).startswith("checkpoint: ")
        for a, b in zip(fields(scene, obj, sphere), before):
            np.testing.assert_array_equal(a, b)

    corrupted = bytearray(good)
    corrupted[len(good) // 2] ^= 0x40
    refused(bytes(corrupted), "Checksum")
    refused(good[: len(good) // 3], "Truncated")
    refused(b"not a checkpoint at all, just some bytes of text", "NotACheckpoint")
    other = mb.Scene(settings(dx=0.025))
    with pytest.raises(mb.CheckpointError) as info:
        other.load_bytes(good)
    assert info.value.reason == "OtherScene" and "dx" in str(info.value)
    with pytest.raises(mb.CheckpointError) as info:
        scene.load("/nonexistent/folder/scene.ckpt")
    assert info.value.reason == "Io"
    assert scene.attachment_of(scene.save_bytes(b"x")) == b"x"
