"""Particle fields as numpy arrays: the initial lattice and F = I known analytically, the
arrays against the library's own per-object sums (ObjectSummary, computed in C++ in double
from its particle state), out= filling the caller's array, and refusals of a wrong out=."""
import json
import pathlib
import subprocess

import numpy as np
import pytest

import mpm_bullet as mb
from tissue_scenes import CENTER, HALF, SPACING, block, scene_with_block, settings


def lattice():
    """The particles of the block as the library seeds them: centres of a lattice of
    SPACING centred on the box, i (x) slowest, k (z) fastest, in float32."""
    n = int(round(2 * HALF / SPACING))
    offsets = (np.arange(n, dtype=np.float32) + np.float32(0.5) - np.float32(0.5 * n)) * np.float32(SPACING)
    i, j, k = np.meshgrid(offsets, offsets, offsets, indexing="ij")
    r = np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1)
    return np.asarray(CENTER, dtype=np.float32) + r


def test_initial_fields_are_the_lattice_at_rest_and_undeformed():
    velocity = (0.25, -0.5, 0.125)
    scene, obj = scene_with_block(velocity)
    x, v, F = scene.positions(obj), scene.velocities(obj), scene.deformation_gradients(obj)
    expected = lattice()
    assert scene.particle_count(obj) == len(expected) == 216
    assert x.dtype == v.dtype == F.dtype == np.float32
    assert x.shape == (216, 3) and v.shape == (216, 3) and F.shape == (216, 3, 3)
    # a misplaced or reordered particle would be off by a whole spacing, 1e-2 m
    np.testing.assert_allclose(x, expected, rtol=0, atol=1e-7)
    np.testing.assert_array_equal(v, np.tile(np.float32(velocity), (216, 1)))
    np.testing.assert_array_equal(F, np.tile(np.eye(3, dtype=np.float32), (216, 1, 1)))


def test_arrays_agree_with_the_librarys_sums_after_steps():
    scene, obj = scene_with_block((0.1, 0.0, -0.05))
    for _ in range(4):
        scene.step(1 / 120)
    x, v, F = scene.positions(obj), scene.velocities(obj), scene.deformation_gradients(obj)
    s = scene.summary(obj)
    n = scene.particle_count(obj)
    assert s["particles"] == n == len(x)
    m = 1000.0 * SPACING ** 3  # density times the lattice cell: every particle's mass
    assert s["mass"] == pytest.approx(n * m, rel=1e-6)
    # sums in double over float32 values: the same to float rounding
    np.testing.assert_allclose(s["center_of_mass"], x.astype(np.float64).mean(axis=0), rtol=0, atol=1e-7)
    np.testing.assert_allclose(s["momentum"], m * v.astype(np.float64).sum(axis=0), rtol=1e-5, atol=1e-10)
    assert s["kinetic_energy"] == pytest.approx(0.5 * m * (v.astype(np.float64) ** 2).sum(), rel=1e-5)
    # the block falls freely: it moved, and a uniform motion deforms nothing (F = I to float
    # rounding: measured 7e-8)
    assert np.abs(x - (scene_with_block()[0].positions(obj))).max() > 1e-3
    assert v[:, 1].mean() < -0.05
    assert np.abs(F - np.eye(3, dtype=np.float32)).max() < 1e-6


def test_arrays_equal_the_cpp_reads_of_the_same_scene_file(tmp_path):
    # field_dump (tests/python/field_dump.cpp, built beside the package in the build tree)
    # loads a scene file with the C++ loader, steps it and writes Scene::readPositions,
    # readVelocities and readDeformationGradients; the module builds the same scene from the
    # same dicts and steps it alike: every float equal
    dump = pathlib.Path(mb._core.__file__).resolve().parent.parent / "field_dump"
    if not dump.exists():
        pytest.skip("field_dump is built with the tests in the build tree (not by pip install)")
    tilted = block((0.2, 0.0, -0.1))
    tilted.update({"primitive": "Sphere", "radius": 0.025, "angularVelocity": [0.0, 3.0, 1.0]})
    objects = [block((0.1, 0.0, 0.0)), dict(tilted, center=[-0.04, 0.12, 0.0])]
    path = tmp_path / "scene.json"
    path.write_text(json.dumps({"settings": settings(), "objects": objects}))
    dt, steps = 1 / 120, 5
    raw = subprocess.run([str(dump), str(path), repr(dt), str(steps)], check=True, capture_output=True).stdout
    cpp = np.frombuffer(raw, dtype=np.float32)

    scene = mb.Scene(settings())
    ids = [scene.add_object(o) for o in objects]
    for _ in range(steps):
        scene.step(dt)
    ours = np.concatenate([a.ravel() for i in ids for a in
                           (scene.positions(i), scene.velocities(i), scene.deformation_gradients(i))])
    assert cpp.size == ours.size == 15 * sum(scene.particle_count(i) for i in ids)
    np.testing.assert_array_equal(ours, cpp)


def test_out_fills_the_callers_array():
    scene, obj = scene_with_block()
    for _ in range(3):
        scene.step(1 / 120)
    n = scene.particle_count(obj)
    for read, shape in ((scene.positions, (n, 3)), (scene.velocities, (n, 3)), (scene.deformation_gradients, (n, 3, 3))):
        buf = np.full(shape, np.nan, dtype=np.float32)
        got = read(obj, out=buf)
        assert got is buf  # filled in place, nothing allocated
        np.testing.assert_array_equal(buf, read(obj))


def test_wrong_out_is_refused_naming_it():
    scene, obj = scene_with_block()
    n = scene.particle_count(obj)
    want = "must be a C-contiguous, writeable float32 numpy array of shape (216, 3)"

    def refused(out, got, read=scene.positions):
        with pytest.raises(mb.InvalidArgument) as info:
            read(obj, out=out)
        assert info.value.field == "out"
        assert str(info.value) == f"out = {got}: {want}"

    refused(np.zeros((n, 3)), "float64 (216, 3)")
    refused(np.zeros((n - 1, 3), dtype=np.float32), "float32 (215, 3)")
    refused(np.zeros((n * 3,), dtype=np.float32), "float32 (648,)")
    refused(np.zeros((n, 6), dtype=np.float32)[:, :3], "float32 (216, 3) not C-contiguous")
    frozen = np.zeros((n, 3), dtype=np.float32)
    frozen.setflags(write=False)
    refused(frozen, "float32 (216, 3) read-only")
    with pytest.raises(mb.InvalidArgument) as info:
        scene.positions(obj, out=[[0.0, 0.0, 0.0]] * n)
    assert str(info.value).endswith(want + " (got no numpy array)")
    with pytest.raises(mb.InvalidArgument) as info:
        scene.deformation_gradients(obj, out=np.zeros((n, 3), dtype=np.float32))
    assert str(info.value) == "out = float32 (216, 3): must be a C-contiguous, writeable float32 numpy array of shape (216, 3, 3)"
