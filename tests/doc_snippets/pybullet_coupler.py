import pybullet as p
import mpm_bullet as mb
from mpm_bullet.pybullet import Coupler

client = p.connect(p.DIRECT)
p.setGravity(0, 0, -9.81)  # pybullet is z-up: the scene gets the same gravity
scene = mb.Scene({"domain": {"lower": [-0.1, -0.1, -0.02], "upper": [0.1, 0.1, 0.2]},
                  "dx": 0.01, "gravity": [0, 0, -9.81]})
cube = scene.add_object({"primitive": "Box", "center": [0, 0, 0.0205], "halfExtents": [0.02, 0.02, 0.02],
                         "material": {"youngsModulus": 3e4, "poissonRatio": 0.4, "density": 1000}})
coupler = Coupler(client, scene)
coupler.add_body(p.createMultiBody(0, p.createCollisionShape(p.GEOM_PLANE)))  # the ground
gripper = p.loadURDF("demos/python/gripper.urdf", [0, 0, 0.18], useFixedBase=True)
coupler.add_body(gripper, contact={"friction": 1.0})  # every link with a collision shape
for _ in range(240):
    coupler.step()  # instead of p.stepSimulation()
x = scene.positions(cube)  # (N, 3) float32
