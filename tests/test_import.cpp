// MJCF and URDF import (modal/import.hpp) against libmujoco as the reference:
// for the bundled models and for seeded random kinematic trees (hinge, slide
// and ball joints, several joints per body, random frames, inertias, joint
// anchors, springs with references, armature), modal's M(q) equals MuJoCo's
// mj_fullM, modal's generalized rest force ∇V equals MuJoCo's
// qfrc_bias − qfrc_passive (at zero velocity), modal's exact K equals the
// central difference of that force, and the frequencies at modal's
// equilibrium agree. Coordinates: a hinge or slide coordinate is qpos − qpos0;
// a ball joint's rotation vector φ has quaternion exp(φ) and MuJoCo's
// velocities are the body-frame angular velocity ω = J_r(φ) φ̇, so M_modal =
// Tᵀ M_mj T and f_modal = Tᵀ f_mj with T the block-diagonal map φ̇ → ω.
#include "core/model.hpp"
#include "modal/pipeline.hpp"
#include "program.hpp"

#include <mujoco/mujoco.h>

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <random>
#include <sstream>
#include <string>

namespace {

struct MjDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using MjModel = std::unique_ptr<mjModel, MjDeleter>;
using MjData = std::unique_ptr<mjData, MjDeleter>;

MjModel load_mujoco(const std::string& text, const std::string& name = "model.xml") {
  auto vfs = std::make_unique<mjVFS>();
  mj_defaultVFS(vfs.get());
  EXPECT_EQ(mj_makeEmptyFileVFS(vfs.get(), name.c_str(), static_cast<int>(text.size())), 0);
  std::memcpy(vfs->filedata[vfs->nfile - 1], text.data(), text.size());
  char error[1000] = "";
  MjModel m(mj_loadXML(name.c_str(), vfs.get(), error, sizeof error));
  mj_deleteVFS(vfs.get());
  EXPECT_TRUE(m) << error;
  return m;
}

// MuJoCo evaluated at modal's coordinates q.
class Reference {
 public:
  Reference(const mjModel& m, const modal::System& sys) : m_(m), d_(mj_makeData(&m)), sys_(sys) {
    const auto names = sys.coordinate_names();
    for (int j = 0; j < m.njnt; ++j) {
      const std::string name = mj_id2name(&m, mjOBJ_JOINT, j);
      const std::string first = m.jnt_type[j] == mjJNT_BALL ? name + ".rx" : name;
      const auto it = std::find(names.begin(), names.end(), first);
      EXPECT_NE(it, names.end()) << "no coordinate " << first;
      index_.push_back(static_cast<int>(it - names.begin()));
    }
  }
  // The joint limits MuJoCo finds active at q (its constraint rows of type limit).
  int active_limits(const modal::VectorX& q) {
    modal::MatrixX T;
    set(q, T);
    int count = 0;
    for (int i = 0; i < d_->nefc; ++i) count += d_->efc_type[i] == mjCNSTR_LIMIT_JOINT;
    return count;
  }
  // qpos of q, and T (nv × n): MuJoCo's velocities of q̇.
  void set(const modal::VectorX& q, modal::MatrixX& T) {
    T.setZero(m_.nv, sys_.size());
    for (int j = 0; j < m_.njnt; ++j) {
      const int a = m_.jnt_qposadr[j], v = m_.jnt_dofadr[j], i = index_[static_cast<std::size_t>(j)];
      if (m_.jnt_type[j] == mjJNT_BALL) {
        const modal::Vec3 phi = q.segment<3>(i);
        const double angle = phi.norm();
        const Eigen::Quaterniond r =
            angle == 0 ? Eigen::Quaterniond::Identity() : Eigen::Quaterniond(Eigen::AngleAxisd(angle, phi / angle));
        d_->qpos[a] = r.w();
        d_->qpos[a + 1] = r.x();
        d_->qpos[a + 2] = r.y();
        d_->qpos[a + 3] = r.z();
        T.block<3, 3>(v, i) = modal::model::rotation_left_jacobian<double>(modal::Vec3(-phi));  // J_r(φ)
      } else {
        d_->qpos[a] = m_.qpos0[a] + q[i];
        T(v, i) = 1;
      }
    }
    mju_zero(d_->qvel, m_.nv);
    mj_forward(&m_, d_.get());
  }
  modal::MatrixX mass(const modal::VectorX& q) {
    modal::MatrixX T;
    set(q, T);
    modal::MatrixX full(m_.nv, m_.nv);
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> dense(m_.nv, m_.nv);
    mj_fullM(&m_, dense.data(), d_->qM);
    full = dense;
    return T.transpose() * full * T;
  }
  // ∇V in modal's coordinates: Tᵀ (qfrc_bias − qfrc_passive) at rest.
  modal::VectorX force(const modal::VectorX& q) {
    modal::MatrixX T;
    set(q, T);
    modal::VectorX f(m_.nv);
    for (int i = 0; i < m_.nv; ++i) f[i] = d_->qfrc_bias[i] - d_->qfrc_passive[i];
    return T.transpose() * f;
  }
  modal::MatrixX stiffness(const modal::VectorX& q, double h) {
    modal::MatrixX K(sys_.size(), sys_.size());
    for (int k = 0; k < sys_.size(); ++k) {
      modal::VectorX a = q, b = q;
      a[k] += h;
      b[k] -= h;
      K.col(k) = (force(a) - force(b)) / (2 * h);
    }
    return K;
  }

 private:
  const mjModel& m_;
  MjData d_;
  const modal::System& sys_;
  std::vector<int> index_;
};

double relative(const modal::MatrixX& a, const modal::MatrixX& b) {
  return (a - b).cwiseAbs().maxCoeff() / std::max(b.cwiseAbs().maxCoeff(), 1e-300);
}

// modal against MuJoCo at q: M to 1e-12, ∇V to 1e-11, K to the central difference's accuracy.
void compare_at(const mjModel& m, const modal::System& sys, const modal::VectorX& q, const std::string& what) {
  Reference ref(m, sys);
  modal::Workspace ws(sys);
  EXPECT_LT(relative(modal::mass_matrix(sys, ws, q), ref.mass(q)), 1e-12) << what;
  const modal::VectorX f = ref.force(q);
  const double fscale = std::max(f.cwiseAbs().maxCoeff(), modal::force_scale(sys, ws, q));
  EXPECT_LT((modal::potential_gradient(sys, ws, q) - f).cwiseAbs().maxCoeff() / fscale, 1e-11) << what;
  const modal::MatrixX Kfd = ref.stiffness(q, 1e-5);
  const modal::MatrixX K = modal::potential_hessian(sys, ws, q);
  EXPECT_LT((K - Kfd).cwiseAbs().maxCoeff() / std::max(K.cwiseAbs().maxCoeff(), fscale), 1e-7) << what;
}

// Frequencies at modal's equilibrium: the undamped ω² of modal's linear model
// (M, K) against the generalized eigenvalues of MuJoCo's M and finite-difference
// K there (and modal's reported ω² when its model is symmetric), and modal's
// damping matrix against MuJoCo's dof_damping.
void compare_frequencies(const mjModel& m, const modal::Model& model, const std::string& what) {
  const modal::Analysis a = modal::analyze(model);
  ASSERT_TRUE(a.linear.has_value()) << what;
  const modal::VectorX q = a.equilibrium().q;
  Reference ref(m, model.system);
  const modal::MatrixX M = ref.mass(q);
  modal::MatrixX K = ref.stiffness(q, 1e-5);
  K = 0.5 * (K + K.transpose()).eval();
  const Eigen::GeneralizedSelfAdjointEigenSolver<modal::MatrixX> mujoco(K, M, Eigen::EigenvaluesOnly);
  const Eigen::GeneralizedSelfAdjointEigenSolver<modal::MatrixX> ours(a.linear->K, a.linear->M, Eigen::EigenvaluesOnly);
  const double scale = mujoco.eigenvalues().cwiseAbs().maxCoeff();
  ASSERT_EQ(ours.eigenvalues().size(), mujoco.eigenvalues().size()) << what;
  for (Eigen::Index i = 0; i < ours.eigenvalues().size(); ++i)
    EXPECT_NEAR(ours.eigenvalues()[i], mujoco.eigenvalues()[i], 1e-6 * scale) << what << " mode " << i + 1;
  if (a.linear->symmetric()) {
    ASSERT_EQ(static_cast<Eigen::Index>(a.result().modes.size()), mujoco.eigenvalues().size()) << what;
    for (std::size_t i = 0; i < a.result().modes.size(); ++i)
      EXPECT_NEAR(a.result().modes[i].omega2, mujoco.eigenvalues()[static_cast<Eigen::Index>(i)], 1e-6 * scale)
          << what << " mode " << i + 1;
  }
  modal::MatrixX T;
  ref.set(q, T);
  modal::MatrixX D = modal::MatrixX::Zero(m.nv, m.nv);
  for (int i = 0; i < m.nv; ++i) D(i, i) = m.dof_damping[i];
  const modal::MatrixX Dq = T.transpose() * D * T;
  const modal::MatrixX Dm = a.linear->has_damping ? a.linear->D : modal::MatrixX::Zero(q.size(), q.size());
  EXPECT_LT((Dm - Dq).cwiseAbs().maxCoeff(), 1e-12 * std::max(1.0, Dq.cwiseAbs().maxCoeff())) << what;
}

// --- random kinematic trees -----------------------------------------------------------

std::string vec(std::mt19937_64& rng, double lo, double hi, int n = 3) {
  std::uniform_real_distribution<double> u(lo, hi);
  std::string s;
  for (int i = 0; i < n; ++i) s += (i ? " " : "") + std::to_string(u(rng));
  return s;
}

// A seeded random tree: `bodies` bodies, each under a random earlier one (or
// the world), with a random frame, one or two joints (hinge, slide or ball,
// random anchors and axes), a random inertia (principal moments obeying the
// triangle inequality, random principal frame), springs on every joint (some
// with a reference), damping and armature.
// With `limits`, every joint is limited: a hinge or slide to a random range
// around its written value, a ball joint to a random cone (drawn from a
// second generator, so the tree itself is the one without limits).
std::string random_tree(unsigned seed, int bodies, bool limits = false) {
  std::mt19937_64 rng(seed), limit_rng(seed + 1000);
  std::uniform_real_distribution<double> span(0.02, 0.6);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<std::string> children(static_cast<std::size_t>(bodies) + 1);
  std::vector<int> parent(static_cast<std::size_t>(bodies) + 1, 0);
  for (int b = 1; b <= bodies; ++b) parent[static_cast<std::size_t>(b)] = static_cast<int>(u(rng) * b);
  int joint = 0;
  std::vector<std::string> body_xml(static_cast<std::size_t>(bodies) + 1);
  for (int b = 1; b <= bodies; ++b) {
    std::string x = "<body name=\"b" + std::to_string(b) + "\" pos=\"" + vec(rng, -0.5, 0.5) + "\" quat=\"" +
                    vec(rng, -1, 1, 4) + "\">\n";
    int nj = u(rng) < 0.25 ? 2 : 1;
    for (int k = 0; k < nj; ++k) {
      const double t = u(rng);
      const char* type = t < 0.45 ? "hinge" : t < 0.7 ? "slide" : "ball";
      if (std::string(type) == "ball") nj = k + 1;  // MuJoCo: nothing may follow a ball joint in its body
      x += std::string("<joint name=\"j") + std::to_string(joint++) + "\" type=\"" + type + "\" pos=\"" +
           vec(rng, -0.3, 0.3) + "\"";
      if (std::string(type) != "ball") x += " axis=\"" + vec(rng, -1, 1) + "\" springref=\"" + vec(rng, -0.3, 0.3, 1) + "\"";
      double ref = 0;
      if (std::string(type) == "hinge") {
        const std::string r = vec(rng, -0.5, 0.5, 1);
        ref = std::stod(r);
        x += " ref=\"" + r + "\"";
      }
      if (limits)
        x += " limited=\"true\" range=\"" +
             (std::string(type) == "ball" ? "0 " + std::to_string(4 * span(limit_rng))
                                          : std::to_string(ref - span(limit_rng)) + " " + std::to_string(ref + span(limit_rng))) +
             "\"";
      x += " stiffness=\"" + vec(rng, 5, 50, 1) + "\" damping=\"" + vec(rng, 0, 1, 1) + "\" armature=\"" +
           vec(rng, 0, 0.05, 1) + "\"/>\n";
    }
    const double i1 = 0.01 + 0.1 * u(rng), i2 = 0.01 + 0.1 * u(rng);
    const double i3 = std::abs(i1 - i2) + (i1 + i2 - std::abs(i1 - i2)) * (0.1 + 0.8 * u(rng));
    x += "<inertial pos=\"" + vec(rng, -0.3, 0.3) + "\" quat=\"" + vec(rng, -1, 1, 4) + "\" mass=\"" +
         vec(rng, 0.2, 3, 1) + "\" diaginertia=\"" + std::to_string(i1) + " " + std::to_string(i2) + " " +
         std::to_string(i3) + "\"/>\n";
    body_xml[static_cast<std::size_t>(b)] = x;
  }
  // Nest: children are written inside their parents (deepest first).
  for (int b = bodies; b >= 1; --b) {
    const auto bb = static_cast<std::size_t>(b);
    const std::string whole = body_xml[bb] + children[bb] + "</body>\n";
    children[static_cast<std::size_t>(parent[bb])] = whole + children[static_cast<std::size_t>(parent[bb])];
  }
  return "<mujoco model=\"random tree " + std::to_string(seed) +
         "\">\n<compiler angle=\"radian\"/>\n<option gravity=\"" + vec(rng, -3, 3, 2) +
         " -9.81\"><flag contact=\"disable\"/></option>\n<worldbody>\n" + children[0] + "</worldbody>\n</mujoco>\n";
}

modal::VectorX random_configuration(const modal::System& sys, std::mt19937_64& rng, double size) {
  std::uniform_real_distribution<double> u(-size, size);
  modal::VectorX q(sys.size());
  for (int i = 0; i < sys.size(); ++i) q[i] = u(rng);
  return q;
}

TEST(Import, RandomTreesMatchMuJoCo) {
  for (unsigned seed = 1; seed <= 12; ++seed) {
    const std::string xml = random_tree(seed, 3 + static_cast<int>(seed % 6));
    const std::string what = "seed " + std::to_string(seed) + "\n" + xml;
    const modal::Model model = modal::model_from_text(xml, "random.xml");
    const MjModel m = load_mujoco(xml);
    ASSERT_TRUE(m);
    ASSERT_EQ(model.system.size(), m->nv) << what;
    std::mt19937_64 rng(seed);
    compare_at(*m, model.system, modal::VectorX::Zero(model.system.size()), what + " at q = 0");
    for (int k = 0; k < 3; ++k) compare_at(*m, model.system, random_configuration(model.system, rng, 1.0), what);
    compare_frequencies(*m, model, what);
  }
}

// Beyond half a turn: a ball joint's spring is MuJoCo's, the geodesic ½kθ²
// with θ ≤ π the angle of the rotation, where ½k‖φ‖² on the rotation vector
// differed by 2πk per turn (an imported sprung ball was balanced at
// configurations MuJoCo's model is not). Every ball of the random trees at a
// rotation vector of length in (π, 2π) or (2π, 3π), 0.3 rad away from the
// multiples of π (at odd ones the spring's force turns over; at 2π the
// rotation vector's chart is singular).
TEST(Import, BallSpringsBeyondHalfATurnMatchMuJoCo) {
  int beyond = 0;
  for (unsigned seed = 1; seed <= 12; ++seed) {
    const std::string xml = random_tree(seed, 3 + static_cast<int>(seed % 6));
    const modal::Model model = modal::model_from_text(xml, "random.xml");
    const MjModel m = load_mujoco(xml);
    ASSERT_TRUE(m);
    const modal::System& sys = model.system;
    std::mt19937_64 rng(seed + 77);
    std::uniform_real_distribution<double> length(0.3, std::numbers::pi - 0.3);
    for (int k = 0; k < 3; ++k) {
      modal::VectorX q = random_configuration(sys, rng, 1.0);
      for (int b = 0; b < static_cast<int>(sys.bodies().size()); ++b) {
        if (sys.bodies()[static_cast<std::size_t>(b)].joint != modal::JointType::ball) continue;
        const int k0 = sys.first_coordinate(b);
        const modal::Vec3 axis = q.segment<3>(k0).normalized();
        const double turns = (k + b) % 2 == 0 ? 1.0 : 2.0;  // (π, 2π) or (2π, 3π)
        q.segment<3>(k0) = axis * ((turns == 1.0 ? std::numbers::pi : 2 * std::numbers::pi) + length(rng));
        ++beyond;
      }
      compare_at(*m, sys, q, "seed " + std::to_string(seed) + "\n" + xml);
    }
  }
  EXPECT_GE(beyond, 10);  // the family holds sprung balls beyond half a turn
}

// --- the bundled models -----------------------------------------------------------------

class Bundled : public testing::TestWithParam<const char*> {};

TEST_P(Bundled, MatchesMuJoCo) {
  const std::string path = std::string(MODAL_SOURCE_DIR) + "/models/" + GetParam();
  const modal::Model model = modal::load_model(path);
  char error[1000] = "";
  const MjModel m(mj_loadXML(path.c_str(), nullptr, error, sizeof error));
  ASSERT_TRUE(m) << error;
  ASSERT_EQ(model.system.size(), m->nv);
  const modal::Analysis a = modal::analyze(model);
  compare_at(*m, model.system, a.equilibrium().q, GetParam());
  compare_frequencies(*m, model, GetParam());
  // The converted TOML scene gives the same frequencies (to round-off: here exactly, the import reads it too).
  const modal::Model again = modal::model_from_text(modal::convert_scene(path), "converted.toml");
  const modal::Analysis b = modal::analyze(again);
  ASSERT_EQ(a.result().modes.size(), b.result().modes.size());
  for (std::size_t i = 0; i < a.result().modes.size(); ++i)
  {
    const modal::Mode& x = a.result().modes[i];
    const modal::Mode& y = b.result().modes[i];
    EXPECT_NEAR(x.omega, y.omega, 1e-12 * std::max(1.0, x.omega));
    EXPECT_NEAR(x.growth_rate, y.growth_rate, 1e-12 * std::max(1.0, x.omega));
  }
}

INSTANTIATE_TEST_SUITE_P(Models, Bundled,
                         testing::Values("double_pendulum.xml", "arm7.xml", "ball_tree.xml", "arm.urdf",
                                         "pendulum_tool.urdf"));

// A connect equality becomes a point [[constraint]]: the four-bar linkage's
// frequency against MuJoCo's M and finite-difference K projected onto the
// null space of MuJoCo's constraint Jacobian efc_J (at the written
// configuration, where springs hold it with zero constraint force, so the
// multipliers' curvature term vanishes).
TEST(Import, ConnectEqualityIsAPointConstraint) {
  const std::string path = std::string(MODAL_SOURCE_DIR) + "/models/four_bar.xml";
  const modal::Model model = modal::load_model(path);
  ASSERT_EQ(model.system.constraints().size(), 1u);
  char error[1000] = "";
  const MjModel m(mj_loadXML(path.c_str(), nullptr, error, sizeof error));
  ASSERT_TRUE(m) << error;
  const modal::Analysis a = modal::analyze(model);
  const modal::VectorX q = a.equilibrium().q;
  EXPECT_LT(q.norm(), 1e-12);
  Reference ref(*m, model.system);
  const modal::MatrixX M = ref.mass(q);
  const modal::MatrixX K = ref.stiffness(q, 1e-5);
  const MjData d(mj_makeData(m.get()));
  mj_forward(m.get(), d.get());
  modal::MatrixX J(d->nefc, m->nv);
  for (int i = 0; i < d->nefc; ++i)
    for (int j = 0; j < m->nv; ++j) J(i, j) = d->efc_J[i * m->nv + j];
  const Eigen::JacobiSVD<modal::MatrixX> svd(J, Eigen::ComputeFullV);
  int rank = 0;
  for (Eigen::Index i = 0; i < svd.singularValues().size(); ++i)
    if (svd.singularValues()[i] > 1e-10 * svd.singularValues()[0]) ++rank;
  const modal::MatrixX N = svd.matrixV().rightCols(m->nv - rank);
  const Eigen::GeneralizedSelfAdjointEigenSolver<modal::MatrixX> es(N.transpose() * K * N, N.transpose() * M * N,
                                                                    Eigen::EigenvaluesOnly);
  ASSERT_EQ(static_cast<Eigen::Index>(a.result().modes.size()), es.eigenvalues().size());
  for (std::size_t i = 0; i < a.result().modes.size(); ++i)
    EXPECT_NEAR(a.result().modes[i].omega2, es.eigenvalues()[static_cast<Eigen::Index>(i)],
                1e-7 * es.eigenvalues().cwiseAbs().maxCoeff());
}

// Joint limits at the equilibrium, the class: random trees whose every joint
// is limited (hinge and slide ranges around the written value, ball cones).
// modal refuses an equilibrium exactly when MuJoCo, put at modal's
// equilibrium, finds a limit active there (its constraint rows of type
// limit), naming a joint of the file with its line; otherwise the analysis
// lists every hinge and slide limit as inactive. Both outcomes must occur.
TEST(Import, LimitsAtTheEquilibriumAsMuJoCoSeesThem) {
  int refused = 0, analyzed = 0;
  for (unsigned seed = 1; seed <= 30; ++seed) {
    const std::string xml = random_tree(seed, 2 + static_cast<int>(seed % 5), true);
    const std::string what = "seed " + std::to_string(seed) + "\n" + xml;
    // (a written value at its limit cannot happen: the ranges contain it)
    const modal::Model model = modal::model_from_text(xml, "limits.xml");
    const MjModel m = load_mujoco(xml);
    ASSERT_TRUE(m);
    const modal::Equilibrium eq = modal::find_equilibrium(model.system, model.system.initial_configuration());
    Reference mujoco(*m, model.system);
    const int active = mujoco.active_limits(eq.q);
    try {
      const modal::Analysis a = modal::analyze(model);
      EXPECT_EQ(active, 0) << what;
      int scalar = 0;
      for (int j = 0; j < m->njnt; ++j) scalar += m->jnt_type[j] == mjJNT_HINGE || m->jnt_type[j] == mjJNT_SLIDE;
      EXPECT_EQ(static_cast<int>(a.equilibrium().limits.size()), scalar) << what;
      for (const modal::JointLimitState& l : a.equilibrium().limits) EXPECT_FALSE(l.active()) << what;
      ++analyzed;
    } catch (const modal::SceneError& e) {
      EXPECT_GT(active, 0) << e.what() << "\n" << what;
      const std::string message = e.what();
      EXPECT_EQ(message.rfind("limits.xml:", 0), 0u) << message;
      EXPECT_GT(e.where().line, 0) << message;
      EXPECT_NE(message.find("limit"), std::string::npos) << message;
      EXPECT_EQ(modal::exit_status(e), modal::ExitStatus::bad_input);
      ++refused;
    }
  }
  EXPECT_GT(refused, 3);
  EXPECT_GT(analyzed, 3);
}

// Contacts, hinge limits and ball cones that the written configuration does
// not touch but the equilibrium does: refused with the element and its line;
// an inactive limit is listed in the text and the JSON.
TEST(Import, ContactsAndLimitsAtTheEquilibrium) {
  // The arm is written horizontal and hangs straight down at equilibrium (90°).
  auto arm = [](const std::string& joint, const std::string& extra, const std::string& option = "") {
    return "<mujoco>\n" + option + "<worldbody>\n" + extra + "<body name=\"arm\" pos=\"0 0 1\">\n" + joint +
           "\n<geom name=\"bob\" type=\"sphere\" pos=\"0.5 0 0\" size=\"0.05\" mass=\"1\"/></body>\n"
           "</worldbody>\n</mujoco>\n";
  };
  const std::string no_contact = "<option><flag contact=\"disable\"/></option>\n";
  auto analysis_error = [](const std::string& xml) -> std::string {
    try {
      modal::analyze(modal::model_from_text(xml, "eq.xml"));
    } catch (const modal::SceneError& e) {
      return e.what();
    }
    return "no error";
  };
  const std::string stopped = arm("<joint name=\"shoulder\" axis=\"0 1 0\" limited=\"true\" range=\"-30 60\"/>", "");
  EXPECT_NE(analysis_error(stopped).find("eq.xml:4: range: the joint of 'shoulder' is at 1.570796327 rad"),
            std::string::npos)
      << analysis_error(stopped);
  const std::string floor =
      arm("<joint name=\"shoulder\" axis=\"0 1 0\"/>", "<geom name=\"floor\" type=\"plane\" pos=\"0 0 0.7\" size=\"2 2 0.1\"/>\n");
  EXPECT_NE(analysis_error(floor).find("eq.xml:3: geom 'floor': is in contact with geom 'bob' in the equilibrium"),
            std::string::npos)
      << analysis_error(floor);
  const std::string cone = "<mujoco>\n<option><flag contact=\"disable\"/></option>\n<worldbody>\n<body name=\"arm\" "
                           "pos=\"0 0 1\">\n<joint name=\"socket\" type=\"ball\" limited=\"true\" range=\"0 45\"/>\n"
                           "<geom type=\"sphere\" pos=\"0.5 0 0\" size=\"0.05\" mass=\"1\"/></body>\n</worldbody>\n"
                           "</mujoco>\n";
  EXPECT_NE(analysis_error(cone).find("eq.xml:5: joint 'socket': the ball joint is turned by 1.5707963"),
            std::string::npos)
      << analysis_error(cone);
  // Inside its range: analyzed, the limit reported.
  const std::string free = arm("<joint name=\"shoulder\" axis=\"0 1 0\" limited=\"true\" range=\"-30 120\"/>", "", no_contact);
  const modal::Analysis a = modal::analyze(modal::model_from_text(free, "eq.xml"));
  ASSERT_EQ(a.equilibrium().limits.size(), 1u);
  EXPECT_NEAR(a.equilibrium().limits[0].value, std::numbers::pi / 2, 1e-12);
  EXPECT_NEAR(a.equilibrium().limits[0].upper, 2 * std::numbers::pi / 3, 1e-15);
  std::ostringstream text;
  modal::write_analysis(text, a);
  EXPECT_NE(text.str().find("shoulder = 1.570796327 in [-0.5235987756, 2.094395102] rad  (90 in [-30, 120] deg)"),
            std::string::npos)
      << text.str();
  const std::string json = modal::analysis_json(a.report);
  EXPECT_NE(json.find("\"limits\""), std::string::npos);
  // The survey keeps an equilibrium at a stop out of its table and says why.
  // Hanging (90°) beyond the range, upright (−90°) inside it:
  const std::string half = arm("<joint name=\"shoulder\" axis=\"0 1 0\" limited=\"true\" range=\"-120 60\"/>", "");
  const modal::EquilibriumSurvey survey = modal::equilibria(modal::model_from_text(half, "eq.xml"));
  ASSERT_EQ(survey.report.equilibria.size(), 1u);
  EXPECT_NEAR(survey.report.equilibria[0].equilibrium.q[0], -std::numbers::pi / 2, 1e-12);
  ASSERT_EQ(survey.unanalyzed.size(), 1u);
  EXPECT_NE(survey.unanalyzed[0].find("eq.xml:4: range: the joint of 'shoulder' is at 1.57"), std::string::npos)
      << survey.unanalyzed[0];
  // Both beyond it: nothing can be analyzed, the refusal is the answer (exit status 2).
  EXPECT_THROW(modal::equilibria(modal::model_from_text(stopped, "eq.xml")), modal::SceneError);
}

// The scene format's `range` key: read, checked, and carried by `modal convert`.
TEST(Import, RangeKeyInTomlScenes) {
  const std::string base = "title = \"r\"\ngravity = [0, 0, -9.81]\n[[body]]\nname = \"p\"\njoint = \"hinge\"\n"
                           "mass = 1\ncom = [0, 0, -1]\n";
  auto error = [](const std::string& toml) -> std::string {
    try {
      modal::model_from_text(toml, "r.toml");
    } catch (const modal::SceneError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_EQ(error(base + "range = [-1, 1]\n"), "no error");
  EXPECT_NE(error(base + "range = [1, -1]\n").find("r.toml:8:"), std::string::npos) << error(base + "range = [1, -1]\n");
  EXPECT_NE(error(base + "range = [1, -1]\n").find("body[1].range: a joint range [lower, upper] needs lower < upper"),
            std::string::npos);
  EXPECT_NE(error(base + "range = [0.5, 1]\n").find("the initial value 0 is not strictly inside"), std::string::npos);
  EXPECT_NE(error(base + "initial = 0.7\nrange = [0.5, 1]\n").find("no error"), std::string::npos);
  EXPECT_NE(error(base + "range = [-1]\n").find("body[1].range"), std::string::npos) << error(base + "range = [-1]\n");
  const std::string ball = "title = \"r\"\n[[body]]\nname = \"p\"\njoint = \"ball\"\nmass = 1\nrange = [-1, 1]\n";
  EXPECT_NE(error(ball).find("'range' is not used by a ball joint"), std::string::npos) << error(ball);
  // modal convert writes the MJCF range (degrees → rad, relative to ref) and the TOML answers the same.
  const std::string xml = "<mujoco>\n<worldbody>\n<body name=\"arm\" pos=\"0 0 1\">\n<joint name=\"shoulder\" "
                          "axis=\"0 1 0\" ref=\"10\" limited=\"true\" range=\"-20 130\"/>\n<geom type=\"sphere\" "
                          "pos=\"0.5 0 0\" size=\"0.05\" mass=\"1\" contype=\"0\" conaffinity=\"0\"/></body>\n"
                          "</worldbody>\n</mujoco>\n";
  const std::string toml = modal::import_scene(xml, "arm.xml", modal::SceneFormat::mjcf);
  const modal::Model converted = modal::model_from_text(toml, "arm.toml");
  const modal::Body& b = converted.system.bodies()[0];
  EXPECT_NEAR(b.lower, -30 * std::numbers::pi / 180, 1e-15);
  EXPECT_NEAR(b.upper, 120 * std::numbers::pi / 180, 1e-15);
  EXPECT_NEAR(modal::analyze(converted).equilibrium().limits[0].value,
              modal::analyze(modal::model_from_text(xml, "arm.xml")).equilibrium().limits[0].value, 1e-15);
}

// A number in full (17 significant digits: the XML holds the test's own values).
std::string exact(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

// Two pendulums on their own pivots (x = 0 and x = 1), each a point-like
// mass m at distance l below its hinge about y, with joint springs, and
// an MJCF joint equality between them.
std::string coupled_pendulums(double m1, double l1, double m2, double l2, double k1, double k2, double ref1,
                              const std::string& equality) {
  auto pendulum = [](const std::string& name, double x, double m, double l, double k, double ref) {
    return "<body name=\"" + name + "\" pos=\"" + exact(x) + " 0 0\">\n<joint name=\"" + name +
           "\" axis=\"0 1 0\" stiffness=\"" + exact(k) + "\" springref=\"" + exact(ref) +
           "\"/>\n<inertial pos=\"0 0 " + exact(-l) + "\" mass=\"" + exact(m) +
           "\" diaginertia=\"1e-3 1e-3 1e-3\"/>\n</body>\n";
  };
  return "<mujoco>\n<option><flag contact=\"disable\"/></option>\n<worldbody>\n" + pendulum("p1", 0, m1, l1, k1, ref1) +
         pendulum("p2", 1, m2, l2, k2, 0) + "</worldbody>\n<equality>\n" + equality + "\n</equality>\n</mujoco>\n";
}

// A joint equality is a coupling constraint q_a = p(q_b): modal's c(q) equals
// MuJoCo's equality residual efc_pos at random configurations; a linear
// gear q1 = r·q2 without springs has the closed form ω² = g(m1 l1 r² +
// m2 l2)/((m1 l1² + I) r² + m2 l2² + I); with springs that load the coupling
// and a quadratic term (the multiplier's curvature term counts), the
// frequency equals a reduction along the constraint computed from MuJoCo
// alone: t = q2, q(t) = (p(t), t), g(t) = f(q(t))·q'(t) with f MuJoCo's rest
// force, the equilibrium g(t*) = 0 by Newton, ω² = g'(t*)/(q'ᵀ M q') with g' a
// central difference (h = 1e-5: about 1e-9 relative, so 1e-7 is asked).
TEST(Import, JointEqualityIsACoupling) {
  std::mt19937_64 rng(16);
  std::uniform_real_distribution<double> u(0, 1);
  const double g = 9.81, I = 1e-3;
  for (int trial = 0; trial < 8; ++trial) {
    const double m1 = 0.5 + u(rng), m2 = 0.5 + u(rng), l1 = 0.3 + u(rng), l2 = 0.3 + u(rng), r = 0.5 + 2 * u(rng);
    const std::string gear = coupled_pendulums(m1, l1, m2, l2, 0, 0, 0,
                                               "<joint name=\"gear\" joint1=\"p1\" joint2=\"p2\" polycoef=\"0 " +
                                                   exact(r) + " 0 0 0\"/>");
    const modal::Model model = modal::model_from_text(gear, "gear.xml");
    ASSERT_EQ(model.system.constraints().size(), 1u);
    EXPECT_EQ(model.system.constraints()[0].type, modal::Constraint::Type::coupling);
    const modal::Analysis a = modal::analyze(model);
    ASSERT_EQ(a.result().modes.size(), 1u);
    const double omega2 = g * (m1 * l1 * r * r + m2 * l2) / ((m1 * l1 * l1 + I) * r * r + m2 * l2 * l2 + I);
    EXPECT_NEAR(a.result().modes[0].omega2, omega2, 1e-12 * omega2) << gear;

    // Loaded and curved: springs with references fight through the coupling.
    const double c0 = 0.2 * (u(rng) - 0.5), c1 = 0.5 + u(rng), c2 = u(rng) - 0.5;
    const std::string curved = coupled_pendulums(
        m1, l1, m2, l2, 5 + 10 * u(rng), 5 + 10 * u(rng), 0.5 * u(rng),
        "<joint name=\"cam\" joint1=\"p1\" joint2=\"p2\" polycoef=\"" + exact(c0) + " " + exact(c1) +
            " " + exact(c2) + " 0 0\"/>");
    const modal::Model cm = modal::model_from_text(curved, "cam.xml");
    const MjModel mj = load_mujoco(curved);
    ASSERT_TRUE(mj);
    // c(q) against MuJoCo's equality residual
    {
      const MjData d(mj_makeData(mj.get()));
      modal::Workspace ws(cm.system);
      for (int k = 0; k < 5; ++k) {
        const modal::VectorX q = random_configuration(cm.system, rng, 1.0);
        for (int i = 0; i < 2; ++i) d->qpos[i] = mj->qpos0[i] + q[i];
        mj_forward(mj.get(), d.get());
        ASSERT_EQ(d->nefc, 1);
        EXPECT_NEAR(modal::constraint_values(cm.system, ws, q)[0], d->efc_pos[0], 1e-13) << curved;
      }
    }
    const modal::Analysis ca = modal::analyze(cm);
    ASSERT_EQ(ca.result().modes.size(), 1u);
    Reference ref(*mj, cm.system);
    const std::array<double, 5> p{c0, c1, c2, 0, 0};
    auto q_of = [&](double t) {
      modal::VectorX q(2);
      q << modal::coupling_polynomial(p, t)[0], t;
      return q;
    };
    auto tangent = [&](double t) {
      modal::VectorX v(2);
      v << modal::coupling_polynomial(p, t)[1], 1.0;
      return v;
    };
    auto slope = [&](double t) { return ref.force(q_of(t)).dot(tangent(t)); };
    const double h = 1e-5;
    double t = ca.equilibrium().q[1];
    for (int it = 0; it < 20; ++it) t -= slope(t) / ((slope(t + h) - slope(t - h)) / (2 * h));
    EXPECT_LT(std::abs(slope(t)), 1e-10);
    const double stiffness = (slope(t + h) - slope(t - h)) / (2 * h);
    const double mass = tangent(t).dot(ref.mass(q_of(t)) * tangent(t));
    EXPECT_NEAR(ca.result().modes[0].omega2, stiffness / mass, 1e-7 * stiffness / mass) << curved;
    EXPECT_NEAR(ca.equilibrium().q[1], t, 1e-9);
  }
  // Without joint2 the joint is held at polycoef[0].
  const std::string held = coupled_pendulums(1, 1, 1, 1, 0, 3, 0,
                                             "<joint name=\"lock\" joint1=\"p1\" polycoef=\"0.3 0 0 0 0\"/>");
  const modal::Analysis h = modal::analyze(modal::model_from_text(held, "held.xml"));
  EXPECT_NEAR(h.equilibrium().q[0], 0.3, 1e-14);
  ASSERT_EQ(h.result().modes.size(), 1u);
  const double w2 = (g * 1 + 3) / (1 + I);  // the free pendulum alone: (m g l + k)/(m l² + I)
  EXPECT_NEAR(h.result().modes[0].omega2, w2, 1e-12 * w2);
}

// The scene format's coupling constraint: its keys and their errors.
TEST(Import, CouplingKeyErrors) {
  const std::string bodies = "title = \"c\"\n[[body]]\nname = \"a\"\njoint = \"hinge\"\nmass = 1\ncom = [0, 0, -1]\n"
                             "[[body]]\nname = \"b\"\njoint = \"hinge\"\norigin = [1, 0, 0]\nmass = 1\ncom = [0, 0, -1]\n"
                             "[[body]]\nname = \"s\"\njoint = \"ball\"\norigin = [2, 0, 0]\nmass = 1\ncom = [0, 0, -1]\n";
  auto error = [&](const std::string& constraint) -> std::string {
    try {
      modal::model_from_text(bodies + "[[constraint]]\ntype = \"coupling\"\n" + constraint, "c.toml");
    } catch (const modal::SceneError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_EQ(error("a = \"a\"\nb = \"b\"\npolynomial = [0, 2]\n"), "no error");
  EXPECT_EQ(error("a = \"a\"\npolynomial = [0.1]\n"), "no error");
  EXPECT_NE(error("a = \"a\"\nb = \"s\"\npolynomial = [0, 1]\n").find("constraint[1].b: 's' has a ball joint"),
            std::string::npos) << error("a = \"a\"\nb = \"s\"\npolynomial = [0, 1]\n");
  EXPECT_NE(error("a = \"a\"\nb = \"b\"\n").find("a coupling needs its polynomial"), std::string::npos);
  EXPECT_NE(error("a = \"a\"\nb = \"b\"\npolynomial = [1, 2, 3, 4, 5, 6]\n").find("1 to 5 numbers"), std::string::npos);
  EXPECT_NE(error("a = \"a\"\npolynomial = [0, 1]\n").find("give one coefficient"), std::string::npos);
  EXPECT_NE(error("a = \"a\"\nb = \"a\"\npolynomial = [0, 1]\n").find("two different joints"), std::string::npos);
  EXPECT_NE(error("a = \"a\"\nb = \"b\"\na_point = [0, 0, 0]\npolynomial = [0, 1]\n").find("'a_point' is not used"),
            std::string::npos);
  EXPECT_NE(error("a = \"world\"\npolynomial = [0]\n").find("must name a body, not the world"), std::string::npos);
}

// --- errors ------------------------------------------------------------------------------

std::string scene_error(const std::string& xml, const std::string& name = "bad.xml") {
  try {
    modal::model_from_text(xml, name);
  } catch (const modal::SceneError& e) {
    return e.what();
  }
  return "no error";
}

const std::string pendulum_body =
    "<body name=\"link\"><joint name=\"pivot\" axis=\"0 1 0\"/>"
    "<geom type=\"capsule\" fromto=\"0 0 0 0 0 -1\" size=\"0.05\" mass=\"1\"/></body>";

TEST(Import, UnsupportedElementsAreRefusedWithNameAndLine) {
  const std::string tendon = "<mujoco>\n<worldbody>\n" + pendulum_body +
                             "\n</worldbody>\n<tendon>\n<fixed name=\"spring\" stiffness=\"3\">"
                             "<joint joint=\"pivot\" coef=\"1\"/></fixed>\n</tendon>\n</mujoco>";
  EXPECT_NE(scene_error(tendon).find("bad.xml:6: tendon 'spring': "), std::string::npos) << scene_error(tendon);
  const std::string servo = "<mujoco>\n<worldbody>\n" + pendulum_body +
                            "\n</worldbody>\n<actuator>\n<position name=\"servo\" joint=\"pivot\" kp=\"10\"/>\n"
                            "</actuator>\n</mujoco>";
  EXPECT_NE(scene_error(servo).find("bad.xml:6: actuator 'servo': "), std::string::npos) << scene_error(servo);
  const std::string motor = "<mujoco>\n<worldbody>\n" + pendulum_body +
                            "\n</worldbody>\n<actuator><motor joint=\"pivot\"/></actuator>\n</mujoco>";
  EXPECT_EQ(scene_error(motor), "no error");  // a motor does nothing at zero control
  const std::string limit = "<mujoco>\n<worldbody>\n<body name=\"link\">\n<joint name=\"pivot\" axis=\"0 1 0\" "
                            "limited=\"true\" range=\"0 1\"/><geom size=\"0.1\" mass=\"1\" pos=\"0 0 -1\"/></body>\n"
                            "</worldbody>\n</mujoco>";
  EXPECT_NE(scene_error(limit).find("bad.xml:4: joint 'pivot': its limit is active"), std::string::npos)
      << scene_error(limit);
  // Inside its range but not inside it narrowed by the margin: the message
  // quotes the narrowed range that refuses it.
  const std::string margin = "<mujoco>\n<compiler angle=\"radian\"/><worldbody>\n<body name=\"link\">\n<joint "
                             "name=\"pivot\" axis=\"0 1 0\" limited=\"true\" range=\"-0.5 1\" margin=\"0.625\"/>"
                             "<geom size=\"0.1\" mass=\"1\" pos=\"0 0 -1\"/></body>\n</worldbody>\n</mujoco>";
  EXPECT_NE(scene_error(margin).find("narrowed by its margin 0.625 to [0.125, 0.375]"), std::string::npos)
      << scene_error(margin);
  const std::string equality = "<mujoco>\n<worldbody>\n" + pendulum_body +
                               "\n</worldbody>\n<equality>\n<weld name=\"loop\" body1=\"link\"/>"
                               "\n</equality>\n</mujoco>";
  EXPECT_NE(scene_error(equality).find("bad.xml:6: equality 'loop': a weld equality"), std::string::npos)
      << scene_error(equality);
  const std::string contact = "<mujoco>\n<worldbody>\n<geom name=\"floor\" type=\"plane\" size=\"5 5 1\"/>\n"
                              "<body name=\"box\" pos=\"0 0 0.05\"><joint name=\"drop\" type=\"slide\" axis=\"0 0 1\"/>"
                              "<geom name=\"cube\" type=\"box\" size=\"0.1 0.1 0.1\" mass=\"1\"/></body>\n"
                              "</worldbody>\n</mujoco>";
  EXPECT_NE(scene_error(contact).find("bad.xml:3: geom 'floor': is in contact with geom 'cube'"), std::string::npos)
      << scene_error(contact);
  const std::string friction = "<mujoco>\n<worldbody>\n<body name=\"link\">\n<joint name=\"pivot\" "
                               "frictionloss=\"0.1\"/><geom size=\"0.1\" mass=\"1\" pos=\"0 0 -1\"/></body>\n"
                               "</worldbody>\n</mujoco>";
  EXPECT_NE(scene_error(friction).find("bad.xml:4: joint 'pivot': dry friction"), std::string::npos)
      << scene_error(friction);
}

// A name MuJoCo accepts but a scene refuses (a control character, written as
// an XML character reference): the error names the file the user gave and no
// line of the converted text (line 8 there would be the XML's closing tag).
TEST(Import, ErrorsInTheConvertedSceneNameTheFileNotTheConversionsLines) {
  const std::string xml = "<mujoco>\n<worldbody>\n<body name=\"arm\" pos=\"0 0 1\">\n<joint name=\"sh&#27;[31m\" "
                          "axis=\"0 1 0\"/>\n<geom type=\"sphere\" pos=\"0.5 0 0\" size=\"0.05\" mass=\"1\"/>\n"
                          "</body>\n</worldbody>\n</mujoco>\n";
  const std::string message = scene_error(xml, "esc.xml");
  EXPECT_EQ(message.rfind("esc.xml: body[1].name: ", 0), 0u) << message;
  EXPECT_NE(message.find("sh\\x1B[31m"), std::string::npos) << message;
}

// Models written for display (ROS's urdf_tutorial: links without <inertial>,
// or joined by fixed joints only) are refused with what is missing and where.
TEST(Import, DisplayOnlyModelsAreRefusedWithWhatIsMissing) {
  const std::string urdf =
      "<robot name=\"r\">\n<link name=\"base\"/>\n<link name=\"wheel\">\n<visual><geometry><cylinder length=\"0.1\" "
      "radius=\"0.03\"/></geometry></visual>\n</link>\n<joint name=\"axle\" type=\"continuous\">\n<parent "
      "link=\"base\"/><child link=\"wheel\"/><axis xyz=\"0 1 0\"/>\n</joint>\n</robot>\n";
  const std::string massless = scene_error(urdf, "display.urdf");
  EXPECT_EQ(massless.rfind("display.urdf:3: ", 0), 0u) << massless;  // the link's line
  EXPECT_NE(massless.find("link 'wheel' moves, but has no <inertial>"), std::string::npos) << massless;
  const std::string body = scene_error(
      "<mujoco><worldbody>\n<body name=\"arm\"><joint axis=\"0 1 0\"/><geom size=\"0.1\" mass=\"0\"/></body>\n"
      "</worldbody></mujoco>");
  EXPECT_NE(body.find("body 'arm' moves, but its mass or a principal moment of inertia is below"), std::string::npos)
      << body;
  // A point mass: an <inertial> with mass but no inertia. The message must not
  // say it has no mass or no <inertial>.
  const std::string point = scene_error(
      "<mujoco><worldbody>\n<body name=\"p\"><joint axis=\"0 1 0\"/><inertial pos=\"0 0 -1\" mass=\"2\" "
      "diaginertia=\"0 0 0\"/></body>\n</worldbody></mujoco>");
  EXPECT_NE(point.find("a point mass a small diaginertia"), std::string::npos) << point;
  EXPECT_EQ(point.find("has no mass"), std::string::npos) << point;
  const std::string fixed =
      scene_error("<robot name=\"r\">\n<link name=\"a\"><inertial><mass value=\"1\"/><inertia ixx=\"1\" iyy=\"1\" "
                  "izz=\"1\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n<link name=\"b\"><inertial><mass "
                  "value=\"1\"/><inertia ixx=\"1\" iyy=\"1\" izz=\"1\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial>"
                  "</link>\n<joint name=\"j\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint>\n</robot>\n",
                  "fixed.urdf");
  EXPECT_NE(fixed.find("links joined by fixed joints are merged into one"), std::string::npos) << fixed;
  const std::string mesh = scene_error(
      "<robot name=\"r\">\n<link name=\"base\"/>\n<link name=\"arm\"><inertial><mass value=\"1\"/><inertia "
      "ixx=\"1\" iyy=\"1\" izz=\"1\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial><collision><geometry><mesh "
      "filename=\"arm.dae\"/></geometry></collision></link>\n<joint name=\"j\" type=\"revolute\"><parent "
      "link=\"base\"/><child link=\"arm\"/><axis xyz=\"0 1 0\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" "
      "velocity=\"1\"/></joint>\n</robot>\n",
      "mesh.urdf");
  EXPECT_NE(mesh.find("MuJoCo reads STL, OBJ and MSH meshes"), std::string::npos) << mesh;
}

TEST(Import, MalformedFilesGiveMuJoCosMessageWithTheFile) {
  const std::string broken = scene_error("<mujoco>\n<worldbody>\n<body name=\"a\">\n</worldbody>\n</mujoco>");
  EXPECT_EQ(broken.rfind("bad.xml:", 0), 0u) << broken;
  EXPECT_NE(broken.find("MuJoCo could not load the model"), std::string::npos) << broken;
  const std::string unknown = scene_error("<mujoco><worldbody><bogus/></worldbody></mujoco>");
  EXPECT_NE(unknown.find("MuJoCo could not load the model"), std::string::npos) << unknown;
  // An element or attribute of a later MuJoCo (here made up): the message names the version that read it.
  EXPECT_NE(unknown.find("this is libmujoco " + modal::mujoco_version() + ", which does not know it"), std::string::npos)
      << unknown;
  const std::string attribute = scene_error(
      "<mujoco><worldbody><body><joint type=\"hinge\" laterattribute=\"1\"/><geom size=\"0.1\"/></body></worldbody>"
      "</mujoco>");
  EXPECT_NE(attribute.find("unrecognized attribute: 'laterattribute'"), std::string::npos) << attribute;
  EXPECT_NE(attribute.find("which does not know it"), std::string::npos) << attribute;
  const std::string wrong_root = scene_error("<robot name=\"r\"/>", "robot.xml");
  EXPECT_NE(wrong_root.find("robot.xml:1: not an MJCF file: its root element is <robot>"), std::string::npos)
      << wrong_root;
  EXPECT_NE(scene_error("", "empty.urdf").find("empty.urdf:1: not a URDF file"), std::string::npos);
  EXPECT_NE(scene_error("<mujoco/>", "empty.xml").find("empty.xml: the model has no body besides the world"),
            std::string::npos);
}

// The scene format's `orientation` and `armature`: a body turned by 90° about z
// with its hinge about its own x axis is the unturned body on a hinge about y
// with its geometry turned; armature adds to M's diagonal.
TEST(Import, OrientationAndArmatureInTomlScenes) {
  const double h = std::sqrt(0.5);
  const std::string turned = "gravity = [0, 0, -9.81]\n[[body]]\nname = \"a\"\njoint = \"hinge\"\naxis = [1, 0, 0]\n"
                             "orientation = [" + std::to_string(h) + ", 0, 0, " + std::to_string(h) + "]\n"
                             "mass = 2\ncom = [0.3, 0, -1]\ninertia = [0.1, 0.2, 0.25, 0, 0, 0]\narmature = 0.5\n";
  const std::string plain = "gravity = [0, 0, -9.81]\n[[body]]\nname = \"a\"\njoint = \"hinge\"\naxis = [0, 1, 0]\n"
                            "mass = 2\ncom = [0, 0.3, -1]\ninertia = [0.2, 0.1, 0.25, 0, 0, 0]\n";
  const modal::Model a = modal::model_from_text(turned, "turned.toml");
  const modal::Model b = modal::model_from_text(plain, "plain.toml");
  modal::Workspace wa(a.system), wb(b.system);
  const modal::VectorX q = modal::VectorX::Constant(1, 0.3);
  EXPECT_NEAR(modal::mass_matrix(a.system, wa, q)(0, 0), modal::mass_matrix(b.system, wb, q)(0, 0) + 0.5, 1e-6);
  EXPECT_NEAR(modal::potential_hessian(a.system, wa, q)(0, 0), modal::potential_hessian(b.system, wb, q)(0, 0), 1e-6);
  const auto bad = [](const std::string& text) {
    try {
      modal::model_from_text(text, "bad.toml");
    } catch (const modal::SceneError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(bad("[[body]]\nname = \"a\"\njoint = \"hinge\"\nmass = 1\norientation = [0, 0, 0, 0]\n")
                .find("body[1].orientation: a quaternion"),
            std::string::npos);
  EXPECT_NE(bad("[[body]]\nname = \"a\"\njoint = \"fixed\"\nmass = 1\narmature = 1\n")
                .find("'armature' is not used by a fixed joint"),
            std::string::npos);
}

TEST(Import, FormatDetection) {
  using modal::SceneFormat;
  EXPECT_EQ(modal::scene_format("a.xml", ""), SceneFormat::mjcf);
  EXPECT_EQ(modal::scene_format("a.URDF", ""), SceneFormat::urdf);
  EXPECT_EQ(modal::scene_format("a.toml", "<mujoco/>"), SceneFormat::toml);
  EXPECT_EQ(modal::scene_format("scene", "<?xml version=\"1.0\"?>\n<!-- c -->\n<mujoco model=\"m\"/>"), SceneFormat::mjcf);
  EXPECT_EQ(modal::scene_format("scene", "  <robot name=\"r\">"), SceneFormat::urdf);
  EXPECT_EQ(modal::scene_format("scene", "title = \"x\""), SceneFormat::toml);
  EXPECT_EQ(modal::scene_format("a.xml", "", SceneFormat::urdf), SceneFormat::urdf);
}

// The command line: analyze and convert an MJCF file, the documented error and exit status.
TEST(ImportCli, AnalyzeConvertAndErrors) {
  const std::string model = std::string(MODAL_SOURCE_DIR) + "/models/double_pendulum.xml";
  const std::string dir = testing::TempDir() + "/modal_import_cli_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  auto run_modal = [&dir](const std::vector<std::string>& args) { return modal::test::run_modal(args, dir); };
  const auto analyzed = run_modal({"analyze", model});
  EXPECT_EQ(analyzed.status, 0) << analyzed.err;
  EXPECT_NE(analyzed.out.find("shoulder"), std::string::npos);
  const auto converted = run_modal({"convert", model});
  EXPECT_EQ(converted.status, 0) << converted.err;
  EXPECT_NE(converted.out.find("name = \"elbow\""), std::string::npos);
  const std::string bad = dir + "/bad.xml";
  std::ofstream(bad) << "<mujoco><worldbody><body></worldbody></mujoco>";
  const auto failed = run_modal({"check", bad});
  EXPECT_EQ(failed.status, 2);
  EXPECT_NE(failed.err.find(bad), std::string::npos) << failed.err;
  const std::string toml = dir + "/converted.toml";
  EXPECT_EQ(run_modal({"convert", model, "-o", toml}).status, 0);
  const auto again = run_modal({"analyze", toml});
  EXPECT_EQ(again.status, 0) << again.err;
  // The scene file as TOML although it is named .xml: --format decides.
  const auto forced = run_modal({"check", toml, "--format", "mjcf"});
  EXPECT_EQ(forced.status, 2);
  EXPECT_NE(forced.err.find("not an MJCF file"), std::string::npos) << forced.err;
  // MJCF files have no parameters to sweep: the message says how to get some.
  const auto swept = run_modal({"sweep", model, "--vary", "g=1:2:3"});
  EXPECT_EQ(swept.status, 2);
  EXPECT_NE(swept.err.find("modal convert"), std::string::npos) << swept.err;
  std::filesystem::remove_all(dir);
}

}  // namespace
