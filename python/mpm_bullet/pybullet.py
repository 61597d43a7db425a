"""Tissue in a pybullet world: two-way coupling of an mpm_bullet.Scene with pybullet bodies.

    import pybullet as p, mpm_bullet as mb
    from mpm_bullet.pybullet import Coupler
    client = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.81)                        # z up: give the scene the same
    scene = mb.Scene({"domain": {...}, "dx": 0.01, "gravity": [0, 0, -9.81]})
    scene.add_object({...})                          # the tissue
    coupler = Coupler(client, scene)
    coupler.add_body(p.loadURDF("gripper.urdf"))     # every link with a collision shape
    for _ in range(240):
        coupler.step()                               # instead of p.stepSimulation()

Each coupled link's collision shapes become one MPM shape whose parts are the link's
collision shapes (box, sphere, capsule, cylinder, plane; a mesh, which pybullet collides
with as the convex hull of its vertices, as that hull). The shape's frame is the link's
centre-of-mass (inertial) frame, the frame pybullet reports poses and velocities in and
gives collision frames relative to (getCollisionShapeData; checked for bases and links).

How a link takes part (add_body's `mode`; None picks by the body):
- "dynamic" (default for every link of a body with a free base): a dynamic shape with the
  link's mass, principal inertia and the world's gravity, as the C++ coupler
  (mpm_bullet/coupler.h) makes a Bullet body with mass. Within a step the tissue moves it
  as a free body would (implicitly), and its momentum goes back to the link.
- "held" (default for the links of a fixed-base robot, e.g. loadURDF(useFixedBase=True)):
  a kinematic shape that moves with the link's velocity, and the momentum the grid gave it
  goes back to the link. Its joints and motors hold such a link, which a free body in the
  scene cannot express: as a dynamic shape it would fall with gravity within every step
  and drag the tissue it carries down with it (measured: a 6 cm tissue block on a 0.3 kg
  pad welded to a fixed base sank 2 cm in 0.45 s; "held", it rests as on a static pad). The
  coupling is explicit: stable while the drive is stiff against the tissue it touches.
- "static": a link without mass (a static body, a fixed base): a kinematic shape that
  moves with the velocity pybullet reports for it; nothing goes back.

What Coupler.step() does, in this order, and why:
 1. each coupled link's shape takes the link's pose and velocities as pybullet left them
    after its last step;
 2. the tissue advances over pybullet's time step (fixedTimeStep; all of it, whatever
    numSubSteps) with its own substeps. Inside, a dynamic shape falls with gravity and its
    velocity is updated implicitly with the mass of the nodes it touches, so the tissue's
    push is felt within the step and a body lighter than the tissue settles instead of
    oscillating;
 3. the momentum J the grid gave each dynamic or held shape goes to its link as a force
    J / dt at its centre of mass and a torque (world frame); pybullet holds an external
    force over the whole stepSimulation (each of its numSubSteps) and clears it
    afterwards, so the link receives exactly J;
 4. p.stepSimulation(): pybullet integrates v += (g + F / m) dt before it moves the body,
    so J arrives before this step's integration, as the C++ coupler's impulse does before
    Bullet's tick. Applied after pybullet had already moved the body with this step's
    gravity, a resting body would creep into the tissue by g dt^2 every step.
With tissue_interval n > 1, steps 1-2 happen at the first step of each n, over n steps of
time, and step 3 applies 1/n of that advance's momentum at every step of the n.

Not handled: bodies loaded with useMaximalCoordinates (pybullet cannot report their
collision shapes; refused), heightfields, concave triangle meshes (taken as their hull),
pybullet's own damping (linearDamping / angularDamping, 0.04 by default: it still acts on
the body; set it to 0 with changeDynamics for conservation checks). A body moved by
resetBasePositionAndOrientation should also be given its velocity (resetBaseVelocity):
the tissue sees a kinematic shape through its velocity. Angular momentum about the origin
is not kept exactly during contact: the scene moves a dynamic shape through its substeps,
while J is applied where the centre of mass was at the step's start (as the C++ coupler
applies it; 2.5 % of L0 in tests/python/test_pybullet_physics.py's thrown sphere).
Blades and needles fixed in a link are coupled (add_slicer, add_needle, as the C++
coupler's addSlicer, addNeedle); threads (addThread) not yet.
"""

import warnings

import numpy as np
import pybullet as _p

import mpm_bullet as _mb

__all__ = ["Coupler", "convex_hull"]


def _invalid(field, value, why):
    """mpm_bullet.InvalidArgument with the C++ message form 'field = value: why'."""
    e = _mb.InvalidArgument(f"{field} = {value}: {why}")
    e.field, e.value = field, str(value)
    return e


def convex_hull(points):
    """Triangles (M, 3) of the convex hull of `points` (N, 3), outward (counter-clockwise),
    and the hull's vertices: (vertices, triangles). Incremental; meant for the few hundred
    vertices of a collision mesh. Raises ValueError when the points are flat."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(pts) < 4:
        raise ValueError(f"{len(pts)} points: a hull needs 4 not in a plane")
    scale = float(np.ptp(pts, axis=0).max())
    eps = 1e-9 * max(scale, 1e-30)
    # a first tetrahedron from extreme points
    i0 = int(np.argmin(pts[:, 0]))
    i1 = int(np.argmax(np.linalg.norm(pts - pts[i0], axis=1)))
    line = pts[i1] - pts[i0]
    i2 = int(np.argmax(np.linalg.norm(np.cross(pts - pts[i0], line), axis=1)))
    normal = np.cross(line, pts[i2] - pts[i0])
    height = (pts - pts[i0]) @ normal
    i3 = int(np.argmax(np.abs(height)))
    if abs(height[i3]) <= eps * np.linalg.norm(normal) or np.linalg.norm(normal) <= eps * scale:
        raise ValueError("the points are flat (no tetrahedron): a hull needs a thickness")
    faces = [(i0, i1, i2), (i0, i2, i3), (i0, i3, i1), (i1, i3, i2)]
    if height[i3] > 0:  # make the first face's normal point away from i3
        faces = [(a, c, b) for a, b, c in faces]
    faces = np.array(faces)
    rest = [k for k in range(len(pts)) if k not in (i0, i1, i2, i3)]
    # farthest points first: later ones are mostly inside and skipped
    centre = pts[[i0, i1, i2, i3]].mean(axis=0)
    rest.sort(key=lambda k: -np.linalg.norm(pts[k] - centre))
    for k in rest:
        a, b, c = pts[faces[:, 0]], pts[faces[:, 1]], pts[faces[:, 2]]
        n = np.cross(b - a, c - a)
        visible = np.einsum("ij,ij->i", n, pts[k] - a) > eps * np.linalg.norm(n, axis=1)
        if not visible.any():
            continue
        edges = {(int(f[e]), int(f[(e + 1) % 3])) for f in faces[visible] for e in range(3)}
        horizon = [(u, v) for (u, v) in edges if (v, u) not in edges]
        faces = np.vstack([faces[~visible], [(u, v, k) for u, v in horizon]])
    used, triangles = np.unique(faces, return_inverse=True)
    return pts[used], triangles.reshape(-1, 3)


def _plane_orientation(normal):
    """Quaternion (x, y, z, w) turning +y (the MPM plane's outward normal) onto `normal`."""
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    y = np.array([0.0, 1.0, 0.0])
    if n @ y < -0.9999:
        return (1.0, 0.0, 0.0, 0.0)  # half a turn about x
    axis = np.cross(y, n)
    w = 1.0 + n @ y
    q = np.array([axis[0], axis[1], axis[2], w])
    return tuple(q / np.linalg.norm(q))


MODES = ("dynamic", "held", "static")


class _Link:
    __slots__ = ("body", "link", "shape", "mode", "desc")

    def __init__(self, body, link, shape, mode, desc):
        self.body, self.link, self.shape, self.mode, self.desc = body, link, shape, mode, desc

    @property
    def dynamic(self):
        return self.mode == "dynamic"


class _Tool:
    """A blade or needle fixed in a link: its frame in the link's centre-of-mass frame."""
    __slots__ = ("body", "link", "kind", "id", "local", "feedback")

    def __init__(self, body, link, kind, id, local, feedback):
        self.body, self.link, self.kind, self.id, self.local, self.feedback = body, link, kind, id, local, feedback


class Coupler:
    """Couples bodies and links of the pybullet world `client_id` to `scene`; call step()
    instead of p.stepSimulation(). The scene's gravity should be pybullet's (the first
    step warns when it is not: pybullet is z-up, the scene's default gravity is along -y).
    An error from the scene (e.g. SimulationDiverged) leaves pybullet unstepped."""

    def __init__(self, client_id, scene, sdf_cell_size=None):
        if not _p.isConnected(physicsClientId=client_id):
            raise _invalid("Coupler client_id", client_id, "no pybullet client is connected with this id")
        self.client = client_id
        self.scene = scene
        self.sdf_cell_size = sdf_cell_size
        self._links = []
        self._tools = []
        self._gravity = self._world_gravity()
        self._gravity_checked = False
        self.last_dt = 0.0
        self._interval = 1
        self._interval_step = 0  # steps of the open interval done (0: the next step advances)
        self._shares = []        # (body, link, tool or None, force, torque) of the open interval
        self.tissue_advanced = False

    @property
    def tissue_interval(self):
        """pybullet steps per tissue advance (1, the default: every step). With n the tissue
        advances once every n steps, over all n, from the links' states at the first; the
        momentum it gave each link arrives as a force over each of the n steps (1/n of it
        per step), so the link has all of it when the interval closes. PB-MPM takes its own
        step this way (its stiffness is its iterations per unit time). As
        Coupler::setTissueInterval in C++: set it between intervals. After a step that
        advanced (tissue_advanced), the scene's impulses are that advance's, over
        n * last_dt."""
        return self._interval

    @tissue_interval.setter
    def tissue_interval(self, n):
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise _invalid("Coupler.tissue_interval", n, "must be an int >= 1")
        if self._interval_step != 0:
            raise _invalid("Coupler.tissue_interval", n, f"cannot change while an interval is open (the scene is "
                           f"{self._interval - self._interval_step} step(s) ahead of pybullet)")
        self._interval = n

    # -- reading pybullet -------------------------------------------------------------
    def _world_gravity(self):
        q = _p.getPhysicsEngineParameters(physicsClientId=self.client)
        return (q["gravityAccelerationX"], q["gravityAccelerationY"], q["gravityAccelerationZ"])

    def _parts(self, body, link, cell):
        """The link's collision shapes as MPM shape parts, in its centre-of-mass frame."""
        try:
            shapes = _p.getCollisionShapeData(body, link, physicsClientId=self.client)
        except _p.error as e:
            raise _invalid(f"Coupler.add_body body {body} link {link}", "collision shapes",
                           f"pybullet cannot report them ({e}); load the body without "
                           "useMaximalCoordinates") from None
        parts = []
        for k, s in enumerate(shapes):
            kind, dims, pos, orn = s[2], s[3], s[5], s[6]
            where = f"body {body} link {link} collision shape {k}"
            part = {"position": list(pos), "orientation": list(orn)}
            if kind == _p.GEOM_SPHERE:
                part.update(type="sphere", radius=dims[0])
            elif kind == _p.GEOM_BOX:
                part.update(type="box", halfExtents=[0.5 * d for d in dims])
            elif kind in (_p.GEOM_CAPSULE, _p.GEOM_CYLINDER):  # (length, radius) along local z
                part.update(type="capsule" if kind == _p.GEOM_CAPSULE else "cylinder",
                            radius=dims[1], halfHeight=0.5 * dims[0], axis=2)
            elif kind == _p.GEOM_PLANE:
                part.update(orientation=list(_quat_mul(orn, _plane_orientation(dims))), type="plane")
            elif kind == _p.GEOM_MESH:
                # getMeshData gives the scaled vertices already in the centre-of-mass frame
                _, verts = _p.getMeshData(body, link, collisionShapeIndex=k, physicsClientId=self.client)
                try:
                    v, t = convex_hull(verts)
                except ValueError as e:
                    raise _invalid(where, "mesh", f"{e}") from None
                part = {"type": "mesh", "vertices": v.astype(np.float32), "triangles": t.astype(np.int32)}
                if cell is not None:
                    part["cellSize"] = cell
            else:
                raise _invalid(where, f"geometry type {kind}",
                               "cannot be coupled (supported: sphere, box, capsule, cylinder, plane, mesh)")
            parts.append(part)
        return parts

    def _states(self, body, links):
        """(position, orientation, linear velocity, angular velocity) of each centre of mass."""
        out = []
        idx = [l for l in links if l >= 0]
        states = dict(zip(idx, _p.getLinkStates(body, idx, computeLinkVelocity=1, computeForwardKinematics=1,
                                                  physicsClientId=self.client))) if idx else {}
        for l in links:
            if l < 0:
                pos, orn = _p.getBasePositionAndOrientation(body, physicsClientId=self.client)
                v, w = _p.getBaseVelocity(body, physicsClientId=self.client)
                out.append((pos, orn, v, w))
            else:
                s = states[l]
                out.append((s[0], s[1], s[6], s[7]))
        return out

    # -- coupling ---------------------------------------------------------------------
    def add_body(self, body_id, link_index=None, contact=None, mode=None, sdf_cell_size=None):
        """Couples link `link_index` of `body_id` (-1: the base; None: the base and every
        link that has collision shapes). `contact`: {"mode", "friction", "drag", "band"}
        as the scene's shapes take it; friction unset: the link's pybullet lateral
        friction. `mode`: "dynamic", "held" or "static" (see the module's docstring); None:
        "static" for a link without mass, else "held" on a body whose base has no mass
        (a fixed base), else "dynamic". Returns the ShapeIds, one per coupled link, base
        first."""
        if mode is not None and mode not in MODES:
            raise _invalid("Coupler.add_body mode", repr(mode), "must be None, 'dynamic', 'held' or 'static'")
        n = _p.getNumJoints(body_id, physicsClientId=self.client)  # raises for an unknown body
        links = list(range(-1, n)) if link_index is None else [link_index]
        for l in links:
            if not -1 <= l < n:
                raise _invalid("Coupler.add_body link_index", l, f"body {body_id} has links -1 (base) to {n - 1}")
            if self._find(body_id, l) is not None:
                raise _invalid("Coupler.add_body link_index", l, f"body {body_id}'s link is already coupled")
        cell = sdf_cell_size if sdf_cell_size is not None else self.sdf_cell_size
        base_mass = _p.getDynamicsInfo(body_id, -1, physicsClientId=self.client)[0]  # 0: a fixed base
        ids = []
        for l, (pos, orn, v, w) in zip(links, self._states(body_id, links)):
            parts = self._parts(body_id, l, cell)
            if not parts:
                if link_index is None:
                    continue  # e.g. a fixed base's root without geometry
                raise _invalid("Coupler.add_body link_index", l, f"body {body_id}'s link has no collision shape")
            info = _p.getDynamicsInfo(body_id, l, physicsClientId=self.client)
            mass, friction, inertia = info[0], info[1], info[2]
            c = dict(contact or {})
            c.setdefault("friction", friction)
            desc = dict(parts=parts, contact=c)
            m = mode
            if m is None:
                m = "static" if mass <= 0 else "held" if base_mass <= 0 else "dynamic"
            if m != "static" and mass <= 0:
                raise _invalid("Coupler.add_body mode", repr(m), f"body {body_id} link {l} has no mass: only 'static'")
            if m == "dynamic":
                desc.update(mass=mass, inertia=tuple(inertia))
            link = _Link(body_id, l, None, m, desc)
            link.shape = self._add_shape(link, (pos, orn, v, w))
            self._links.append(link)
            ids.append(link.shape)
        return ids

    def _add_shape(self, link, state):
        pos, orn, v, w = state
        extra = {"gravity": self._gravity} if link.dynamic else {}
        return self.scene.add_shape(position=pos, orientation=orn, linear_velocity=v, angular_velocity=w,
                                    **link.desc, **extra)

    def _find(self, body, link):
        for k, l in enumerate(self._links):
            if l.body == body and l.link == link:
                return k
        return None

    def remove(self, body_id, link_index=None):
        """Stops coupling a link (None: all of the body's coupled links); their shapes,
        blades and needles leave the scene."""
        tools = []
        for t in self._tools:
            if t.body == body_id and (link_index is None or t.link == link_index):
                (self.scene.remove_slicer if t.kind == "slicer" else self.scene.remove_curve)(t.id)
            else:
                tools.append(t)
        self._tools = tools
        keep = []
        for l in self._links:
            if l.body == body_id and (link_index is None or l.link == link_index):
                self.scene.remove_shape(l.shape)
            else:
                keep.append(l)
        self._links = keep
        # what the open interval still owed them goes with them
        self._shares = [x for x in self._shares if not (x[0] == body_id and (link_index is None or x[1] == link_index))]

    def shape_of(self, body_id, link_index=-1):
        """ShapeId of a coupled link, e.g. for scene.shape_impulse."""
        k = self._find(body_id, link_index)
        if k is None:
            raise _invalid("Coupler.shape_of", f"body {body_id} link {link_index}", "not coupled")
        return self._links[k].shape

    def add_slicer(self, body_id, link_index=-1, pose=((0, 0, 0), (0, 0, 0, 1)), **blade):
        """Couples a link as a scalpel, as the C++ Coupler::addSlicer: a quad blade
        (scene.add_quad_slicer's keywords: half_length, width, spine_radius, half_thickness,
        friction) whose frame is `pose` (position, orientation (x, y, z, w)) in the link's
        centre-of-mass frame. Every step the blade takes the link's motion, and a link with
        mass receives what the tissue gave the blade (contact and the resistance to cutting)
        as a force at the blade frame's origin and a torque. The link's collision shapes are
        not coupled by this (add_body does that). Returns the SlicerId."""
        return self._add_tool(body_id, link_index, pose, "slicer", self.scene.add_quad_slicer, blade)

    def add_needle(self, body_id, link_index=-1, pose=((0, 0, 0), (0, 0, 0, 1)), **arc):
        """Couples a link as a suture needle, as the C++ Coupler::addNeedle: an arc
        (scene.add_arc's keywords: radius, start_angle, end_angle, wire_radius, friction,
        puncture_force) whose frame is `pose` in the link's centre-of-mass frame. The needle
        is kinematic in the scene, so the coupling is explicit: the link must be heavier
        than the tissue it drags (see mpm_bullet/coupler.h). Returns the CurveId."""
        return self._add_tool(body_id, link_index, pose, "needle", self.scene.add_arc, arc)

    def _add_tool(self, body, link, pose, kind, add, desc):
        n = _p.getNumJoints(body, physicsClientId=self.client)
        if not -1 <= link < n:
            raise _invalid(f"Coupler.add_{'slicer' if kind == 'slicer' else 'needle'} link_index", link,
                           f"body {body} has links -1 (base) to {n - 1}")
        local = (tuple(pose[0]), tuple(pose[1]))
        tool = _Tool(body, link, kind, None, local, _p.getDynamicsInfo(body, link, physicsClientId=self.client)[0] > 0)
        p, q, v, w = self._tool_state(tool, self._states(body, [link])[0])
        tool.id = add(position=p, orientation=q, linear_velocity=v, angular_velocity=w, **desc)
        self._tools.append(tool)
        return tool.id

    @staticmethod
    def _tool_state(tool, state):
        """The tool frame's pose and the velocities of its origin, from its link's state."""
        com, orn, v, w = state
        p, q = _p.multiplyTransforms(com, orn, *tool.local)
        return p, q, tuple(np.add(v, np.cross(w, np.subtract(p, com)))), w

    def step(self):
        """One pybullet step with the tissue; see the module's docstring for the order."""
        params = _p.getPhysicsEngineParameters(physicsClientId=self.client)
        dt = params["fixedTimeStep"]
        gravity = (params["gravityAccelerationX"], params["gravityAccelerationY"], params["gravityAccelerationZ"])
        wanted = {}
        for l in self._links + self._tools:
            wanted.setdefault(l.body, set()).add(l.link)
        now = {}  # (body, link) -> (centre of mass, orientation, linear and angular velocity)
        for body, links in wanted.items():
            links = sorted(links)
            now.update(((body, l), s) for l, s in zip(links, self._states(body, links)))
        self.tissue_advanced = self._interval_step == 0
        if self.tissue_advanced:
            self._advance(dt, now, gravity)
        self.last_dt = dt
        # 3. each link's share: a force over this step at its centre of mass (where it still
        # is: pybullet has not moved it since it was read), a blade's or needle's at its
        # frame's origin
        for body, link, tool, force, torque in self._shares:
            pos = (self._tool_state(tool, now[body, link]) if tool else now[body, link])[0]
            _p.applyExternalForce(body, link, force, pos, _p.WORLD_FRAME, physicsClientId=self.client)
            _p.applyExternalTorque(body, link, torque, _p.WORLD_FRAME, physicsClientId=self.client)
        self._interval_step = (self._interval_step + 1) % self._interval
        # 4. pybullet integrates with the tissue's push in
        _p.stepSimulation(physicsClientId=self.client)

    def _advance(self, dt, now, gravity):
        """Steps 1-2, and the shares of step 3 for the interval's steps."""
        n = self._interval
        # 1. shapes, blades and needles take the links' poses and velocities
        states = [(l, now[l.body, l.link]) for l in self._links]
        tools = [(t, self._tool_state(t, now[t.body, t.link])) for t in self._tools]
        for t, s in tools:
            (self.scene.set_slicer_state if t.kind == "slicer" else self.scene.set_curve_state)(t.id, *s)
        if not self._gravity_checked:  # a z-up pybullet world with the scene's default (0, -9.81, 0)?
            self._gravity_checked = True
            if not np.allclose(self.scene.gravity, gravity, rtol=1e-5, atol=1e-6):
                warnings.warn(f"the scene's gravity {tuple(float(g) for g in self.scene.gravity)} is not pybullet's "
                              f"{gravity}: the tissue falls another way than the bodies (give the scene's settings "
                              f"\"gravity\": {list(gravity)})", stacklevel=3)
        regravitate = gravity != self._gravity  # the world's gravity changed: dynamic shapes take it
        self._gravity = gravity
        for l, s in states:
            if l.dynamic and regravitate:
                self.scene.remove_shape(l.shape)
                l.shape = self._add_shape(l, s)
            else:
                self.scene.set_shape_state(l.shape, *s)
        # 2. the tissue advances over the interval's steps
        self.scene.step(dt * n)
        # 3. the grid's momentum, a share per step, as a force over it (J / (n dt): J / dt
        # bit for bit with an interval of one step)
        span = dt * n
        self._shares = []
        for l, _ in states:
            if l.mode == "static":
                continue
            linear, angular = self.scene.shape_impulse(l.shape)
            self._shares.append((l.body, l.link, None, [float(j) / span for j in linear],
                                 [float(j) / span for j in angular]))
        # a blade's or needle's momentum is given about its frame's origin
        for t, _ in tools:
            if not t.feedback:
                continue
            linear, angular = (self.scene.slicer_impulse if t.kind == "slicer" else self.scene.curve_impulse)(t.id)
            self._shares.append((t.body, t.link, t, [float(j) / span for j in linear],
                                 [float(j) / span for j in angular]))

def _quat_mul(a, b):
    """Hamilton product of quaternions in pybullet's (x, y, z, w) order."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)
