"""MPM soft tissue for Bullet, in Python: scenes, tissue, shapes, slicers, curves, checkpoints.

    import mpm_bullet as mb
    scene = mb.Scene({"domain": {"lower": [-0.1, 0, -0.1], "upper": [0.1, 0.2, 0.1]}, "dx": 0.01})
    tissue = scene.add_object({"primitive": "Box", "center": [0, 0.05, 0],
                               "halfExtents": [0.03, 0.03, 0.03]})
    scene.step(1 / 240)
    x = scene.positions(tissue)          # (N, 3) float32

Settings and object dicts are those of a scene file (assets/scenes/scene.schema.json).
Quaternions are (x, y, z, w), as in pybullet. Errors: InvalidArgument (a ValueError),
CheckpointError, SimulationDiverged, BackendUnavailable, StepInProgress (a call while another
thread steps the scene), AdvanceCancelled (Scene.cancel()), OutOfMemory (a MemoryError), all
subclasses of Error.
"""
from ._core import (AdvanceCancelled, BackendUnavailable, CheckpointError, CurveId, EnergyBalance, Error,
                    InvalidArgument, ObjectId, OutOfMemory, Scene, SceneBatch, ShapeId, SimulationDiverged,
                    SlicerId, StepInProgress, StepReport, cuda_device_available)

__all__ = ["AdvanceCancelled", "BackendUnavailable", "CheckpointError", "CurveId", "EnergyBalance", "Error",
           "InvalidArgument", "ObjectId", "OutOfMemory", "Scene", "SceneBatch", "ShapeId", "SimulationDiverged",
           "SlicerId", "StepInProgress", "StepReport", "cuda_device_available"]
