// Small Systems built directly in C++ for the tests of the library stages.
#pragma once

#include "modal/core.hpp"
#include "modal/linearize.hpp"
#include "modal/modes.hpp"

#include <string>

namespace modal::test {

// The sparse path's modes of `lin` as the pipeline solves them (its
// K_magnitude, K_rounding_form unless `rounding_form` is false, and
// inertia_scale; copied, not lent), the lowest `modes`.
inline ModalResult sparse_modes_of(const SparseLinearModel& lin, int modes, bool rounding_form = true) {
  SparseModalOptions options;
  options.modes = modes;
  options.K_magnitude = lin.K_magnitude;
  if (rounding_form) {
    options.K_rounding_form = lin.K_rounding_form;
    options.K_spring_rounding = lin.K_spring_rounding;
  }
  options.inertia_scale = lin.inertia_scale;
  return solve_sparse_modes(lin.K, lin.M, options);
}

// A body on a one-axis joint (axis normalized) at `origin` in its parent's
// frame, with a point mass at its frame origin.
inline Body axis_body(const std::string& name, int parent, JointType joint, const Vec3& origin, double mass,
                      const Vec3& axis) {
  Body b;
  b.name = name;
  b.parent = parent;
  b.joint = joint;
  b.axis = axis.normalized();
  b.origin = origin;
  b.mass = mass;
  return b;
}

// A hinge body with a point mass at `com`, or an inertia added by the caller.
inline Body hinge(const std::string& name, int parent, const Vec3& origin, double mass, const Vec3& com,
                  const Vec3& axis = Vec3::UnitY()) {
  Body b = axis_body(name, parent, JointType::hinge, origin, mass, axis);
  b.com = com;
  return b;
}

// A slide body, its point mass at its frame origin.
inline Body slide(const std::string& name, int parent, const Vec3& origin, double mass,
                  const Vec3& axis = Vec3::UnitX()) {
  return axis_body(name, parent, JointType::slide, origin, mass, axis);
}

// docs/design.md R1: pivot → rod l1 → m1 → rod l2 → m2, hinges about y, point
// masses, gravity (0, 0, −g); coordinates are the relative angles (upper, lower).
inline System double_pendulum(double m1, double m2, double l1, double l2, double g) {
  SystemDescription d;
  d.gravity = Vec3(0, 0, -g);
  d.bodies.push_back(hinge("upper", -1, Vec3::Zero(), m1, Vec3(0, 0, -l1)));
  d.bodies.push_back(hinge("lower", 0, Vec3(0, 0, -l1), m2, Vec3(0, 0, -l2)));
  return System(d);
}

// A 3-D tree with every joint type, inertias, springs between bodies and to the
// world, joint springs and dead loads: exercises every term of the derivatives.
inline System everything_tree() {
  SystemDescription d;
  d.gravity = Vec3(0.3, -0.2, -9.81);
  Body base = hinge("base", -1, Vec3(0.1, 0, 0), 1.3, Vec3(0.2, 0.1, -0.8), Vec3(0.2, 1, 0.1));
  base.inertia << 0.3, 0.01, 0.02, 0.01, 0.25, 0.03, 0.02, 0.03, 0.2;
  base.stiffness = 2.0;
  base.rest = VectorX::Constant(1, 0.1);
  d.bodies.push_back(base);
  Body ball;
  ball.name = "ball";
  ball.parent = 0;
  ball.joint = JointType::ball;
  ball.origin = Vec3(0.1, 0.2, -1.0);
  ball.mass = 0.7;
  ball.com = Vec3(0.05, -0.1, -0.6);
  ball.inertia = Vec3(0.05, 0.06, 0.02).asDiagonal();
  ball.stiffness = 0.8;
  ball.rest = Vec3(0.05, -0.02, 0.1);
  d.bodies.push_back(ball);
  Body slide;
  slide.name = "slider";
  slide.parent = 1;
  slide.joint = JointType::slide;
  slide.axis = Vec3(1, 0.3, -0.2).normalized();
  slide.origin = Vec3(0, 0, -0.7);
  slide.mass = 0.4;
  slide.com = Vec3(0.1, 0, 0);
  slide.stiffness = 5;
  d.bodies.push_back(slide);
  Body fixed;
  fixed.name = "bracket";
  fixed.parent = 2;
  fixed.joint = JointType::fixed;
  fixed.origin = Vec3(0.2, 0.1, 0);
  fixed.mass = 0.2;
  fixed.com = Vec3(0, 0.05, 0);
  fixed.inertia = Vec3(0.01, 0.02, 0.015).asDiagonal();
  d.bodies.push_back(fixed);
  Body tip = hinge("tip", 3, Vec3(0, 0, -0.1), 0.3, Vec3(0.3, 0, -0.2), Vec3(0, 0.4, 1));
  d.bodies.push_back(tip);
  Body flyer;
  flyer.name = "flyer";
  flyer.parent = 0;
  flyer.joint = JointType::free;
  flyer.origin = Vec3(0.5, 0, -0.5);
  flyer.mass = 0.9;
  flyer.com = Vec3(0.02, 0.01, -0.03);
  Mat3 I;
  I << 0.04, 0.002, 0.001, 0.002, 0.05, 0.003, 0.001, 0.003, 0.03;
  flyer.inertia = I;
  d.bodies.push_back(flyer);
  Spring s1;  // body to world, non-zero rest length
  s1.a = {4, Vec3(0.1, 0, -0.3)};
  s1.b = {-1, Vec3(1.0, 0.5, -2.0)};
  s1.stiffness = 30;
  s1.rest_length = 0.4;
  s1.damping = 0.3;
  Spring s2;  // between two bodies of different branches, zero rest length
  s2.a = {5, Vec3(0, 0.1, 0.1)};
  s2.b = {2, Vec3(0, 0, 0.05)};
  s2.stiffness = 12;
  Spring s3;  // flyer to world
  s3.a = {5, Vec3(0.05, -0.05, 0)};
  s3.b = {-1, Vec3(0.7, -0.2, -0.4)};
  s3.stiffness = 20;
  s3.rest_length = 0.1;
  d.springs = {s1, s2, s3};
  d.loads.push_back({{4, Vec3(0.2, 0.1, 0)}, Vec3(1.5, -0.5, 0.7)});
  d.loads.push_back({{5, Vec3(0, 0, 0.1)}, Vec3(-0.3, 0.2, 0.4)});
  return System(d);
}

}  // namespace modal::test
