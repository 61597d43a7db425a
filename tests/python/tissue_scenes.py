"""Small tissue scenes shared by the module's tests (coarse and short, for CI)."""
import mpm_bullet as mb

# a 6 x 6 x 6 lattice of particles (dx 0.02, 2 per cell axis: spacing 0.01) in a small domain
DX = 0.02
SPACING = DX / 2
HALF = 0.03
CENTER = (0.013, 0.051, -0.007)


def settings(**extra):
    s = {"domain": {"lower": [-0.1, -0.1, -0.1], "upper": [0.1, 0.2, 0.1]}, "dx": DX,
         "gravity": [0.0, -9.81, 0.0], "backend": "Cpu"}
    s.update(extra)
    return s


def block(velocity=(0.0, 0.0, 0.0)):
    return {"primitive": "Box", "center": list(CENTER), "halfExtents": [HALF] * 3,
            "material": {"youngsModulus": 2e4, "poissonRatio": 0.3, "density": 1000.0},
            "velocity": list(velocity)}


def scene_with_block(velocity=(0.0, 0.0, 0.0), **extra):
    scene = mb.Scene(settings(**extra))
    return scene, scene.add_object(block(velocity))
