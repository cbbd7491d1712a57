// Small Systems built directly in C++ for the tests of the library stages.
#pragma once

#include "modal/core.hpp"

#include <string>

namespace modal::test {

// A hinge body (axis normalized) with a point mass, or an inertia added by the caller.
inline Body hinge(const std::string& name, int parent, const Vec3& origin, double mass, const Vec3& com,
                  const Vec3& axis = Vec3::UnitY()) {
  Body b;
  b.name = name;
  b.parent = parent;
  b.joint = JointType::hinge;
  b.axis = axis.normalized();
  b.origin = origin;
  b.mass = mass;
  b.com = com;
  return b;
}

// REFERENCES.md R1: pivot → rod l1 → m1 → rod l2 → m2, hinges about y, point
// masses, gravity (0, 0, −g); coordinates are the relative angles (upper, lower).
inline System double_pendulum(double m1, double m2, double l1, double l2, double g) {
  SystemDescription d;
  d.gravity = Vec3(0, 0, -g);
  d.bodies.push_back(hinge("upper", -1, Vec3::Zero(), m1, Vec3(0, 0, -l1)));
  d.bodies.push_back(hinge("lower", 0, Vec3(0, 0, -l1), m2, Vec3(0, 0, -l2)));
  return System(d);
}

}  // namespace modal::test
