// Malformed scenes: every error names the file, line, column and key and says
// what is wrong (docs/design.md section 6). Each case asserts all four.
#include "modal/core.hpp"
#include "modal/scene.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

namespace {

struct Expected {
  int line;
  int column;
  std::string key;
  std::string message;  // a substring of the reason
};

void check_error(const std::string& text, const Expected& expected,
                 const std::vector<modal::ParameterOverride>& overrides = {}) {
  try {
    (void)modal::parse_scene(text, "bad.toml", overrides);
    ADD_FAILURE() << "no error for:\n" << text;
  } catch (const modal::SceneError& e) {
    EXPECT_EQ(e.where().file, overrides.empty() || expected.line > 0 ? "bad.toml" : "--set") << e.what();
    EXPECT_EQ(e.where().line, expected.line) << e.what();
    EXPECT_EQ(e.where().column, expected.column) << e.what();
    EXPECT_EQ(e.key(), expected.key) << e.what();
    EXPECT_NE(e.reason().find(expected.message), std::string::npos) << e.what();
  }
}

// A valid hinge body to which cases append.
const std::string pendulum = "[[body]]\nname = \"p\"\njoint = \"hinge\"\nmass = 1\n";  // lines 1-4

TEST(scene_errors, TomlSyntax) {
  check_error("[[body]\nname = \"p\"\n", {1, 8, "", "expected ']'"});
  check_error(pendulum + "mass = 2\n", {5, 8, "", "cannot redefine existing integer 'mass'"});
}

TEST(scene_errors, UnknownKeys) {
  check_error(pendulum + "masss = 2\n", {5, 1, "body[1].masss", "unknown key 'masss' in [[body]] (did you mean 'mass'?)"});
  check_error("titel = \"x\"\n" + pendulum, {1, 1, "titel", "unknown key 'titel' in the top level of the scene (did you mean 'title'?)"});
  check_error(pendulum + "[[spring]]\na = \"p\"\nb = \"world\"\nstifness = 1\n",
              {8, 1, "spring[1].stifness", "(did you mean 'stiffness'?)"});
  check_error("[[chain]]\nname = \"c\"\nlinks = 2\nlength = 1\nmass = 1\ncolour = 3\n",
              {6, 1, "chain[1].colour", "unknown key 'colour' in [[chain]]"});
}

TEST(scene_errors, KeysOfLaterVersions) {
  // Every key once planned for a later version is read now: [[lattice]] is a
  // generator like any other table (its own errors are in test_network.cpp).
  EXPECT_NO_THROW((void)modal::parse_scene("[[lattice]]\nsize = [2, 2, 1]\nspacing = 1\nmass = 1\nstiffness = 1\n" + pendulum,
                                           "good.toml"));
  check_error(pendulum + "[[lattice]]\nspacing = 1\n", {5, 1, "lattice[1].size", "missing required key 'size' in [[lattice]]"});
  check_error(pendulum + "[[latice]]\nspacing = 1\n",
              {5, 3, "latice", "unknown key 'latice' in the top level of the scene (did you mean 'lattice'?)"});
  check_error("[lattice]\nsize = [2, 2, 1]\n", {1, 1, "lattice", "write [[lattice]], not [lattice]"});
  check_error("network = 1\n", {1, 11, "network", "expected an array of tables ([[network]]), got an integer"});
  check_error(pendulum + "potential = \"x^2\"\n", {5, 1, "body[1].potential", "unknown key 'potential' in [[body]]"});
}

TEST(scene_errors, FrameRotation) {
  // Accepted since frame rotations are supported; malformed values are errors.
  EXPECT_NO_THROW((void)modal::parse_scene("frame_rotation = [0, 0, 1]\n" + pendulum, "good.toml"));
  check_error("frame_rotation = [0, 1]\n" + pendulum, {1, 18, "frame_rotation", "expected an array of 3 numbers, got 2"});
  check_error("frame_rotation = 3\n" + pendulum, {1, 18, "frame_rotation", "expected an array of 3 numbers, got an integer"});
  check_error("frame_rotation = [0, 0, inf]\n" + pendulum, {1, 25, "frame_rotation[3]", "the value must be finite"});
  check_error("frame_rotation = [0, 0, \"1/w\"]\n[parameters]\nw = 0\n" + pendulum,
              {1, 25, "frame_rotation[3]", "evaluates to inf; the value must be finite"});
}

TEST(scene_errors, WrongTypes) {
  check_error("body = \"p\"\n", {1, 8, "body", "expected an array of tables ([[body]]), got a string"});
  check_error("[body]\nname = \"p\"\n", {1, 1, "body", "write [[body]], not [body]"});
  check_error("parameters = 3\n" + pendulum, {1, 14, "parameters", "expected a table ([parameters]), got an integer"});
  check_error(pendulum + "com = [0, 0, true]\n", {5, 14, "body[1].com[3]", "expected a number or an expression string, got a boolean"});
  check_error("title = 3\n" + pendulum, {1, 9, "title", "expected a string, got an integer"});
  check_error(pendulum + "[[load]]\nbody = \"p\"\nforce = [0, 0, 1]\nfollower = \"no\"\n",
              {8, 12, "load[1].follower", "expected true or false, got a string"});
}

TEST(scene_errors, MissingRequiredKeys) {
  check_error("[[body]]\nname = \"p\"\nmass = 1\n", {1, 1, "body[1].joint", "missing required key 'joint' in [[body]]"});
  check_error(pendulum + "[[chain]]\nname = \"c\"\nlinks = 2\nmass = 1\n",
              {5, 1, "chain[1].length", "missing required key 'length' in [[chain]]"});
}

TEST(scene_errors, BodyNamesAndParents) {
  check_error(pendulum + "[[body]]\nname = \"q\"\nparent = \"pp\"\njoint = \"hinge\"\n",
              {7, 10, "body[2].parent", "unknown parent body 'pp' (did you mean 'p'?)"});
  check_error(pendulum + "[[body]]\nname = \"p\"\njoint = \"slide\"\n",
              {6, 8, "body[2].name", "duplicate body name 'p': already used by the [[body]] at line 1"});
  check_error("[[body]]\nname = \"a\"\nparent = \"b\"\njoint = \"hinge\"\n"
              "[[body]]\nname = \"b\"\nparent = \"a\"\njoint = \"hinge\"\n",
              {3, 10, "body[1].parent", "parent cycle (each followed by its parent): a -> b -> a"});
  check_error("[[body]]\nname = \"world\"\njoint = \"hinge\"\n", {2, 8, "body[1].name", "'world' is reserved"});
  check_error(pendulum + "[[chain]]\nname = \"p\"\nlinks = 3\nlength = 1\nmass = 1\n[[body]]\nname = \"p2\"\njoint = \"free\"\n",
              {11, 8, "body[2].name", "duplicate body name 'p2': already used by chain 'p' at line 5"});
}

TEST(scene_errors, PhysicallyMeaninglessValues) {
  check_error(pendulum + "[[body]]\nname = \"q\"\njoint = \"hinge\"\nmass = -2\n",
              {8, 8, "body[2].mass", "must be non-negative, got -2"});
  check_error(pendulum + "axis = [0, 0, 0]\n", {5, 8, "body[1].axis", "must be a nonzero finite direction, got [0, 0, 0]"});
  check_error(pendulum + "inertia = [1, 1, 1, 2, 0, 0]\n",
              {5, 11, "body[1].inertia", "not positive semidefinite (principal moments -1, 1, 3 kg·m²)"});
  check_error(pendulum + "inertia = [1, 1, 3, 0, 0, 0]\n",
              {5, 11, "body[1].inertia", "violate the triangle inequality"});
  check_error(pendulum + "stiffness = \"-1e3\"\n", {5, 13, "body[1].stiffness", "must be non-negative, got -1000"});
}

TEST(scene_errors, NonFiniteValues) {
  check_error(pendulum + "com = [0, 0, nan]\n", {5, 14, "body[1].com[3]", "the value must be finite, got nan"});
  check_error(pendulum + "origin = [\"1/0\", 0, 0]\n", {5, 11, "body[1].origin[1]", "\"1/0\" evaluates to inf"});
  check_error("[parameters]\nl = -inf\n" + pendulum, {2, 5, "parameters.l", "the value must be finite, got -inf"});
}

TEST(scene_errors, Expressions) {
  // The column points at the offending character inside the string.
  check_error("[parameters]\nl = 1\n" + pendulum + "com = [0, 0, \"2*q\"]\n",
              {7, 17, "body[1].com[3]", "in \"2*q\" at 3: unknown name 'q'"});
  check_error("[parameters]\nl = 1\n" + pendulum + "com = [0, 0, \"-(l\"]\n",
              {7, 18, "body[1].com[3]", "in \"-(l\" at 4: expected ')' to close '(' at 1"});
  check_error("[parameters]\nlength = 1\nm = \"2*lenght\"\n" + pendulum,
              {3, 8, "parameters.m", "unknown name 'lenght' (did you mean 'length'?)"});
  check_error("[parameters]\na = \"b + 1\"\nb = \"2*c\"\nc = \"a/2\"\n" + pendulum,
              {2, 5, "parameters.a", "parameters depend on each other in a cycle: a -> b -> c -> a"});
  check_error("[parameters]\nsin = 1\n" + pendulum, {2, 1, "parameters.sin", "'sin' is a function name"});
}

TEST(scene_errors, Joints) {
  check_error("[[body]]\nname = \"p\"\njoint = \"hnge\"\n",
              {3, 9, "body[1].joint", "unknown joint type 'hnge'; expected hinge, slide, ball, free or fixed (did you mean 'hinge'?)"});
  check_error("[[body]]\nname = \"p\"\njoint = \"ball\"\naxis = [0, 0, 1]\n",
              {4, 8, "body[1].axis", "'axis' is not used by a ball joint"});
  check_error("[[body]]\nname = \"p\"\njoint = \"fixed\"\ninitial = 0\n",
              {4, 11, "body[1].initial", "'initial' is not used by a fixed joint"});
  check_error("[[body]]\nname = \"p\"\njoint = \"ball\"\nrest = [0, 0]\n",
              {4, 8, "body[1].rest", "expected an array of 3 numbers, got 2"});
  check_error(pendulum + "com = [0, 1]\n", {5, 7, "body[1].com", "expected an array of 3 numbers, got 2"});
  check_error(pendulum + "initial = [0.1]\n", {5, 11, "body[1].initial", "expected a number or an expression string, got an array"});
}

TEST(scene_errors, Chains) {
  const std::string chain = "[[chain]]\nname = \"c\"\nmass = 1\n";  // lines 1-3
  check_error(chain + "length = 1\nlinks = 2.5\n", {5, 9, "chain[1].links", "must be an integer, got 2.5"});
  check_error(chain + "length = 1\nlinks = 200000\n",
              {5, 9, "chain[1].links", "at most 100000 links are supported, got 200000"});
  check_error(chain + "length = 1\nlinks = \"3 - 3\"\n", {5, 9, "chain[1].links", "must be at least 1, got 0"});
  check_error(chain + "length = 1\nlinks = 3\naxis = [0, 1, 0]\ndirection = [0, -2, 0]\n",
              {7, 13, "chain[1].direction", "parallel to its hinge axis"});
  check_error(chain + "length = 1\nlinks = 3\nmass_model = \"rods\"\n", {6, 14, "chain[1].mass_model", "(did you mean 'rod'?)"});
  check_error(chain + "length = 1\nlinks = 3\ninitial = [0.1, 0.2]\n", {6, 11, "chain[1].initial", "expected an array of 3 numbers, got 2"});
  check_error(chain + "links = 3\nlength = 0\n", {5, 10, "chain[1].length", "must be positive, got 0"});
}

TEST(scene_errors, SpringsAndLoads) {
  check_error(pendulum + "[[spring]]\na = \"p\"\nb = \"wrld\"\nstiffness = 1\n",
              {7, 5, "spring[1].b", "unknown body 'wrld' (did you mean 'world'?)"});
  check_error(pendulum + "[[spring]]\na = \"p\"\nb = \"p\"\nstiffness = 1\n",
              {7, 5, "spring[1].b", "a spring must join two different bodies; both ends are 'p'"});
  check_error(pendulum + "[[spring]]\na = \"p\"\nb = \"world\"\nstiffness = 0\n",
              {8, 13, "spring[1].stiffness", "must be positive, got 0"});
  check_error(pendulum + "[[spring]]\na = \"p\"\nb = \"world\"\n", {5, 1, "spring[1].stiffness", "missing required key 'stiffness'"});
  check_error(pendulum + "[[load]]\nbody = \"p\"\nforce = [0, 0, -1]\nfollower = 1\n",
              {8, 12, "load[1].follower", "expected true or false, got an integer"});
  check_error(pendulum + "[[load]]\nbody = \"world\"\nforce = [0, 0, -1]\nfollower = true\n",
              {6, 8, "load[1].body", "must name a body, not the world"});
  check_error(pendulum + "[[load]]\nbody = \"column.tip\"\nforce = [0, 0, -1]\n",
              {6, 8, "load[1].body", "unknown chain 'column' in 'column.tip'; the scene has no [[chain]]"});
  check_error(pendulum + "[[chain]]\nname = \"column\"\nlinks = 2\nlength = 1\nmass = 1\n"
                         "[[spring]]\na = \"colum.tip\"\nb = \"world\"\nstiffness = 1\n",
              {11, 5, "spring[1].a", "unknown chain 'colum' in 'colum.tip' (did you mean 'column'?)"});
  check_error(pendulum + "[[load]]\nbody = \"world\"\nforce = [0, 0, -1]\n", {6, 8, "load[1].body", "must name a body, not the world"});
}

// A hinge body "p" at the origin and a particle "q" at (1, 0, 0), lines 1-8.
const std::string body_and_particle = pendulum + "[[particle]]\nname = \"q\"\nposition = [1, 0, 0]\nmass = 1\n";

TEST(scene_errors, Particles) {
  EXPECT_NO_THROW((void)modal::parse_scene(body_and_particle, "good.toml"));
  const std::string particle = "[[particle]]\nname = \"q\"\nposition = [0, 0, 0]\n";  // lines 5-7 after the pendulum
  check_error(pendulum + particle + "mass = -1\n", {8, 8, "particle[1].mass", "must be non-negative, got -1"});
  check_error(pendulum + "[[particle]]\nname = \"q\"\nmass = 1\n",
              {5, 1, "particle[1].position", "missing required key 'position' in [[particle]]"});
  check_error(pendulum + particle, {5, 1, "particle[1].mass", "missing required key 'mass' in [[particle]]"});
  check_error(pendulum + particle + "mass = 1\nfixed = [true, false]\n",
              {9, 9, "particle[1].fixed", "expected true, false or an array of 3 booleans [x, y, z], got 2 elements"});
  check_error(pendulum + particle + "mass = 1\nfixed = \"z\"\n",
              {9, 9, "particle[1].fixed", "expected true, false or an array of 3 booleans [x, y, z], got a string"});
  check_error(pendulum + particle + "mass = 1\nfixed = [true, 1, false]\n",
              {9, 16, "particle[1].fixed[2]", "expected true or false, got an integer"});
  check_error(pendulum + particle + "mass = 1\ninitial = [0, 0, 0]\n",
              {9, 1, "particle[1].initial", "unknown key 'initial' in [[particle]]"});
  check_error("[[particle]]\nname = \"world\"\nposition = [0, 0, 0]\nmass = 1\n",
              {2, 8, "particle[1].name", "'world' is reserved"});
}

TEST(scene_errors, ParticleAndBodyNames) {
  check_error(pendulum + "[[particle]]\nname = \"p\"\nposition = [0, 0, 0]\nmass = 1\n",
              {6, 8, "particle[1].name", "duplicate particle name 'p': already used by the [[body]] at line 1"});
  check_error("[[particle]]\nname = \"p\"\nposition = [0, 0, 0]\nmass = 1\n" + pendulum,
              {6, 8, "body[1].name", "duplicate body name 'p': already used by the [[particle]] at line 1"});
  check_error(body_and_particle + "[[particle]]\nname = \"q\"\nposition = [0, 0, 1]\nmass = 1\n",
              {10, 8, "particle[2].name", "duplicate particle name 'q': already used by the [[particle]] at line 5"});
  const std::string chain = "[[chain]]\nname = \"r\"\nlinks = 1\nlength = 1\nmass = 1\n";  // generates "r1"
  check_error(body_and_particle + chain + "[[particle]]\nname = \"r1\"\nposition = [0, 0, 0]\nmass = 1\n",
              {15, 8, "particle[2].name", "duplicate particle name 'r1': already used by chain 'r' at line 9"});
  check_error("[[particle]]\nname = \"r1\"\nposition = [0, 0, 0]\nmass = 1\n" + chain,
              {6, 8, "chain[1].name", "chain 'r' generates the body name 'r1', which is already used by the [[particle]] at line 1"});
}

TEST(scene_errors, ParticleEndsArePoints) {
  check_error(body_and_particle + "[[spring]]\na = \"q\"\na_point = [0, 0, 1]\nb = \"world\"\nstiffness = 1\n",
              {11, 11, "spring[1].a_point", "a particle is a point: 'a_point' is not used for particle 'q'"});
  check_error(body_and_particle + "[[spring]]\na = \"p\"\na_point = [0, 0, 1]\nb = \"q\"\nb_point = [1, 0, 0]\nstiffness = 1\n",
              {13, 11, "spring[1].b_point", "a particle is a point: 'b_point' is not used for particle 'q'"});
  check_error(body_and_particle + "[[constraint]]\ntype = \"point\"\na = \"p\"\nb = \"q\"\nb_point = [0, 0, 0]\n",
              {13, 11, "constraint[1].b_point", "a particle is a point: 'b_point' is not used for particle 'q'"});
}

TEST(scene_errors, Constraints) {
  const std::string constraint = body_and_particle + "[[constraint]]\n";  // line 9
  check_error(constraint + "type = \"pint\"\na = \"p\"\nb = \"q\"\n",
              {10, 8, "constraint[1].type",
               "unknown constraint type 'pint'; expected \"point\" (two points coincide), \"distance\" (two points "
               "keep their distance) or \"coupling\" (a joint follows another) (did you mean 'point'?)"});
  check_error(constraint + "a = \"p\"\nb = \"q\"\n", {9, 1, "constraint[1].type", "missing required key 'type' in [[constraint]]"});
  check_error(constraint + "type = \"point\"\nb = \"q\"\n", {9, 1, "constraint[1].a", "missing required key 'a' in [[constraint]]"});
  check_error(constraint + "type = \"point\"\na = \"p\"\nb = \"qq\"\n",
              {12, 5, "constraint[1].b", "unknown body 'qq' (did you mean 'q'?)"});
  check_error(constraint + "type = \"point\"\na = \"world\"\nb = \"world\"\n",
              {12, 5, "constraint[1].b", "both ends of the constraint are the world"});
  check_error(constraint + "type = \"distance\"\na = \"p\"\nb = \"p\"\nb_point = [0, 0, 1]\n",
              {12, 5, "constraint[1].b", "a constraint must join two different bodies; both ends are 'p'"});
  check_error(constraint + "type = \"point\"\na = \"p\"\nb = \"q\"\nlength = 1\n",
              {13, 10, "constraint[1].length", "'length' is not used by a point constraint"});
  check_error(constraint + "type = \"distance\"\na = \"p\"\nb = \"q\"\nlength = 0\n",
              {13, 10, "constraint[1].length", "must be positive, got 0"});
  // The default length, the distance as written, is 0: q is at (1, 0, 0).
  check_error(constraint + "type = \"distance\"\na = \"q\"\nb = \"world\"\nb_point = [1, 0, 0]\n",
              {9, 1, "constraint[1].length", "its default length would be 0; give a positive 'length'"});
  check_error(constraint + "type = \"distance\"\nname = \"rod\"\na = \"p\"\nb = \"q\"\n"   // lines 10-13
                           "[[constraint]]\ntype = \"point\"\nname = \"rod\"\na = \"p\"\nb = \"q\"\n",  // lines 14-18
              {16, 8, "constraint[2].name", "duplicate constraint name 'rod': already used by the [[constraint]] at line 11"});
  // A default name counts too (at the table that gets it).
  check_error(constraint + "type = \"point\"\nname = \"constraint2\"\na = \"p\"\nb = \"q\"\n"
                           "[[constraint]]\ntype = \"point\"\na = \"p\"\nb = \"q\"\n",
              {14, 1, "constraint[2].name", "duplicate constraint name 'constraint2': already used by the [[constraint]] at line 11"});
  check_error(constraint + "type = \"point\"\na = \"p\"\nb = \"q\"\nb_pont = [0, 0, 0]\n",
              {13, 1, "constraint[1].b_pont", "unknown key 'b_pont' in [[constraint]] (did you mean 'b_point'"});
}

// Expression-defined systems ([coordinates], [[point]], potential).
const std::string map_pendulum =  // lines 1-8
    "[parameters]\nl = 1\n[coordinates]\nphi = 0.1\n[[point]]\nmass = 1\n"
    "position = [\"l*sin(phi)\", 0, \"-l*cos(phi)\"]\ninertia = [0, 0, 0, 0, 0, 0]\n";

TEST(scene_errors, MapExpressionsAndNames) {
  EXPECT_NO_THROW((void)modal::parse_scene(map_pendulum, "good.toml"));
  // The column points at the offending character inside the position string.
  check_error("[parameters]\nl = 1\n[coordinates]\nphi = 0.1\n[[point]]\nmass = 1\n"
              "position = [\"l*sin(phi)\", 0, \"-l*cos(ph)\"]\n",
              {7, 38, "point[1].position[3]", "in \"-l*cos(ph)\" at 8: unknown name 'ph' (did you mean 'phi'"});
  check_error("[parameters]\nl = 1\n[coordinates]\nl = 0.1\n[[point]]\nmass = 1\nposition = [\"l\", 0, 0]\n",
              {4, 5, "coordinates.l", "the coordinate name 'l' is also a parameter"});
  check_error("[coordinates]\nt = 0.1\n[[point]]\nmass = 1\nposition = [\"t\", 0, 0]\n",
              {2, 5, "coordinates.t", "the coordinate name 't' is reserved"});
  check_error("[parameters]\nt = 0.5\n[coordinates]\nphi = 0.1\n[[point]]\nmass = 1\nposition = [\"cos(t)\", 0, 0]\n",
              {2, 5, "parameters.t", "in an expression-defined system t is the time: rename the parameter 't'"});
}

TEST(scene_errors, MapPoints) {
  check_error("[coordinates]\nphi = 0.1\n[[point]]\nmass = 1\n", {3, 1, "point[1].position", "missing required key 'position' in [[point]]"});
  check_error("[coordinates]\nphi = 0.1\n[[point]]\nmass = 1\nposition = [\"sin(phi)\", 0]\n",
              {5, 12, "point[1].position", "expected an array of 3 numbers or expressions"});
  check_error("[coordinates]\nphi = 0.1\n[[point]]\nmass = -1\nposition = [\"sin(phi)\", 0, 0]\n",
              {4, 8, "point[1].mass", "must be non-negative, got -1"});
  check_error(map_pendulum.substr(0, map_pendulum.rfind("inertia")) + "orientation = [{ axis = [0, 0, 1], angle = \"phi\" }]\n",
              {8, 15, "point[1].orientation", "an orientation only matters with an inertia"});
  check_error("[[point]]\nmass = 1\nposition = [0, 0, -1]\n",
              {1, 1, "coordinates", "an expression-defined system needs a [coordinates] table"});
}

TEST(scene_errors, MapCoordinates) {
  check_error("coordinates = [1]\n" + pendulum, {1, 15, "coordinates", "expected a table ([coordinates]), got an array"});
  check_error("[coordinates]\nphi = { initial = 0.1, kind = \"angel\" }\n[[point]]\nmass = 1\nposition = [\"sin(phi)\", 0, 0]\n",
              {2, 31, "coordinates.phi.kind", "must be \"angle\" or \"length\", got \"angel\""});
  check_error("[coordinates]\nphi = 0.1\npsi = { rate = 2, momentum = 1 }\n[[point]]\nmass = 1\n"
              "position = [\"sin(phi)\", 0, 0]\n",
              {3, 30, "coordinates.psi.momentum", "its steady rate or its momentum, not both"});
  // A coordinate no expression uses moves nothing (M would have a zero row).
  check_error("[coordinates]\nphi = 0.1\nchi = 0.2\n[[point]]\nmass = 1\nposition = [\"sin(phi)\", 0, 0]\n",
              {3, 7, "coordinates.chi", "appears in no position, orientation or potential"});
}

TEST(scene_errors, MapAndBodiesDoNotMix) {
  check_error(map_pendulum + "[[body]]\nname = \"p\"\njoint = \"hinge\"\n",
              {9, 1, "body", "a scene is either a kinematic map ([coordinates], [[point]]) or a tree of bodies"});
  check_error(map_pendulum + "[[particle]]\nname = \"q\"\nposition = [0, 0, 0]\nmass = 1\n",
              {9, 1, "particle", "a scene is either a kinematic map ([coordinates], [[point]]) or a tree of bodies; "
                                 "'particle' belongs to the second"});
  check_error(map_pendulum + "[[constraint]]\ntype = \"distance\"\na = \"world\"\nb = \"x\"\nlength = 1\n",
              {9, 1, "constraint", "'constraint' belongs to the second"});
  check_error(map_pendulum + "[[lattice]]\nsize = [2, 2, 1]\nspacing = 1\nmass = 1\nstiffness = 1\n",
              {9, 1, "lattice", "a scene is either a kinematic map ([coordinates], [[point]]) or a tree of bodies; "
                                "'lattice' belongs to the second"});
  check_error(map_pendulum + "[[network]]\nnodes = \"nodes.csv\"\nedges = \"edges.csv\"\n",
              {9, 1, "network", "'network' belongs to the second"});
  check_error("frame_rotation = [0, 0, 1]\n" + map_pendulum,
              {1, 18, "frame_rotation", "a map writes a moving frame with the time t"});
}

TEST(scene_errors, Overrides) {
  const std::string scene = "[parameters]\nm = 1\nl = 2\n" + pendulum;
  check_error(scene, {0, 0, "mm", "'mm' is not a parameter of this scene (did you mean 'm'?); its parameters are: m, l"},
              {{"mm", "2"}});
  check_error(scene, {0, 0, "parameters.m", "in \"2*x\" at 3: unknown name 'x'"}, {{"m", "2*x"}});
  check_error(scene, {0, 0, "parameters.m", "evaluates to inf"}, {{"m", "1/0"}});

  try {
    (void)modal::parse_override("m2.5");
    ADD_FAILURE() << "no error";
  } catch (const modal::SceneError& e) {
    EXPECT_EQ(e.where().file, "--set");
    EXPECT_EQ(e.where().line, 0);
    EXPECT_NE(e.reason().find("expected NAME=VALUE, got 'm2.5'"), std::string::npos) << e.what();
  }
  try {
    (void)modal::parse_override(" =2");
    ADD_FAILURE() << "no error";
  } catch (const modal::SceneError& e) {
    EXPECT_EQ(e.where().file, "--set");
    EXPECT_NE(e.reason().find("missing parameter name before '='"), std::string::npos) << e.what();
  }
}

TEST(scene_errors, FilesAndEmptyScenes) {
  try {
    (void)modal::load_scene("/nonexistent/scene.toml");
    ADD_FAILURE() << "no error";
  } catch (const modal::SceneError& e) {
    EXPECT_EQ(e.where().file, "/nonexistent/scene.toml");
    EXPECT_EQ(e.where().line, 0);
    EXPECT_EQ(e.key(), "");
    EXPECT_NE(e.reason().find("No such file or directory"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()), "/nonexistent/scene.toml: " + e.reason());
  }
  check_error("title = \"nothing\"\n", {1, 1, "", "the scene has no bodies: add a [[body]], a [[chain]], a [[particle]], a "
                                               "[[lattice]] or a [[network]]"});
  check_error("", {1, 1, "", "the scene has no bodies"});
}

TEST(scene_errors, MessageFormat) {
  try {
    (void)modal::parse_scene("[[body]]\nname = \"p\"\njoint = \"hinge\"\nmass = -1\n", "m.toml");
    ADD_FAILURE() << "no error";
  } catch (const modal::SceneError& e) {
    EXPECT_EQ(std::string(e.what()), "m.toml:4:8: body[1].mass: must be non-negative, got -1");
  }
}

}  // namespace

// Values the reader derives from what is written (a spring's or a distance
// constraint's length as written, a lattice's diagonal springs) can overflow
// although every written number is finite; the reader refuses them at the key
// instead of handing the system a length it rejects (found by the fuzzer).
TEST(scene_errors, DerivedLengthsOverflow) {
  const std::string far_apart = "[[particle]]\nname = \"a\"\nposition = [-1e308, 0, 0]\nmass = 1\n"
                                "[[particle]]\nname = \"b\"\nposition = [1e308, 0, 0]\nmass = 1\n";  // lines 1-8
  check_error(far_apart + "[[spring]]\na = \"a\"\nb = \"b\"\nstiffness = 1\n",
              {9, 1, "spring[1].rest_length", "overflows"});
  check_error(far_apart + "[[constraint]]\ntype = \"distance\"\na = \"a\"\nb = \"b\"\n",
              {9, 1, "constraint[1].length", "overflows"});
  check_error("[[lattice]]\nsize = [2, 1, 1]\nspacing = [1.5e308, 1.5e308, 1]\nmass = 1\nstiffness = 1\ndiagonals = true\n",
              {3, 11, "lattice[1].spacing", "overflows"});
}

// The class behind it: whatever the reader accepts, the system accepts. Every
// number in every bundled scene is replaced in turn by extreme values; the
// scene must then either be refused with a SceneError or build a System (a
// std::invalid_argument from the System's own checks is a reader defect).
TEST(scene_errors, AcceptedScenesBuildSystems) {
  const std::vector<std::string> extremes{"1e308", "-1e308", "1e-308", "-1e-308", "0", "4.9e-324"};
  const std::regex number(R"((^|[=\[,\s])(-?[0-9]+(\.[0-9]*)?([eE][-+]?[0-9]+)?)(?=[\s,\]]|$))");
  int built = 0, refused = 0;
  for (const auto& entry : std::filesystem::directory_iterator(std::string(MODAL_SOURCE_DIR) + "/models")) {
    if (entry.path().extension() != ".toml") continue;
    std::ifstream in(entry.path());
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    for (std::size_t l = 0; l < lines.size(); ++l) {
      if (lines[l].empty() || lines[l][0] == '#' || lines[l][0] == '[') continue;
      const auto hash = lines[l].find('#');
      const std::string code = lines[l].substr(0, hash);
      std::vector<std::pair<std::size_t, std::size_t>> spans;  // [begin, length) of each number
      for (auto it = std::sregex_iterator(code.begin(), code.end(), number); it != std::sregex_iterator(); ++it)
        spans.emplace_back(static_cast<std::size_t>(it->position(2)), static_cast<std::size_t>(it->length(2)));
      for (const auto& [begin, length] : spans)
        for (const std::string& value : extremes) {
          std::vector<std::string> changed = lines;
          changed[l] = code.substr(0, begin) + value + code.substr(begin + length);
          std::string text;
          for (const std::string& line : changed) text += line + "\n";
          modal::Scene scene;
          try {
            scene = modal::parse_scene(text, entry.path().filename().string());
          } catch (const modal::SceneError&) {
            ++refused;
            continue;
          }
          try {
            (void)modal::build_system(scene);
            ++built;
          } catch (const modal::SceneError&) {
            ++refused;
          } catch (const std::exception& e) {
            ADD_FAILURE() << entry.path().filename().string() << ":" << l + 1 << " with " << value
                          << ": accepted by the reader, refused by the system: " << e.what();
          }
        }
    }
  }
  EXPECT_GT(built, 100);
  EXPECT_GT(refused, 100);
}
