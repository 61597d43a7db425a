import mpm_bullet as mb
scene = mb.Scene({"domain": {"lower": [-0.1, -0.1, -0.1], "upper": [0.1, 0.2, 0.1]}, "dx": 0.01})
tissue = scene.add_object({"primitive": "Box", "center": [0, 0.05, 0], "halfExtents": [0.03, 0.03, 0.03],
                           "material": {"youngsModulus": 2e4, "poissonRatio": 0.3}})
tool = scene.add_shape([{"type": "sphere", "radius": 0.01}], position=(0, 0.095, 0),
                       orientation=(0, 0, 0, 1), linear_velocity=(0, -0.2, 0))  # (x, y, z, w)
scene.step(1 / 240)                         # the GIL is released while it runs
x = scene.positions(tissue)                 # (N, 3) float32; also velocities(), deformation_gradients() (N, 3, 3)
scene.positions(tissue, out=x)              # fills your array, allocates nothing
impulse, angular = scene.shape_impulse(tool)
state = scene.save_bytes()                  # scene.load_bytes(state): continues bit for bit
