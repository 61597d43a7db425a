#pragma once
// Rigid bodies in the grid's contact: their motion and contact model, the momentum the
// grid's nodes exchange with them, the implicit update of a dynamic body's velocity from
// it, and the placement of their parts as they move.
#include "core/symmetric3.h"
#include "shapes/part_view.h"

namespace mpm {

/// kContactCurve: a curve's (mpm/curves.h): within the contact region only the slip along
/// the curve's tangent survives (curveVelocity).
enum : int { kContactFrictional = 0, kContactSticky = 1, kContactBonded = 2, kContactCurve = 3 };

/// Rigid motion and contact model of one shape.
struct BodyView {
  Vec3f com;            ///< centre of mass, world [m]
  Mat3f rotation;       ///< shape frame -> world
  Vec3f linearVelocity; ///< of the centre of mass [m/s]
  Vec3f angularVelocity;///< world [rad/s]
  Vec3f shapeOrigin;    ///< world position of the shape frame's origin [m]
  int mode = kContactFrictional;
  float friction = 0.f, drag = 1.f, band = 0.f;
  /// Bonded on a grid: how far from the body's parts material that touched it stays glued
  /// to it (push_out.h, pushOutOfParts) [m]; 0: nothing is glued
  float glueReach = 0.f;
  int dynamic = 0;      ///< 1: velocity responds to the grid within the step
  float mass = 0.f;     ///< [kg] (dynamic)
  Vec3f inertia;        ///< principal moments in the shape frame [kg m^2] (dynamic)
  Vec3f gravity;        ///< acceleration between substeps [m/s^2] (dynamic)
  Vec3f comLocal;       ///< centre of mass in the shape frame [m]
  Vec3f v0, w0;         ///< velocities at the start of the substep (implicit update)
  float substepDt = 0.f;///< [s] the time this exchange stands for (the substep, or PB-MPM's share of it): a needle's shaft friction acts over it
  /// Motion since the shapes were uploaded: the centre of mass's displacement, and the
  /// rotation as R(t) R(upload)^T - I. Kept apart from the pose (small numbers, exactly 0
  /// for a body at rest), they place the parts (placePart) without the float rounding of a
  /// pose far from the domain (a static ground's centre 50 m below: 4e-6 m). Summed in
  /// double, once per body per substep, so their rounding does not grow with the number of
  /// substeps whatever the lever (a float turn loses ulp(turn) x 50 m a substep).
  double travel[3] = {0, 0, 0};
  double turn[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  /// Mass and inertia about the centre of mass (xx, yy, zz, xy, xz, yz) of the nodes the
  /// first measuring pass of the substep found in contact; negative mass: not measured yet
  /// (predictBodyVelocity)
  float contactMass = -1.f;
  float contactInertia[6] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f};

  MPM_HD Vec3f velocityAt(Vec3f x) const { return linearVelocity + cross(angularVelocity, x - com); }
};

/// Momentum a node exchanges with a body, accumulated per body: the impulse on the
/// body, its moment about the body's centre of mass, and the mass and inertia of the
/// nodes in contact (the "effective mass" of the implicit velocity update).
struct ContactSums {
  float impulse[3];
  float angular[3];
  float mass;
  float inertia[6];  ///< xx, yy, zz, xy, xz, yz about the body's centre of mass
};
constexpr int kContactSumFloats = 13;

MPM_HD void addContact(ContactSums& s, Vec3f dp, Vec3f r, float m) {
  const Vec3f h = cross(r, dp);
  s.impulse[0] += dp.x; s.impulse[1] += dp.y; s.impulse[2] += dp.z;
  s.angular[0] += h.x; s.angular[1] += h.y; s.angular[2] += h.z;
  s.mass += m;
  s.inertia[0] += m * (r.y * r.y + r.z * r.z);
  s.inertia[1] += m * (r.x * r.x + r.z * r.z);
  s.inertia[2] += m * (r.x * r.x + r.y * r.y);
  s.inertia[3] -= m * r.x * r.y;
  s.inertia[4] -= m * r.x * r.z;
  s.inertia[5] -= m * r.y * r.z;
}

/// World inertia tensor of a body as xx, yy, zz, xy, xz, yz.
MPM_HD void worldInertia(const BodyView& b, float out[6]) {
  const Mat3f& R = b.rotation;
  Mat3f I;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      I.m[i][j] = R.m[i][0] * b.inertia.x * R.m[j][0] + R.m[i][1] * b.inertia.y * R.m[j][1] +
                  R.m[i][2] * b.inertia.z * R.m[j][2];
  out[0] = I.m[0][0]; out[1] = I.m[1][1]; out[2] = I.m[2][2];
  out[3] = I.m[0][1]; out[4] = I.m[0][2]; out[5] = I.m[1][2];
}

/// exp([w dt]x) - I (Rodrigues), the change of a rotation over dt; false (and E untouched)
/// when the angle is negligible.
MPM_HD bool rotationChange(Vec3f w, float dt, Mat3f& E) {
  const float angle = norm(w) * dt;
  if (angle < 1e-12f) return false;
  const Vec3f k = (1.f / norm(w)) * w;
  // 1 - cos as 2 sin^2(angle / 2): cosf of a small angle rounds to 1 (below 3e-4 rad), which
  // dropped the second-order term of every substep's rotation (a face 50 m from the centre
  // of mass drifted 5e-7 m in 200 substeps at 0.01 rad/s)
  const float s = sinf(angle), h = sinf(0.5f * angle), oneMinusCos = 2.f * h * h;
  Mat3f K;
  K.m[0][1] = -k.z; K.m[0][2] = k.y; K.m[1][0] = k.z; K.m[1][2] = -k.x; K.m[2][0] = -k.y; K.m[2][1] = k.x;
  E = s * K + oneMinusCos * (K * K);
  return true;
}

/// R <- exp([w dt]x) R (Rodrigues), integrating a body's orientation inside a step.
MPM_HD Mat3f rotateBy(const Mat3f& R, Vec3f w, float dt) {
  Mat3f E;
  if (!rotationChange(w, dt, E)) return R;
  return (Mat3f::identity() + E) * R;
}

/// Implicit velocity prediction of a dynamic body from pass 0: the body and the nodes it
/// touches move on together, V' = V + J / (M + M_c), w' = w + (I + I_c)^-1 H. With the
/// nodes then projected against V', a body lighter than the tissue it touches receives
/// M / (M + M_c) of the momentum an immovable body would: no overshoot, no oscillation.
/// Repeated, pass 0 measuring against the last prediction, it is a chord step on the
/// body's momentum balance M (V - v0) = J(V), J(V) what the nodes give a body moving at V:
/// V += (J(V) - M (V - v0)) / (M + M_c), with the M_c (and I_c) of the first pass. Not
/// Newton's M_c(V): nodes that move with a predicted body do not approach it, M_c(V) falls
/// toward zero and the step throws the body back toward v0 (with two Newton steps 0.2 g
/// capsules fell through a 6-cell block on standard MPM; the first pass's contact mass,
/// the largest, does not overshoot).
MPM_HD void predictBodyVelocity(BodyView& b, const ContactSums& s) {
  if (!b.dynamic) return;
  if (b.contactMass < 0.f) {
    b.contactMass = s.mass;
    for (int k = 0; k < 6; ++k) b.contactInertia[k] = s.inertia[k];
  }
  const Vec3f J{s.impulse[0], s.impulse[1], s.impulse[2]};
  b.linearVelocity =
      b.linearVelocity + (1.f / (b.mass + b.contactMass)) * (J - b.mass * (b.linearVelocity - b.v0));
  if (b.mode == kContactCurve) return;  // a thread's segment does not turn in the scene (settleBodyVelocity)
  float I[6];
  worldInertia(b, I);
  const Vec3f H = Vec3f{s.angular[0], s.angular[1], s.angular[2]} - symmetricTimes(I, b.angularVelocity - b.w0);
  for (int k = 0; k < 6; ++k) I[k] += b.contactInertia[k];
  b.angularVelocity = b.angularVelocity + inverseSymmetric(I) * H;
}

/// Steps of the prediction per substep (predictBodyVelocity). One is exact while the nodes
/// touching the body stay the same, but contact cannot pull: nodes that approached the
/// immovable body of pass 0 and separate from the predicted one give nothing in pass 1,
/// and a body much lighter than those nodes then settles far from its prediction (a 0.2 g
/// capsule dropped on a 30 kPa block, standard MPM, M_c / M = 6.5: predicted w -0.30 rad/s,
/// settled 18 rad/s; in another substep V predicted near rest, settled +0.75 m/s). Such
/// kicks spun it to 138 rad/s and threw it 2.7 cells up; on PB-MPM (ten exchanges a
/// substep) one stood on its end and blew the tissue up (J = -17 at 2.3 s). Measured in
/// ThinCapsules (0.2 g capsules of radius 0.2 / 0.4 / 0.6 dx, bottom above the block's
/// top): one step, standard MPM -6.1 (fell through) / -0.17 / -0.26 dx, PB-MPM 0.6 dx
/// -0.38 dx; two: 0.36 / 0.16 / -0.24 dx; three: 0.36 / 0.16 / -0.04 dx, PB-MPM -0.04 dx.
constexpr int kBodyPredictionSteps = 3;

/// Before the contact passes: the substep's length `dt`, a dynamic body's gravity for it (none for `gravityDt` 0),
/// then the velocities its exchange starts from (v0, w0). Gravity must come before the
/// contact so the contact can take it back; added after, a resting body would step
/// g dt^2 into the tissue every substep (measured: 3.4 mm/s of steady sinking).
MPM_HD void startBodyExchange(BodyView& b, float dt, float gravityDt) {
  b.substepDt = dt;
  if (!b.dynamic) return;
  b.linearVelocity += gravityDt * b.gravity;
  b.v0 = b.linearVelocity;
  b.w0 = b.angularVelocity;
  b.contactMass = -1.f;
}

/// After pass 1: the body's velocity from the momentum it actually received (so total
/// momentum is conserved exactly). Returns the angular impulse the body took.
///
/// A thread's segment (a dynamic kContactCurve body) is not turned by the material inside
/// the scene, and takes no angular impulse from it: its turn is its chain's (Bullet's
/// joints, set before each advance from its points' velocities); the material acts on the
/// chain through each segment's linear impulse, so a bend along the thread is resisted
/// segment by segment. Measured: the angular impulse of the unturning segment, I_c / I
/// times what the segment can take (hundreds: 2.5 mm at 0.05 g/m is 6.5e-14 against ~3e-11
/// kg m^2 of nodes), handed to its Bullet link whipped the chain at 8 m/s within 3 ticks
/// (a thread pinned to a holder drawn sideways through tissue); turning the segment in the
/// scene, predicted or settled (w0 + I^-1 H), made its linear exchange blow up within a
/// tick (1e3 m/s: the nodes' answer to a turn is not the one the prediction assumes); the
/// implicit share I (I + I_c)^-1 H given every substep drove the links 1.4 times faster
/// than the block dragging them. The angular impulse the material got from a segment is
/// angular momentum not conserved; linear momentum is, exactly.
MPM_HD Vec3f settleBodyVelocity(BodyView& b, const ContactSums& s) {
  const Vec3f H{s.angular[0], s.angular[1], s.angular[2]};
  if (!b.dynamic) return H;
  b.linearVelocity = b.v0 + (1.f / b.mass) * Vec3f{s.impulse[0], s.impulse[1], s.impulse[2]};
  if (b.mode == kContactCurve) return Vec3f{0.f, 0.f, 0.f};
  float I[6];
  worldInertia(b, I);
  b.angularVelocity = b.w0 + inverseSymmetric(I) * H;
  return H;
}

/// At the end of a substep: the body's pose advanced by dt at its velocity.
MPM_HD void moveBody(BodyView& b, float dt) {
  b.com += dt * b.linearVelocity;
  for (int i = 0; i < 3; ++i) b.travel[i] += (double)dt * (double)b.linearVelocity[i];
  Mat3f E;
  if (rotationChange(b.angularVelocity, dt, E)) {
    b.rotation = (Mat3f::identity() + E) * b.rotation;
    double next[3][3];  // (I + E)(I + turn) - I
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        double v = b.turn[i][j] + (double)E.m[i][j];
        for (int k = 0; k < 3; ++k) v += (double)E.m[i][k] * b.turn[k][j];
        next[i][j] = v;
      }
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) b.turn[i][j] = next[i][j];
  }
  b.shapeOrigin = b.com - b.rotation * b.comLocal;
}

/// World placement and bounds of a part: its placement at upload moved with its body since
/// (a point fixed in the body goes to x0 + travel + turn (x0 - com0)). Small numbers near
/// the domain, exact for a body at rest. `margin`: the grid's reach beyond the bounds;
/// `touchReach`: the largest touchDistance of the particles (infinite: none known).
MPM_HD void placePart(PartView& p, const BodyView& b, float margin, float touchReach) {
  Mat3f turn;
  Vec3f move;
  for (int i = 0; i < 3; ++i) {
    double m = b.travel[i];
    for (int k = 0; k < 3; ++k) {
      m += b.turn[i][k] * (double)p.lever[k];
      turn.m[i][k] = (float)b.turn[i][k];
    }
    move[i] = (float)m;
  }
  p.rotation = p.uploadRotation + turn * p.uploadRotation;
  p.position = p.uploadPosition + move;
  Vec3f lo{3.4e38f, 3.4e38f, 3.4e38f}, hi{-3.4e38f, -3.4e38f, -3.4e38f};
  for (int c = 0; c < 8; ++c) {
    const Vec3f corner{(c & 1) ? p.localUpper.x : p.localLower.x, (c & 2) ? p.localUpper.y : p.localLower.y,
                       (c & 4) ? p.localUpper.z : p.localLower.z};
    const Vec3f w = p.position + p.rotation * corner;
    for (int a = 0; a < 3; ++a) {  // fminf / fmaxf (a NaN corner is skipped), inline: not a libm call each
      lo[a] = w[a] < lo[a] ? w[a] : lo[a];
      hi[a] = w[a] > hi[a] ? w[a] : hi[a];
    }
  }
  const float grow = margin + fmaxf(fmaxf(b.band, p.band), 0.f);
  p.boundsLower = lo - Vec3f{grow, grow, grow};
  p.boundsUpper = hi + Vec3f{grow, grow, grow};
  p.boundsGrowth = grow;
  // A particle sees an analytic part's own surface (its distance, not the grid's band), so
  // it is pushed or touches only within touchReach of the part's own box; the slack covers
  // the rounding of the box and of the distance (a few float spacings of the coordinates
  // and extents involved). The grid's bounds had been used: under 100 small spheres each
  // top particle was tried against about twelve, a third of what the spheres cost G2P.
  // Never beyond the grid's bounds, which the blocks' part lists are made from. A Bonded
  // part's glued material is looked for within its glue reach.
  p.glueReach = b.glueReach;
  float push = grow;
  if (p.lipschitzDistance()) {
    float scale = fmaxf(fmaxf(fabsf(p.position.x), fabsf(p.position.y)), fabsf(p.position.z));
    if (p.type != kPartPlane)  // a plane's extents are unbounded: its distance is along its normal
      for (int a = 0; a < 3; ++a) scale = fmaxf(scale, fmaxf(fabsf(p.localLower[a]), fabsf(p.localUpper[a])));
    push = fminf(grow, fmaxf(1.001f * touchReach, p.glueReach) + 1e-5f * scale);
  }
  p.pushLower = lo - Vec3f{push, push, push};
  p.pushUpper = hi + Vec3f{push, push, push};
}

}  // namespace mpm
