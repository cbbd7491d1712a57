// Generators: [[lattice]] (particles on a grid, springs to the neighbours and
// face diagonals) and [[network]] (particles and springs from CSV files):
// counts, names, positions, rest lengths with prestrain, fixed particles, the
// spectrum of a pre-tensioned net, the example models, every located error
// (CSV errors name the CSV file, line and column), and the time to read and
// build a scene of 10⁶ coordinates.
#include "modal/scene.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <malloc.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <charconv>
#include <cstdlib>
#include <new>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <fstream>
#include <iostream>
#include <numbers>
#include <numeric>
#include <optional>
#include <random>
#include <set>
#include <tuple>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using modal::JointType;
using modal::Vec3;

modal::Scene parse(const std::string& text) { return modal::parse_scene(text, "test.toml"); }

const modal::Body& body(const modal::Scene& s, const std::string& name) {
  const auto& bodies = s.description.bodies;
  const auto it = std::find_if(bodies.begin(), bodies.end(), [&](const modal::Body& b) { return b.name == name; });
  if (it == bodies.end()) throw std::runtime_error("no body " + name);
  return *it;
}

int index_of(const modal::Scene& s, const std::string& name) {
  return static_cast<int>(&body(s, name) - s.description.bodies.data());
}

std::size_t count_fixed(const modal::Scene& s) {
  return static_cast<std::size_t>(std::count_if(s.description.bodies.begin(), s.description.bodies.end(),
                                                [](const modal::Body& b) { return b.joint == JointType::fixed; }));
}

// A lattice scene: [[lattice]] on line 1, then `keys`.
std::string lattice(const std::string& keys) { return "[[lattice]]\n" + keys; }

// --- [[lattice]]: counts, names, positions ------------------------------------

TEST(lattice, CountsIn3D) {
  const std::string keys = "size = [3, 4, 5]\nspacing = 0.5\nmass = 1\nstiffness = 10\n";
  const modal::Scene plain = parse(lattice(keys));
  EXPECT_EQ(plain.description.bodies.size(), 60u);
  // Along x: 2·4·5, along y: 3·3·5, along z: 3·4·4.
  EXPECT_EQ(plain.description.springs.size(), 40u + 45u + 48u);
  EXPECT_EQ(modal::build_system(plain).size(), 180);

  const modal::Scene diagonal = parse(lattice(keys + "diagonals = true\n"));
  // Two diagonals per square: xy 2·(2·3·5), xz 2·(2·4·4), yz 2·(3·3·4).
  EXPECT_EQ(diagonal.description.springs.size(), 133u + 60u + 64u + 72u);
  EXPECT_EQ(modal::build_system(diagonal).size(), 180);
}

TEST(lattice, CountsOfA2DNet) {
  const std::string keys = "size = [4, 5, 1]\nspacing = 1\nmass = 1\nstiffness = 10\n";
  const modal::Scene plain = parse(lattice(keys));
  EXPECT_EQ(plain.description.bodies.size(), 20u);
  EXPECT_EQ(plain.description.springs.size(), 3u * 5u + 4u * 4u);
  // Every particle of a net keeps three coordinates (it may leave its plane).
  EXPECT_EQ(modal::build_system(plain).size(), 60);
  const modal::Scene diagonal = parse(lattice(keys + "diagonals = true\n"));
  EXPECT_EQ(diagonal.description.springs.size(), 31u + 2u * 3u * 4u);
  // A single row is a net too: a string of particles.
  EXPECT_EQ(parse(lattice("size = [5, 1, 1]\nspacing = 1\nmass = 1\nstiffness = 10\ndiagonals = true\n"))
                .description.springs.size(),
            4u);
}

TEST(lattice, NamesPositionsAndOrder) {
  const modal::Scene s = parse(lattice(
      "name = \"lat\"\nsize = [2, 3, 4]\nspacing = [0.1, 0.2, 0.3]\norigin = [1, 2, 3]\nmass = 0.5\nstiffness = 10\n"));
  const auto& bodies = s.description.bodies;
  ASSERT_EQ(bodies.size(), 24u);
  // The last index runs fastest.
  EXPECT_EQ(bodies[0].name, "lat.0.0.0");
  EXPECT_EQ(bodies[1].name, "lat.0.0.1");
  EXPECT_EQ(bodies[4].name, "lat.0.1.0");
  EXPECT_EQ(bodies[23].name, "lat.1.2.3");
  const modal::Body& b = body(s, "lat.1.2.3");
  EXPECT_EQ(b.joint, JointType::particle);
  EXPECT_EQ(b.parent, -1);
  EXPECT_DOUBLE_EQ(b.mass, 0.5);
  EXPECT_NEAR((b.origin - Vec3(1.1, 2.4, 3.9)).norm(), 0.0, 1e-15);
  EXPECT_EQ(b.particle_axes, (std::array<bool, 3>{true, true, true}));
  EXPECT_EQ(b.initial, Eigen::VectorXd::Zero(3));
  ASSERT_EQ(s.body_locations.size(), 24u);
  EXPECT_EQ(s.body_locations[23].line, 1);  // the [[lattice]] table
  EXPECT_EQ(modal::build_system(s).coordinate_names()[0], "lat.0.0.0.x");

  // A 2-D net has two indices; in the xz plane j runs along z (spacing[3]).
  const modal::Scene net = parse(lattice(
      "name = \"n\"\nsize = [3, 2, 1]\nplane = \"xz\"\nspacing = [1, 5, 2]\norigin = [0, 1, 0]\nmass = 1\nstiffness = 10\n"));
  EXPECT_EQ(net.description.bodies[1].name, "n.0.1");
  EXPECT_EQ(body(net, "n.2.1").origin, Vec3(2, 1, 2));
  const modal::Scene xy = parse(lattice("name = \"n\"\nsize = [3, 2, 1]\nspacing = [1, 5, 2]\nmass = 1\nstiffness = 10\n"));
  EXPECT_EQ(body(xy, "n.2.1").origin, Vec3(2, 5, 0));
}

TEST(lattice, RestLengthsWithPrestrain) {
  const modal::Scene s = parse(lattice(
      "size = [3, 3, 3]\nspacing = [1, 2, 3]\nmass = 1\nstiffness = 7\ndamping = 0.25\ndiagonals = true\nprestrain = 0.1\n"));
  const auto& d = s.description;
  ASSERT_EQ(d.springs.size(), 3u * 18u + 6u * 12u);
  std::vector<double> lengths;
  for (const modal::Spring& spring : d.springs) {
    const Vec3 xa = d.bodies[static_cast<std::size_t>(spring.a.body)].origin;
    const Vec3 xb = d.bodies[static_cast<std::size_t>(spring.b.body)].origin;
    EXPECT_NEAR(spring.rest_length, 0.9 * (xa - xb).norm(), 1e-14);
    EXPECT_EQ(spring.a.point, Vec3::Zero());
    EXPECT_EQ(spring.stiffness, 7.0);
    EXPECT_EQ(spring.damping, 0.25);
    lengths.push_back((xa - xb).norm());
  }
  std::sort(lengths.begin(), lengths.end());
  lengths.erase(std::unique(lengths.begin(), lengths.end(), [](double x, double y) { return std::abs(x - y) < 1e-12; }),
                lengths.end());
  // Axes 1, 2, 3; face diagonals √5, √10, √13; no body diagonals.
  ASSERT_EQ(lengths.size(), 6u);
  EXPECT_NEAR(lengths[2], std::sqrt(5.0), 1e-14);
  EXPECT_NEAR(lengths[5], std::sqrt(13.0), 1e-14);
  // Without prestrain the springs rest as written.
  const modal::Scene relaxed = parse(lattice("size = [2, 2, 1]\nspacing = 2\nmass = 1\nstiffness = 1\n"));
  for (const modal::Spring& spring : relaxed.description.springs) EXPECT_EQ(spring.rest_length, 2.0);
}

TEST(lattice, FixedVariants) {
  const std::string cube = "size = [4, 4, 4]\nspacing = 1\nmass = 1\nstiffness = 10\n";
  EXPECT_EQ(count_fixed(parse(lattice(cube))), 0u);
  EXPECT_EQ(count_fixed(parse(lattice(cube + "fixed = \"none\"\n"))), 0u);
  EXPECT_EQ(count_fixed(parse(lattice(cube + "fixed = \"boundary\"\n"))), 64u - 8u);
  const modal::Scene base = parse(lattice(cube + "fixed = \"z-\"\n"));
  EXPECT_EQ(count_fixed(base), 16u);
  EXPECT_EQ(body(base, "lattice.2.3.0").joint, JointType::fixed);
  EXPECT_EQ(modal::joint_coordinate_count(body(base, "lattice.2.3.0")), 0);
  EXPECT_EQ(body(base, "lattice.2.3.1").joint, JointType::particle);
  EXPECT_EQ(modal::build_system(base).size(), 3 * 48);
  EXPECT_EQ(body(parse(lattice(cube + "fixed = \"x+\"\n")), "lattice.3.1.2").joint, JointType::fixed);
  EXPECT_EQ(count_fixed(parse(lattice(cube + "fixed = [\"x-\", \"x+\"]\n"))), 32u);
  EXPECT_EQ(count_fixed(parse(lattice(cube + "fixed = [\"y-\", \"z+\", \"none\"]\n"))), 16u + 16u - 4u);
  EXPECT_EQ(count_fixed(parse(lattice(cube + "fixed = []\n"))), 0u);

  // A net's boundary is its perimeter; its edges are named by world axes.
  const std::string net = "size = [4, 5, 1]\nspacing = 1\nmass = 1\nstiffness = 10\n";
  EXPECT_EQ(count_fixed(parse(lattice(net + "fixed = \"boundary\"\n"))), 20u - 6u);
  EXPECT_EQ(count_fixed(parse(lattice(net + "fixed = \"y+\"\n"))), 4u);
  const modal::Scene xz = parse(lattice(net + "plane = \"xz\"\nfixed = \"z+\"\n"));
  EXPECT_EQ(count_fixed(xz), 4u);
  EXPECT_EQ(body(xz, "lattice.0.4").joint, JointType::fixed);
  EXPECT_EQ(body(xz, "lattice.0.4").origin, Vec3(0, 0, 4));
  // A one-layer direction has no boundary: a [5, 1, 3] slab keeps its inside.
  EXPECT_EQ(count_fixed(parse(lattice("size = [5, 1, 3]\nspacing = 1\nmass = 1\nstiffness = 10\nfixed = \"boundary\"\n"))),
            15u - 3u);
}

// A pre-tensioned square net (boundary fixed, no gravity) is in equilibrium
// flat, and its spectrum is known: each spring pulls with T = k p a, so it
// has stiffness k along itself and T/a = k p across (geometric stiffness):
//   out of plane  ω² = (k p/m) (4 sin²(rπ/2N) + 4 sin²(sπ/2N))
//   in plane (x)  ω² = (k/m) 4 sin²(rπ/2N) + (k p/m) 4 sin²(sπ/2N)
// with N = 5 segments per side and r, s = 1 … 4.
TEST(lattice, SpectrumOfAPretensionedNet) {
  const double k = 200, m = 0.3, p = 0.05;
  const modal::Scene s = parse("gravity = [0, 0, 0]\n" + lattice("size = [6, 6, 1]\nspacing = 0.5\nmass = 0.3\n"
                                                                 "stiffness = 200\nprestrain = 0.05\nfixed = \"boundary\"\n"
                                                                 "origin = [-1, 2, 0.5]\n"));
  const modal::System system = modal::build_system(s);
  ASSERT_EQ(system.size(), 48);
  modal::Workspace w(system);
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(48);
  EXPECT_NEAR(modal::potential_gradient(system, w, q).norm(), 0.0, 1e-12);
  const Eigen::MatrixXd K = modal::potential_hessian(system, w, q);
  const Eigen::MatrixXd M = modal::mass_matrix(system, w, q);
  const Eigen::VectorXd computed =
      Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd>(K, M, Eigen::EigenvaluesOnly).eigenvalues();
  std::vector<double> expected;
  auto lambda = [](int r) { return 4 * std::pow(std::sin(r * std::numbers::pi / 10), 2); };
  for (int r = 1; r <= 4; ++r)
    for (int t = 1; t <= 4; ++t) {
      expected.push_back(k * p / m * (lambda(r) + lambda(t)));
      expected.push_back(k / m * lambda(r) + k * p / m * lambda(t));  // x
      expected.push_back(k * p / m * lambda(r) + k / m * lambda(t));  // y
    }
  std::sort(expected.begin(), expected.end());
  for (int i = 0; i < 48; ++i)
    EXPECT_NEAR(computed[i], expected[static_cast<std::size_t>(i)], 1e-9 * expected.back()) << i;
}

TEST(lattice, WithOtherBodiesSpringsAndLoads) {
  const modal::Scene s = parse(R"([[particle]]
name = "weight"
position = [0.5, 0.5, -1]
mass = 2

[[lattice]]
name = "net"
size = [3, 3, 1]
spacing = 1
mass = 1
stiffness = 10
fixed = "boundary"

[[body]]
name = "pendulum"
parent = "net.1.1"
joint = "hinge"
mass = 1
com = [0, 0, -0.5]

[[spring]]
a = "weight"
b = "net.1.1"
stiffness = 3

[[load]]
body = "net.2.2"
force = [0, 0, -1]

[[constraint]]
type = "distance"
a = "net.0.1"
b = "net.1.1"
)");
  const auto& d = s.description;
  ASSERT_EQ(d.bodies.size(), 1u + 9u + 1u);
  EXPECT_EQ(d.bodies[0].name, "weight");  // file order
  EXPECT_EQ(d.bodies[1].name, "net.0.0");
  EXPECT_EQ(d.bodies[10].name, "pendulum");
  EXPECT_EQ(d.bodies[10].parent, index_of(s, "net.1.1"));  // a generated particle may be a parent
  EXPECT_EQ(s.body_locations[1].line, 6);
  EXPECT_EQ(s.body_locations[10].line, 14);
  // The [[spring]] first, then the net's 12 springs with their ends shifted.
  ASSERT_EQ(d.springs.size(), 13u);
  EXPECT_EQ(d.springs[0].a.body, 0);
  EXPECT_EQ(d.springs[0].b.body, index_of(s, "net.1.1"));
  EXPECT_DOUBLE_EQ(d.springs[0].rest_length, std::sqrt(0.5 * 0.5 * 2 + 1));
  EXPECT_EQ(d.springs[1].a.body, index_of(s, "net.0.0"));
  EXPECT_EQ(d.springs[1].b.body, index_of(s, "net.1.0"));
  EXPECT_EQ(d.loads.at(0).at.body, index_of(s, "net.2.2"));
  EXPECT_DOUBLE_EQ(d.constraints.at(0).length, 1.0);
  EXPECT_EQ(modal::build_system(s).size(), 3 + 3 + 1);
}

// --- [[lattice]]: errors -------------------------------------------------------

struct Expected {
  std::string file;
  int line;
  int column;
  std::string key;
  std::string message;  // a substring of the reason
};

void check_error(const std::function<void()>& action, const Expected& expected) {
  try {
    action();
    ADD_FAILURE() << "no error, expected " << expected.message;
  } catch (const modal::SceneError& e) {
    EXPECT_EQ(e.where().file, expected.file) << e.what();
    EXPECT_EQ(e.where().line, expected.line) << e.what();
    EXPECT_EQ(e.where().column, expected.column) << e.what();
    EXPECT_EQ(e.key(), expected.key) << e.what();
    EXPECT_NE(e.reason().find(expected.message), std::string::npos) << e.what();
  }
}

void check_scene_error(const std::string& text, int line, int column, const std::string& key, const std::string& message) {
  check_error([&] { (void)modal::parse_scene(text, "bad.toml"); }, {"bad.toml", line, column, key, message});
}

const std::string good = "spacing = 1\nmass = 1\nstiffness = 10\n";  // lines 2-4 after [[lattice]]

TEST(lattice_errors, Size) {
  check_scene_error(lattice(good), 1, 1, "lattice[1].size", "missing required key 'size' in [[lattice]]");
  check_scene_error(lattice(good + "size = 3\n"), 5, 8, "lattice[1].size",
                    "expected an array of 3 positive integers [nx, ny, nz] (nz = 1: a 2-D net), got an integer");
  check_scene_error(lattice(good + "size = [2, 2]\n"), 5, 8, "lattice[1].size", "got 2 elements");
  check_scene_error(lattice(good + "size = [2, 0, 1]\n"), 5, 12, "lattice[1].size[2]", "must be at least 1, got 0");
  check_scene_error(lattice(good + "size = [2.5, 2, 1]\n"), 5, 9, "lattice[1].size[1]", "must be an integer, got 2.5");
  check_scene_error(lattice(good + "size = [2, \"x\", 1]\n"), 5, 13, "lattice[1].size[2]", "unknown name 'x'");
  check_scene_error(lattice(good + "size = [2000, 2000, 2]\n"), 5, 8, "lattice[1].size",
                    "the lattice would have 8000000 particles; at most 5000000 are supported");
  check_scene_error(lattice(good + "size = [1e7, 1, 1]\n"), 5, 9, "lattice[1].size[1]",
                    "at most 5000000 particles are supported, got 10000000");
}

TEST(lattice_errors, Values) {
  const std::string size = "size = [2, 2, 2]\n";  // line 2
  check_scene_error(lattice(size + "spacing = 0\nmass = 1\nstiffness = 1\n"), 3, 11, "lattice[1].spacing", "must be positive, got 0");
  check_scene_error(lattice(size + "spacing = [1, 1]\nmass = 1\nstiffness = 1\n"), 3, 11, "lattice[1].spacing",
                    "expected an array of 3 numbers, got 2");
  check_scene_error(lattice(size + "spacing = [1, -1, 1]\nmass = 1\nstiffness = 1\n"), 3, 15, "lattice[1].spacing[2]",
                    "must be positive, got -1");
  check_scene_error(lattice(size + "mass = 1\nstiffness = 1\n"), 1, 1, "lattice[1].spacing", "missing required key 'spacing'");
  check_scene_error(lattice(size + "spacing = 1\nstiffness = 1\n"), 1, 1, "lattice[1].mass", "missing required key 'mass'");
  check_scene_error(lattice(size + "spacing = 1\nmass = -1\nstiffness = 1\n"), 4, 8, "lattice[1].mass", "must be non-negative, got -1");
  check_scene_error(lattice(size + "spacing = 1\nmass = 1\nstiffness = 0\n"), 5, 13, "lattice[1].stiffness", "must be positive, got 0");
  check_scene_error(lattice(size + good + "damping = -1\n"), 6, 11, "lattice[1].damping", "must be non-negative");
  check_scene_error(lattice(size + good + "prestrain = 1\n"), 6, 13, "lattice[1].prestrain", "must be less than 1");
  check_scene_error(lattice(size + good + "prestrain = -0.5\n"), 6, 13, "lattice[1].prestrain", "must be non-negative");
  check_scene_error(lattice(size + good + "diagonals = 1\n"), 6, 13, "lattice[1].diagonals", "expected true or false");
  check_scene_error(lattice(size + good + "spacings = 1\n"), 6, 1, "lattice[1].spacings",
                    "unknown key 'spacings' in [[lattice]] (did you mean 'spacing'?)");
  check_scene_error(lattice(size + good + "name = \"world\"\n"), 6, 8, "lattice[1].name", "'world' is reserved");
  check_scene_error(lattice(size + good + "name = \"\"\n"), 6, 8, "lattice[1].name", "a lattice name must not be empty");
}

TEST(lattice_errors, FixedAndPlane) {
  const std::string cube = "size = [2, 2, 2]\n" + good;  // lines 2-5
  const std::string net = "size = [2, 2, 1]\n" + good;
  check_scene_error(lattice(cube + "fixed = \"bondary\"\n"), 6, 9, "lattice[1].fixed",
                    "unknown value 'bondary'; expected \"none\", \"boundary\" or a face \"x-\", \"x+\", \"y-\", \"y+\", "
                    "\"z-\" or \"z+\" (did you mean 'boundary'?)");
  check_scene_error(lattice(cube + "fixed = \"X-\"\n"), 6, 9, "lattice[1].fixed", "unknown value 'X-'; expected \"none\", \"boundary\" or a face \"x-\", \"x+\", \"y-\", \"y+\", \"z-\" or \"z+\" (did you mean 'x-'");
  check_scene_error(lattice(cube + "fixed = true\n"), 6, 9, "lattice[1].fixed",
                    "expected a string (\"none\", \"boundary\" or a face such as \"x-\") or an array of them, got a boolean");
  check_scene_error(lattice(cube + "fixed = [\"x-\", \"top\"]\n"), 6, 16, "lattice[1].fixed[2]", "unknown value 'top'");
  check_scene_error(lattice(cube + "fixed = [\"x-\", 1]\n"), 6, 16, "lattice[1].fixed[2]", "expected a string, got an integer");
  check_scene_error(lattice(net + "fixed = \"z-\"\n"), 6, 9, "lattice[1].fixed",
                    "the net lies in the xy plane, so 'z-' is not one of its edges; expected \"none\", \"boundary\", "
                    "\"x-\", \"x+\", \"y-\" or \"y+\"");
  check_scene_error(lattice(net + "plane = \"xz\"\nfixed = \"y+\"\n"), 7, 9, "lattice[1].fixed",
                    "the net lies in the xz plane, so 'y+' is not one of its edges");
  check_scene_error(lattice(net + "plane = \"yz\"\n"), 6, 9, "lattice[1].plane",
                    "unknown plane 'yz'; expected \"xy\" or \"xz\"");
  check_scene_error(lattice(cube + "plane = \"xy\"\n"), 6, 9, "lattice[1].plane",
                    "'plane' is for 2-D nets (size = [n1, n2, 1]); this lattice is 3-D (size[3] = 2)");
}

TEST(lattice_errors, Names) {
  const std::string net = "size = [2, 2, 1]\n" + good;  // lines 2-5 after [[lattice]]
  // Two generators with the default name.
  check_scene_error(lattice(net) + lattice(net), 6, 1, "lattice[2].name",
                    "duplicate generator name 'lattice': already used by the [[lattice]] at line 1 (the default name; "
                    "give each one a 'name')");
  check_scene_error(lattice(net + "name = \"n\"\n") + "[[network]]\nname = \"n\"\nnodes = \"x.csv\"\nedges = \"y.csv\"\n",
                    8, 8, "network[1].name", "duplicate generator name 'n': already used by the [[lattice]] at line 1");
  const std::string body = "[[body]]\nname = \"lattice.1.0\"\njoint = \"hinge\"\n";
  check_scene_error(lattice(net) + body, 7, 8, "body[1].name",
                    "duplicate body name 'lattice.1.0': already used by [[lattice]] 'lattice' at line 1");
  check_scene_error(body + lattice(net), 4, 1, "lattice[1].name",
                    "[[lattice]] 'lattice' generates the particle name 'lattice.1.0', which is already used by the "
                    "[[body]] at line 1");
  // Names of two lattices can meet: "a" (3-D) and "a.1" (2-D) both make "a.1.0.0".
  check_scene_error(lattice("name = \"a\"\nsize = [2, 2, 2]\n" + good) + lattice("name = \"a.1\"\n" + net), 8, 8,
                    "lattice[2].name",
                    "[[lattice]] 'a.1' generates the particle name 'a.1.0.0', which is already used by [[lattice]] 'a' "
                    "at line 1");
  check_scene_error(lattice(net) + "[[spring]]\na = \"lattice.1.2\"\nb = \"world\"\nstiffness = 1\n", 7, 5, "spring[1].a",
                    "unknown body 'lattice.1.2' (did you mean 'lattice.1.0', 'lattice.1.1'");
  check_scene_error(lattice(net) + "[[spring]]\na = \"lattice.1.1\"\na_point = [0, 0, 1]\nb = \"world\"\nstiffness = 1\n",
                    8, 11, "spring[1].a_point", "a particle is a point");
}

// --- [[network]] ---------------------------------------------------------------

// A scratch directory for a scene and its CSV files.
class Directory {
 public:
  Directory() {
    std::random_device random;
    path_ = fs::temp_directory_path() / ("modal_network_test_" + std::to_string(random()) + std::to_string(random()));
    fs::create_directories(path_);
  }
  ~Directory() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  Directory(const Directory&) = delete;
  Directory& operator=(const Directory&) = delete;
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  std::string write(const std::string& name, const std::string& text) const {
    fs::create_directories((path_ / name).parent_path());
    std::ofstream(path_ / name, std::ios::binary) << text;
    return file(name);
  }

 private:
  fs::path path_;
};

// lines 1-5 of the scene
const std::string network_scene =
    "[[network]]\nname = \"truss\"\nnodes = \"nodes.csv\"\nedges = \"edges.csv\"\nstiffness = 100\n";
const std::string network_with_mass = network_scene + "mass = 1\n";  // line 6
const std::string good_nodes = "name,x,y,z,mass,fixed\na,0,0,0,1,1\nb,1,0,0,2,0\nc,0,1,0,,z\n";  // lines 1-4
const std::string good_edges = "a,b,stiffness,rest_length,damping\na,b,,,\nb,c,50,,0.5\n";        // lines 1-3

modal::Scene load_network(const Directory& dir, const std::string& scene, const std::string& nodes,
                          const std::string& edges) {
  dir.write("nodes.csv", nodes);
  dir.write("edges.csv", edges);
  return modal::load_scene(dir.write("scene.toml", scene));
}

TEST(network, NodesAndEdges) {
  const Directory dir;
  const modal::Scene s = load_network(
      dir, network_scene + "mass = 3\ndamping = 0.25\nprestrain = 0.5\n",
      "# a comment, then the header\n\nname , x,y,z,mass,fixed\r\na,0,0,0,1,1\r\nb,1,0,0,2,0\n\nc,0,1,+0.5e0,,z\nd, 1,1,0,,xy\n",
      good_edges + "c,d,,2,\n  # a comment\na,d,,,\n");
  const auto& d = s.description;
  ASSERT_EQ(d.bodies.size(), 4u);
  EXPECT_EQ(d.bodies[0].name, "truss.a");
  EXPECT_EQ(d.bodies[0].joint, JointType::fixed);
  EXPECT_EQ(d.bodies[1].joint, JointType::particle);
  EXPECT_DOUBLE_EQ(d.bodies[1].mass, 2.0);
  EXPECT_DOUBLE_EQ(d.bodies[2].mass, 3.0);  // the default
  EXPECT_EQ(d.bodies[2].origin, Vec3(0, 1, 0.5));
  EXPECT_EQ(d.bodies[2].particle_axes, (std::array<bool, 3>{true, true, false}));
  EXPECT_EQ(d.bodies[3].particle_axes, (std::array<bool, 3>{false, false, true}));
  // Body locations point into the nodes file.
  EXPECT_EQ(s.body_locations[1].file, dir.file("nodes.csv"));
  EXPECT_EQ(s.body_locations[1].line, 5);
  EXPECT_EQ(s.body_locations[3].line, 8);

  ASSERT_EQ(d.springs.size(), 4u);
  EXPECT_EQ(d.springs[0].a.body, 0);
  EXPECT_EQ(d.springs[0].b.body, 1);
  EXPECT_DOUBLE_EQ(d.springs[0].stiffness, 100.0);  // the default
  EXPECT_DOUBLE_EQ(d.springs[0].rest_length, 0.5);   // (1 - prestrain) × 1
  EXPECT_DOUBLE_EQ(d.springs[0].damping, 0.25);
  EXPECT_DOUBLE_EQ(d.springs[1].stiffness, 50.0);
  EXPECT_DOUBLE_EQ(d.springs[1].damping, 0.5);
  EXPECT_DOUBLE_EQ(d.springs[1].rest_length, 0.5 * std::sqrt(2.25));
  EXPECT_DOUBLE_EQ(d.springs[2].rest_length, 2.0);  // given: no prestrain
  EXPECT_EQ(modal::build_system(s).size(), 0 + 3 + 2 + 1);
}

TEST(network, ColumnsInAnyOrderAndNodesUsedByOtherSections) {
  const Directory dir;
  const modal::Scene s = load_network(dir,
                                      network_scene + "mass = 1\n[[particle]]\nname = \"p\"\nposition = [0, 0, -1]\nmass = 1\n"
                                                      "[[spring]]\na = \"p\"\nb = \"truss.b\"\nstiffness = 2\n",
                                      "z,y,x,name\n0,0,0,a\n0,0,1,b\n", "b,a\na,b\n");
  const auto& d = s.description;
  ASSERT_EQ(d.bodies.size(), 3u);
  EXPECT_EQ(d.bodies[0].name, "truss.a");  // the [[network]] comes first in the file
  EXPECT_EQ(d.bodies[1].origin, Vec3(1, 0, 0));
  EXPECT_EQ(d.bodies[2].name, "p");
  ASSERT_EQ(d.springs.size(), 2u);
  EXPECT_EQ(d.springs[0].a.body, 2);  // the [[spring]]
  EXPECT_EQ(d.springs[0].b.body, 1);
  EXPECT_EQ(d.springs[1].a.body, 1);  // the row "a,b" under the header "b,a"
  EXPECT_EQ(d.springs[1].b.body, 0);
}

TEST(network, TheTowerModel) {
  const modal::Scene s = modal::load_scene(std::string(MODAL_SOURCE_DIR) + "/models/network.toml");
  const auto& d = s.description;
  EXPECT_EQ(d.bodies.size(), 28u);
  EXPECT_EQ(count_fixed(s), 4u);
  EXPECT_EQ(d.springs.size(), 102u);
  EXPECT_EQ(body(s, "tower.a3").origin, Vec3(0, 0, 3));
  EXPECT_DOUBLE_EQ(body(s, "tower.c6").mass, 150.0);
  for (const modal::Spring& spring : d.springs) EXPECT_DOUBLE_EQ(spring.damping, 2.0e4);
  const modal::System system = modal::build_system(s);
  ASSERT_EQ(system.size(), 72);
  // The truss is rigid: K is positive definite at the written configuration.
  modal::Workspace w(system);
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(72);
  const Eigen::VectorXd k = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(modal::potential_hessian(system, w, q),
                                                                           Eigen::EigenvaluesOnly)
                                .eigenvalues();
  EXPECT_GT(k[0], 1e3);
}

TEST(network, ExampleModelsOfGenerators) {
  const modal::Scene block = modal::load_scene(std::string(MODAL_SOURCE_DIR) + "/models/lattice.toml");
  EXPECT_EQ(block.description.bodies.size(), 216u);
  EXPECT_EQ(count_fixed(block), 36u);
  EXPECT_EQ(block.description.springs.size(), 540u + 900u);
  EXPECT_EQ(modal::build_system(block).size(), 540);
  const modal::Scene net = modal::load_scene(std::string(MODAL_SOURCE_DIR) + "/models/net.toml");
  EXPECT_EQ(net.description.bodies.size(), 900u);
  EXPECT_EQ(count_fixed(net), 116u);
  EXPECT_EQ(modal::build_system(net).size(), 2352);
  EXPECT_LT(net.description.springs.at(0).rest_length, 0.1);  // pre-tensioned
}

// --- [[network]]: errors -------------------------------------------------------

void check_network_error(const std::string& scene, const std::string& nodes, const std::string& edges,
                         const std::string& file, int line, int column, const std::string& key,
                         const std::string& message) {
  const Directory dir;
  check_error([&] { (void)load_network(dir, scene, nodes, edges); },
              {dir.file(file), line, column, key, message});
}

TEST(network_errors, Files) {
  const Directory dir;
  dir.write("edges.csv", good_edges);
  const std::string scene = dir.write("scene.toml", network_scene);
  check_error([&] { (void)modal::load_scene(scene); },
              {scene, 3, 9, "network[1].nodes",
               "cannot open the nodes file '" + dir.file("nodes.csv") +
                   "' (\"nodes.csv\" relative to the scene file's directory): No such file or directory"});
  // A path relative to the scene's directory is named as resolved. Outside
  // that directory only when allowed (by default refused before opening).
  modal::SceneLimits outside;
  outside.allow_outside_data = true;
  const std::string nested = dir.write("sub/scene.toml", "[[network]]\nnodes = \"../missing.csv\"\nedges = \"e.csv\"\n");
  check_error([&] { (void)modal::load_scene(nested); },
              {nested, 2, 9, "network[1].nodes",
               "the nodes file '" + dir.file("missing.csv") +
                   "' (\"../missing.csv\" relative to the scene file's directory) lies outside the scene file's "
                   "directory"});
  check_error([&] { (void)modal::load_scene(nested, {}, outside); },
              {nested, 2, 9, "network[1].nodes",
               "cannot open the nodes file '" + dir.file("missing.csv") +
                   "' (\"../missing.csv\" relative to the scene file's directory): No such file or directory"});
  fs::create_directories(dir.file("sub/dir"));
  const std::string directory = dir.write("sub/d.toml", "[[network]]\nnodes = \"dir\"\nedges = \"e.csv\"\n");
  check_error([&] { (void)modal::load_scene(directory); },
              {directory, 2, 9, "network[1].nodes", "cannot read the nodes file '" + dir.file("sub/dir") + "'"});
  // A device would never end (/dev/zero) or would block (a terminal): refused by name.
  const std::string device = dir.write("dev.toml", "[[network]]\nnodes = \"/dev/zero\"\nedges = \"e.csv\"\n");
  check_error([&] { (void)modal::load_scene(device, {}, outside); },
              {device, 2, 9, "network[1].nodes", "cannot read the nodes file '/dev/zero': it is a device, not a file"});
  check_error([&] { (void)modal::load_scene(dir.write("s.toml", "[[network]]\nedges = \"e.csv\"\n")); },
              {dir.file("s.toml"), 1, 1, "network[1].nodes", "missing required key 'nodes' in [[network]]"});

  const std::string header = "; a nodes file starts with the header name,x,y,z[,mass][,fixed]";
  check_network_error(network_with_mass, "", good_edges, "nodes.csv", 1, 1, "",
                      "the nodes file has no header line (it is empty)" + header);
  check_network_error(network_with_mass, "# only\n\n# comments\n", good_edges, "nodes.csv", 1, 1, "",
                      "the nodes file has no header line (it is empty or only comments)");
  check_network_error(network_with_mass, good_nodes, "", "edges.csv", 1, 1, "",
                      "the edges file has no header line (it is empty); an edges file starts with the header "
                      "a,b[,stiffness][,rest_length][,damping]");
}

TEST(network_errors, Headers) {
  check_network_error(network_with_mass, "name,x,y,mass\na,0,0,1\n", good_edges, "nodes.csv", 1, 1, "z",
                      "missing column 'z' in the header; a nodes file starts with the header name,x,y,z[,mass][,fixed]");
  check_network_error(network_with_mass, "# nodes\nname,x,y,z,mas\n", good_edges, "nodes.csv", 2, 12, "mas",
                      "unknown column 'mas' in the nodes file (did you mean 'mass'?)");
  check_network_error(network_with_mass, "name,x,y,z,x\n", good_edges, "nodes.csv", 1, 12, "x",
                      "the column 'x' appears twice in the header");
  check_network_error(network_with_mass, "name,x,,z\n", good_edges, "nodes.csv", 1, 8, "", "empty column name in the header, column 3");
  check_network_error(network_with_mass, "name,x,y,z\n", good_edges, "nodes.csv", 1, 1, "", "the nodes file has a header but no nodes");
  check_network_error(network_with_mass, good_nodes, "a,stiffness\n", "edges.csv", 1, 1, "b", "missing column 'b' in the header");
}

TEST(network_errors, NodeRows) {
  const std::string header = "name,x,y,z,mass,fixed\na,0,0,0,1,1\n";  // lines 1-2
  auto nodes_error = [&](const std::string& row, int column, const std::string& key, const std::string& message) {
    check_network_error(network_with_mass, header + row + "c,0,1,0,1,0\n", good_edges, "nodes.csv", 3, column, key, message);
  };
  nodes_error("b,1,0\n", 1, "", "expected 6 fields (name,x,y,z,mass,fixed), got 3");
  nodes_error("b,1,0,0,1,0,7\n", 1, "", "expected 6 fields (name,x,y,z,mass,fixed), got 7");
  nodes_error("b,1,zero,0,1,0\n", 5, "y", "expected a finite number, got 'zero'");
  nodes_error("b,1, nan ,0,1,0\n", 6, "y", "expected a finite number, got 'nan'");
  nodes_error("b,1,0,1e999,1,0\n", 7, "z", "expected a finite number, got '1e999'");
  nodes_error("b,1,0,0,-2,0\n", 9, "mass", "must be non-negative, got -2");
  nodes_error("b,,0,0,1,0\n", 3, "x", "missing value");
  nodes_error(",1,0,0,1,0\n", 1, "name", "missing value");
  nodes_error("b,1,0,0,1,yes\n", 11, "fixed",
              "expected 0, 1, true, false or the fixed axes as letters (\"z\", \"xy\", \"xyz\"), got 'yes'");
  nodes_error("b,1,0,0,1,xx\n", 11, "fixed", "got 'xx'");
  nodes_error("a,1,0,0,1,0\n", 1, "name", "duplicate node name 'a': already used on line 2");
  // No mass: neither in the row nor as a default.
  const std::string no_default = "[[network]]\nname = \"truss\"\nnodes = \"nodes.csv\"\nedges = \"edges.csv\"\nstiffness = 1\n";
  check_network_error(no_default, good_nodes, good_edges, "nodes.csv", 4, 9, "mass",
                      "no mass for node 'c': fill in the mass column or give [[network]] a default 'mass'");
  check_network_error(no_default, "name,x,y,z\na,0,0,0\n", good_edges, "scene.toml", 1, 1, "network[1].mass",
                      "has no mass column, so [[network]] needs a default 'mass'");
}

TEST(network_errors, EdgeRows) {
  const std::string nodes = good_nodes + "d,0,0,0,1,0\n";  // d where a is
  auto edges_error = [&](const std::string& edges, int line, int column, const std::string& key, const std::string& message) {
    check_network_error(network_with_mass, nodes, edges, "edges.csv", line, column, key, message);
  };
  edges_error("a,b\na,b\nb,cc\n", 3, 3, "b", "unknown node 'cc' (did you mean 'c'?); an edge joins two nodes of the nodes file");
  edges_error("a,b\nB,c\n", 2, 1, "a", "unknown node 'B' (did you mean 'b'?)");
  edges_error("a,b\nworld,b\n", 2, 1, "a", "(to tie a node to the world, fix it: fixed = 1)");
  edges_error("a,b\nc, c\n", 2, 4, "b", "an edge must join two different nodes; both ends are 'c'");
  edges_error("a,b\nb,c\na,d\n", 3, 1, "rest_length",
              "the nodes 'a' and 'd' are at the same place, so the edge's rest length would be 0; give a rest_length");
  edges_error("a,b,rest_length\nb,c,\na,d,\n", 3, 5, "rest_length", "are at the same place");
  edges_error("a,b,stiffness\na,b,-1\n", 2, 5, "stiffness", "must be positive, got -1");
  edges_error("a,b,rest_length\na,b,-1\n", 2, 5, "rest_length", "must be non-negative, got -1");
  edges_error("a,b,damping\na,b,x\n", 2, 5, "damping", "expected a finite number, got 'x'");
  edges_error("a,b,damping\na,b\n", 2, 1, "", "expected 3 fields (a,b,damping), got 2");
  // A zero-length edge with a rest length is accepted.
  const Directory dir;
  EXPECT_EQ(load_network(dir, network_with_mass, nodes, "a,b,rest_length\na,d,0.5\n").description.springs.at(0).rest_length, 0.5);
  // No stiffness: neither in the row nor as a default.
  const std::string no_default = "[[network]]\nname = \"truss\"\nnodes = \"nodes.csv\"\nedges = \"edges.csv\"\nmass = 1\n";
  check_network_error(no_default, nodes, "a,b,stiffness\na,b,3\nb,c,\n", "edges.csv", 3, 5, "stiffness",
                      "no stiffness for the edge 'b'-'c': fill in the stiffness column or give [[network]] a default 'stiffness'");
  check_network_error(no_default, nodes, "a,b\na,b\n", "scene.toml", 1, 1, "network[1].stiffness",
                      "has no stiffness column, so [[network]] needs a default 'stiffness'");
}

TEST(network_errors, KeysAndNames) {
  check_network_error(network_scene + "mass = -1\n", good_nodes, good_edges, "scene.toml", 6, 8, "network[1].mass",
                      "must be non-negative, got -1");
  check_network_error(network_with_mass + "prestrain = 2\n", good_nodes, good_edges, "scene.toml", 7, 13, "network[1].prestrain",
                      "must be less than 1");
  check_network_error(network_with_mass + "edge = \"x\"\n", good_nodes, good_edges, "scene.toml", 7, 1, "network[1].edge",
                      "unknown key 'edge' in [[network]] (did you mean 'edges'?)");
  // Particle names are unique across all bodies.
  const std::string body = "[[body]]\nname = \"truss.b\"\njoint = \"hinge\"\n";
  const Directory dir;
  check_error([&] { (void)load_network(dir, network_with_mass + body, good_nodes, good_edges); },
              {dir.file("scene.toml"), 8, 8, "body[1].name",
               "duplicate body name 'truss.b': already used by node 'b' of [[network]] 'truss' (" + dir.file("nodes.csv") +
                   " line 3)"});
  check_network_error(body + network_with_mass, good_nodes, good_edges, "nodes.csv", 3, 1, "name",
                      "node 'b' of [[network]] 'truss' is the particle 'truss.b', a name already used by the [[body]] at line 1");
}

// --- scale ---------------------------------------------------------------------

// Reading and building scenes of about 10⁶ coordinates: reported, not asserted
// (timings depend on the machine; sanitizer builds are much slower).
TEST(generators_scale, MillionCoordinates) {
  const std::vector<std::pair<std::string, std::string>> scenes{
      {"lattice 70x70x70, diagonals, fixed z-",
       "[[lattice]]\nsize = [70, 70, 70]\nspacing = 0.01\nmass = 1e-3\nstiffness = 100\ndiagonals = true\nfixed = \"z-\"\n"},
      {"net 580x580, boundary fixed, prestrain",
       "[[lattice]]\nname = \"net\"\nsize = [580, 580, 1]\nspacing = 0.01\nmass = 1e-3\nstiffness = 100\n"
       "prestrain = 0.01\nfixed = \"boundary\"\n"}};
  for (const auto& [label, text] : scenes) {
    using clock = std::chrono::steady_clock;
    const auto start = clock::now();
    const modal::Scene scene = modal::parse_scene(text, "large.toml");
    const auto parsed = clock::now();
    const modal::System system = modal::build_system(scene);
    const auto built = clock::now();
    EXPECT_GT(system.size(), 1000000);
    const auto ms = [](auto d) { return std::chrono::duration<double, std::milli>(d).count(); };
    std::cout << "  " << label << ": " << scene.description.bodies.size() << " particles, " << system.size()
              << " coordinates, " << scene.description.springs.size() << " springs: parse " << ms(parsed - start)
              << " ms, build " << ms(built - parsed) << " ms\n";
  }
}

// SceneLimits: a caller's tighter bounds on the generators are refused at the
// key, like the defaults (the fuzzer reads scenes with such limits).
TEST(lattice, CallerLimits) {
  modal::SceneLimits limits;
  limits.particles = 100;
  limits.links = 5;
  const std::string big = lattice("size = [20, 20, 1]\nspacing = 0.1\nmass = 1\nstiffness = 1\n");
  EXPECT_EQ(parse(big).description.bodies.size(), 400u);  // the defaults allow it
  try {
    (void)modal::parse_scene(big, "test.toml", {}, limits);
    ADD_FAILURE() << "a lattice beyond the caller's limit was read";
  } catch (const modal::SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("400 particles; at most 100"), std::string::npos) << e.what();
  }
  const std::string chain = "[[chain]]\nname = \"c\"\nlinks = 6\nlength = 1\nmass = 1\n";
  EXPECT_EQ(parse(chain).description.bodies.size(), 6u);
  try {
    (void)modal::parse_scene(chain, "test.toml", {}, limits);
    ADD_FAILURE() << "a chain beyond the caller's limit was read";
  } catch (const modal::SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("at most 5 links"), std::string::npos) << e.what();
  }
}

}  // namespace

// --- distributed generation: a scene read in parts (SceneWindow) ----------------

namespace parts {

// A spring by its ends' whole-scene indices and values, to compare as sets.
using Key = std::tuple<long long, long long, double, double>;

long long global(const modal::Scene& s, int b) {
  return b < 0 ? -1 : s.global_bodies.empty() ? b : s.global_bodies[static_cast<std::size_t>(b)];
}

}  // namespace parts

// Generated family: random lattices (2-D and 3-D, diagonals, fixed faces), a
// random network (nodes in random order, random edges), [[particle]]s before
// and after them, a [[spring]] and a [[load]] on generated particles; read
// whole and in 1 to 5 parts. Reference: the whole reading, which the serial
// path uses. Each part must hold bodies identical to the whole scene's at
// their global indices; the owned ranges must tile the scene in order
// (⌊N/p⌋ or one more); the springs owned by the parts (first end owned, the
// second when the first is the world) must be the whole scene's springs, each
// exactly once; loads as the whole scene's; and every held body that is not
// owned must be a hand-written body, an end of an owned spring or named by a
// table, so that no part holds more than its owned range and its halo.
TEST(scene_parts, PartsTileTheWholeScene) {
  std::mt19937 random(18);
  const Directory dir;
  for (int trial = 0; trial < 12; ++trial) {
    std::uniform_int_distribution<int> side(1, 6);
    const bool flat = trial % 2 == 0;
    const int n1 = side(random) + 1, n2 = side(random), n3 = flat ? 1 : side(random) + 1;
    const char* fixed[] = {"\"none\"", "\"boundary\"", "\"x-\"", "[\"x+\", \"y-\"]"};
    const int nodes = std::uniform_int_distribution<int>(2, 15)(random);
    std::string node_csv = "name,x,y,z,mass\n", edge_csv = "a,b\n";
    std::vector<int> order(static_cast<std::size_t>(nodes));
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), random);
    for (const int v : order)
      node_csv += "v" + std::to_string(v) + "," + std::to_string(v) + "," + std::to_string(v * v % 7) + ",0,1\n";
    for (int e = 0; e < 2 * nodes; ++e) {
      const int a = std::uniform_int_distribution<int>(0, nodes - 1)(random);
      const int b = (a + 1 + std::uniform_int_distribution<int>(0, nodes - 2)(random)) % nodes;
      edge_csv += "v" + std::to_string(a) + ",v" + std::to_string(b) + "\n";
    }
    dir.write("nodes.csv", node_csv);
    dir.write("edges.csv", edge_csv);
    const std::string grid = flat ? "net.1.0" : "net.1.0.0";
    const std::string text =
        "[[particle]]\nname = \"p\"\nposition = [0, 0, 5]\nmass = 1\n"
        "[[lattice]]\nname = \"net\"\nsize = [" + std::to_string(n1) + ", " + std::to_string(n2) + ", " +
        std::to_string(n3) + "]\nspacing = 0.5\nmass = 0.1\nstiffness = 10\ndiagonals = " +
        (trial % 3 == 0 ? "true" : "false") + "\nfixed = " + fixed[trial % 4] + "\nprestrain = 0.01\n" +
        "[[network]]\nname = \"truss\"\nnodes = \"nodes.csv\"\nedges = \"edges.csv\"\nstiffness = 3\n" +
        "[[particle]]\nname = \"q\"\nposition = [1, 0, 5]\nmass = 1\n"
        "[[spring]]\na = \"q\"\nb = \"" + grid + "\"\nstiffness = 7\n"
        "[[spring]]\na = \"world\"\nb = \"truss.v0\"\nstiffness = 2\nrest_length = 1\n"
        "[[load]]\nbody = \"" + grid + "\"\nforce = [0, 0, -1]\n";
    const std::string file = dir.write("scene.toml", text);
    const modal::Scene whole = modal::load_scene(file);
    const auto& all = whole.description;
    const long long total = static_cast<long long>(all.bodies.size());
    EXPECT_EQ(whole.total_bodies, total);
    std::multiset<parts::Key> springs, owned_springs;
    for (const modal::Spring& s : all.springs)
      springs.insert({parts::global(whole, s.a.body), parts::global(whole, s.b.body), s.stiffness, s.rest_length});
    for (int count = 1; count <= 5; ++count) {
      SCOPED_TRACE("trial " + std::to_string(trial) + ", " + std::to_string(count) + " parts");
      owned_springs.clear();
      long long next = 0;
      for (int p = 0; p < count; ++p) {
        const modal::SceneWindow window{p, count};
        const modal::Scene part = modal::load_scene(file, {}, {}, &window);
        const auto& d = part.description;
        EXPECT_EQ(part.total_bodies, total);
        EXPECT_EQ(part.first_owned, next);
        const long long size = part.end_owned - part.first_owned;
        EXPECT_TRUE(size == total / count || size == total / count + 1);
        next = part.end_owned;
        ASSERT_EQ(part.global_bodies.size(), d.bodies.size());
        EXPECT_TRUE(std::is_sorted(part.global_bodies.begin(), part.global_bodies.end()));
        const auto owned = [&](long long g) { return g >= part.first_owned && g < part.end_owned; };
        std::set<long long> explained;  // ends of owned springs and named bodies
        for (const std::string& name : {std::string("p"), std::string("q"), grid, std::string("truss.v0")})
          explained.insert(index_of(whole, name));
        for (std::size_t b = 0; b < d.bodies.size(); ++b) {
          const modal::Body& mine = d.bodies[b];
          const modal::Body& reference = all.bodies[static_cast<std::size_t>(part.global_bodies[b])];
          EXPECT_EQ(mine.name, reference.name);
          EXPECT_EQ(mine.origin, reference.origin);
          EXPECT_EQ(mine.mass, reference.mass);
          EXPECT_EQ(mine.joint, reference.joint);
          EXPECT_EQ(mine.particle_axes, reference.particle_axes);
        }
        for (const modal::Spring& s : d.springs) {
          const long long a = parts::global(part, s.a.body), b = parts::global(part, s.b.body);
          if (!owned(a >= 0 ? a : b)) continue;
          owned_springs.insert({a, b, s.stiffness, s.rest_length});
          explained.insert(a);
          explained.insert(b);
        }
        for (const long long g : part.global_bodies)
          EXPECT_TRUE(owned(g) || explained.count(g)) << "part " << p << " holds body " << g << " for no reason";
        ASSERT_EQ(d.loads.size(), all.loads.size());
        EXPECT_EQ(parts::global(part, d.loads[0].at.body), all.loads[0].at.body);
      }
      EXPECT_EQ(next, total);
      EXPECT_EQ(owned_springs, springs);
    }
  }
}

// A scene read in parts needs every body on the world (the bodies' numbering
// is then the file order); a body hanging from another is refused where its
// parent is named, while the whole reading accepts it.
TEST(scene_parts, BodiesMustHangFromTheWorld) {
  const std::string text =
      "[[body]]\nname = \"arm\"\njoint = \"hinge\"\nmass = 1\n"
      "[[body]]\nname = \"hand\"\nparent = \"arm\"\njoint = \"hinge\"\nmass = 1\n";
  EXPECT_NO_THROW(parse(text));
  const modal::SceneWindow window{0, 2};
  try {
    (void)modal::parse_scene(text, "test.toml", {}, {}, &window);
    FAIL() << "no error";
  } catch (const modal::SceneError& e) {
    EXPECT_EQ(e.where().line, 7);  // parent = "arm"
    EXPECT_EQ(e.key(), "body[2].parent");
    EXPECT_NE(e.reason().find("needs every body on the world"), std::string::npos) << e.reason();
  }
}

// A scene read in parts is bounded per part: SceneLimits apply to what the
// part builds (its particles, its springs, their memory), the whole only by
// what 32-bit indices number (max_particles_in_parts). Reference: the counts
// of the lattice, by hand (40 × 50 particles; 39·50 + 40·49 = 3910 springs).
TEST(scene_parts, LimitsBoundEachPart) {
  const std::string text =
      "[[lattice]]\nname = \"net\"\nsize = [40, 50, 1]\nspacing = 0.1\nmass = 0.1\nstiffness = 10\n"
      "fixed = \"boundary\"\n";
  for (const bool particles : {true, false}) {
    SCOPED_TRACE(particles ? "particle limit 1200" : "spring limit 2400");
    modal::SceneLimits limits;
    if (particles) limits.particles = 1200;
    else limits.springs = 2400;
    EXPECT_THROW((void)modal::parse_scene(text, "t.toml", {}, limits), modal::SceneError);  // 2000, 3910 whole
    const modal::SceneWindow one{0, 1};
    EXPECT_THROW((void)modal::parse_scene(text, "t.toml", {}, limits, &one), modal::SceneError);
    for (const int count : {2, 3, 4})  // 1000 particles and about 1955 springs or fewer a part
      for (int p = 0; p < count; ++p) {
        const modal::SceneWindow window{p, count};
        const modal::Scene part = modal::parse_scene(text, "t.toml", {}, limits, &window);
        EXPECT_EQ(part.total_bodies, 2000);
        EXPECT_LE(part.end_owned - part.first_owned, 1000);
      }
  }
  // 10⁸ particles, beyond the default limit of a whole scene (5·10⁶), read in
  // 10⁴ parts: each builds its 10⁴ particles and a row of ghosts.
  const std::string huge =
      "[[lattice]]\nname = \"net\"\nsize = [10000, 10000, 1]\nspacing = 0.1\nmass = 0.1\nstiffness = 10\n"
      "fixed = \"boundary\"\n";
  EXPECT_THROW((void)modal::parse_scene(huge, "t.toml"), modal::SceneError);
  const modal::SceneWindow window{1234, 10000};
  const modal::Scene part = modal::parse_scene(huge, "t.toml", {}, {}, &window);
  EXPECT_EQ(part.total_bodies, 100'000'000);
  EXPECT_EQ(part.first_owned, 12'340'000);
  EXPECT_EQ(part.end_owned, 12'350'000);
  EXPECT_LE(part.description.bodies.size(), 20'000u);
  // 10⁹ particles cannot be numbered, in any number of parts.
  const std::string beyond =
      "[[lattice]]\nname = \"net\"\nsize = [1000, 1000, 1000]\nspacing = 0.1\nmass = 0.1\nstiffness = 10\n";
  try {
    (void)modal::parse_scene(beyond, "t.toml", {}, {}, &window);
    FAIL() << "no error";
  } catch (const modal::SceneError& e) {
    EXPECT_NE(e.reason().find("can be numbered in a scene read in parts"), std::string::npos) << e.reason();
  }
}

// --- networks read in parts: streamed, kept by part ---------------------------

// Every heap allocation of this test program is counted (live bytes and their
// peak), so that a reading's peak heap is measured exactly, without the noise
// of the process's resident size.
namespace heap {
std::atomic<long long> live{0}, peak{0};
void* allocate(std::size_t size) {
  void* p = std::malloc(size == 0 ? 1 : size);
  if (p == nullptr) throw std::bad_alloc();
  const long long now = live += static_cast<long long>(malloc_usable_size(p));
  long long high = peak.load();
  while (now > high && !peak.compare_exchange_weak(high, now)) {
  }
  return p;
}
void release(void* p) noexcept {
  if (p == nullptr) return;
  live -= static_cast<long long>(malloc_usable_size(p));
  std::free(p);
}
// The peak heap bytes above the start while `work` runs.
template <class Work>
long long peak_during(Work&& work) {
  const long long start = live.load();
  peak = start;
  work();
  return peak.load() - start;
}
}  // namespace heap

void* operator new(std::size_t size) { return heap::allocate(size); }
void* operator new[](std::size_t size) { return heap::allocate(size); }
void operator delete(void* p) noexcept { heap::release(p); }
void operator delete[](void* p) noexcept { heap::release(p); }
void operator delete(void* p, std::size_t) noexcept { heap::release(p); }
void operator delete[](void* p, std::size_t) noexcept { heap::release(p); }
// The nothrow forms too (std::stable_sort's buffer): every unaligned new and
// delete then goes through malloc and free here, as AddressSanitizer checks.
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  try {
    return heap::allocate(size);
  } catch (const std::bad_alloc&) {
    return nullptr;
  }
}
void* operator new[](std::size_t size, const std::nothrow_t& tag) noexcept { return operator new(size, tag); }
void operator delete(void* p, const std::nothrow_t&) noexcept { heap::release(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { heap::release(p); }

namespace {

// The shortest text that reads back as `x`.
std::string number_text(double x) {
  std::array<char, 32> buffer{};
  return std::string(buffer.data(), std::to_chars(buffer.data(), buffer.data() + buffer.size(), x).ptr);
}

// A random network's CSV files and what the scene must make of them, computed
// here from the generated data (an independent reference for the serial
// reading, which the parts are then compared with).
struct RandomNetwork {
  std::string nodes, edges;  // the files' text
  std::vector<std::string> names;  // by row
  std::vector<std::array<double, 3>> positions;
  std::vector<double> masses;
  struct Edge {
    int a, b;
    double stiffness, rest, damping;
  };
  std::vector<Edge> list;
};

// Names of random length (some beyond the 15 characters a std::string keeps
// inline), rows in random order, a random subset and order of the optional
// columns, empty optional fields (defaults), comments, blank lines, spaces
// around fields, CRLF line ends and a byte order mark at random.
RandomNetwork random_network(std::mt19937& random, int count, double mass, double stiffness, double damping,
                             double prestrain) {
  RandomNetwork n;
  const auto chance = [&](double p) { return std::uniform_real_distribution<double>(0, 1)(random) < p; };
  const bool crlf = chance(0.5);
  const std::string end = crlf ? "\r\n" : "\n";
  std::set<std::string> used;
  while (static_cast<int>(n.names.size()) < count) {
    std::string name;
    const int length = std::uniform_int_distribution<int>(1, 24)(random);
    for (int c = 0; c < length; ++c) name += "abcxyzAB_0123456789"[std::uniform_int_distribution<int>(0, 18)(random)];
    if (name.front() == '#' || !used.insert(name).second) continue;
    n.names.push_back(name);
  }
  std::vector<std::string> node_columns{"name", "x", "y", "z"}, optional{"mass", "fixed"};
  for (const auto& c : optional)
    if (chance(0.6)) node_columns.push_back(c);
  std::shuffle(node_columns.begin(), node_columns.end(), random);
  const auto header = [&](const std::vector<std::string>& columns) {
    std::string h;
    for (const auto& c : columns) h += (h.empty() ? "" : ",") + c;
    return h + end;
  };
  const auto noise = [&](std::string& text) {
    if (chance(0.1)) text += "# a comment, with commas" + end;
    if (chance(0.05)) text += (chance(0.5) ? "  " : "") + end;
  };
  n.nodes = chance(0.3) ? "\xEF\xBB\xBF" : "";
  noise(n.nodes);
  n.nodes += header(node_columns);
  std::uniform_real_distribution<double> coordinate(-5, 5);
  for (int r = 0; r < count; ++r) {
    noise(n.nodes);
    const std::array<double, 3> x{coordinate(random), coordinate(random), coordinate(random)};
    n.positions.push_back(x);
    n.masses.push_back(mass);
    std::string row;
    for (const auto& c : node_columns) {
      std::string field;
      if (c == "name") field = n.names[static_cast<std::size_t>(r)];
      if (c == "x" || c == "y" || c == "z") field = number_text(x[static_cast<std::size_t>(c[0] - 'x')]);
      if (c == "mass" && chance(0.7)) {
        n.masses.back() = std::uniform_int_distribution<int>(1, 9)(random) * 0.25;
        field = number_text(n.masses.back());
      }
      if (c == "fixed" && chance(0.2)) field = chance(0.5) ? "0" : "false";
      row += (&c == &node_columns.front() ? "" : ",") + std::string(chance(0.2) ? " " : "") + field +
             (chance(0.2) ? "\t" : "");
    }
    n.nodes += row + end;
  }
  std::vector<std::string> edge_columns{"a", "b"};
  for (const std::string c : {"stiffness", "rest_length", "damping"})
    if (chance(0.5)) edge_columns.push_back(c);
  std::shuffle(edge_columns.begin(), edge_columns.end(), random);
  n.edges = header(edge_columns);
  const int edges = std::uniform_int_distribution<int>(0, 3 * count)(random);
  for (int e = 0; e < edges; ++e) {
    noise(n.edges);
    RandomNetwork::Edge edge{};
    edge.a = std::uniform_int_distribution<int>(0, count - 1)(random);
    edge.b = (edge.a + 1 + std::uniform_int_distribution<int>(0, count - 2)(random)) % count;
    const auto& xa = n.positions[static_cast<std::size_t>(edge.a)];
    const auto& xb = n.positions[static_cast<std::size_t>(edge.b)];
    edge.stiffness = stiffness;
    edge.rest = (1 - prestrain) * std::sqrt((xa[0] - xb[0]) * (xa[0] - xb[0]) + (xa[1] - xb[1]) * (xa[1] - xb[1]) +
                                            (xa[2] - xb[2]) * (xa[2] - xb[2]));
    edge.damping = damping;
    std::string row;
    for (const auto& c : edge_columns) {
      std::string field;
      if (c == "a") field = n.names[static_cast<std::size_t>(edge.a)];
      if (c == "b") field = n.names[static_cast<std::size_t>(edge.b)];
      if (c == "stiffness" && chance(0.6)) field = number_text(edge.stiffness = e + 1.5);
      if (c == "rest_length" && chance(0.6)) field = number_text(edge.rest = 0.125 * e);
      if (c == "damping" && chance(0.6)) field = number_text(edge.damping = 0.5 * e);
      row += (&c == &edge_columns.front() ? "" : ",") + std::string(chance(0.2) ? " " : "") + field;
    }
    n.edges += row + end;
    n.list.push_back(edge);
  }
  if (chance(0.5) && n.edges.ends_with(end)) n.edges.resize(n.edges.size() - end.size());  // no final line end
  return n;
}

}  // namespace

// Random networks (see random_network) among [[particle]]s, with a [[spring]]
// and a [[load]] on nodes, read whole and in 1 to 5 parts. The whole reading
// is first checked against the generated data (bodies by name, position,
// mass; springs by their ends, stiffness, rest length computed here from the
// positions, damping; each body's CSV line); then each part must hold
// exactly the whole scene's bodies at their global indices (name, origin,
// mass, joint, source line), the owned ranges must tile the scene, the
// parts' owned springs must be the whole scene's, each once (ends, stiffness,
// rest length, damping: bit for bit, as both compute the same expression),
// and the parts' owned edge rows must add up to the file's.
TEST(scene_parts, StreamedNetworksTileTheSerialScene) {
  std::mt19937 random(1818);
  const Directory dir;
  for (int trial = 0; trial < 40; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const int count = std::uniform_int_distribution<int>(2, 70)(random);
    const RandomNetwork n = random_network(random, count, 0.5, 3, 0.25, 0.01);
    dir.write("nodes.csv", n.nodes);
    dir.write("edges.csv", n.edges);
    const std::string named = n.names[static_cast<std::size_t>(count / 2)];
    const std::string text = "[[particle]]\nname = \"p\"\nposition = [0, 0, 9]\nmass = 1\n"
                             "[[network]]\nname = \"w\"\nnodes = \"nodes.csv\"\nedges = \"edges.csv\"\nmass = 0.5\n"
                             "stiffness = 3\ndamping = 0.25\nprestrain = 0.01\n"
                             "[[particle]]\nname = \"q\"\nposition = [1, 0, 9]\nmass = 1\n"
                             "[[spring]]\na = \"q\"\nb = \"w." + named + "\"\nstiffness = 7\n"
                             "[[load]]\nbody = \"w." + n.names[0] + "\"\nforce = [0, 0, -1]\n";
    const std::string file = dir.write("scene.toml", text);
    const modal::Scene whole = modal::load_scene(file);
    const auto& all = whole.description;
    ASSERT_EQ(all.bodies.size(), static_cast<std::size_t>(count) + 2);
    std::vector<long long> line_of(static_cast<std::size_t>(count));
    for (int r = 0; r < count; ++r) {
      const modal::Body& b = all.bodies[static_cast<std::size_t>(r) + 1];
      EXPECT_EQ(b.name, "w." + n.names[static_cast<std::size_t>(r)]);
      EXPECT_EQ(b.origin, Eigen::Vector3d(n.positions[static_cast<std::size_t>(r)].data()));
      EXPECT_EQ(b.mass, n.masses[static_cast<std::size_t>(r)]);
      line_of[static_cast<std::size_t>(r)] = whole.body_locations[static_cast<std::size_t>(r) + 1].line;
      if (r > 0) {
        EXPECT_GT(line_of[static_cast<std::size_t>(r)], line_of[static_cast<std::size_t>(r) - 1]);
      }
    }
    ASSERT_EQ(all.springs.size(), n.list.size() + 1);
    for (std::size_t e = 0; e < n.list.size(); ++e) {
      const modal::Spring& s = all.springs[e + 1];  // after the [[spring]]
      EXPECT_EQ(s.a.body, n.list[e].a + 1);
      EXPECT_EQ(s.b.body, n.list[e].b + 1);
      EXPECT_EQ(s.stiffness, n.list[e].stiffness);
      // The same expression up to the order of the sum of squares: a few ulps.
      EXPECT_NEAR(s.rest_length, n.list[e].rest, 1e-14 * n.list[e].rest);
      EXPECT_EQ(s.damping, n.list[e].damping);
    }
    using Key = std::tuple<long long, long long, double, double, double>;
    std::multiset<Key> springs, owned_springs;
    for (const modal::Spring& s : all.springs)
      springs.insert({parts::global(whole, s.a.body), parts::global(whole, s.b.body), s.stiffness, s.rest_length,
                      s.damping});
    const long long total = static_cast<long long>(all.bodies.size());
    for (int parts_count = 1; parts_count <= 5; ++parts_count) {
      SCOPED_TRACE(std::to_string(parts_count) + " parts");
      owned_springs.clear();
      long long next = 0, owned_edges = 0;
      for (int p = 0; p < parts_count; ++p) {
        const modal::SceneWindow window{p, parts_count};
        const modal::Scene part = modal::load_scene(file, {}, {}, &window);
        const auto& d = part.description;
        EXPECT_EQ(part.first_owned, next);
        next = part.end_owned;
        EXPECT_EQ(part.network_edges, static_cast<long long>(n.list.size()));
        owned_edges += part.owned_network_edges;
        ASSERT_EQ(part.global_bodies.size(), d.bodies.size());
        for (std::size_t b = 0; b < d.bodies.size(); ++b) {
          const auto g = static_cast<std::size_t>(part.global_bodies[b]);
          EXPECT_EQ(d.bodies[b].name, all.bodies[g].name);
          EXPECT_EQ(d.bodies[b].origin, all.bodies[g].origin);
          EXPECT_EQ(d.bodies[b].mass, all.bodies[g].mass);
          EXPECT_EQ(d.bodies[b].joint, all.bodies[g].joint);
          EXPECT_EQ(part.body_locations[b].file, whole.body_locations[g].file);
          EXPECT_EQ(part.body_locations[b].line, whole.body_locations[g].line);
        }
        for (const modal::Spring& s : d.springs) {
          const long long a = parts::global(part, s.a.body), b = parts::global(part, s.b.body);
          if (a >= part.first_owned && a < part.end_owned) owned_springs.insert({a, b, s.stiffness, s.rest_length, s.damping});
        }
      }
      EXPECT_EQ(next, total);
      EXPECT_EQ(owned_edges, static_cast<long long>(n.list.size()));
      EXPECT_EQ(owned_springs, springs);
    }
  }
}

// A large network (a 400 × 500 grid of 2·10⁵ nodes, edges to the right and
// down neighbours, rows in order) read in 8 parts: each part holds its owned
// rows and the next grid row (the down neighbours) only, owns exactly the
// edges of its rows, and its reading's peak heap is a fraction of the whole
// reading's: the files are streamed, never held whole. Bound: the part holds
// 1/8 of the nodes and edges; the whole reading holds both files' text and
// every row's fields besides. 0.25 leaves room for the fixed costs (the
// parser, the hash map's buckets) without letting an O(whole) reading pass.
TEST(scene_parts, LargeNetworkReadInPartsHoldsOnlyItsPart) {
  const Directory dir;
  const int rows = 400, columns = 500;
  std::string nodes = "name,x,y,z\n", edges = "a,b\n";
  const auto name = [&](int i, int j) { return "node_" + std::to_string(i) + "_" + std::to_string(j); };
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < columns; ++j) {
      nodes += name(i, j) + "," + std::to_string(j) + "," + std::to_string(i) + ",0\n";
      if (j + 1 < columns) edges += name(i, j) + "," + name(i, j + 1) + "\n";
      if (i + 1 < rows) edges += name(i, j) + "," + name(i + 1, j) + "\n";
    }
  dir.write("nodes.csv", nodes);
  dir.write("edges.csv", edges);
  const std::string file = dir.write(
      "scene.toml", "[[network]]\nname = \"g\"\nnodes = \"nodes.csv\"\nedges = \"edges.csv\"\nmass = 1\nstiffness = 1\n");
  const long long edge_count = static_cast<long long>(rows) * (columns - 1) + static_cast<long long>(rows - 1) * columns;
  long long whole_peak = 0;
  {
    modal::Scene whole;
    whole_peak = heap::peak_during([&] { whole = modal::load_scene(file); });
    ASSERT_EQ(whole.description.springs.size(), static_cast<std::size_t>(edge_count));
  }
  const int parts = 8;
  for (const int p : {0, 3, 7}) {
    SCOPED_TRACE("part " + std::to_string(p));
    const modal::SceneWindow window{p, parts};
    modal::Scene part;
    const long long part_peak = heap::peak_during([&] { part = modal::load_scene(file, {}, {}, &window); });
    const long long owned = part.end_owned - part.first_owned;
    ASSERT_EQ(owned, rows * columns / parts);  // whole grid rows: 50 of them
    const long long first_row = part.first_owned / columns, last_row = part.end_owned / columns;
    EXPECT_EQ(static_cast<long long>(part.description.bodies.size()), owned + (last_row < rows ? columns : 0));
    EXPECT_EQ(part.owned_network_edges, (last_row - first_row) * (columns - 1) + (last_row - first_row) * columns -
                                            (last_row == rows ? columns : 0));
    EXPECT_EQ(part.network_edges, edge_count);
    EXPECT_LT(static_cast<double>(part_peak), 0.25 * static_cast<double>(whole_peak))
        << "part peak " << part_peak << " bytes, whole " << whole_peak;
    std::cout << "  part " << p << " of " << parts << ": peak heap " << part_peak / 1048576.0 << " MiB, whole reading "
              << whole_peak / 1048576.0 << " MiB\n";
  }
}

// Faults in a network read in parts: some part reports the fault where the
// serial reading does (file, line, column, key; the reason too, except that
// an unknown node's suggestions come from the names the part holds), an
// earlier fault before a later one, and no part reports one before it (a
// part that does not own the faulty edge may report a later fault: the
// distributed backend then reads the scene whole on rank 0 for the serial
// message); a fault no part can see alone (an edge from a node no part has)
// leaves the parts' owned edge rows short of the file's, which the backend
// checks. Reference: the serial reading.
TEST(scene_parts, FaultsInANetworkReadInParts) {
  const Directory dir;
  std::string nodes = "name,x,y,z\n";
  for (int i = 0; i < 12; ++i) nodes += "n" + std::to_string(i) + "," + std::to_string(i) + ",0,0\n";
  const std::string scene = dir.write(
      "scene.toml", "[[network]]\nname = \"w\"\nnodes = \"nodes.csv\"\nedges = \"edges.csv\"\nmass = 1\nstiffness = 1\n");
  struct Case {
    std::string what, nodes, edges;
    bool seen;  // by some part alone
  };
  const std::vector<Case> cases{
      {"unknown second node", nodes, "a,b\nn0,n1\nn10,n99\nn5,n6\n", true},
      {"unknown second node before a bad value", nodes, "a,b,stiffness\nn0,n1,1\nn10,n99,1\nn2,n3,-1\n", true},
      {"bad value before an unknown second node", nodes, "a,b,stiffness\nn0,n1,-1\nn10,n99,1\n", true},
      {"same ends", nodes, "a,b\nn0,n1\nn7,n7\n", true},
      {"same place", nodes + "n12,3,0,0\n", "a,b\nn0,n1\nn3,n12\n", true},
      {"duplicate in one part", nodes + "n11,1,1,1\n", "a,b\n", true},
      {"line longer than 1 MiB", nodes, "a,b\nn0,n1\n" + std::string(std::size_t{1} << 20, 'x') + "\n", true},
      {"unknown first node", nodes, "a,b\nn0,n1\nzz,n3\n", false},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    dir.write("nodes.csv", c.nodes);
    dir.write("edges.csv", c.edges);
    std::optional<modal::SceneError> serial;
    try {
      (void)modal::load_scene(scene);
    } catch (const modal::SceneError& e) {
      serial = e;
    }
    ASSERT_TRUE(serial.has_value());
    int seen = 0;
    long long owned = 0, rows = 0;
    for (int p = 0; p < 3; ++p) {
      const modal::SceneWindow window{p, 3};
      try {
        const modal::Scene part = modal::load_scene(scene, {}, {}, &window);
        owned += part.owned_network_edges;
        rows = part.network_edges;
      } catch (const modal::SceneError& e) {
        EXPECT_EQ(e.where().file, serial->where().file);
        EXPECT_GE(e.where().line, serial->where().line);
        const std::string reason = e.reason(), expected = serial->reason();
        seen += e.where().line == serial->where().line && e.where().column == serial->where().column &&
                e.key() == serial->key() &&
                reason.substr(0, reason.find(" (did you mean")) == expected.substr(0, expected.find(" (did you mean"));
      }
    }
    if (c.seen) {
      EXPECT_GE(seen, 1) << serial->what();
    } else {
      EXPECT_EQ(seen, 0);
      EXPECT_LT(owned, rows);
    }
  }
}
