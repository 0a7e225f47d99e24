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

struct States {
  int n = 0;
  std::string frame;
  std::vector<std::string> joints;
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();
  Vec armature;
  std::vector<Vec> q, v;
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

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) fail("usage: side_by_side URDF STATES RESULTS");
  const States s = read_states(argv[2]);

  pinocchio::Model model;
  pinocchio::urdf::buildModel(argv[1], model);
  if (model.nq != s.n || model.nv != s.n) fail("the URDF's nq/nv differ from the states' dof");
  for (int i = 0; i < s.n; ++i)
    if (model.names[i + 1] != s.joints[i])
      fail("Pinocchio's joint " + std::to_string(i) + " is " + model.names[i + 1] + ", hapticgen's is " +
           s.joints[i]);
  model.gravity.linear(s.gravity);
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
