// Actuator torque and torque rate of the 6-axis robot sample at one path point.
//   ./bench_dynamics --benchmark_min_time=0.5
// Aim: tau and tau-dot together under 2 us on one core (FIELD-NOTES: RBDL 0.8-0.9 us for tau
// alone, Pinocchio's inverse-dynamics derivatives 3.7-4.1 us).
#include <benchmark/benchmark.h>

#include <Eigen/Core>

#include "vmsim/kinematics/dynamics.hpp"
#include "vmsim/kinematics/sample_models.hpp"

namespace {

using namespace vmsim::kinematics;

struct RobotPoint {
  MachineModel machine = make_robot_sample();
  DynamicsModel model{machine};
  DynamicsData data{model};
  Eigen::VectorXd q = machine.home_positions();
  Eigen::VectorXd q_s{6}, q_ss{6}, q_sss{6};
  PathMotion motion{0.2, 0.5, 3.0};
  RobotPoint() {
    q += Eigen::VectorXd::LinSpaced(6, 0.1, 0.6);
    q_s << 0.8, -1.1, 0.5, 1.7, -0.9, 2.1;
    q_ss << 3.0, -2.0, 5.0, -8.0, 4.0, 10.0;
    q_sss << 30.0, 20.0, -50.0, 80.0, -40.0, 100.0;
  }
};

/// Full model: tau and tau-dot in one recursion (chain rule included).
void BM_RobotTorqueAndRate(benchmark::State& state) {
  RobotPoint p;
  for (auto _ : state) {
    actuator_torque_on_path(p.model, p.data, p.q, p.q_s, p.q_ss, p.q_sss, p.motion);
    benchmark::DoNotOptimize(p.data.tau_dot.data());
  }
}
BENCHMARK(BM_RobotTorqueAndRate);

/// Full model from joint motion directly (no chain rule).
void BM_RobotTorqueAndRateJoint(benchmark::State& state) {
  RobotPoint p;
  path_joint_motion(p.data, p.q_s, p.q_ss, p.q_sss, p.motion);
  const Eigen::VectorXd qd = p.data.qd, qdd = p.data.qdd, qddd = p.data.qddd;
  for (auto _ : state) {
    actuator_torque(p.model, p.data, p.q, qd, qdd, qddd);
    benchmark::DoNotOptimize(p.data.tau_dot.data());
  }
}
BENCHMARK(BM_RobotTorqueAndRateJoint);

/// Term by term (six effects and their rates): about 2n + 2 recursions.
void BM_RobotTermSplit(benchmark::State& state) {
  RobotPoint p;
  path_joint_motion(p.data, p.q_s, p.q_ss, p.q_sss, p.motion);
  const Eigen::VectorXd qd = p.data.qd, qdd = p.data.qdd, qddd = p.data.qddd;
  for (auto _ : state) {
    actuator_torque_terms(p.model, p.data, p.q, qd, qdd, qddd);
    benchmark::DoNotOptimize(p.data.terms.total_torque_rate_N_m_per_s.data());
  }
}
BENCHMARK(BM_RobotTermSplit);

/// The planner's coefficients a, b, c, d, e and their s-derivatives (three recursions).
void BM_RobotPathCoefficients(benchmark::State& state) {
  RobotPoint p;
  for (auto _ : state) {
    path_torque_coefficients(p.model, p.data, p.q, p.q_s, p.q_ss, p.q_sss);
    benchmark::DoNotOptimize(p.data.coefficients.b_s.data());
  }
}
BENCHMARK(BM_RobotPathCoefficients);

/// Mass matrix by n recursions (for reference).
void BM_RobotMassMatrix(benchmark::State& state) {
  RobotPoint p;
  for (auto _ : state) {
    mass_matrix(p.model, p.data, p.q);
    benchmark::DoNotOptimize(p.data.mass_matrix.data());
  }
}
BENCHMARK(BM_RobotMassMatrix);

}  // namespace
