"""The surgical tasks: tissue retraction with a grasper, an incision along a marked line with
a scalpel, and a curved needle driven to a target inside the tissue. Tissue is y up on a
floor it is bonded to (grid units: metres, seconds, newtons)."""

import numpy as np

from .base import SurgicalEnv, box_space
from .render import box_points

TISSUE = {"model": "NeoHookeanDecoupled", "youngsModulus": 2e4, "poissonRatio": 0.4, "density": 1000}
TISSUE_RGB, TOOL_RGB, TARGET_RGB = (215, 110, 105), (90, 100, 120), (40, 160, 60)


def _settings(lower, upper, dx):
    return {"domain": {"lower": list(lower), "upper": list(upper)}, "dx": dx, "gravity": [0.0, -9.81, 0.0],
            "solver": "MlsMpm"}


def _tracked(x, points):
    """The indices of the particles nearest `points` (first of equals): followed every step."""
    return np.array([int(np.argmin(np.sum((x - p) ** 2, axis=1))) for p in points])


def _limited(position, velocity, lower, upper, dt):
    """`velocity`, slowed per axis so that the tool stays within lower..upper over dt."""
    nxt = np.clip(position + velocity * dt, lower, upper)
    return (nxt - position) / dt


def _planar(points):
    return np.asarray(points, np.float32).reshape(-1)


class TissueRetractionEnv(SurgicalEnv):
    """Lift the free end of a tissue flap (10 x 2 x 4 cm, E 20 kPa, bonded to the floor under
    its left half, the right half overhanging) with a grasper whose two jaws are closed on its
    end (Bonded kinematic boxes above and below it) to a target point.

    Action (3,) in [-1, 1]: the grasper's velocity times 5 cm/s.
    Observation (63,): grasper position, velocity; target; the flap's end (the mean of the
    particles that were under the grasper); the force of the tissue on the grasper [N]; 16
    tracked points on the flap's top.
    Reward: the flap end's approach to the target over the step [cm]; terminated (+1) within
    5 mm of it."""

    settings = _settings((-0.09, -0.04, -0.06), (0.09, 0.1, 0.06), 0.01)
    speed = 0.05
    lower, upper = np.array([-0.02, 0.0, -0.02]), np.array([0.06, 0.07, 0.02])

    def __init__(self, **kwargs):
        self.action_space = box_space(3, -1.0, 1.0)
        self.observation_space = box_space(63)
        super().__init__(**kwargs)

    def _build(self):
        s = self.scene
        self.tissue = s.add_object({"primitive": "Box", "center": [0, 0.01, 0], "halfExtents": [0.05, 0.01, 0.02],
                                    "material": TISSUE})
        s.add_shape([{"type": "box", "halfExtents": [0.03, 0.005, 0.03]}], position=(-0.03, -0.005, 0),
                    contact={"mode": "bonded"})
        # two jaws closed on the flap's end, above and below it: the lower one carries it up
        jaw = {"type": "box", "halfExtents": [0.01, 0.004, 0.01]}
        self.grasper = s.add_shape([dict(jaw, position=[0, 0.014, 0]), dict(jaw, position=[0, -0.014, 0])],
                                   position=(0.035, 0.01, 0), contact={"mode": "bonded"})
        x = s.positions(self.tissue)
        self.end = np.flatnonzero((np.abs(x[:, 0] - 0.035) < 0.01) & (x[:, 1] > 0.01) & (np.abs(x[:, 2]) < 0.01))
        grid = [(u, 0.02, w) for u in np.linspace(-0.045, 0.045, 8) for w in (-0.01, 0.01)]
        self.points = _tracked(x, grid)

    def _edge(self):
        return self.scene.positions(self.tissue)[self.end].mean(axis=0)

    def _restart(self, rng):
        target = [float(rng.uniform(0.015, 0.035)), float(rng.uniform(0.035, 0.05)), 0.0]
        return {"target": target, "distance": float(np.linalg.norm(self._edge() - target))}

    def _move(self, a):
        p, q, _, _ = self.scene.shape_state(self.grasper)
        v = _limited(np.asarray(p, float), self.speed * a, self.lower, self.upper, self.action_dt)
        self.scene.set_shape_state(self.grasper, p, q, v)

    def _observe(self):
        p, _, v, _ = self.scene.shape_state(self.grasper)
        x = self.scene.positions(self.tissue)
        return np.concatenate([_planar(p), _planar(v), _planar(self.task["target"]), _planar(self._edge()),
                               self._force(self.scene.shape_impulse(self.grasper)), _planar(x[self.points])])

    def _score(self):
        d = float(np.linalg.norm(self._edge() - self.task["target"]))
        reward, self.task["distance"] = 100.0 * (self.task["distance"] - d), d
        return (reward + 1.0, True) if d < 0.005 else (reward, False)

    def _render_points(self):
        p = np.asarray(self.scene.shape_state(self.grasper)[0])
        jaws = [box_points(p + (0, y, 0), (0.01, 0.004, 0.01)) for y in (0.014, -0.014)]
        return [(self.scene.positions(self.tissue), TISSUE_RGB), (np.concatenate(jaws), TOOL_RGB),
                (box_points(self.task["target"], (0.002, 0.002, 0.002), 0.001), TARGET_RGB)]


class IncisionEnv(SurgicalEnv):
    """Cut along a line marked on a tissue block (12 x 3 x 6 cm, E 20 kPa, fracture toughness
    160 J/m^2, bonded to the floor) with a scalpel (a quad slicer, its edge down, cutting
    along x). The line runs along x from -4 to 4 cm at a depth z drawn per episode; the blade
    starts above its start, up to 5 mm off it.

    Action (3,) in [-1, 1]: the blade's velocity times 5 cm/s.
    Observation (62,): blade position (its edge's centre), velocity; the line (x start, x end,
    z); the edge's depth below the top; the progress along the line; the tissue's force on
    the blade [N]; 16 tracked points of the top along the line.
    Reward: the progress along the line over the step [cm] (the edge at least 5 mm deep and
    within 4 mm of the line), less 0.1 per cm off the line; terminated (+1) at the line's end."""

    settings = _settings((-0.1, -0.04, -0.07), (0.1, 0.1, 0.07), 0.01)
    speed = 0.05
    top = 0.03
    view = ((-0.075, -0.01), (0.075, 0.09))
    lower, upper = np.array([-0.06, 0.01, -0.025]), np.array([0.06, 0.05, 0.025])

    def __init__(self, **kwargs):
        self.action_space = box_space(3, -1.0, 1.0)
        self.observation_space = box_space(62)
        super().__init__(**kwargs)

    def _build(self):
        s = self.scene
        self.tissue = s.add_object({"primitive": "Box", "center": [0, 0.015, 0], "halfExtents": [0.06, 0.015, 0.03],
                                    "material": dict(TISSUE, fractureToughness=160)})
        s.add_shape([{"type": "box", "halfExtents": [0.08, 0.005, 0.04]}], position=(0, -0.005, 0),
                    contact={"mode": "bonded"})
        self.blade = s.add_quad_slicer(half_length=0.01, width=0.04, half_thickness=0.0002,
                                       position=(-0.05, self.top + 0.005, 0))
        self._x0 = s.positions(self.tissue)

    def _restart(self, rng):
        z = float(rng.uniform(-0.015, 0.015))
        start = (-0.05, self.top + 0.005, z + float(rng.uniform(-0.005, 0.005)))
        self.scene.set_slicer_state(self.blade, start, (0, 0, 0, 1))
        grid = [(u, self.top, z) for u in np.linspace(-0.04, 0.04, 16)]
        return {"line": [-0.04, 0.04, z], "progress": -0.04, "points": _tracked(self._x0, grid).tolist()}

    def _move(self, a):
        p, q, _, _ = self.scene.slicer_state(self.blade)
        v = _limited(np.asarray(p, float), self.speed * a, self.lower, self.upper, self.action_dt)
        self.scene.set_slicer_state(self.blade, p, q, v)

    def _observe(self):
        p, _, v, _ = self.scene.slicer_state(self.blade)
        t = self.task
        x = self.scene.positions(self.tissue)[t["points"]]
        return np.concatenate([_planar(p), _planar(v), _planar(t["line"]), _planar([self.top - p[1], t["progress"]]),
                               self._force(self.scene.slicer_impulse(self.blade)), _planar(x)])

    def _score(self):
        p = self.scene.slicer_state(self.blade)[0]
        t = self.task
        off = abs(p[2] - t["line"][2])
        before = t["progress"]
        if self.top - p[1] >= 0.005 and off <= 0.004:
            t["progress"] = float(min(max(before, p[0]), t["line"][1]))
        reward = 100.0 * (t["progress"] - before) - 10.0 * off
        return (reward + 1.0, True) if t["progress"] >= t["line"][1] else (reward, False)

    def _render_points(self):
        p = np.asarray(self.scene.slicer_state(self.blade)[0])
        line = np.c_[np.linspace(-0.04, 0.04, 41), np.full(41, self.top), np.full(41, self.task["line"][2])]
        return [(self.scene.positions(self.tissue), TISSUE_RGB), (line, TARGET_RGB),
                (box_points(p + (0, 0.02, 0), (0.01, 0.02, 0.0)), TOOL_RGB)]


class NeedleInsertionEnv(SurgicalEnv):
    """Drive a curved needle's tip (a half circle of radius 12 mm, wire 0.25 mm, puncture
    force 0.3 N) into a tissue block (6 x 2 x 4 cm, E 20 kPa, bonded to the floor) to a target
    point 4-10 mm under its top. The needle turns about its centre in its own plane (x-y).

    Action (3,) in [-1, 1]: the centre's velocity in x and y times 2 cm/s, the turn about z
    times 2 rad/s (positive: the tip goes down into the tissue).
    Observation (63,): the centre's position; cos and sin of the turn; the tip's position;
    the target; the tissue's force on the needle [N]; the tip inside the tissue (0 or 1); 16
    tracked points of the tissue's top.
    Reward: the tip's approach to the target over the step [cm]; terminated (+1) within 2 mm."""

    settings = _settings((-0.045, -0.02, -0.035), (0.045, 0.05, 0.035), 0.005)
    radius = 0.012
    top = 0.02
    lower, upper = np.array([-0.02, 0.015, 0.0]), np.array([0.02, 0.04, 0.0])

    def __init__(self, **kwargs):
        self.action_space = box_space(3, -1.0, 1.0)
        self.observation_space = box_space(63)
        super().__init__(**kwargs)

    def _build(self):
        s = self.scene
        self.tissue = s.add_object({"primitive": "Box", "center": [0, 0.01, 0], "halfExtents": [0.03, 0.01, 0.02],
                                    "material": dict(TISSUE, fractureToughness=200)})
        s.add_shape([{"type": "box", "halfExtents": [0.05, 0.005, 0.03]}], position=(0, -0.005, 0),
                    contact={"mode": "bonded"})
        self.needle = s.add_arc(radius=self.radius, start_angle=0.0, end_angle=np.pi, wire_radius=0.00025,
                                puncture_force=0.3, position=(0, self.top + 0.004, 0))
        grid = [(u, self.top, w) for u in np.linspace(-0.025, 0.025, 8) for w in (-0.01, 0.01)]
        self.points = _tracked(s.positions(self.tissue), grid)

    def _pose(self):
        p, q, _, _ = self.scene.curve_state(self.needle)
        return np.asarray(p, float), q, 2.0 * np.arctan2(q[2], q[3])

    def _tip(self):
        c, _, turn = self._pose()  # the tip at angle pi of the arc, turned about z
        return c + self.radius * np.array([np.cos(np.pi + turn), np.sin(np.pi + turn), 0.0])

    def _restart(self, rng):
        x = float(rng.uniform(-0.005, 0.005))
        self.scene.set_curve_state(self.needle, (x, self.top + 0.004, 0), (0, 0, 0, 1))
        target = [float(rng.uniform(-0.012, 0.0)), float(self.top - rng.uniform(0.004, 0.01)), 0.0]
        return {"target": target, "distance": float(np.linalg.norm(self._tip() - target))}

    def _move(self, a):
        c, q, _ = self._pose()
        v = _limited(c, 0.02 * np.array([a[0], a[1], 0.0]), self.lower, self.upper, self.action_dt)
        self.scene.set_curve_state(self.needle, c, q, v, (0.0, 0.0, 2.0 * a[2]))

    def _observe(self):
        c, _, turn = self._pose()
        x = self.scene.positions(self.tissue)
        return np.concatenate([_planar(c), _planar([np.cos(turn), np.sin(turn)]), _planar(self._tip()),
                               _planar(self.task["target"]), self._force(self.scene.curve_impulse(self.needle)),
                               _planar([float(self.scene.tip_inside(self.needle))]), _planar(x[self.points])])

    def _score(self):
        d = float(np.linalg.norm(self._tip() - self.task["target"]))
        reward, self.task["distance"] = 100.0 * (self.task["distance"] - d), d
        return (reward + 1.0, True) if d < 0.002 else (reward, False)

    def _render_points(self):
        c, _, turn = self._pose()
        angles = np.linspace(0.0, np.pi, 60) + turn
        arc = c + self.radius * np.c_[np.cos(angles), np.sin(angles), np.zeros(60)]
        return [(self.scene.positions(self.tissue), TISSUE_RGB), (arc, TOOL_RGB),
                (box_points(self.task["target"], (0.001, 0.001, 0.001), 0.0005), TARGET_RGB)]
