// Pinocchio's side of the side-by-side benchmark (`bench/pinocchio-side-by-side.sh`).
//
//   side_by_side URDF STATES RESULTS
//
// Loads the URDF that `hapticgen export-urdf` wrote for the model, reads the states (and the
// gravity, rotor inertias and task frame) that the Rust side wrote into STATES, writes
// Pinocchio's D, C·q̇ + g, g, p, J and J̇·q̇ at every state into RESULTS (for the Rust side's
// agreement check), then prints one line `KEY NS` per timed quantity: nanoseconds per call,
// the best of BATCHES batches of CALLS calls cycling over the states.
//
// A closed chain (the STATES file names its tree and closures: `tree`, `closure` lines) comes
// as its open tree (`hapticgen_codegen::urdf::export_open_tree`: every joint, the passive ones
// included, the loops cut). At each state, given the actuated q_a and q̇_a, the program closes
// the loops itself (class LoopClosure below): Newton's method on the closure constraints
// Φ(q) = 0 over the passive coordinates (closure points' frame placements and frame Jacobians),
// warm-started from the previous state's solution moved along its A, as the generated code
// does; then A = −Φ_p⁻¹Φ_a, S = [I; A] (rows in Pinocchio's order), q̇ = S q̇_a, and the bias
// Ṡq̇_a = [0; −Φ_p⁻¹ γ] with γ = Φ̈ at q̈ = 0 (the closure points' classical accelerations,
// and for a perpendicularity the axes' angular velocities and accelerations). The tree's
// quantities are projected: D_a = SᵀDS, C_a q̇_a + g_a = Sᵀ rnea(q, q̇, Ṡq̇_a) (that is
// Sᵀ(C q̇ + D Ṡq̇_a + g)), g_a = Sᵀg, J_a = J S, J̇_a q̇_a = J̇ q̇ + J Ṡq̇_a. Every timed call
// closes the loops at its state, as every generated function does at a new state.
//
// The build decides where the algorithms' code comes from (see the script): with
// PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION (as Pinocchio's CMake package config prescribes) the
// algorithms (crba, nonLinearEffects, computeGeneralizedGravity, forwardKinematics,
// computeFrameJacobian, getFrameJacobian, computeAllTerms) are the wheel's precompiled ones in
// libpinocchio_default.so, and only small accessors are inlined here; without it, everything is
// instantiated from the headers in this translation unit with this compiler's flags.
//
// Pinocchio's crba fills the upper triangle of D only; the lower triangle is copied outside
// the timed region (hapticgen returns the full matrix: this favours Pinocchio slightly).

#include <pinocchio/parsers/urdf.hpp>

#include <pinocchio/algorithm/compute-all-terms.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/algorithm/rnea.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

namespace {

// The same timing parameters as the Rust side (tests/examples/pinocchio_side_by_side.rs).
constexpr int CALLS = 2000;
constexpr int BATCHES = 25;

using Vec = Eigen::VectorXd;

// A loop closure of a closed chain, as `pinocchio_side_by_side states` writes it: two links
// (frames) whose origins coincide, and optionally two axes (each fixed in a link) kept square.
struct ClosureSpec {
  std::string name;
  std::string point[2];
  bool perpendicular = false;
  std::string axis_link[2];
  Eigen::Vector3d axis[2];
};

struct States {
  int n = 0;
  std::string frame;
  std::vector<std::string> joints;
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();
  Vec armature;
  std::vector<Vec> q, v;
  // Closed chains only: the tree's coordinates (actuated first, as `joints`, then passive),
  // the assembly Newton starts from (tree coordinates), the solver's bounds, the closures.
  std::vector<std::string> tree;
  Vec assembly;
  double loop_tolerance = 0;
  int loop_max_steps = 0;
  double warm_start_radius = 0;
  std::vector<ClosureSpec> closures;
  bool closed() const { return !tree.empty(); }
};

[[noreturn]] void fail(const std::string& why) {
  std::cerr << "side_by_side: " << why << std::endl;
  std::exit(1);
}

// The format written by `pinocchio_side_by_side states`: keyword lines, then one line per state.
States read_states(const std::string& path) {
  std::ifstream in(path);
  if (!in) fail("cannot read " + path);
  States s;
  std::string line;
  int count = -1;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream words(line);
    std::string key;
    words >> key;
    if (key == "dof") {
      words >> s.n;
    } else if (key == "frame") {
      words >> s.frame;
    } else if (key == "joints") {
      std::string j;
      while (words >> j) s.joints.push_back(j);
    } else if (key == "gravity") {
      words >> s.gravity[0] >> s.gravity[1] >> s.gravity[2];
    } else if (key == "armature") {
      s.armature.resize(s.n);
      for (int i = 0; i < s.n; ++i) words >> s.armature[i];
    } else if (key == "tree") {
      std::string j;
      while (words >> j) s.tree.push_back(j);
    } else if (key == "assembly") {
      s.assembly.resize(static_cast<Eigen::Index>(s.tree.size()));
      for (Eigen::Index i = 0; i < s.assembly.size(); ++i) words >> s.assembly[i];
    } else if (key == "loop_solver") {
      words >> s.loop_tolerance >> s.loop_max_steps >> s.warm_start_radius;
    } else if (key == "closure") {
      ClosureSpec c;
      words >> c.name >> c.point[0] >> c.point[1];
      std::string perpendicular;
      if (words >> perpendicular) {
        if (perpendicular != "perpendicular") fail("bad closure line in " + path + ": " + line);
        c.perpendicular = true;
        for (int k = 0; k < 2; ++k) words >> c.axis_link[k] >> c.axis[k][0] >> c.axis[k][1] >> c.axis[k][2];
      } else {
        words.clear(std::ios::eofbit);
      }
      s.closures.push_back(c);
    } else if (key == "states") {
      words >> count;
      break;
    } else {
      fail("unknown line in " + path + ": " + line);
    }
    if (!words && !words.eof()) fail("bad line in " + path + ": " + line);
  }
  if (s.n <= 0 || count <= 0 || s.frame.empty() || (int)s.joints.size() != s.n || s.armature.size() != s.n)
    fail("incomplete header in " + path);
  if (s.closed() && (s.closures.empty() || s.assembly.size() != (Eigen::Index)s.tree.size() ||
                     s.loop_tolerance <= 0 || s.loop_max_steps <= 0 || s.warm_start_radius <= 0 ||
                     (int)s.tree.size() <= s.n))
    fail("incomplete closed-chain header in " + path);
  for (int k = 0; k < count; ++k) {
    Vec q(s.n), v(s.n);
    for (int i = 0; i < s.n; ++i) in >> q[i];
    for (int i = 0; i < s.n; ++i) in >> v[i];
    if (!in) fail("truncated states in " + path);
    s.q.push_back(q);
    s.v.push_back(v);
  }
  return s;
}

// Nanoseconds per call, best batch.
template <class F>
double nanoseconds(std::size_t states, F&& call) {
  double best = std::numeric_limits<double>::infinity();
  for (int b = 0; b < BATCHES; ++b) {
    const auto start = std::chrono::steady_clock::now();
    for (int k = 0; k < CALLS; ++k) call(static_cast<std::size_t>(k) % states);
    const auto stop = std::chrono::steady_clock::now();
    best = std::min(best, std::chrono::duration<double, std::nano>(stop - start).count() / CALLS);
  }
  return best;
}

// crba's explicit instantiation in the wheel's library is declared for an Eigen::Ref argument
// (the public wrappers of the other algorithms convert their arguments to Ref themselves).
const Eigen::MatrixXd& crba(const pinocchio::Model& model, pinocchio::Data& data, const Vec& q) {
  return pinocchio::crba(model, data, Eigen::Ref<const Vec>(q));
}

void write_numbers(std::ostream& out, const Eigen::Ref<const Eigen::MatrixXd>& m) {
  // Row-major, shortest round-trip precision.
  char buffer[40];
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) {
      std::snprintf(buffer, sizeof buffer, " %.17g", m(r, c));
      out << buffer;
    }
}

// ---- Closed chains ------------------------------------------------------------------------

// The loops of a closed chain closed at one state, on Pinocchio's open tree (see the top of the
// file), for N actuated and P passive coordinates (fixed sizes where the dispatch in
// closed_chain_main knows them, so that the glue around Pinocchio's calls allocates nothing).
template <int N, int P>
class LoopClosure {
 public:
  using VecN = Eigen::Matrix<double, N, 1>;
  using VecP = Eigen::Matrix<double, P, 1>;
  using MatPN = Eigen::Matrix<double, P, N>;
  using MatPP = Eigen::Matrix<double, P, P>;
  using MatNN = Eigen::Matrix<double, N, N>;
  using Mat3N = Eigen::Matrix<double, 3, N>;
  using Selection = Eigen::Matrix<double, Eigen::Dynamic, N>;
  using Matrix6x = pinocchio::Data::Matrix6x;

  LoopClosure(const pinocchio::Model& model, pinocchio::Data& data, const States& s, pinocchio::FrameIndex task)
      : model_(model), data_(data), n_((int)s.n), p_((int)s.tree.size() - s.n), task_(task) {
    auto index = [&](const std::string& joint) {
      if (!model.existJointName(joint)) fail("the URDF has no joint " + joint);
      const auto id = model.getJointId(joint);
      if (model.joints[id].nq() != 1 || model.joints[id].nv() != 1) fail("joint " + joint + " is not 1-dof");
      return model.joints[id].idx_v();
    };
    for (int i = 0; i < n_; ++i) actuated_.push_back(index(s.tree[i]));
    for (int i = 0; i < p_; ++i) passive_.push_back(index(s.tree[n_ + i]));
    if (model.nq != (int)s.tree.size() || model.nv != model.nq) fail("the URDF's nq/nv differ from the tree's coordinates");
    auto frame = [&](const std::string& link) {
      if (!model.existBodyName(link)) fail("the URDF has no link " + link);
      return model.getBodyId(link);
    };
    int equations = 0;
    for (const ClosureSpec& c : s.closures) {
      Closure k;
      for (int j = 0; j < 2; ++j) k.point[j] = frame(c.point[j]);
      k.perpendicular = c.perpendicular;
      if (c.perpendicular)
        for (int j = 0; j < 2; ++j) {
          k.axis_frame[j] = frame(c.axis_link[j]);
          k.axis[j] = c.axis[j];
        }
      equations += 3 + (c.perpendicular ? 1 : 0);
      closures_.push_back(k);
    }
    if (equations != p_) fail("the closures give " + std::to_string(equations) + " equations for " + std::to_string(p_) + " passive joints");
    // A frame Jacobian only writes its supporting joints' columns: zeroed once, the others stay 0.
    for (std::size_t k = 0; k < 4 * closures_.size() + 1; ++k) jacobians_.push_back(Matrix6x::Zero(6, model.nv));
    q = Vec::Zero(model.nq);
    v = Vec::Zero(model.nv);
    zero_ = Vec::Zero(model.nv);
    bias = Vec::Zero(model.nv);
    selection = Selection::Zero(model.nv, n_);
    for (int i = 0; i < n_; ++i) selection(actuated_[i], i) = 1;
    phi_q_ = Eigen::Matrix<double, P, Eigen::Dynamic>::Zero(p_, model.nv);
    assembly_actuated_ = s.assembly.head(n_);
    assembly_passive_ = s.assembly.tail(p_);
    tolerance_ = s.loop_tolerance;
    max_steps_ = s.loop_max_steps;
    radius_ = s.warm_start_radius;
  }

  // Closes the loops at q_a: q (and data's placements at q); with `sensitivity`, also A, the
  // selection S = [I; A] and data.J at q. Newton from the last solution (moved along its A
  // where that was computed) when no actuated coordinate moved more than the warm-start
  // radius, else continued from the assembly. Stops the program where the loops do not close.
  void close(const VecN& qa, bool sensitivity) {
    VecP passive;
    if (has_last_ && (qa - last_actuated_).cwiseAbs().maxCoeff() <= radius_) {
      passive = last_passive_;
      if (last_has_sensitivity_) passive.noalias() += sensitivity_ * (qa - last_actuated_);
    } else {
      // From the assembly along the straight line in the actuated coordinates (its branch).
      passive = assembly_passive_;
      constexpr int steps = 8;
      for (int k = 1; k <= steps; ++k) {
        const VecN along = assembly_actuated_ + (double(k) / steps) * (qa - assembly_actuated_);
        if (!newton(along, passive, false)) fail("the loops do not close on the way from the assembly");
      }
    }
    if (!newton(qa, passive, sensitivity)) fail("the loops do not close (Newton's method did not converge)");
    ++solves;
  }

  // After close(q_a, true): q̇ = S q̇_a into `v`, the bias Ṡq̇_a into `bias`. The tree's
  // velocities and accelerations at q̈ = 0 come from forwardKinematics(q, q̇, 0), or with
  // `all_terms` from computeAllTerms(q, q̇) (which also leaves D, C q̇ + g, g and data.J).
  void close_rates(const VecN& qda, bool all_terms) {
    for (int i = 0; i < n_; ++i) v[actuated_[i]] = qda[i];
    const VecP passive_rate = sensitivity_ * qda;
    for (int i = 0; i < p_; ++i) v[passive_[i]] = passive_rate[i];
    if (all_terms)
      pinocchio::computeAllTerms(model_, data_, q, v);
    else
      pinocchio::forwardKinematics(model_, data_, q, v, zero_);
    // γ = Φ̈ at q̈ = 0.
    VecP gamma(p_);
    const auto lwa = pinocchio::LOCAL_WORLD_ALIGNED;
    int r = 0;
    for (const Closure& c : closures_) {
      gamma.template segment<3>(r) = pinocchio::getFrameClassicalAcceleration(model_, data_, c.point[0], lwa).linear() -
                                     pinocchio::getFrameClassicalAcceleration(model_, data_, c.point[1], lwa).linear();
      r += 3;
      if (c.perpendicular) {
        Eigen::Vector3d u[2], du[2], ddu[2];
        for (int j = 0; j < 2; ++j) {
          const Eigen::Vector3d w = pinocchio::getFrameVelocity(model_, data_, c.axis_frame[j], lwa).angular();
          const Eigen::Vector3d alpha = pinocchio::getFrameAcceleration(model_, data_, c.axis_frame[j], lwa).angular();
          u[j] = data_.oMf[c.axis_frame[j]].rotation() * c.axis[j];
          du[j] = w.cross(u[j]);
          ddu[j] = alpha.cross(u[j]) + w.cross(du[j]);
        }
        gamma[r] = ddu[0].dot(u[1]) + 2 * du[0].dot(du[1]) + u[0].dot(ddu[1]);
        r += 1;
      }
    }
    const VecP passive_bias = -(lu_.solve(gamma));
    for (int i = 0; i < p_; ++i) bias[passive_[i]] = passive_bias[i];
  }

  // D_a = Sᵀ D S from data.M (crba's or computeAllTerms' upper triangle).
  MatNN inertia() {
    data_.M.template triangularView<Eigen::StrictlyLower>() = data_.M.transpose().template triangularView<Eigen::StrictlyLower>();
    md_ = data_.M.lazyProduct(selection);
    return selection.transpose().lazyProduct(md_);
  }
  // Sᵀ x for a tree vector x.
  VecN project(const Vec& x) const { return selection.transpose().lazyProduct(x); }
  // The task point's position (data's placements at q).
  Eigen::Vector3d position() { return pinocchio::updateFramePlacement(model_, data_, task_).translation(); }
  // J_a = J S (data.J at q).
  Mat3N jacobian() {
    Matrix6x& j = jacobians_.back();
    pinocchio::getFrameJacobian(model_, data_, task_, pinocchio::LOCAL_WORLD_ALIGNED, j);
    return j.topRows<3>().lazyProduct(selection);
  }
  // J̇_a q̇_a = J̇ q̇ + J Ṡq̇_a (after close_rates, with data.J at q).
  Eigen::Vector3d jacobian_dot_times_qdot() {
    Matrix6x& j = jacobians_.back();
    pinocchio::getFrameJacobian(model_, data_, task_, pinocchio::LOCAL_WORLD_ALIGNED, j);
    return pinocchio::getFrameClassicalAcceleration(model_, data_, task_, pinocchio::LOCAL_WORLD_ALIGNED).linear() +
           j.topRows<3>().lazyProduct(bias);
  }

  Vec q, v, bias;       // the tree's configuration, velocity and Ṡq̇_a (Pinocchio's order)
  long solves = 0, newton_steps = 0;  // calls of close, Newton steps of their last solves
  Selection selection;  // S: the tree's velocity per actuated velocity

 private:
  struct Closure {
    pinocchio::FrameIndex point[2];
    bool perpendicular = false;
    pinocchio::FrameIndex axis_frame[2] = {0, 0};
    Eigen::Vector3d axis[2];
  };

  // Newton's method from `passive`, updated in place; with `sensitivity`, A and S at the
  // solution. False where it does not converge within the bound.
  bool newton(const VecN& qa, VecP& passive, bool sensitivity) {
    for (int i = 0; i < n_; ++i) q[actuated_[i]] = qa[i];
    VecP phi(p_);
    for (int step = 0;; ++step) {
      for (int i = 0; i < p_; ++i) q[passive_[i]] = passive[i];
      pinocchio::forwardKinematics(model_, data_, q);
      residual(phi);
      if (!phi.allFinite()) return false;
      const bool converged = phi.cwiseAbs().maxCoeff() <= tolerance_;
      if (converged && !sensitivity) break;
      if (!converged && step >= max_steps_) return false;
      pinocchio::computeJointJacobians(model_, data_);  // at the placements above
      constraint_jacobian();
      if (converged) break;
      passive.noalias() -= lu_.solve(phi);
      ++newton_steps;
    }
    last_actuated_ = qa;
    last_passive_ = passive;
    has_last_ = true;
    last_has_sensitivity_ = sensitivity;
    if (sensitivity) {
      sensitivity_ = -(lu_.solve(phi_a_));
      for (int i = 0; i < p_; ++i) selection.row(passive_[i]) = sensitivity_.row(i);
    }
    return true;
  }

  // Φ at data's joint placements (updating the closure frames' placements).
  void residual(VecP& phi) {
    int r = 0;
    for (const Closure& c : closures_) {
      phi.template segment<3>(r) = pinocchio::updateFramePlacement(model_, data_, c.point[0]).translation() -
                                   pinocchio::updateFramePlacement(model_, data_, c.point[1]).translation();
      r += 3;
      if (c.perpendicular) {
        const Eigen::Vector3d u0 = pinocchio::updateFramePlacement(model_, data_, c.axis_frame[0]).rotation() * c.axis[0];
        const Eigen::Vector3d u1 = pinocchio::updateFramePlacement(model_, data_, c.axis_frame[1]).rotation() * c.axis[1];
        phi[r] = u0.dot(u1);
        r += 1;
      }
    }
  }

  // Φ_q from data.J (after residual at the same placements), its columns split into Φ_p
  // (factorised) and Φ_a.
  void constraint_jacobian() {
    const auto lwa = pinocchio::LOCAL_WORLD_ALIGNED;
    int r = 0;
    std::size_t k = 0;
    for (const Closure& c : closures_) {
      Matrix6x& a = jacobians_[k++];
      Matrix6x& b = jacobians_[k++];
      pinocchio::getFrameJacobian(model_, data_, c.point[0], lwa, a);
      pinocchio::getFrameJacobian(model_, data_, c.point[1], lwa, b);
      phi_q_.template middleRows<3>(r) = a.topRows<3>() - b.topRows<3>();
      r += 3;
      if (c.perpendicular) {
        Matrix6x& x = jacobians_[k++];
        Matrix6x& y = jacobians_[k++];
        pinocchio::getFrameJacobian(model_, data_, c.axis_frame[0], lwa, x);
        pinocchio::getFrameJacobian(model_, data_, c.axis_frame[1], lwa, y);
        const Eigen::Vector3d u0 = data_.oMf[c.axis_frame[0]].rotation() * c.axis[0];
        const Eigen::Vector3d u1 = data_.oMf[c.axis_frame[1]].rotation() * c.axis[1];
        // d(u0·u1) = (u0 × u1)ᵀ (J_ω0 − J_ω1) dq.
        phi_q_.row(r) = u0.cross(u1).transpose() * (x.bottomRows<3>() - y.bottomRows<3>());
        r += 1;
      } else {
        k += 2;
      }
    }
    MatPP phi_p(p_, p_);
    for (int i = 0; i < p_; ++i) phi_p.col(i) = phi_q_.col(passive_[i]);
    for (int i = 0; i < n_; ++i) phi_a_.col(i) = phi_q_.col(actuated_[i]);
    lu_.compute(phi_p);
  }

  const pinocchio::Model& model_;
  pinocchio::Data& data_;
  int n_, p_;
  pinocchio::FrameIndex task_;
  std::vector<Eigen::Index> actuated_, passive_;
  std::vector<Closure> closures_;
  std::vector<Matrix6x> jacobians_;  // per closure: two points, two axes; last: the task point
  Vec zero_;
  Eigen::Matrix<double, P, Eigen::Dynamic> phi_q_;
  MatPN phi_a_ = MatPN::Zero(p_, n_);
  MatPN sensitivity_ = MatPN::Zero(p_, n_);
  Eigen::PartialPivLU<MatPP> lu_{p_};
  Eigen::Matrix<double, Eigen::Dynamic, N> md_;
  VecN assembly_actuated_, last_actuated_;
  VecP assembly_passive_, last_passive_;
  bool has_last_ = false, last_has_sensitivity_ = false;
  double tolerance_ = 0, radius_ = 0;
  int max_steps_ = 0;
};

template <int N, int P>
int run_closed_chain(const pinocchio::Model& model, const States& s, const std::string& results) {
  using Closed = LoopClosure<N, P>;
  if (!model.existFrame(s.frame)) fail("the URDF has no frame " + s.frame);
  const pinocchio::FrameIndex frame = model.getFrameId(s.frame);
  pinocchio::Data data(model);
  Closed loops(model, data, s, frame);
  using VecN = typename Closed::VecN;
  using MatNN = typename Closed::MatNN;
  using Mat3N = typename Closed::Mat3N;
  const std::size_t S = s.q.size();
  std::vector<VecN> qa(S), qda(S);
  for (std::size_t k = 0; k < S; ++k) {
    qa[k] = s.q[k];
    qda[k] = s.v[k];
  }

  {
    std::ofstream out(results);
    if (!out) fail("cannot write " + results);
    out << "# tag state | D_a (row-major) | C_a*qd_a + g_a | g_a | p | J_a (3 rows) | Jdot_a*qd_a (closed chain)\n";
    MatNN D;
    VecN nle, g;
    Eigen::Vector3d p, a;
    Mat3N J;
    auto line = [&](const char* tag, std::size_t k) {
      out << tag << ' ' << k;
      write_numbers(out, D);
      write_numbers(out, nle.transpose());
      write_numbers(out, g.transpose());
      write_numbers(out, p.transpose());
      write_numbers(out, J);
      write_numbers(out, a.transpose());
      out << '\n';
    };
    for (std::size_t k = 0; k < S; ++k) {
      // Separate: each quantity closes the loops itself.
      loops.close(qa[k], true);
      crba(model, data, loops.q);
      D = loops.inertia();
      loops.close(qa[k], true);
      loops.close_rates(qda[k], false);
      nle = loops.project(pinocchio::rnea(model, data, loops.q, loops.v, loops.bias));
      loops.close(qa[k], true);
      g = loops.project(pinocchio::computeGeneralizedGravity(model, data, loops.q));
      loops.close(qa[k], false);
      p = loops.position();
      loops.close(qa[k], true);
      J = loops.jacobian();
      loops.close(qa[k], true);
      loops.close_rates(qda[k], false);
      a = loops.jacobian_dot_times_qdot();
      line("separate", k);
      // The bundle, as timed below: one loop solve, then the calls.
      loops.close(qa[k], true);
      loops.close_rates(qda[k], false);
      p = loops.position();
      J = loops.jacobian();
      a = loops.jacobian_dot_times_qdot();
      crba(model, data, loops.q);
      D = loops.inertia();
      nle = loops.project(pinocchio::rnea(model, data, loops.q, loops.v, loops.bias));
      g = loops.project(pinocchio::computeGeneralizedGravity(model, data, loops.q));
      line("bundle", k);
      // computeAllTerms at (q, q̇) after the loop solve.
      loops.close(qa[k], true);
      loops.close_rates(qda[k], true);
      p = loops.position();
      J = loops.jacobian();
      a = loops.jacobian_dot_times_qdot();
      g = loops.project(data.g);
      nle = loops.project(data.nle);
      D = loops.inertia();
      nle.noalias() += loops.selection.transpose().lazyProduct(data.M.lazyProduct(loops.bias));
      line("allterms", k);
    }
  }

  volatile double sink = 0;
  double total = 0;
  auto report = [](const char* key, double ns) { std::printf("%s %.2f\n", key, ns); };
  // The loop solve alone (with A and the bias, as in the bundles), and Newton's steps per solve
  // in it (the continuation from the assembly at the first state, before, not counted).
  loops.solves = loops.newton_steps = 0;
  report("loops", nanoseconds(S, [&](std::size_t k) {
           loops.close(qa[k], true);
           loops.close_rates(qda[k], false);
           total += loops.bias[0];
         }));
  report("newton_steps_per_solve", double(loops.newton_steps) / double(loops.solves));
  report("D", nanoseconds(S, [&](std::size_t k) {
           loops.close(qa[k], true);
           crba(model, data, loops.q);
           total += loops.inertia()(0, 0);
         }));
  report("nle", nanoseconds(S, [&](std::size_t k) {
           loops.close(qa[k], true);
           loops.close_rates(qda[k], false);
           total += loops.project(pinocchio::rnea(model, data, loops.q, loops.v, loops.bias))[0];
         }));
  report("g", nanoseconds(S, [&](std::size_t k) {
           loops.close(qa[k], true);
           total += loops.project(pinocchio::computeGeneralizedGravity(model, data, loops.q))[0];
         }));
  report("p", nanoseconds(S, [&](std::size_t k) {
           loops.close(qa[k], false);
           total += loops.position()[0];
         }));
  report("J", nanoseconds(S, [&](std::size_t k) {
           loops.close(qa[k], true);
           total += loops.jacobian()(0, 0);
         }));
  report("Jdqd", nanoseconds(S, [&](std::size_t k) {
           loops.close(qa[k], true);
           loops.close_rates(qda[k], false);
           total += loops.jacobian_dot_times_qdot()[0];
         }));
  report("bundle", nanoseconds(S, [&](std::size_t k) {
           loops.close(qa[k], true);
           loops.close_rates(qda[k], false);
           total += loops.position()[0] + loops.jacobian()(0, 0) + loops.jacobian_dot_times_qdot()[0];
           crba(model, data, loops.q);
           total += loops.inertia()(0, 0);
           total += loops.project(pinocchio::rnea(model, data, loops.q, loops.v, loops.bias))[0];
           total += loops.project(pinocchio::computeGeneralizedGravity(model, data, loops.q))[0];
         }));
  report("allterms", nanoseconds(S, [&](std::size_t k) {
           loops.close(qa[k], true);
           loops.close_rates(qda[k], true);
           total += loops.position()[0] + loops.jacobian()(0, 0) + loops.jacobian_dot_times_qdot()[0];
           total += loops.project(data.g)[0];
           VecN nle = loops.project(data.nle);
           const MatNN D = loops.inertia();
           nle.noalias() += loops.selection.transpose().lazyProduct(data.M.lazyProduct(loops.bias));
           total += nle[0] + D(0, 0);
         }));
  sink = total;
  (void)sink;
  return 0;
}

// The Falcon-like Delta's sizes fixed, anything else dynamic.
int closed_chain_main(const pinocchio::Model& model, const States& s, const std::string& results) {
  const int passive = (int)s.tree.size() - s.n;
  if (s.n == 3 && passive == 8) return run_closed_chain<3, 8>(model, s, results);
  return run_closed_chain<Eigen::Dynamic, Eigen::Dynamic>(model, s, results);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) fail("usage: side_by_side URDF STATES RESULTS");
  const States s = read_states(argv[2]);

  pinocchio::Model model;
  pinocchio::urdf::buildModel(argv[1], model);
  model.gravity.linear(s.gravity);
  if (s.closed()) {
    // hapticgen adds N²·J_m to the actuated coordinates' diagonal entries of D; passive joints
    // have no rotor.
    model.armature.setZero();
    for (int i = 0; i < s.n; ++i) {
      if (!model.existJointName(s.tree[i])) fail("the URDF has no joint " + s.tree[i]);
      model.armature[model.joints[model.getJointId(s.tree[i])].idx_v()] = s.armature[i];
    }
    return closed_chain_main(model, s, argv[3]);
  }
  if (model.nq != s.n || model.nv != s.n) fail("the URDF's nq/nv differ from the states' dof");
  for (int i = 0; i < s.n; ++i)
    if (model.names[i + 1] != s.joints[i])
      fail("Pinocchio's joint " + std::to_string(i) + " is " + model.names[i + 1] + ", hapticgen's is " +
           s.joints[i]);
  // hapticgen adds N²·J_m to D's diagonal; Pinocchio's crba adds model.armature.
  model.armature = s.armature;
  if (!model.existFrame(s.frame)) fail("the URDF has no frame " + s.frame);
  const pinocchio::FrameIndex frame = model.getFrameId(s.frame);
  pinocchio::Data data(model);
  const pinocchio::ReferenceFrame rf = pinocchio::LOCAL_WORLD_ALIGNED;
  const Vec zero = Vec::Zero(model.nv);
  pinocchio::Data::Matrix6x J = pinocchio::Data::Matrix6x::Zero(6, model.nv);
  const std::size_t S = s.q.size();

  // Results at every state: the separate calls, the bundle of separate calls, and the bundle
  // around computeAllTerms; one line each, tagged.
  {
    std::ofstream out(argv[3]);
    if (!out) fail(std::string("cannot write ") + argv[3]);
    out << "# tag state | D (row-major) | C*qd + g | g | p | J (3 rows) | Jdot*qd\n";
    for (std::size_t k = 0; k < S; ++k) {
      const Vec &q = s.q[k], &v = s.v[k];
      Eigen::MatrixXd D, Jp;
      Vec nle, g;
      Eigen::Vector3d p, a;
      auto line = [&](const char* tag) {
        D.triangularView<Eigen::StrictlyLower>() = D.transpose().triangularView<Eigen::StrictlyLower>();
        out << tag << ' ' << k;
        write_numbers(out, D);
        write_numbers(out, nle.transpose());
        write_numbers(out, g.transpose());
        write_numbers(out, p.transpose());
        write_numbers(out, Jp);
        write_numbers(out, a.transpose());
        out << '\n';
      };
      // Separate calls.
      D = crba(model, data, q);
      nle = pinocchio::nonLinearEffects(model, data, q, v);
      g = pinocchio::computeGeneralizedGravity(model, data, q);
      pinocchio::forwardKinematics(model, data, q);
      p = pinocchio::updateFramePlacement(model, data, frame).translation();
      J.setZero();
      pinocchio::computeFrameJacobian(model, data, q, frame, rf, J);
      Jp = J.topRows<3>();
      pinocchio::forwardKinematics(model, data, q, v, zero);
      a = pinocchio::getFrameClassicalAcceleration(model, data, frame, rf).linear();
      line("separate");
      // The same calls back to back, as timed below.
      D = crba(model, data, q);
      nle = pinocchio::nonLinearEffects(model, data, q, v);
      g = pinocchio::computeGeneralizedGravity(model, data, q);
      J.setZero();
      pinocchio::computeFrameJacobian(model, data, q, frame, rf, J);
      p = data.oMf[frame].translation();
      Jp = J.topRows<3>();
      pinocchio::forwardKinematics(model, data, q, v, zero);
      a = pinocchio::getFrameClassicalAcceleration(model, data, frame, rf).linear();
      line("bundle");
      // One pass of computeAllTerms (M, nle, g, joint Jacobians, kinematics with a = 0).
      pinocchio::computeAllTerms(model, data, q, v);
      D = data.M;
      nle = data.nle;
      g = data.g;
      p = pinocchio::updateFramePlacement(model, data, frame).translation();
      J.setZero();
      pinocchio::getFrameJacobian(model, data, frame, rf, J);
      Jp = J.topRows<3>();
      a = pinocchio::getFrameClassicalAcceleration(model, data, frame, rf).linear();
      line("allterms");
    }
  }

  // Timing. Every call writes into `data` (or J) and the calls are in another library or
  // have side effects on `data`, so nothing is optimised away; `sink` makes sure of it.
  volatile double sink = 0;
  auto report = [](const char* key, double ns) { std::printf("%s %.2f\n", key, ns); };
  report("D", nanoseconds(S, [&](std::size_t k) { crba(model, data, s.q[k]); }));
  sink = data.M(0, 0);
  report("nle", nanoseconds(S, [&](std::size_t k) { pinocchio::nonLinearEffects(model, data, s.q[k], s.v[k]); }));
  sink = data.nle[0];
  report("g", nanoseconds(S, [&](std::size_t k) { pinocchio::computeGeneralizedGravity(model, data, s.q[k]); }));
  sink = data.g[0];
  report("p", nanoseconds(S, [&](std::size_t k) {
           pinocchio::forwardKinematics(model, data, s.q[k]);
           pinocchio::updateFramePlacement(model, data, frame);
         }));
  sink = data.oMf[frame].translation()[0];
  report("J", nanoseconds(S, [&](std::size_t k) { pinocchio::computeFrameJacobian(model, data, s.q[k], frame, rf, J); }));
  sink = J(0, 0);
  double acceleration = 0;
  report("Jdqd", nanoseconds(S, [&](std::size_t k) {
           pinocchio::forwardKinematics(model, data, s.q[k], s.v[k], zero);
           acceleration += pinocchio::getFrameClassicalAcceleration(model, data, frame, rf).linear()[0];
         }));
  report("bundle", nanoseconds(S, [&](std::size_t k) {
           const Vec &q = s.q[k], &v = s.v[k];
           crba(model, data, q);
           pinocchio::nonLinearEffects(model, data, q, v);
           pinocchio::computeGeneralizedGravity(model, data, q);
           pinocchio::computeFrameJacobian(model, data, q, frame, rf, J);  // also sets oMf[frame]: p
           pinocchio::forwardKinematics(model, data, q, v, zero);
           acceleration += pinocchio::getFrameClassicalAcceleration(model, data, frame, rf).linear()[0];
         }));
  report("allterms", nanoseconds(S, [&](std::size_t k) {
           pinocchio::computeAllTerms(model, data, s.q[k], s.v[k]);
           pinocchio::updateFramePlacement(model, data, frame);
           pinocchio::getFrameJacobian(model, data, frame, rf, J);
           acceleration += pinocchio::getFrameClassicalAcceleration(model, data, frame, rf).linear()[0];
         }));
  sink = acceleration + J(0, 0) + data.M(0, 0);
  (void)sink;
  return 0;
}
