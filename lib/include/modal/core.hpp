// modal/core.hpp — the Lagrangian core.
//
// A System is the constant model of a tree of rigid bodies joined by joints,
// with springs, joint springs and dampers, dead and follower loads, or of a
// kinematic map (point masses and rigid bodies placed by expressions in the
// coordinates and time, see KinematicMap below): everything needed to
// evaluate, at generalized coordinates q (n of them) and velocities q̇,
//
//   M(q)        mass matrix (n×n, symmetric positive semidefinite)      [kg·m², kg·m, kg]
//   V(q)        potential energy (gravity, springs, dead loads; − T₀ in a rotating frame)  [J]
//   Q(q, q̇)     non-conservative generalized forces (dampers, followers)  [N·m or N]
//
// and their exact derivatives. All evaluation is by free functions taking the
// System (constant) and a Workspace (scratch memory, one per thread):
//
//   modal::System sys = modal::build_system(modal::load_scene("models/double_pendulum.toml"));
//   modal::Workspace ws(sys);
//   const Eigen::VectorXd q = sys.initial_configuration();
//   double V = modal::potential(sys, ws, q);
//   const Eigen::VectorXd& g = modal::potential_gradient(sys, ws, q);    // ∇V, n
//   const Eigen::MatrixXd& K = modal::potential_hessian(sys, ws, q);     // ∇∇V, n×n
//   const Eigen::MatrixXd& M = modal::mass_matrix(sys, ws, q);           // n×n
//
// How derivatives are exact: joints and elements (springs, loads, gravity) are
// written once, templated on the scalar (see lib/core/model.hpp). Their local
// derivatives come from forward-mode automatic differentiation (modal/ad.hpp);
// the chain rule through the kinematic tree is applied by a tree-structured
// accumulation of the element cotangents (the data flow of reverse mode), which
// costs O(n·depth) for a Hessian instead of O(n²·depth) for nested forward
// mode through the whole tree. Tests check it against nested forward AD through
// the same templated model and against central differences.
//
// Rotating frame. A scene may be written in a frame that rotates steadily at
// Ω = SystemDescription::frame_rotation (rad/s, constant, about the world
// origin, components in the scene frame). The inertial velocity of a body point
// is then ẋ + Ω × x, every body's inertial twist is Σ_k ξ_k q̇_k + ξ_Ω with
// ξ_Ω = (Ω, 0), and T = ½q̇ᵀMq̇ + q̇ᵀg(q) + T₀(q) (docs/design.md, "Mechanics and
// sign conventions") with
//   g_k(q) = ξ_kᵀ Ic(b(k)) ξ_Ω                                   frame_coupling()
//   T₀(q)  = ½ Σ_b ξ_Ωᵀ I6_b ξ_Ω = ½ Σ_b [m_b |Ω × x_b|² + Ωᵀ R_b I_b R_bᵀ Ω]   [J]
// In a rotating system the potential V(q) below is V_eff = V − T₀ throughout:
// potential(), its gradient and Hessian, energy() (then ½q̇ᵀMq̇ + V − T₀, the
// Jacobi integral, conserved for a conservative scene), and therefore
// equilibria (∇V_eff = Q) and K = ∇∇V_eff − ∂Q/∂q. The equations of motion
// are M q̈ + C q̇ + G q̇ + ∇V_eff = Q with the gyroscopic matrix
//   G_ij = ∂g_i/∂q_j − ∂g_j/∂q_i                                 gyroscopic_matrix()
// (skew-symmetric, units of M/s); written as (∂g/∂q)ᵀ − ∂g/∂q with
// (∂g/∂q)_ij = ∂g_j/∂q_i (gradient layout), it is the same matrix. Example:
// a particle on two slides x, y in a plane rotating at Ω about z has
// g = mΩ(−y, x) and G = 2mΩ[[0, −1], [1, 0]], i.e. m ẍ − 2mΩ ẏ + … = 0 (the
// Coriolis force −2m Ω × ẋ).
//
// Conventions (docs/design.md, "Mechanics and sign conventions"): coordinates
// are joint values relative to the parent body (hinge angle in rad, slide in
// m, ball: rotation vector relative to the written orientation, free:
// translation then rotation vector). At q = 0 a body frame is the parent
// frame moved to the joint origin and turned by the body's fixed
// `orientation` (identity unless given).
#pragma once

#include "modal/expression.hpp"

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <array>
#include <limits>
#include <new>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace modal {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using VectorX = Eigen::VectorXd;
using MatrixX = Eigen::MatrixXd;
using SparseMatrix = Eigen::SparseMatrix<double>;  // column-major, int indices

// Numerical trouble that makes a result impossible or untrustworthy (singular
// mass matrix, no equilibrium, non-convergence). The message says what failed
// in words a user can act on. Command-line exit status 4.
class NumericalError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// particle: a point mass translating along the parent's x, y and z axes (the
// scene's [[particle]]; Body::particle_axes says which of them move).
enum class JointType { hinge, slide, ball, free, fixed, particle };
// Number of generalized coordinates of a joint: hinge, slide 1; ball 3; free 6;
// fixed 0; particle 3 (fewer when axes are fixed: see joint_coordinate_count(Body)).
int joint_coordinate_count(JointType type);

// The scene-file word for a joint type: "hinge", "slide", "ball", "free", "fixed", "particle".
const char* to_string(JointType type);

// What a coordinate measures; decides wrapping and search ranges.
enum class CoordinateKind {
  angle,     // hinge angle, rad, periodic with period 2π
  length,    // slide or free translation, m
  rotation,  // component of a rotation vector (ball, free), rad
};

const char* to_string(CoordinateKind kind);  // "angle", "length", "rotation"

struct Coordinate {
  std::string name;  // hinge/slide: body name; ball: body.rx|ry|rz; free: body.x|y|z|rx|ry|rz
  CoordinateKind kind = CoordinateKind::angle;
  int body = -1;       // index of the body whose joint owns the coordinate
  double initial = 0;  // starting value for searches
  // Whether q and q + 2π (angles; rotation vectors of length differing by 2π)
  // are the same configuration for the energy. A joint spring ½k(q − rest)²
  // makes its joint's coordinates non-periodic: θ and θ + 2π then differ.
  bool periodic = false;
};

// A point fixed to a body (point in the body frame) or to the world (body = -1,
// point in world coordinates).
struct Attachment {
  int body = -1;
  Vec3 point = Vec3::Zero();
};

struct Body {
  std::string name;
  int parent = -1;  // index of the parent body; -1 is the world. Parents precede children.
  JointType joint = JointType::hinge;
  Vec3 axis = Vec3::UnitY();     // unit axis of a hinge or slide, body frame (= parent frame turned by `orientation`)
  Vec3 origin = Vec3::Zero();    // joint position, parent frame, m
  // Orientation of the body frame relative to the parent frame at q = 0 (a
  // rotation matrix, body → parent; identity: the parent's orientation). The
  // joint acts after it: R_b = R_parent · orientation · R_joint(q).
  Mat3 orientation = Mat3::Identity();
  double mass = 0;               // kg
  Vec3 com = Vec3::Zero();       // centre of mass, body frame, m
  Mat3 inertia = Mat3::Zero();   // about the centre of mass, body frame, kg·m²
  double stiffness = 0;          // joint spring, N·m/rad (hinge, ball) or N/m (slide)
  double damping = 0;            // joint damper, N·m·s/rad or N·s/m
  // Rotor inertia of the joint (MuJoCo's armature), kg·m² (rotations) or kg
  // (translations): kinetic energy ½a(|ω|² + |v|²) of the joint's own relative
  // motion, which adds a to M's diagonal for a hinge or slide and a·J_lᵀJ_l
  // (a at φ = 0) to a rotation vector's block.
  double armature = 0;
  // Joint limits of a hinge or slide: the range [lower, upper] its coordinate
  // may take, rad or m (the coordinate's own units, so relative to q = 0),
  // lower < upper; unlimited (the default) is −∞, +∞. modal has no model of a
  // limit stop: an equilibrium at or beyond a limit has no linear model
  // (joint_limits, Equilibrium::limits; the pipeline refuses it).
  double lower = -std::numeric_limits<double>::infinity();
  double upper = std::numeric_limits<double>::infinity();
  VectorX rest;                  // joint spring rest values (size = joint coordinates)
  VectorX initial;               // joint starting values (size = joint coordinates)
  // particle joint: which parent axes (x, y, z) carry a coordinate; a fixed
  // axis keeps the written position (`origin`) along it.
  std::array<bool, 3> particle_axes{true, true, true};
};

// Number of generalized coordinates of a body's joint (counts a particle's free axes).
int joint_coordinate_count(const Body& body);

struct Spring {
  Attachment a, b;
  double stiffness = 0;    // N/m
  double rest_length = 0;  // m
  double damping = 0;      // N·s/m, along the spring
};

// A force of fixed direction in the scene frame applied at a body point
// (conservative: V = −f·x).
struct DeadLoad {
  Attachment at;
  Vec3 force = Vec3::Zero();  // N
};

// A force that turns with the body it acts on (a follower load, circulatory:
// Q = Jᵀ R f is not the gradient of any potential). `force` is given in the
// body frame; at q = 0 that is the scene frame turned by the `orientation` of
// the body and its ancestors (the scene frame itself where none is given).
struct FollowerLoad {
  Attachment at;
  Vec3 force = Vec3::Zero();  // N, body frame
};

// A holonomic constraint c(q) = 0 between two points (a loop closure,
// docs/design.md, "Mechanics and sign conventions" and "Scene format"):
//   point:     c = x_a − x_b            3 equations (x, y, z), m: the points coincide
//   distance:  c = |x_a − x_b| − length 1 equation, m: the points keep their distance
// With multipliers s the constraint's generalized force is ∇c s (Lagrange's
// equations of the first kind, M q̈ = f + ∇c s): the force s (N, world
// components) acts on a at x_a and −s on b (point), or s·u on a and −s·u on b
// with u = (x_a − x_b)/|x_a − x_b| (distance: s < 0 pulls the ends together,
// the rod is in tension −s).
//   coupling:  c = q_a − Σ_k polynomial[k]·q_b^k   1 equation, rad or m: the
//              joint coordinate of body a (a hinge or slide) follows the joint
//              coordinate of body b (MuJoCo's joint equality; b.body = −1: q_a is
//              held at polynomial[0]). Only a.body and b.body are used; the force
//              s acts on q_a and −s·p'(q_b) on q_b (N·m or N).
struct Constraint {
  enum class Type { point, distance, coupling };
  Type type = Type::point;
  std::string name;    // for reports: "<name>.x|y|z" (point) or "<name>" (distance, coupling)
  Attachment a, b;
  std::array<double, 5> polynomial{};  // coupling: coefficients of 1, q_b, q_b², q_b³, q_b⁴
  double length = 0;   // distance constraints, m (> 0)
  int equations() const { return type == Type::point ? 3 : 1; }
};
const char* to_string(Constraint::Type type);  // "point", "distance", "coupling"

// A coupling's polynomial p and its first two derivatives at x (any scalar).
template <class S> std::array<S, 3> coupling_polynomial(const std::array<double, 5>& c, const S& x) {
  S p = S(c[4]), dp = S(4 * c[4]), ddp = S(12 * c[4]);
  for (int k = 3; k >= 0; --k) p = p * x + c[static_cast<std::size_t>(k)];
  for (int k = 3; k >= 1; --k) dp = dp * x + k * c[static_cast<std::size_t>(k)];
  for (int k = 3; k >= 2; --k) ddp = ddp * x + k * (k - 1) * c[static_cast<std::size_t>(k)];
  return {p, dp, ddp};
}

// --- kinematic maps (expression-defined systems) -----------------------------
//
// Instead of a tree of bodies, a system may be written the classic way: choose
// generalized coordinates z (n_z of them) and write where every mass is,
// x = x(z, t), with time t (s). Expressions (modal/expression.hpp) are over the
// variables [z_0 … z_{n_z−1}, t, constants…] in that order; `constants` holds
// the values of the trailing variables (the scene's parameters). With
// v = Σ_k ∂x/∂z_k ż_k + ∂x/∂t the kinetic energy is
//   T = ½żᵀM(z)ż + żᵀg(z) + T₀(z),
//   M = Σ m S_kᵀS_l + W_kᵀ I_w W_l,  g_k = Σ m S_k·∂ₜx + W_kᵀ I_w ω_t,  T₀ = ½Σ m|∂ₜx|² + ½ω_tᵀ I_w ω_t
// with S_k = ∂x/∂z_k, W_k = vee(∂R/∂z_k Rᵀ) the angular Jacobian of a rigid
// point's orientation R (ω_t from ∂R/∂t), I_w = R I Rᵀ. All are exact by
// forward AD through the expressions, evaluated at t = 0; the map must be
// steady (M, g, T₀, V independent of t), which System's constructor checks.
// V = Σ −m gravity·x + potential(z).
struct MapRotation {  // a rotation by `angle` (rad) about the fixed unit `axis` (body frame so far)
  Vec3 axis = Vec3::UnitZ();
  Expression angle;
};
struct MapMass {
  std::string name;                        // for messages ("point 2" when unnamed)
  double mass = 0;                         // kg
  std::array<Expression, 3> position;      // centre of mass, m, scene frame
  // Orientation R = R_1 R_2 … (each about its axis in the frame the previous ones
  // produced); empty: R = I. Only matters with rotational inertia.
  std::vector<MapRotation> orientation;
  Mat3 inertia = Mat3::Zero();             // about the centre of mass, body frame, kg·m²
};
// A coordinate the Lagrangian does not depend on (cyclic). Its conjugate
// momentum p = ∂L/∂ż is conserved; the other coordinates are analyzed about a
// steady motion through Routh's reduction (see KinematicMap).
struct Ignorable {
  enum class Given { rate, momentum };
  Given given = Given::rate;
  double value = 0;  // rate ż (rad/s or m/s) or momentum p (kg·m²/s or kg·m/s)
};
struct MapCoordinate {
  std::string name;
  double initial = 0;
  // angle or length; unset: decided by System (angle when the energy is
  // 2π-periodic in the coordinate, else length). An angle is periodic (compared
  // modulo 2π) only when M, g, T₀ and V are 2π-periodic in it (checked).
  std::optional<CoordinateKind> kind;
  std::optional<Ignorable> ignorable;
};
// Routh's reduction. With the coordinates split into kept r and ignorable c,
// and p the momenta of c (given, or given through the rate at a steady motion),
// the reduced system in r has
//   M' = M_rr − M_rc M_cc⁻¹ M_cr,   g' = g_r + M_rc M_cc⁻¹ (p − g_c),
//   V' = V − T₀ + ½(p − g_c)ᵀ M_cc⁻¹ (p − g_c)         (the amended potential)
// and ċ = M_cc⁻¹(p − g_c − M_cr ṙ). When rates Ω are given instead, the steady
// motions are the equilibria of V − T₀ − Ωᵀg_c − ½ΩᵀM_ccΩ with M' = M_rr and
// g' = g_r + M_rc Ω (the coordinate driven at the rate); `with_steady_momenta`
// turns such a system into the free one at the momenta of a steady motion,
// which is what linearize() analyzes.
struct KinematicMap {
  std::vector<MapCoordinate> coordinates;  // z, in the order of the expression variables
  std::vector<double> constants;           // values of the variables after t
  std::vector<MapMass> points;
  Expression potential;                    // extra potential energy, J (default 0)
  bool empty() const { return coordinates.empty() && points.empty(); }
};

struct SystemDescription {
  std::string title;
  Vec3 gravity{0, 0, -9.81};  // m/s²
  std::vector<Body> bodies;   // parents before children
  std::vector<Spring> springs;
  std::vector<DeadLoad> loads;
  std::vector<FollowerLoad> followers;
  std::vector<Constraint> constraints;  // loop closures (trees only)
  // Angular velocity (rad/s, scene-frame components) of the frame the scene is
  // written in, constant, about the world origin; zero: an inertial frame.
  Vec3 frame_rotation = Vec3::Zero();
  // An expression-defined system (then bodies, springs, loads and
  // frame_rotation must be empty: a system is either a tree or a map).
  KinematicMap map;
};

class System;
System with_steady_momenta(const System& s, const VectorX& q);

// The constant model. Construction validates (throws std::invalid_argument on
// misuse: bad parent order, non-unit axis, negative mass, …) and precomputes
// the coordinate layout. Copyable value; thread-safe to share.
class System {
 public:
  explicit System(SystemDescription description);

  int size() const { return n_; }  // number of generalized coordinates n
  const std::string& title() const { return d_.title; }
  const Vec3& gravity() const { return d_.gravity; }
  const std::vector<Body>& bodies() const { return d_.bodies; }
  const std::vector<Spring>& springs() const { return d_.springs; }
  const std::vector<DeadLoad>& loads() const { return d_.loads; }
  const std::vector<FollowerLoad>& followers() const { return d_.followers; }
  bool has_follower_loads() const { return !d_.followers.empty(); }
  const std::vector<Constraint>& constraints() const { return d_.constraints; }
  bool has_constraints() const { return !d_.constraints.empty(); }
  // Number m of constraint equations (3 per point constraint, 1 per distance).
  int constraint_equations() const { return m_; }
  // Names of the m equations: "<name>.x", "<name>.y", "<name>.z" or "<name>".
  std::vector<std::string> constraint_equation_names() const;
  // Index of the constraint that equation i (0 ≤ i < m) belongs to.
  int constraint_of_equation(int i) const { return equation_owner_[static_cast<std::size_t>(i)]; }
  const Vec3& frame_rotation() const { return d_.frame_rotation; }  // Ω, rad/s
  bool rotating() const { return !d_.frame_rotation.isZero(0.0); }   // Ω ≠ 0
  // Expression-defined system (a kinematic map) rather than a tree of bodies.
  bool is_map() const { return !d_.map.empty(); }
  const KinematicMap& map() const { return d_.map; }
  // T has the terms q̇ᵀg + T₀ (a rotating frame, a moving map, or Routh's
  // reduction): frame_coupling and gyroscopic_matrix may be non-zero.
  bool has_frame_coupling() const { return rotating() || moving_map_; }
  // Map coordinates kept as generalized coordinates (index into map().coordinates), n.
  const std::vector<int>& kept_coordinates() const { return kept_; }
  // Ignorable map coordinates (index into map().coordinates), in declaration order.
  const std::vector<int>& ignorable_coordinates() const { return ignorable_; }
  // Whether a map's expressions use the time t.
  bool map_time_dependent() const { return map_time_; }
  const std::vector<Coordinate>& coordinates() const { return coords_; }
  std::vector<std::string> coordinate_names() const;

  int first_coordinate(int body) const { return q_index_[static_cast<std::size_t>(body)]; }
  int joint_size(int body) const { return nq_[static_cast<std::size_t>(body)]; }
  const std::vector<int>& children(int body) const { return children_[static_cast<std::size_t>(body)]; }

  VectorX initial_configuration() const;  // from the joints' `initial` values
  bool has_damping() const { return has_damping_; }
  // A length that characterizes the scene (largest distance of a body point,
  // joint or attachment from the origin at q = 0; at least 1e-3 m). Used for
  // search ranges of translations and for relative tolerances.
  double length_scale() const { return length_scale_; }

 private:
  SystemDescription d_;
  int n_ = 0;
  int m_ = 0;
  std::vector<int> equation_owner_;
  std::vector<int> q_index_, nq_;
  std::vector<std::vector<int>> children_;
  std::vector<Coordinate> coords_;
  bool has_damping_ = false;
  double length_scale_ = 1.0;
  bool moving_map_ = false;          // a map with t, or with ignorable coordinates
  bool map_time_ = false;
  std::vector<int> kept_, ignorable_;
  void build_map();
  friend System with_steady_momenta(const System& s, const VectorX& q);
};

// Scratch memory for evaluating one System. Results returned by reference live
// here and are overwritten by the next call of the same function.
struct KinematicsCache;
class Workspace {
 public:
  explicit Workspace(const System& system);
  ~Workspace();
  Workspace(Workspace&&) noexcept;
  Workspace& operator=(Workspace&&) noexcept;
  Workspace(const Workspace&) = delete;
  Workspace& operator=(const Workspace&) = delete;

  KinematicsCache& cache() { return *cache_; }
  VectorX gradient;  // last potential_gradient
  MatrixX hessian;   // last potential_hessian
  MatrixX mass;      // last mass_matrix
  SparseMatrix sparse_hessian;  // last sparse_potential_hessian (its pattern is reused)
  SparseMatrix sparse_convex_hessian;  // last sparse_convex_potential_hessian

 private:
  KinematicsCache* cache_;
};

// --- potential energy (V_eff = V − T₀ in a rotating frame) ---------------------
double potential(const System& s, Workspace& w, const VectorX& q);                     // V, J
const VectorX& potential_gradient(const System& s, Workspace& w, const VectorX& q);   // ∇V, n
// The first spring of positive rest length whose ends meet at q: |x_a − x_b|
// at most √ε × its rest length, or within the rounding of the ends' positions
// (8ε (|x_a| + |x_b|)): its index in s.springs() and the ends' distance (m); nullopt if
// none. V is not differentiable there (the spring's force has no direction):
// no equilibrium, no linear model. (A spring of rest length 0 is smooth
// through its ends' meeting.)
struct MeetingEnds {
  std::size_t spring = 0;
  double distance = 0;  // m
};
std::optional<MeetingEnds> spring_with_meeting_ends(const System& s, Workspace& w, const VectorX& q);
// The words for it, shared by every stage that meets it: "the ends of the
// spring between 'a' and the world (rest length 0.1 m) meet at this
// configuration (2e-17 m apart): V is not differentiable there (the spring's
// force has no direction)". (No index: a lattice's springs are not in the
// file, and a distributed rank's part numbers its own.)
std::string describe_meeting_ends(const System& s, const MeetingEnds& meet);
const MatrixX& potential_hessian(const System& s, Workspace& w, const VectorX& q);    // ∇∇V, n×n, symmetric

// Σ|terms| of ∇∇V entry by entry (n×n, ≥ |∇∇V| componentwise): the sum of
// the absolute values of the contributions that potential_hessian() adds up
// (each element's Jᵀ H_e J entries, each tree term, each joint spring). The
// rounding error of an entry of ∇∇V is a few ε times this, not times |∇∇V|:
// where terms cancel (a spring balancing gravity at a buckling load) the
// entry is small and its error is not. Used for the eigenvalues' error
// estimates. Maps (one expression per entry): |∇∇V|.
MatrixX potential_hessian_magnitude(const System& s, Workspace& w, const VectorX& q);

// The same matrices assembled sparse (n×n, both triangles; entries that no
// term touches are left out): the elements' local derivatives and the tree
// terms are added entry by entry, so no dense n×n matrix is formed. For a scene of particles and
// springs each spring adds a 6×6 block and the cost is O(elements); a deep
// tree fills in (a chain's ∇∇V is dense) and gains nothing. Maps: the dense
// result converted.
const SparseMatrix& sparse_potential_hessian(const System& s, Workspace& w, const VectorX& q);  // ∇∇V
SparseMatrix sparse_mass_matrix(const System& s, Workspace& w, const VectorX& q);        // M(q)

// ∇∇V with every spring's local Hessian replaced by its positive
// semidefinite part: k[uuᵀ + (1 − L₀/L)(I − uuᵀ)] in x_a − x_b loses the
// negative transverse stiffness of a compressed spring (L < L₀), keeping k uuᵀ.
// Equal to ∇∇V where no spring is compressed; the tree terms, joint springs
// and other elements as in ∇∇V. Positive semidefinite for a scene of
// particles and springs (whatever its state), where ∇∇V is indefinite once
// a spring is compressed: the matrix of the large-scene equilibrium's damped
// steps, which then need no shift for definiteness, only for trust. Same
// pattern and units as ∇∇V. Maps: ∇∇V.
const SparseMatrix& sparse_convex_potential_hessian(const System& s, Workspace& w, const VectorX& q);

// Σ|terms| of each entry of ∇∇V, sparse (potential_hessian_magnitude's
// entries on ∇∇V's pattern): the size its rounding scales with, which is
// far above |∇∇V| where a spring's terms cancel (a small prestrain: the
// transverse k(1 − L₀/L) from k and k L₀/L). Units of ∇∇V, entries ≥ 0.
SparseMatrix sparse_potential_hessian_magnitude(const System& s, Workspace& w, const VectorX& q);

// A positive semidefinite F (n×n, ∇∇V's pattern and units) with
// |φᵀ δ(∇∇V) φ| ≤ 4ε φᵀFφ to first order for the rounding δ of ∇∇V's
// assembly and of the configuration's positions: each spring's error as a
// block [s −s; −s s] in its end points (its stiffness, its transverse
// stiffness T/L with the length's rounding ε(‖x_a‖ + ‖x_b‖), its direction),
// and every other term's magnitude halved onto the diagonal. Unlike the
// entrywise |φ|ᵀ(4ε E)|φ| (E = sparse_potential_hessian_magnitude) it keeps
// the springs' Laplacian structure: on a smooth mode of a net the bound
// scales with the mode's own λ, not with k/m. Empty for a map or a scene
// without springs. For the kind of the sparse path's modes
// (SparseModalOptions::K_rounding_form).
SparseMatrix sparse_rounding_form(const System& s, Workspace& w, const VectorX& q);

// sparse_rounding_form's bound kept spring by spring, split by where each
// rounding comes from, so that a mode's estimate can add the springs'
// independent errors at their typical size (a root sum of squares) instead
// of all at their worst together. Spring e's end points move apart at
// v_e = (G q̇)_{3e…3e+2}; its share of φᵀFφ is vᵀs v with s = a uuᵀ +
// (a + b)(I − uuᵀ) + r (uuᵀ + 2(I − uuᵀ)) (u its axis, unit; in units of ε):
//   a = |k| and b = |k − t| = |k| L₀/L, the rounding of its own computation
//     and data (stiffness, rest length, length): springs computed alike
//     round alike, so these add coherently over the springs;
//   r = ρ|k − t|, ρ = (‖x_a‖ + ‖x_b‖)/L: the rounding of its end points'
//     positions (ε of their size), independent from spring to spring.
// A spring whose ends meet has u = 0 and a the largest row sum of |h|.
// `others`: every other term's magnitude halved onto the diagonal (n, units
// of 4ε, as in F). So φᵀFφ = Σ_e v_eᵀ s_e v_e + Σ_i others_i φ_i².
struct SpringRounding {
  Eigen::SparseMatrix<double, Eigen::RowMajor> G;  // 3 · springs × n
  // Column e: u (3), a, b, r.
  Eigen::Matrix<double, 6, Eigen::Dynamic> blocks;
  VectorX others;  // n
  bool empty() const { return blocks.cols() == 0; }
};

// SpringRounding at q: O(elements). Empty for a map or a scene without
// springs (SparseModalOptions::K_spring_rounding).
SpringRounding spring_rounding(const System& s, Workspace& w, const VectorX& q);

// The stiffness the scene would have if every spring carried a tension per
// unit length equal to its stiffness (T/L = k, so its 6×6 block is
// k [I −I; −I I] in its end points instead of k uuᵀ + T/L (I − uuᵀ)), and
// every joint spring its stiffness: Σ k Jᵀ[I −I; −I I]J + the joint springs
// (n×n, both triangles, diagonal always stored, units of ∇∇V). Positive
// semidefinite, with the sparsity of ∇∇V, and definite wherever every
// coordinate is held by some chain of springs. It is the metric of the damped
// steps of the large-scene equilibrium: unlike the identity it stiffens a
// slack net's out-of-plane coordinates as a tensioned membrane would, so a
// damped step from a flat start takes the shape of a membrane's sag (a
// Poisson solve), not a uniform drop. Maps: the identity.
SparseMatrix sparse_tension_metric(const System& s, Workspace& w, const VectorX& q);
SparseMatrix sparse_damping_matrix(const System& s, Workspace& w, const VectorX& q);     // D(q)

// A scale for generalized forces at q: the sum over elements of |element
// force| × |point Jacobian| (springs counted at 100 % strain, joint springs at
// 1 rad or the length scale): the size of the terms whose rounding ∇V
// carries. Same units as ∇V. (force_scales(s, w, q).full)
double force_scale(const System& s, Workspace& w, const VectorX& q);

// Two scales for generalized forces at q (units of ∇V), sums over the
// elements of |element force| × |point Jacobian|: `full` counts springs at
// 100 % strain and joint springs at 1 rad or the length scale (force_scale:
// what the rounding of ∇V is relative to); `acting` counts every element at
// the force it exerts at q (a spring at its rest length: none). Loads,
// gravity and centrifugal forces count alike in both. `rounding`: the
// springs' and joint springs' full forces summed in 2-norm (their rounding
// errors are independent, so ∇V carries about ε times this), a spring's
// length counted with the distances of its ends from the origin (the world
// points it is computed from are rounded to ε of those), plus the loads.
// Maps: all three are the map's force scale.
struct ForceScales {
  double full = 0;
  double acting = 0;
  double rounding = 0;  // 0: take `full`
};
ForceScales force_scales(const System& s, Workspace& w, const VectorX& q);

// The relative residual of a generalized force of norm ‖r‖ left unbalanced
// at q: ‖r‖/full, and where ‖r‖ exceeds the rounding level 8ε·rounding, at
// least its excess over it relative to the acting forces. Against `full`
// alone, a slack structure's whole weight is a tiny residual (a flat net of
// steel springs under gravity: 8e-13 of its springs' forces at 100 % strain),
// although no spring balances any of it; against the forces acting there
// (the weight alone) it is 1. 0 for ‖r‖ = 0; ∞ when a non-zero ‖r‖ has no
// positive scale.
double relative_residual(double residual_norm, const ForceScales& scales);

// The same scales coordinate by coordinate (n each, units of ∇V's entry): the
// forces of the elements that coordinate k moves, each times how far k moves
// its point (bounded by |ω_k| × the point's arm about k's joint centre +
// |u_k|, arms summed up the tree by the triangle inequality: O(n)); `rounding`
// summed linearly. One stiff element then does not hide the others' unbalanced
// forces: beside a slide of 1e14 N/m, two pendulums' gravity torques are 1e-13
// of the whole scene's force scale but all of their own coordinates'.
// `stiffness` (units of ∇∇V's diagonal entry: N·m/rad, N/m): a scale of
// ∂²V/∂q_k², the springs' k |∂x/∂q_k|² (bounded like the arms above), the
// joint springs' k and the acting loads' curvature |ω_k|² × their moment
// arms; from the elements, not from ∇∇V, so a zero mode's rounding is not
// mistaken for a stiffness. Maps: empty vectors.
struct CoordinateForceScales {
  VectorX full;
  VectorX acting;
  VectorX rounding;
  VectorX stiffness;
};
CoordinateForceScales coordinate_force_scales(const System& s, Workspace& w, const VectorX& q);

// The relative residual of the generalized force r (n, without constraint
// reactions) left unbalanced at q: the larger of relative_residual(‖r‖,
// force_scales(q)) and, for every coordinate with a positive scale,
// relative_residual(|r_k|, coordinate k's scales). Scenes with constraints
// (whose residual carries reactions no element's scale counts) and maps: the
// first alone.
double relative_residual(const System& s, Workspace& w, const VectorX& q, const VectorX& r);
// The same where some element produces a force at q (a positive
// force_scales(q).full; ∞ for r ≠ 0 where that scale overflows), with
// coordinate_force_scales(s, w, q) taken from `each` when given; nullopt
// where none does (V is constant there and r zero or rounding), for the
// caller's absolute measure.
std::optional<double> relative_residual_if_scaled(const System& s, Workspace& w, const VectorX& q, const VectorX& r,
                                                  const CoordinateForceScales* each = nullptr);

// The rounding of ∇V − Q as computed at q (units of ∇V's entries: N, N·m):
// `whole` = 8ε × force_scales(q).rounding for its 2-norm, `each` (n) = 8ε ×
// coordinate_force_scales(q).rounding for its entries. These scales count
// every spring's ends' distances from the origin, to ε of which the world
// points are rounded, so far from the origin they exceed the forces
// themselves: a bead 1e10 m out on a spring of 1 N/m and 1 mm rest length
// has forces of 1e-3 N computed to ±3.6e-5 N. A residual within them
// (‖r‖ ≤ whole, |r_k| ≤ each_k) cannot be told from zero in this
// evaluation. nullopt for maps, scenes with constraints (whose residual
// carries reactions these scales do not count) and where no element
// produces a force.
struct ResidualRounding {
  double whole = 0;
  VectorX each;
};
std::optional<ResidualRounding> residual_rounding(const System& s, Workspace& w, const VectorX& q);

// --- kinetic energy, forces --------------------------------------------------
const MatrixX& mass_matrix(const System& s, Workspace& w, const VectorX& q);          // M(q), n×n
// The natural inertia scale of every coordinate at q (n; kg·m² for angles,
// kg for lengths): an upper bound of M_ii whatever the orientation of the
// coordinate's axis, from the composite inertia of its body's subtree about
// the joint centre: the trace of its rotational inertia for a rotation, its
// mass for a translation. M_ii / scale_i ≤ 1 is then a scale-free geometric
// ratio: small where the coordinate's axis carries little of the subtree's
// inertia (a coordinate singularity, aligned axes), 0 for a massless subtree.
// The modal solvers equilibrate M by it (LinearModel::inertia_scale). Empty
// for kinematic maps, whose coordinates have no such scale.
VectorX inertia_scale(const System& s, Workspace& w, const VectorX& q);

// Absolute angles of parallel axes (docs/design.md, "Graded scenes"). A
// rotational coordinate (hinge or rotation-vector component) is measured from
// the nearest coordinate above its body that turns about the same world axis
// at q (to 8ε), whatever joints lie between: in a chain with a short link
// before a long one, M in these relative angles is singular to
// (l_short/l_long)² in double precision, whatever the diagonal scaling. In
// the absolute angles θ_k = θ_parent(k) + q_k (q = Tθ, T unit lower
// triangular) the same chain is as well conditioned as its links, provided
// the matrices are ASSEMBLED in θ (TᵀMT formed from a rounded M keeps M's
// lost digits lost). Links other than a hinge under a parallel parent hinge
// are made only while Σ over bodies of (coordinates on the body's path)² is
// at most 2e7 (a chain of about 390 coordinates), the cost of their assembly.
// absolute_angle_parents: per coordinate, the coordinate it is measured
// from, or -1 (all -1 for maps and where nothing is parallel).
std::vector<int> absolute_angle_parents(const System& s, Workspace& w, const VectorX& q);
// The links of `parents` that the pencil favours. A stiff joint spring k
// between parallel hinges is the other grading: in relative angles it is one
// diagonal entry, in absolute angles it enters the parent's diagonal too, and
// the parent's own stiffness is then its rounding (a 1.7e11 N·m/rad link on
// a 1 m pendulum: the pendulum's 9.81 N·m/rad is 1e-10 of its entry). Per
// link k → j where j or k is a hinge (the other a hinge or a ball's
// component), the relative
// pencil (M, K, n×n,
// relative angles) decides: the Schur complement of the pair onto j, S =
// X_jj − X_jk²/X_kk for X = M and X = K, is the same in both bases, and the
// basis whose diagonal entry at j is larger against |S| loses that many
// digits of it, X_jj in relative angles and X_jj − 2X_jk + X_kk in absolute
// ones (a loss counts only where X_kk ≠ 0, and is at most 1/ε). The link is
// set to -1 (the relative angle) only where the relative basis loses at
// most 100 (both M and K) and the absolute one at least 1e4 times more: in
// absolute angles a stiff spring's cancellation is in K_magnitude, and the
// estimates say so; in relative angles a graded chain's lost digits of M
// were not always (generated chains of hinges and balls with links dropped
// at a loss ratio of 10, or a ball's spin from a ball above at these
// margins: estimates 1e7 below the error).
void keep_favourable_links(const System& s, const MatrixX& M, const MatrixX& K, std::vector<int>& parents);
// A point-mass chain in absolute angles (docs/design.md, "Point-mass
// chains"): a chain of parallel hinges, body j (coordinate j) carrying its
// whole mass m_j as a point at the hinge of body j + 1 (the last anywhere
// on its line), every link on one line at q (hanging or standing straight).
// Its kinetic energy is ½Σ_b m_b (Σ_{j≤b} l_j θ̇_j)², l_j the signed length
// of link j along that line, so M = D_l Ĵᵀ D_m Ĵ D_l (Ĵ the unit lower
// triangle of ones: n × n, dense) = UUᵀ with U = D_l Ĵᵀ D_m^½ upper
// triangular, whose inverse is upper bidiagonal: products with M and M⁻¹,
// and the reduction of a diagonal K to the tridiagonal U⁻¹KU⁻ᵀ, cost O(n)
// per vector, formed from l and m without cancellation.
struct PointMassChain {
  VectorX lever;         // n: l_j, signed, m (nonzero)
  VectorX mass;          // n: m_j, kg (positive)
  double mismatch = 0;   // max over i ≤ j of |M_ij − l_i l_j Σ_{b≥j} m_b| / |l_i l_j Σ_{b≥j} m_b| (M as assembled)
  bool empty() const { return lever.size() == 0; }
};
// The structure of M (n×n, in the absolute angles of `parents`) where the
// scene is such a chain: every body a one-coordinate joint whose coordinate
// is measured from its parent's (parents[j] = j − 1), every mass positive,
// and M equal to D_l Ĵᵀ D_m Ĵ D_l entrywise within 1e-11 relative (l from
// M's diagonal and m, a sign from M's first row); else empty. Any other
// scene (rods, offset or rotating masses, a bent chain, a tree) fails the
// entrywise test, which is what decides.
PointMassChain point_mass_chain(const System& s, const MatrixX& M, const std::vector<int>& parents);
struct AbsoluteAngleModel {
  std::vector<int> parent;  // n: as absolute_angle_parents; empty: no change of basis
  MatrixX M;                // TᵀMT (n×n)
  MatrixX K;                // Tᵀ∇∇V T (n×n, symmetric)
  MatrixX K_magnitude;      // Σ|terms| of each entry of K, as potential_hessian_magnitude
  VectorX inertia_scale;    // n: as inertia_scale, for θ
  MatrixX D;                // TᵀDT (n×n) when the scene has dampers (linearize fills it), else empty
  MatrixX D_rounding;       // entrywise bound of D's rounding: 4ε|T|ᵀ|D_q||T| (n×n, or empty)
  PointMassChain chain;     // M's structure where it is a point-mass chain's, else empty
  bool empty() const { return parent.empty(); }
};
// M, ∇∇V and their companions assembled in θ (trees only: no map; the
// potential's elements only, so neither follower loads nor constraints). M
// is exact to rounding for any links; ∇∇V is exact for hinges under a parallel
// parent hinge, and the other links are applied to it as a congruence, whose
// cancellation K_magnitude carries (|T₂|ᵀ Σ|terms| |T₂|).
AbsoluteAngleModel absolute_angle_model(const System& s, Workspace& w, const VectorX& q,
                                        const std::vector<int>& parents);
double kinetic_energy(const System& s, Workspace& w, const VectorX& q, const VectorX& qd);  // ½q̇ᵀMq̇, J
// T + V, J; in a rotating frame ½q̇ᵀMq̇ + V − T₀ (the Jacobi integral).
double energy(const System& s, Workspace& w, const VectorX& q, const VectorX& qd);
// Damping matrix D(q) (n×n, symmetric PSD): the dampers' forces are Q = −D q̇.
MatrixX damping_matrix(const System& s, Workspace& w, const VectorX& q);
// Non-conservative generalized forces Q(q, q̇), n (dampers, follower loads).
VectorX generalized_forces(const System& s, Workspace& w, const VectorX& q, const VectorX& qd);
// ∂Q/∂q at q̇ = 0 (n×n, not symmetric in general): the follower loads' part of
// the stiffness, K = ∇∇V − ∂Q/∂q. Exact (same tree accumulation as ∇∇V).
MatrixX generalized_force_jacobian(const System& s, Workspace& w, const VectorX& q);

// ∂M/∂q: n matrices, entry k is ∂M/∂q_k (n×n). Exact (AD through the templated mass matrix).
std::vector<MatrixX> mass_matrix_derivatives(const System& s, Workspace& w, const VectorX& q);
// Christoffel symbols of the first kind Γ_ijk = ½(∂M_ij/∂q_k + ∂M_ik/∂q_j − ∂M_jk/∂q_i),
// returned as n matrices: entry i is the n×n matrix (Γ_ijk)_jk (symmetric in j, k).
std::vector<MatrixX> christoffel(const System& s, Workspace& w, const VectorX& q);
// Coriolis matrix C_ij = Σ_k Γ_ijk q̇_k (n×n); Ṁ − 2C is skew-symmetric.
MatrixX coriolis(const System& s, Workspace& w, const VectorX& q, const VectorX& qd);
// Rotating frame: g(q) (n; kg·m²/s for angles, kg·m/s for lengths), zero when
// the frame does not rotate.
VectorX frame_coupling(const System& s, Workspace& w, const VectorX& q);
// Gyroscopic matrix G_ij = ∂g_i/∂q_j − ∂g_j/∂q_i (n×n, skew-symmetric; zero
// when the frame does not rotate). Exact (AD through the templated g).
MatrixX gyroscopic_matrix(const System& s, Workspace& w, const VectorX& q);
// Accelerations q̈ = M⁻¹(Q − C q̇ − G q̇ − ∇V). Throws NumericalError if M is singular.
// With constraints, the q̈ of Lagrange's equations of the first kind,
// M q̈ = Q − C q̇ − G q̇ − ∇V + ∇c s with A q̈ = −q̇ᵀ∇∇c q̇ (the constraints
// held to second order), by the null-space method on the independent
// equations; then NᵀMN must be positive definite.
VectorX accelerations(const System& s, Workspace& w, const VectorX& q, const VectorX& qd);

// --- derivatives by differences: a selectable, measured alternative to AD ------
//
// The linear model's derivative matrices (K, G) are exact by default. These
// give the same matrices by differencing the model's first derivatives, so
// that their cost and accuracy can be compared (results/tradeoff.md):
//   exact         AD (potential_hessian and friends)
//   central       (f(q + h e_j) − f(q − h e_j)) / 2h    error O(h²) + O(ε/h)
//   forward       (f(q + h e_j) − f(q)) / h             error O(h) + O(ε/h)
//   complex-step  Im f(q + i h e_j) / h                 error O(h²), no cancellation
// Step rule: h_j = factor × max(|q_j|, u_j), u_j = 1 rad or the length scale,
// with factor √ε ≈ 1.5e-8 (forward), ε^(1/3) ≈ 6.1e-6 (central), which balance
// truncation against rounding for derivatives of order one in those units,
// and 1e-20 × u_j for complex steps (any tiny h: no subtraction). A step of
// differences is rounded so that (q_j + h) − q_j = h exactly. The rule's
// units need not fit the scene (a net of 1 cm springs spanning 10 m takes
// steps relative to 10 m), so the error is not predicted but measured: on
// request the Jacobian is taken again at 2h and 2|J_h − J_2h| is the
// estimate of J_h's error (truncation, O(h) forward or O(h²) central, and
// the rounding of the differenced values, ε/h, both show in it).
// Complex steps evaluate the templated model in modal::Complex (modal/ad.hpp);
// they are not available for kinematic maps (std::invalid_argument).
enum class DerivativeMethod { exact, central, forward, complex_step };
const char* to_string(DerivativeMethod method);  // "exact", "central", "forward", "complex-step"
std::optional<DerivativeMethod> parse_derivative_method(std::string_view word);
// The default step factor of a method (0 for exact).
double default_step_factor(DerivativeMethod method);
// The largest step factor accepted (std::invalid_argument above it): steps
// of a tenth of a radian or of the scene's length scale. Larger steps do
// not measure a derivative: at a factor near π or 2π a force periodic in an
// angle takes the same value at every step, its differences vanish, and so
// does their measured error.
inline constexpr double max_step_factor = 0.1;
// The least step factor of differences (central, forward): ε. Below it the
// step h = factor·max(|q_j|, unit) can vanish against q_j (q + h = q) and
// the difference is 0/0. Complex steps take any positive factor.
inline constexpr double min_difference_step_factor = std::numeric_limits<double>::epsilon();

// The generalized force at rest f(q) = ∇V(q) − Q(q, 0) − ∇c(q)ᵀ s (n), whose
// zero is an equilibrium and whose Jacobian is the stiffness K; s are fixed
// constraint multipliers (m, N) or empty.
VectorX rest_force(const System& s, Workspace& w, const VectorX& q, const VectorX& multipliers = {});
// K = ∂f/∂q (n×n) by `method` (exact: ∇∇V − ∂Q/∂q − Σ sᵢ∇∇cᵢ); step_factor
// 0: the default of the method, else in (0, max_step_factor]. With `error`
// (differences only; exact leaves it alone) the entrywise estimate of K's
// error (n×n, same units) 2 max(|K_h − K_2h|, |K_2h − K_4h|/2^p), p the
// method's order, at the cost of two more sets of evaluations.
MatrixX rest_force_jacobian(const System& s, Workspace& w, const VectorX& q, DerivativeMethod method,
                            const VectorX& multipliers = {}, double step_factor = 0, MatrixX* error = nullptr);
// G (n×n, skew) with ∂g/∂q by `method` (exact: gyroscopic_matrix(s, w, q)).
// With `error` (differences only) the entrywise estimate of G's error, as
// for rest_force_jacobian.
MatrixX gyroscopic_matrix(const System& s, Workspace& w, const VectorX& q, DerivativeMethod method,
                          double step_factor = 0, MatrixX* error = nullptr);

// --- steady motions (maps with ignorable coordinates) -------------------------
struct SteadyRate {
  std::string coordinate;  // the ignorable coordinate's name
  double rate = 0;         // ċ at the steady motion, rad/s or m/s
  double momentum = 0;     // its conserved momentum p = ∂T/∂ċ
};
// The rates and momenta of the ignorable coordinates in the steady motion at
// q (kept coordinates at rest). Empty for systems without ignorable coordinates.
std::vector<SteadyRate> steady_motion(const System& s, const VectorX& q);
// The same system with every ignorable coordinate given by its momentum in the
// steady motion at q (a copy of s when all are already given by momentum).
System with_steady_momenta(const System& s, const VectorX& q);
// World positions of the points of a map system at q (centres of mass), and
// the tips of their body axes (one length scale along each) for points with
// rotational inertia. Empty for body systems (see body_poses).
std::vector<Vec3> map_point_positions(const System& s, const VectorX& q);
// d/dτ map_point_positions(q + τ dq) at τ = 0, point by point, exact (AD of
// the map's expressions). Empty for body systems.
std::vector<Vec3> map_point_rates(const System& s, const VectorX& q, const VectorX& dq);

// --- holonomic constraints (System::constraints(); m equations) -------------------
// c(q), m entries, m (see Constraint).
VectorX constraint_values(const System& s, Workspace& w, const VectorX& q);
// The constraint Jacobian A = ∂c/∂q (m×n; row i is ∇c_iᵀ), exact.
MatrixX constraint_jacobian(const System& s, Workspace& w, const VectorX& q);
// Σ_i s_i ∇∇c_i (n×n, symmetric) for multipliers s (m, N): the multiplier
// term of the constrained stiffness K − Σ s_i ∇∇c_i (docs/design.md, "The
// linear model"), exact (the same tree accumulation as ∇∇V with the
// constraint forces as cotangents).
// Throws NumericalError for a distance constraint whose points coincide.
MatrixX constraint_hessian(const System& s, Workspace& w, const VectorX& q, const VectorX& multipliers);

// q̇ᵀ∇∇c_i q̇ (m): the part of the constraint accelerations d²c/dt² = A q̈ + this
// that does not depend on q̈. Exact (second-order forward AD along q̇ through
// the kinematics, one pass for all equations).
VectorX constraint_curvature(const System& s, Workspace& w, const VectorX& q, const VectorX& qd);

// A configuration brought onto c(q) = 0 from q by Gauss–Newton with
// minimum-norm steps (a complete orthogonal decomposition of A, so redundant
// equations do no harm), each limited to 0.5 rad or length scales, with
// backtracking on ‖c‖; stops at ‖c‖ ≤ 1e-15 × length scale or when ‖c‖ stops
// decreasing. `violation` is ‖c‖ (m) at the point returned (∞ if c is
// undefined at q).
struct ConstraintProjection {
  VectorX q;
  double violation = 0;
};
ConstraintProjection project_onto_constraints(const System& s, Workspace& w, const VectorX& q);

// Rank structure of constraint equations with Jacobian A (m×n) at one
// configuration, from a column-pivoted Householder QR of Aᵀ: an equation is
// redundant when its gradient is a combination of the others' to within a
// relative 1e-10 (of the largest pivot); the independent ones are kept in
// pivot order's greedy choice (largest gradients first), then sorted.
struct ConstraintBasis {
  int rank = 0;                  // number of independent equations r
  std::vector<int> independent;  // r equation indices, ascending
  std::vector<int> redundant;    // m − r equation indices, ascending
  MatrixX null_space;            // N, n×(n − r), orthonormal columns with A N = 0 (to rounding)
};
ConstraintBasis constraint_basis(const MatrixX& A);
// Least-squares multipliers (m, N) of ∇c_I s_I = force on the independent
// equations of `basis` (A: m×n, force: n); 0 on the redundant equations.
VectorX fit_multipliers(const MatrixX& A, const ConstraintBasis& basis, const VectorX& force);

// --- energy by element (docs/design.md, "Energy distribution and participation") ---
//
// The quadratic forms that make up vᵀM v and vᵀK v element by element, for a
// direction v of the coordinates (n; a mode shape), with the model's own
// templated elements differentiated along v by forward AD (first order for
// the kinetic energy, second order for the potential): O(bodies + springs +
// loads + constraints) per direction, no matrix is formed.
//   kinetic[b]   = vᵀM_b v: twice the kinetic energy of body b (a particle is a
//                  body) at q̇ = v, m|v_c|² + ωᵀ R I Rᵀ ω + its joint's armature
//                  term; Σ_b = vᵀM v.
//   potential[t] = vᵀK_t v for the terms named by potential_terms(): each body's
//                  gravity, joint spring and (rotating frame) centrifugal term,
//                  each spring and dead load (d²V_t/dτ² along q + τv), each
//                  follower load (−vᵀ ∂Q_t/∂q v) and each constraint
//                  (−Σ_i s_i vᵀ∇∇c_i v over its equations, multipliers s);
//                  Σ_t = vᵀK v with K = ∇∇V − ∂Q/∂q − Σ s_i∇∇c_i (its
//                  symmetric part: only that enters vᵀK v).
//   momentum     = Σ_b m_b ẋ_b at q̇ = v: the total linear momentum (world
//                  components; kg times the units of v's translation), so that
//                  d·momentum = vᵀL_d with L_d = Σ_b m_b J_bᵀ d.
// Kinematic maps have no elements: std::invalid_argument.
struct ElementQuadratics {
  VectorX kinetic;    // per body
  VectorX potential;  // per potential term
  Vec3 momentum = Vec3::Zero();
};
// Names of the potential terms, in the order of ElementQuadratics::potential:
// "<body>.gravity", "<body>.joint", "spring<k>", "load<k>", "follower<k>"
// (k from 1 in the system's order, which is `modal check`'s), "<body>.centrifugal",
// "<constraint name>".
std::vector<std::string> potential_terms(const System& s);
ElementQuadratics element_quadratics(const System& s, const VectorX& q, const VectorX& v,
                                     const VectorX& multipliers = {});
// The mass that can move along the unit direction d at q (kg): Σ m_b over the
// bodies whose centre of mass some coordinate moves along d to first order
// (|d·J_bk| above 1e-9 |J_bk| for a coordinate k of b or of an ancestor,
// J_bk = ∂x_b/∂q_k). Constraints are not considered (an upper bound then).
double movable_mass(const System& s, const VectorX& q, const Vec3& d);

// World pose of every body at q: rotation (body → world) and frame origin.
struct Pose {
  Mat3 rotation = Mat3::Identity();
  Vec3 position = Vec3::Zero();
};
std::vector<Pose> body_poses(const System& s, Workspace& w, const VectorX& q);
// The first-order motion of every body along dq at q, d/dτ body_poses(q + τ dq)
// at τ = 0: the velocity of its frame origin and its angular velocity (world
// components; m and rad per unit of dq). Exact (forward-mode AD of the
// kinematics). Empty for kinematic maps (see map_point_rates).
struct PoseRate {
  Vec3 velocity = Vec3::Zero();
  Vec3 angular = Vec3::Zero();
};
std::vector<PoseRate> body_pose_rates(const System& s, const VectorX& q, const VectorX& dq);

// Coordinates brought to their canonical chart: periodic hinge angles to
// (−π, π], periodic rotation vectors to length ≤ π (the same rotation); joints
// with springs are left as they are. Used to compare and report configurations.
VectorX canonical_coordinates(const System& s, const VectorX& q);
// Distance between configurations after canonicalization (periodic angles
// modulo 2π, periodic rotations by their geodesic angle, translations divided
// by the length scale, other coordinates by their difference).
double configuration_distance(const System& s, const VectorX& a, const VectorX& b);

// --- K and M of a tree without the matrices (docs/design.md, "Matrix-free path") ---
//
// In the coordinates of a tree, M and ∇∇V are dense wherever bodies lie on
// one path (a chain of n links couples all n² pairs), yet both have an
// ordered form of O(bodies) numbers: for a coordinate j at or above k (k of
// body b, twists ξ about b's joint centre p_b)
//   M_jk = ξ_jᵀ Ic_b ξ_k            Ic_b: b's composite spatial inertia
//   K_jk = ξ_jᵀ A_b ξ_k,  A_b = [[P − tr(P) I, −F̂], [0, 0]]
// with F and P the subtree sums of the potential's cotangents (header of
// lib/core/derivatives.cpp), plus the joints' own terms on the diagonal
// (springs in K, armatures in M). Products and an LDLᵀ factorization of
// αK + βM + γI follow by recursions over the tree in O(bodies) time and
// memory (tree_product, TreeFactor).
//
// Why tree_pencil cannot describe s, in words; nullopt when it can: a tree
// (no map) of hinge, slide and fixed joints whose potential is gravity, dead
// loads and joint springs, with no springs between points, constraints,
// follower loads, dampers or rotating frame.
std::optional<std::string> tree_pencil_unsupported(const System& s);
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;
struct TreePencil {
  std::vector<int> parent;      // per body: parent body, −1 the world (parents precede children)
  std::vector<int> coordinate;  // per body: its coordinate (0 … n−1), −1 for a fixed joint
  std::vector<Vec6> twist;      // per body: ξ of its coordinate about p_b (zero when fixed)
  std::vector<Vec3> offset;     // per body: p_b − p_parent, m
  std::vector<Mat6> K;          // per body: A_b above (units of K times m⁻² and m⁻¹ by block)
  std::vector<Mat6> M;          // per body: Ic_b, kg·m², kg·m, kg by block
  VectorX K_diagonal;           // n: joint springs added to K_kk (N·m/rad or N/m)
  VectorX M_diagonal;           // n: armatures added to M_kk (kg·m² or kg)
  int depth = 0;                // most bodies on one path (the recursions' length)
  // Where the bodies prove a straight point-mass chain of parallel hinges,
  // hanging or standing (as absolute_angle_model's PointMassChain:
  // mismatch 0, the lengths taken from the kinematics) and ∇∇V in its
  // absolute angles θ (q_j = θ_j − θ_{j−1}) is diagonal: M = D_l Ĵᵀ D_m Ĵ
  // D_l and K's diagonal there, the O(n) data from which solve_tree_modes
  // solves a hanging one (every K_jj > 0) to rounding; else all three empty.
  PointMassChain chain;
  VectorX chain_K;        // n: K_jj in θ (N·m/rad)
  VectorX chain_K_terms;  // n: Σ|terms| of each K_jj (its rounding is within 4ε of it)
  int size() const { return static_cast<int>(K_diagonal.size()); }
};
// The pencil at q. Throws std::invalid_argument when tree_pencil_unsupported(s).
TreePencil tree_pencil(const System& s, Workspace& w, const VectorX& q);
// y = (αK + βM) x in O(bodies). With `magnitude`, the same recursion over the
// absolute values of every number (|α|, |β|, |x| and each matrix and twist
// entrywise): an upper bound of Σ|terms| of each entry of the product, for
// rounding bounds and norms (y ≥ |αK + βM| |x| entrywise).
VectorX tree_product(const TreePencil& p, double alpha, double beta, const VectorX& x, bool magnitude = false);
// y = (αK + βM) x for many x: the columns A_b ξ_b formed once, work vectors
// kept (a Lanczos iteration takes hundreds of products with M). Holds a
// reference to the pencil.
class TreeProduct {
 public:
  TreeProduct(const TreePencil& p, double alpha, double beta);
  void apply(const double* x, double* y) const;

 private:
  const TreePencil& p_;
  std::vector<Vec6> u_;  // per body: A_b ξ_b
  VectorX diagonal_;     // n: the joints' own terms
  mutable std::vector<Vec6> z_, v_;
};
// The diagonal of αK + βM (n): ξ_kᵀ A_b ξ_k plus the joint's own term.
VectorX tree_diagonal(const TreePencil& p, double alpha, double beta);
// The LDLᵀ factorization of H = αK + βM + γI in elimination order (leaves
// first, the articulated-body recursion): O(bodies) time and memory, one
// 1×1 pivot per coordinate, no pivoting. By Sylvester's law the number of
// negative pivots is the number of negative eigenvalues of H.
class TreeFactor {
 public:
  TreeFactor() = default;
  // False when a pivot is exactly zero or not finite (then nothing can be solved).
  bool factor(const TreePencil& p, double alpha, double beta, double gamma = 0);
  int negative_pivots() const { return negative_; }
  // The coordinate of the first pivot, in elimination order, that is not
  // positive and finite (−1 when none), and the pivots (n; those after a failed one
  // are zero). For diagnoses: where the factorization broke down.
  int first_nonpositive() const { return first_nonpositive_; }
  const VectorX& pivots() const { return d_; }
  // x = H⁻¹ b (n); requires a successful factor().
  void solve(const double* b, double* x) const;
  VectorX solve(const VectorX& b) const;

 private:
  const TreePencil* p_ = nullptr;
  std::vector<Vec6> u_;  // per body: U_b = A_b ξ_b (articulated A_b)
  VectorX d_;            // n pivots
  int negative_ = 0;
  int first_nonpositive_ = -1;
  mutable std::vector<Vec6> work_;
};

// --- memory, estimated before allocating (docs/design.md, "Memory policy") ---

// Memory ran out although the estimate made before allocating fitted (the
// estimates are measured per coordinate pair, body and spring, not exact),
// or a stage found, before allocating, that what it is about to allocate
// exceeds what the machine has (the sparse factor's size from its symbolic
// analysis). what() says so, with the estimate of what was being computed;
// exit status 4 like every std::bad_alloc.
class OutOfMemory : public std::bad_alloc {
 public:
  explicit OutOfMemory(std::string message) : message_(std::move(message)) {}
  const char* what() const noexcept override { return message_.c_str(); }

 private:
  std::string message_;
};

// What the machine can still give a process: MemAvailable of /proc/meminfo,
// in bytes; 0 when it cannot be read.
double available_memory();
// The process's address-space limit (RLIMIT_AS: ulimit -v, a batch system's
// h_vmem) in bytes, 0 when none is set. Allocates nothing (safe where malloc
// has failed).
double address_space_limit() noexcept;
// "3.2 GB", "850 MB", "12 kB": a size in decimal units, for messages.
std::string format_bytes(double bytes);
// Nothing when `bytes` fit the limit; else the sentence that refuses: "… needs
// about 90 GB for <what>, more than the 21 GB …", naming the limit's source.
// `limit` > 0 is a limit the user set (`--max-memory`, SceneLimits::memory);
// 0 stands for the machine's available memory (no refusal when unknown).
std::optional<std::string> memory_refusal(double bytes, const std::string& what, double limit);
// The memory the process's allocations hold, in bytes (glibc's mallinfo2:
// the heap's blocks in use and the blocks mapped on their own); 0 under
// another allocator (the sanitizers', jemalloc), which the checks below then
// leave out.
double memory_in_use();
// Before `bytes` are allocated for `what` on top of what the process holds:
// throws OutOfMemory ("out of memory, found before allocating: it would need
// about …") when they would bring the process's use (memory_in_use + bytes)
// over `limit` (> 0, a limit the user set) or, with limit 0, when they are
// more than the machine has available and the heap's free memory, which
// they may reuse (nothing is refused where that cannot be read).
void check_allocation(double bytes, const std::string& what, double limit);

// Coordinate pairs (j, k), both orders, that the tree couples in M and in the
// potential's Hessian: those of each body's coordinates with its own and its
// ancestors', and those across the paths of each spring's two ends. An upper
// bound of the nonzeros of the sparse M or K, in O(bodies + springs); a chain
// of n hinges couples every pair: n².
double coupled_pairs(const System& s);

}  // namespace modal
