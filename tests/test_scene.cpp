// Scenes: valid files land in the SystemDescription field by field; chains,
// parameters, overrides, body ordering, default rest lengths; every model of
// models/ loads, builds, and has its documented reference spectrum.
#include "modal/scene.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
#include <string>

namespace {

using modal::JointType;
using modal::Mat3;
using modal::Vec3;

constexpr double tight = 1e-14;

modal::Scene parse(const std::string& text, const std::vector<modal::ParameterOverride>& overrides = {}) {
  return modal::parse_scene(text, "test.toml", overrides);
}

const modal::Body& body(const modal::Scene& s, const std::string& name) {
  const auto& bodies = s.description.bodies;
  const auto it = std::find_if(bodies.begin(), bodies.end(), [&](const modal::Body& b) { return b.name == name; });
  if (it == bodies.end()) throw std::runtime_error("no body " + name);
  return *it;
}

std::string model_path(const std::string& name) { return std::string(MODAL_SOURCE_DIR) + "/models/" + name; }

TEST(scene, EveryBodyFieldLands) {
  const modal::Scene s = parse(R"(
title = "All fields"
gravity = [0, "-g", 0]

[parameters]
g = 3
m = 2

[[body]]
name = "arm"
joint = "hinge"
axis = [0, 0, 2]
origin = [1, 2, 3]
mass = "m"
com = [0.5, 0, "-1/2"]
inertia = [2, 3, 4, 0.5, 0.25, -0.5]
stiffness = 7
rest = 0.25
damping = 0.5
initial = "pi/4"

[[body]]
name = "socket"
parent = "arm"
joint = "ball"
mass = 1
stiffness = 3
rest = [0.1, 0.2, 0.3]
initial = [0, 0.5, 0]

[[body]]
name = "drone"
joint = "free"
mass = 1.5
initial = [1, 2, 3, 0.1, 0.2, 0.3]

[[body]]
name = "tip"
parent = "socket"
joint = "fixed"
origin = [0, 0, -1]
mass = 0.5

[[body]]
name = "carriage"
joint = "slide"
axis = [1, 1, 0]
damping = 2
)");
  const auto& d = s.description;
  EXPECT_EQ(s.file, "test.toml");
  EXPECT_EQ(d.title, "All fields");
  EXPECT_EQ(d.gravity, Vec3(0, -3, 0));
  ASSERT_EQ(d.bodies.size(), 5u);

  const modal::Body& arm = body(s, "arm");
  EXPECT_EQ(arm.parent, -1);
  EXPECT_EQ(arm.joint, JointType::hinge);
  EXPECT_EQ(arm.axis, Vec3::UnitZ());  // normalized
  EXPECT_EQ(arm.origin, Vec3(1, 2, 3));
  EXPECT_DOUBLE_EQ(arm.mass, 2.0);
  EXPECT_EQ(arm.com, Vec3(0.5, 0, -0.5));
  Mat3 inertia;
  inertia << 2, 0.5, 0.25, 0.5, 3, -0.5, 0.25, -0.5, 4;
  EXPECT_EQ(arm.inertia, inertia);
  EXPECT_DOUBLE_EQ(arm.stiffness, 7.0);
  EXPECT_DOUBLE_EQ(arm.damping, 0.5);
  ASSERT_EQ(arm.rest.size(), 1);
  EXPECT_DOUBLE_EQ(arm.rest[0], 0.25);
  ASSERT_EQ(arm.initial.size(), 1);
  EXPECT_DOUBLE_EQ(arm.initial[0], std::numbers::pi / 4);

  const modal::Body& socket = body(s, "socket");
  EXPECT_EQ(d.bodies[static_cast<std::size_t>(socket.parent)].name, "arm");
  EXPECT_EQ(socket.joint, JointType::ball);
  EXPECT_EQ(socket.rest, Eigen::Vector3d(0.1, 0.2, 0.3));
  EXPECT_EQ(socket.initial, Eigen::Vector3d(0, 0.5, 0));
  EXPECT_DOUBLE_EQ(socket.stiffness, 3.0);

  const modal::Body& drone = body(s, "drone");
  EXPECT_EQ(drone.joint, JointType::free);
  ASSERT_EQ(drone.initial.size(), 6);
  EXPECT_DOUBLE_EQ(drone.initial[5], 0.3);
  EXPECT_EQ(drone.rest.size(), 6);

  const modal::Body& tip = body(s, "tip");
  EXPECT_EQ(tip.joint, JointType::fixed);
  EXPECT_EQ(tip.rest.size(), 0);
  EXPECT_EQ(tip.initial.size(), 0);
  EXPECT_EQ(d.bodies[static_cast<std::size_t>(tip.parent)].name, "socket");

  const modal::Body& carriage = body(s, "carriage");
  EXPECT_EQ(carriage.joint, JointType::slide);
  EXPECT_NEAR((carriage.axis - Vec3(1, 1, 0) / std::sqrt(2.0)).norm(), 0.0, tight);
  EXPECT_DOUBLE_EQ(carriage.damping, 2.0);
  EXPECT_DOUBLE_EQ(carriage.rest[0], 0.0);

  ASSERT_EQ(s.body_locations.size(), 5u);
  EXPECT_EQ(s.body_locations[0].file, "test.toml");
  EXPECT_EQ(s.body_locations[0].line, 9);  // [[body]] of "arm"
  EXPECT_EQ(s.body_locations[0].column, 1);

  const modal::System system = modal::build_system(s);
  EXPECT_EQ(system.size(), 1 + 3 + 6 + 0 + 1);
}

TEST(scene, Defaults) {
  const modal::Scene s = modal::parse_scene("[[body]]\nname = \"b\"\njoint = \"hinge\"\n", "dir/my_scene.toml");
  const auto& d = s.description;
  EXPECT_EQ(d.title, "my_scene");
  EXPECT_EQ(d.gravity, Vec3(0, 0, -9.81));
  const modal::Body& b = d.bodies.at(0);
  EXPECT_EQ(b.parent, -1);
  EXPECT_EQ(b.axis, Vec3::UnitY());
  EXPECT_EQ(b.origin, Vec3::Zero());
  EXPECT_EQ(b.mass, 0.0);
  EXPECT_EQ(b.com, Vec3::Zero());
  EXPECT_EQ(b.inertia, Mat3::Zero());
  EXPECT_EQ(b.stiffness, 0.0);
  EXPECT_EQ(b.damping, 0.0);
  EXPECT_EQ(b.rest, Eigen::VectorXd::Zero(1));
  EXPECT_EQ(b.initial, Eigen::VectorXd::Zero(1));
  EXPECT_TRUE(d.springs.empty());
  EXPECT_TRUE(d.loads.empty());
  EXPECT_TRUE(s.parameters.empty());
}

TEST(scene, ParametersInAnyOrderAndOverrides) {
  const std::string text = R"(
[parameters]
area = "pi*r^2"     # uses r, defined below
r = "d/2"
d = 2
mass = "rho*area"
rho = 3

[[body]]
name = "disc"
joint = "hinge"
mass = "mass"
)";
  const modal::Scene s = parse(text);
  ASSERT_EQ(s.parameters.size(), 5u);
  const std::vector<std::string> order{"area", "r", "d", "mass", "rho"};  // file order
  for (std::size_t i = 0; i < order.size(); ++i) EXPECT_EQ(s.parameters[i].first, order[i]);
  EXPECT_DOUBLE_EQ(s.parameters[0].second, std::numbers::pi);
  EXPECT_DOUBLE_EQ(s.description.bodies[0].mass, 3 * std::numbers::pi);

  // --set replaces definitions before evaluation; values may be expressions.
  const modal::Scene o = parse(text, {modal::parse_override("d=4"), modal::parse_override(" rho = 2*d ")});
  EXPECT_DOUBLE_EQ(o.parameters[2].second, 4.0);
  EXPECT_DOUBLE_EQ(o.parameters[4].second, 8.0);
  EXPECT_DOUBLE_EQ(o.description.bodies[0].mass, 8 * 4 * std::numbers::pi);
}

TEST(scene, ParseOverride) {
  const modal::ParameterOverride o = modal::parse_override("m=2.5");
  EXPECT_EQ(o.name, "m");
  EXPECT_EQ(o.value, "2.5");
  const modal::ParameterOverride e = modal::parse_override("k = sqrt(2)*m");
  EXPECT_EQ(e.name, "k");
  EXPECT_EQ(e.value, "sqrt(2)*m");
}

TEST(scene, ParentsListedLaterComeFirst) {
  const modal::Scene s = parse(R"(
[[body]]
name = "c"
parent = "b"
joint = "hinge"

[[body]]
name = "a"
joint = "hinge"

[[body]]
name = "b"
joint = "slide"
parent = "a"

[[body]]
name = "z"
joint = "hinge"
)");
  const auto& bodies = s.description.bodies;
  ASSERT_EQ(bodies.size(), 4u);
  // Among the bodies whose parent is placed, the earliest in the file goes
  // next: a, then b (ready once a is placed), then c (before z, as in the file).
  EXPECT_EQ(bodies[0].name, "a");
  EXPECT_EQ(bodies[1].name, "b");
  EXPECT_EQ(bodies[2].name, "c");
  EXPECT_EQ(bodies[3].name, "z");
  EXPECT_EQ(bodies[1].parent, 0);
  EXPECT_EQ(bodies[2].parent, 1);
  EXPECT_EQ(bodies[3].parent, -1);
  EXPECT_EQ(s.body_locations[0].line, 7);  // locations follow their bodies
  EXPECT_EQ(s.body_locations[2].line, 2);
  EXPECT_NO_THROW(modal::build_system(s));
}

TEST(scene, ChainOfPointMasses) {
  const modal::Scene s = parse(R"(
[[body]]
name = "cart"
joint = "slide"
axis = [1, 0, 0]
mass = 1

[[chain]]
name = "rope"
parent = "cart"
origin = [0, 0, -0.5]
links = "2*2"
length = 2
mass = 4
axis = [0, 1, 0]
direction = [1, 0, 0]
stiffness = 5
damping = 0.1
rest = 0.2
initial = [0.1, 0.2, 0.3, 0.4]
)");
  const auto& bodies = s.description.bodies;
  ASSERT_EQ(bodies.size(), 5u);
  EXPECT_EQ(bodies[0].name, "cart");
  for (int k = 1; k <= 4; ++k) {
    const modal::Body& b = bodies[static_cast<std::size_t>(k)];
    EXPECT_EQ(b.name, "rope" + std::to_string(k));
    EXPECT_EQ(b.parent, k - 1);
    EXPECT_EQ(b.joint, JointType::hinge);
    EXPECT_EQ(b.axis, Vec3::UnitY());
    EXPECT_EQ(b.origin, k == 1 ? Vec3(0, 0, -0.5) : Vec3(0.5, 0, 0));
    EXPECT_DOUBLE_EQ(b.mass, 1.0);
    EXPECT_EQ(b.com, Vec3(0.5, 0, 0));  // at the link's far end
    EXPECT_EQ(b.inertia, Mat3::Zero());
    EXPECT_DOUBLE_EQ(b.stiffness, 5.0);
    EXPECT_DOUBLE_EQ(b.damping, 0.1);
    EXPECT_DOUBLE_EQ(b.rest[0], 0.2);
    EXPECT_DOUBLE_EQ(b.initial[0], 0.1 * k);
    EXPECT_EQ(s.body_locations[static_cast<std::size_t>(k)].line, 8);  // the [[chain]] table
  }
}

TEST(scene, ChainOfRods) {
  const modal::Scene s = parse(R"(
[[chain]]
name = "arm"
links = 3
length = 3
mass = 6
mass_model = "rod"
axis = [0, 1, 0]
direction = [1, 0, -1]
initial = 0.7
)");
  const auto& bodies = s.description.bodies;
  ASSERT_EQ(bodies.size(), 3u);
  const Vec3 d = Vec3(1, 0, -1).normalized();
  const double m = 2.0, a = 1.0;
  const Mat3 rod = m * a * a / 12 * (Mat3::Identity() - d * d.transpose());
  for (std::size_t k = 0; k < 3; ++k) {
    const modal::Body& b = bodies[k];
    EXPECT_EQ(b.parent, static_cast<int>(k) - 1);
    EXPECT_NEAR((b.origin - (k == 0 ? Vec3::Zero() : Vec3(a * d))).norm(), 0.0, tight);
    EXPECT_NEAR((b.com - 0.5 * a * d).norm(), 0.0, tight);
    EXPECT_NEAR((b.inertia - rod).norm(), 0.0, tight);
    EXPECT_DOUBLE_EQ(b.mass, m);
    EXPECT_DOUBLE_EQ(b.initial[0], k == 0 ? 0.7 : 0.0);  // a number sets the first joint only
  }
  EXPECT_NO_THROW(modal::build_system(s));
}

TEST(scene, ChainsAndBodiesKeepFileOrder) {
  const modal::Scene s = parse(R"(
[[body]]
name = "hub"
joint = "hinge"

[[chain]]
name = "r"
links = 2
length = 1
mass = 1

[[body]]
name = "weight"
parent = "r2"
joint = "fixed"
mass = 1
)");
  std::vector<std::string> names;
  for (const auto& b : s.description.bodies) names.push_back(b.name);
  EXPECT_EQ(names, (std::vector<std::string>{"hub", "r1", "r2", "weight"}));
  EXPECT_EQ(s.description.bodies[3].parent, 2);
}

TEST(scene, SpringsAndLoads) {
  const modal::Scene s = parse(R"(
[parameters]
k = 100

[[body]]
name = "upper"
joint = "hinge"
origin = [0, 0, 1]
mass = 1
com = [0, 0, -1]

[[body]]
name = "lower"
parent = "upper"
joint = "hinge"
origin = [0, 0, -1]
mass = 1

[[spring]]
a = "lower"
a_point = [0, 0, -1]
b = "world"
b_point = [3, 0, -1]
stiffness = "k"
damping = 0.5

[[spring]]
a = "upper"
b = "lower"
b_point = [1, 0, 0]
stiffness = 2
rest_length = 0.25

[[load]]
body = "lower"
point = [0, 0, -1]
force = [0, 0, "-k/10"]
follower = false
)");
  const auto& d = s.description;
  ASSERT_EQ(d.springs.size(), 2u);
  const modal::Spring& s1 = d.springs[0];
  EXPECT_EQ(s1.a.body, 1);
  EXPECT_EQ(s1.a.point, Vec3(0, 0, -1));
  EXPECT_EQ(s1.b.body, -1);
  EXPECT_EQ(s1.b.point, Vec3(3, 0, -1));
  EXPECT_DOUBLE_EQ(s1.stiffness, 100.0);
  EXPECT_DOUBLE_EQ(s1.damping, 0.5);
  // Default rest length: "lower" frame at (0,0,1)+(0,0,-1) = 0; point (0,0,-1);
  // world point (3,0,-1): distance 3.
  EXPECT_DOUBLE_EQ(s1.rest_length, 3.0);
  EXPECT_DOUBLE_EQ(d.springs[1].rest_length, 0.25);
  EXPECT_DOUBLE_EQ(d.springs[1].damping, 0.0);

  ASSERT_EQ(d.loads.size(), 1u);
  EXPECT_EQ(d.loads[0].at.body, 1);
  EXPECT_EQ(d.loads[0].at.point, Vec3(0, 0, -1));
  EXPECT_EQ(d.loads[0].force, Vec3(0, 0, -10));
  EXPECT_NO_THROW(modal::build_system(s));
}

TEST(scene, Particles) {
  const modal::Scene s = parse(R"(
[[particle]]
name = "free"
position = [1, 2, 3]
mass = 2

[[body]]
name = "arm"
parent = "bead"
joint = "hinge"
mass = 1

[[particle]]
name = "pinned"
position = [0, 0, 1]
mass = 0.5
fixed = true

[[particle]]
name = "bead"
position = [4, 0, "-1/2"]
mass = 1.5
fixed = [false, true, false]

[[particle]]
name = "loose"
position = [0, 0, 0]
mass = 0
fixed = false
)");
  const auto& d = s.description;
  std::vector<std::string> names;
  for (const auto& b : d.bodies) names.push_back(b.name);
  // File order where the tree allows: "arm" waits for its parent "bead".
  EXPECT_EQ(names, (std::vector<std::string>{"free", "pinned", "bead", "arm", "loose"}));
  ASSERT_EQ(s.body_locations.size(), 5u);
  EXPECT_EQ(s.body_locations[0].line, 2);  // [[particle]] "free"
  EXPECT_EQ(s.body_locations[0].column, 1);
  EXPECT_EQ(s.body_locations[2].line, 19);  // [[particle]] "bead"
  EXPECT_EQ(s.body_locations[3].line, 7);   // [[body]] "arm"

  const modal::Body& free = body(s, "free");
  EXPECT_EQ(free.parent, -1);
  EXPECT_EQ(free.joint, JointType::particle);
  EXPECT_EQ(free.particle_axes, (std::array<bool, 3>{true, true, true}));
  EXPECT_EQ(free.origin, Vec3(1, 2, 3));
  EXPECT_DOUBLE_EQ(free.mass, 2.0);
  EXPECT_EQ(free.com, Vec3::Zero());
  EXPECT_EQ(free.inertia, Mat3::Zero());

  const modal::Body& pinned = body(s, "pinned");  // every axis fixed: a fixed joint
  EXPECT_EQ(pinned.joint, JointType::fixed);
  EXPECT_EQ(pinned.origin, Vec3(0, 0, 1));
  EXPECT_DOUBLE_EQ(pinned.mass, 0.5);
  EXPECT_EQ(modal::joint_coordinate_count(pinned), 0);

  const modal::Body& bead = body(s, "bead");
  EXPECT_EQ(bead.joint, JointType::particle);
  EXPECT_EQ(bead.particle_axes, (std::array<bool, 3>{true, false, true}));
  EXPECT_EQ(bead.origin, Vec3(4, 0, -0.5));
  EXPECT_EQ(modal::joint_coordinate_count(bead), 2);
  EXPECT_EQ(d.bodies[static_cast<std::size_t>(body(s, "arm").parent)].name, "bead");  // a particle may be a parent

  const modal::Body& loose = body(s, "loose");
  EXPECT_EQ(loose.joint, JointType::particle);
  EXPECT_EQ(loose.particle_axes, (std::array<bool, 3>{true, true, true}));
  EXPECT_EQ(loose.mass, 0.0);

  const modal::System system = modal::build_system(s);
  EXPECT_EQ(system.size(), 3 + 0 + 2 + 1 + 3);
  EXPECT_EQ(system.coordinate_names(), (std::vector<std::string>{"free.x", "free.y", "free.z", "bead.x", "bead.z", "arm",
                                                                 "loose.x", "loose.y", "loose.z"}));
  for (const modal::Coordinate& c : system.coordinates()) {
    EXPECT_EQ(c.kind, c.name == "arm" ? modal::CoordinateKind::angle : modal::CoordinateKind::length) << c.name;
  }
  EXPECT_EQ(system.initial_configuration(), Eigen::VectorXd::Zero(9));
}

TEST(scene, SpringsBetweenParticles) {
  const modal::Scene s = parse(R"(
[[particle]]
name = "p1"
position = [0, 0, 0]
mass = 1

[[particle]]
name = "p2"
position = [3, 4, 0]
mass = 1
fixed = [false, false, true]

[[spring]]
a = "p1"
b = "p2"
stiffness = 10

[[spring]]
a = "p2"
b = "world"
b_point = [3, 4, 2]
stiffness = 5
damping = 1
)");
  const auto& d = s.description;
  ASSERT_EQ(d.springs.size(), 2u);
  EXPECT_EQ(d.springs[0].a.body, 0);
  EXPECT_EQ(d.springs[0].b.body, 1);
  EXPECT_EQ(d.springs[0].a.point, Vec3::Zero());  // the particle itself
  EXPECT_EQ(d.springs[0].b.point, Vec3::Zero());
  EXPECT_DOUBLE_EQ(d.springs[0].rest_length, 5.0);  // as written
  EXPECT_EQ(d.springs[1].a.body, 1);
  EXPECT_EQ(d.springs[1].b.body, -1);
  EXPECT_EQ(d.springs[1].b.point, Vec3(3, 4, 2));
  EXPECT_DOUBLE_EQ(d.springs[1].rest_length, 2.0);

  const modal::System system = modal::build_system(s);
  EXPECT_EQ(system.size(), 5);
  // Springs at their rest lengths: only gravity acts, on the free z of p1.
  modal::Workspace w(system);
  Eigen::VectorXd expected = Eigen::VectorXd::Zero(5);
  expected[2] = 9.81;
  EXPECT_NEAR((modal::potential_gradient(system, w, Eigen::VectorXd::Zero(5)) - expected).norm(), 0.0, 1e-12);
}

TEST(scene, Constraints) {
  const modal::Scene s = parse(R"(
[parameters]
l = 1

[[body]]
name = "crank"
joint = "hinge"
mass = 1
com = [1, 0, 0]

[[particle]]
name = "p"
position = [1, 0, 1]
mass = 1

[[chain]]
name = "c"
links = 2
length = 1
mass = 1

[[constraint]]
type = "point"
a = "crank"
a_point = [1, 0, 0]
b = "world"
b_point = [1, 0, 0]

[[constraint]]
type = "distance"
name = "rod"
a = "crank"
a_point = [1, 0, 0]
b = "p"

[[constraint]]
type = "distance"
a = "p"
b = "world"
length = "2*l"

[[constraint]]
type = "point"
name = "tip"
a = "world"
a_point = [0, 0, -1]
b = "c.tip"
b_point = [0, 0, -0.5]
)");
  const auto& d = s.description;
  ASSERT_EQ(d.constraints.size(), 4u);
  using Type = modal::Constraint::Type;
  const modal::Constraint& pin = d.constraints[0];
  EXPECT_EQ(pin.type, Type::point);
  EXPECT_EQ(pin.name, "constraint1");  // default: its position among the [[constraint]] tables
  EXPECT_EQ(pin.a.body, 0);
  EXPECT_EQ(pin.a.point, Vec3(1, 0, 0));
  EXPECT_EQ(pin.b.body, -1);
  EXPECT_EQ(pin.b.point, Vec3(1, 0, 0));
  EXPECT_EQ(pin.length, 0.0);

  const modal::Constraint& rod = d.constraints[1];
  EXPECT_EQ(rod.type, Type::distance);
  EXPECT_EQ(rod.name, "rod");
  EXPECT_EQ(rod.a.body, 0);
  EXPECT_EQ(rod.b.body, 1);
  EXPECT_EQ(rod.b.point, Vec3::Zero());
  EXPECT_DOUBLE_EQ(rod.length, 1.0);  // default: |(1, 0, 0) − (1, 0, 1)| as written

  const modal::Constraint& tether = d.constraints[2];
  EXPECT_EQ(tether.name, "constraint3");
  EXPECT_EQ(tether.a.body, 1);
  EXPECT_EQ(tether.b.body, -1);
  EXPECT_EQ(tether.b.point, Vec3::Zero());
  EXPECT_DOUBLE_EQ(tether.length, 2.0);

  const modal::Constraint& tip = d.constraints[3];
  EXPECT_EQ(tip.name, "tip");
  EXPECT_EQ(tip.a.body, -1);
  EXPECT_EQ(tip.a.point, Vec3(0, 0, -1));
  EXPECT_EQ(d.bodies[static_cast<std::size_t>(tip.b.body)].name, "c2");  // "<chain>.tip"
  EXPECT_EQ(tip.b.point, Vec3(0, 0, -0.5));

  const modal::System system = modal::build_system(s);
  EXPECT_EQ(system.size(), 1 + 3 + 2);
  EXPECT_EQ(system.constraint_equations(), 3 + 1 + 1 + 3);
  EXPECT_EQ(system.constraint_equation_names(),
            (std::vector<std::string>{"constraint1.x", "constraint1.y", "constraint1.z", "rod", "constraint3", "tip.x",
                                      "tip.y", "tip.z"}));
  // As written, every constraint but the tether (|p| = √2, length 2) holds.
  modal::Workspace w(system);
  const Eigen::VectorXd c = modal::constraint_values(system, w, Eigen::VectorXd::Zero(system.size()));
  ASSERT_EQ(c.size(), 8);
  Eigen::VectorXd expected = Eigen::VectorXd::Zero(8);
  expected[4] = std::sqrt(2.0) - 2;
  EXPECT_NEAR((c - expected).norm(), 0.0, 1e-12);
}

TEST(scene, LoadSceneReadsFilesWithOverrides) {
  const modal::Scene s = modal::load_scene(model_path("double_pendulum.toml"), {{"m2", "2*m1"}});
  EXPECT_EQ(s.file, model_path("double_pendulum.toml"));
  EXPECT_DOUBLE_EQ(body(s, "lower").mass, 2.0);
  EXPECT_EQ(s.body_locations.at(0).file, s.file);
}

// --- the models --------------------------------------------------------------

// Eigenvalues λ of K φ = λ M φ at q (ascending).
Eigen::VectorXd spectrum(const modal::System& system, const Eigen::VectorXd& q) {
  modal::Workspace w(system);
  const Eigen::MatrixXd K = modal::potential_hessian(system, w, q);
  const Eigen::MatrixXd M = modal::mass_matrix(system, w, q);
  return Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd>(K, M, Eigen::EigenvaluesOnly).eigenvalues();
}

TEST(scene_models, EveryModelLoadsAndBuilds) {
  const std::map<std::string, int> sizes{
      {"double_pendulum.toml", 2}, {"seesaw.toml", 1},      {"spherical_pendulum.toml", 3},
      {"hanging_chain.toml", 20},  {"spring_chain.toml", 3}, {"inverted_pendulum.toml", 1},
  };
  std::size_t found = 0;
  for (const auto& entry : std::filesystem::directory_iterator(std::string(MODAL_SOURCE_DIR) + "/models")) {
    if (entry.path().extension() != ".toml") continue;
    SCOPED_TRACE(entry.path().string());
    modal::Scene scene;
    ASSERT_NO_THROW(scene = modal::load_scene(entry.path().string()));
    EXPECT_FALSE(scene.description.title.empty());
    const modal::System system = modal::build_system(scene);
    const auto it = sizes.find(entry.path().filename().string());
    if (it != sizes.end()) {
      EXPECT_EQ(system.size(), it->second);
      ++found;
    }
  }
  EXPECT_EQ(found, sizes.size());
}

// The reference results written in each model's header, from M and ∇∇V.
TEST(scene_models, ReferenceSpectra) {
  auto system = [](const std::string& name) { return modal::build_system(modal::load_scene(model_path(name))); };
  {  // R1: ω² = 2 ∓ √2 with all parameters 1
    const Eigen::VectorXd l = spectrum(system("double_pendulum.toml"), Eigen::VectorXd::Zero(2));
    EXPECT_NEAR(l[0], 2 - std::sqrt(2.0), 1e-12);
    EXPECT_NEAR(l[1], 2 + std::sqrt(2.0), 1e-12);
  }
  {  // R1: the four equilibria in relative angles and their Morse indices
    const modal::System s = system("double_pendulum.toml");
    const double pi = std::numbers::pi;
    const std::pair<Eigen::Vector2d, int> equilibria[] = {
        {{0, 0}, 0}, {{0, pi}, 1}, {{pi, pi}, 1}, {{pi, -pi}, 1}, {{pi, 0}, 2}};
    modal::Workspace w(s);
    for (const auto& [q, morse] : equilibria) {
      EXPECT_NEAR(modal::potential_gradient(s, w, q).norm(), 0.0, 1e-14) << q.transpose();
      const Eigen::VectorXd l = spectrum(s, q);
      EXPECT_EQ((l.array() < 0).count(), morse) << q.transpose();
    }
  }
  {  // R2: ω_j = 2 sin(jπ/8) for k = m = 1
    const Eigen::VectorXd l = spectrum(system("spring_chain.toml"), Eigen::VectorXd::Zero(3));
    for (int j = 1; j <= 3; ++j) EXPECT_NEAR(std::sqrt(l[j - 1]), 2 * std::sin(j * std::numbers::pi / 8), 1e-12);
  }
  {  // seesaw: tan θ0 = S/(hM), ω² = g sqrt(S² + (hM)²) / Σ m (s² + h²)
    const double S = 0.3, hM = 0.9;
    Eigen::VectorXd q(1);
    q << std::atan(S / hM);
    const modal::System s = system("seesaw.toml");
    modal::Workspace w(s);
    EXPECT_NEAR(modal::potential_gradient(s, w, q)[0], 0.0, 1e-14);
    const Eigen::VectorXd l = spectrum(s, q);
    EXPECT_NEAR(l[0], 9.81 * std::hypot(S, hM) / 0.84, 1e-11);
  }
  {  // spherical pendulum: spin mode 0, swing ω² = g l / (l² + 2/5 r²) twice
    const Eigen::VectorXd l = spectrum(system("spherical_pendulum.toml"), Eigen::VectorXd::Zero(3));
    EXPECT_NEAR(l[0], 0.0, 1e-12);
    EXPECT_NEAR(l[1], 9.81 / 1.004, 1e-11);
    EXPECT_NEAR(l[2], 9.81 / 1.004, 1e-11);
  }
  {  // inverted pendulum: λ = −g/l at the top
    const Eigen::VectorXd l = spectrum(system("inverted_pendulum.toml"), Eigen::VectorXd::Zero(1));
    EXPECT_NEAR(l[0], -9.81, 1e-12);
  }
  {  // hanging chain: ω_k² = (g/a) x_k, x_k the zeros of the Laguerre polynomial L_20
    const Eigen::VectorXd l = spectrum(system("hanging_chain.toml"), Eigen::VectorXd::Zero(20));
    const double x[] = {0.0705398897, 0.372126818, 0.9165821025, 1.707306531, 2.7491992553};
    for (int k = 0; k < 5; ++k) EXPECT_NEAR(l[k] / (9.81 / 0.05), x[k], 1e-8);
  }
}

}  // namespace
