// The validity checks of simulate-part (app/validity_checks.hpp) against set points made by hand:
// on the path, a known distance off it, beyond the travel.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "validity_checks.hpp"
#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/sample_models.hpp"

namespace vmsim {
namespace {

constexpr double kToolLength = 0.05;

struct StraightMove {
  kinematics::MachineModel machine = kinematics::make_table_table_sample();
  std::vector<kinematics::PathPose> path;
  std::vector<double> path_s_m;
  planner::SetPoints setpoints;
  std::vector<std::string> block_names{"part.nc:10 N10", "part.nc:11 N20"};
  std::vector<bool> rapid_end{false, false};

  // X from -10 to +10 mm at Y = 1 mm, Z = -100 mm, A = C = 0: 101 set points on the line.
  StraightMove() {
    Eigen::VectorXd q_start = Eigen::VectorXd::Zero(5), q_end = Eigen::VectorXd::Zero(5);
    q_start << -0.01, 0.001, -0.1, 0.0, 0.0;
    q_end << 0.01, 0.001, -0.1, 0.0, 0.0;
    const auto start = kinematics::forward_kinematics(machine, q_start, kToolLength);
    const auto end = kinematics::forward_kinematics(machine, q_end, kToolLength);
    path = {{start, 0}, {end, 1}};
    const double length = (end.tip_W_m - start.tip_W_m).norm();
    path_s_m = {0.0, length};
    setpoints.q.resize(5, 101);
    for (int k = 0; k <= 100; ++k) {
      const double f = k / 100.0;
      setpoints.t_s.push_back(0.01 * k);
      setpoints.s_m.push_back(f * length);
      setpoints.q.col(k) = (1 - f) * q_start + f * q_end;
    }
  }
};

TEST(ValidityChecks, SetPointsOnTheLinePass) {
  const StraightMove move;
  const app::ValidityCheck check = app::check_setpoints_on_path(
      move.machine, move.path, move.rapid_end, move.path_s_m, kToolLength, move.setpoints, move.block_names, "production", 1e-6);
  EXPECT_EQ(check.status, app::CheckStatus::passed) << app::check_line(check);
  EXPECT_LT(check.value, 1e-6);  // um: rounding only
}

TEST(ValidityChecks, ASetPointOffThePathFailsWithItsDistanceAndBlock) {
  StraightMove move;
  move.setpoints.q(1, 60) += 5e-6;  // Y 5 um off the line: the tip moves 5 um across it
  const app::ValidityCheck check = app::check_setpoints_on_path(
      move.machine, move.path, move.rapid_end, move.path_s_m, kToolLength, move.setpoints, move.block_names, "production", 1e-6);
  EXPECT_EQ(check.status, app::CheckStatus::failed);
  EXPECT_NEAR(check.value, 5.0, 1e-6);
  EXPECT_NE(check.detail.find("part.nc:11 N20"), std::string::npos) << check.detail;
  EXPECT_NE(app::check_line(check).find("FAILED"), std::string::npos);
  // On a rapid the NC moves the axes on their own: not checked.
  move.rapid_end[1] = true;
  EXPECT_EQ(app::check_setpoints_on_path(move.machine, move.path, move.rapid_end, move.path_s_m, kToolLength,
                                         move.setpoints, move.block_names, "production", 1e-6)
                .status,
            app::CheckStatus::passed);
}

TEST(ValidityChecks, TheProgramsContourToleranceIsTheLimitWhereItIsLarger) {
  StraightMove move;
  move.setpoints.q(1, 60) += 7e-6;  // 7 um off the line, on the motion that ends at point 1
  auto check_with = [&](std::vector<double> contour_tolerance_m) {
    return app::check_setpoints_on_path(move.machine, move.path, move.rapid_end, move.path_s_m, kToolLength,
                                        move.setpoints, move.block_names, "production", 5e-6,
                                        contour_tolerance_m);
  };
  // G64 P0.01 on that motion: the NC itself may leave the polyline by 10 um there.
  const app::ValidityCheck within = check_with({0.0, 10e-6});
  EXPECT_EQ(within.status, app::CheckStatus::passed) << app::check_line(within);
  EXPECT_NEAR(within.value, 7.0, 1e-6);
  EXPECT_NEAR(within.limit, 10.0, 1e-9);
  EXPECT_NE(within.detail.find("contour tolerance"), std::string::npos) << within.detail;
  // A tolerance below the default changes nothing; none given: the default limit.
  EXPECT_EQ(check_with({0.0, 2e-6}).status, app::CheckStatus::failed);
  EXPECT_EQ(check_with({}).status, app::CheckStatus::failed);
  // 12 um off is beyond the program's tolerance too.
  move.setpoints.q(1, 60) += 5e-6;
  const app::ValidityCheck beyond = check_with({0.0, 10e-6});
  EXPECT_EQ(beyond.status, app::CheckStatus::failed);
  EXPECT_NEAR(beyond.value, 12.0, 1e-6);
}

TEST(ValidityChecks, ANaNSetPointFails) {
  StraightMove move;
  move.setpoints.q(0, 3) = std::nan("");
  EXPECT_EQ(app::check_setpoints_on_path(move.machine, move.path, move.rapid_end, move.path_s_m, kToolLength, move.setpoints,
                                         move.block_names, "production", 1e-6)
                .status,
            app::CheckStatus::failed);
  EXPECT_EQ(app::check_setpoints_within_travel(move.machine, move.path, move.path_s_m, move.setpoints,
                                               move.block_names, "production")
                .status,
            app::CheckStatus::failed);
}

TEST(ValidityChecks, TravelMarginAndExcessNameTheAxis) {
  StraightMove move;
  app::ValidityCheck check = app::check_setpoints_within_travel(move.machine, move.path, move.path_s_m,
                                                                move.setpoints, move.block_names, "production");
  EXPECT_EQ(check.status, app::CheckStatus::passed);
  EXPECT_NE(check.detail.find("smallest margin"), std::string::npos) << check.detail;
  move.setpoints.q(0, 80) = 0.36;  // X travel is [-355, 355] mm: 5 mm beyond
  check = app::check_setpoints_within_travel(move.machine, move.path, move.path_s_m, move.setpoints,
                                             move.block_names, "production");
  EXPECT_EQ(check.status, app::CheckStatus::failed);
  EXPECT_NEAR(check.value, 5.0, 1e-9);
  EXPECT_NE(check.detail.find("axis X at 360 mm"), std::string::npos) << check.detail;
  EXPECT_NE(check.detail.find("part.nc:11 N20"), std::string::npos) << check.detail;
}

TEST(ValidityChecks, RoundingAtAnEndOfTheTravelIsNoExcess) {
  // A G28 return to Z0, the end of Z's travel, lands 2e-13 m beyond it after the planner's sums.
  StraightMove move;
  move.setpoints.q(2, 40) = 2e-13;
  EXPECT_EQ(app::check_setpoints_within_travel(move.machine, move.path, move.path_s_m, move.setpoints,
                                               move.block_names, "production")
                .status,
            app::CheckStatus::passed);
  move.setpoints.q(2, 40) = 1e-6;  // a micrometre is an excess
  EXPECT_EQ(app::check_setpoints_within_travel(move.machine, move.path, move.path_s_m, move.setpoints,
                                               move.block_names, "production")
                .status,
            app::CheckStatus::failed);
}

TEST(ValidityChecks, AnOvershootingDriveIsAWarning) {
  const StraightMove move;
  Eigen::MatrixXd actual = move.setpoints.q;
  actual(2, 10) = 0.0002;  // Z travel ends at 0: 0.2 mm beyond
  const app::ValidityCheck check =
      app::check_actual_within_travel(move.machine, move.setpoints.t_s, actual, "production");
  EXPECT_EQ(check.status, app::CheckStatus::warning);
  EXPECT_NEAR(check.value, 0.2, 1e-9);
  EXPECT_NE(check.detail.find("axis Z"), std::string::npos);
}

TEST(ValidityChecks, ASettlingOvershootAtAnEndOfTheTravelIsNoAlarm) {
  // A G28 return to the Z home at the end of Z's travel, the drive settling 15 um beyond it: a
  // control's actual-position monitoring allows 0.1 mm there (no alarm); 0.1 mm + 1 um does not.
  const StraightMove move;
  Eigen::MatrixXd actual = move.setpoints.q;
  actual(2, 10) = 15e-6;
  app::ValidityCheck check = app::check_actual_within_travel(move.machine, move.setpoints.t_s, actual, "production");
  EXPECT_EQ(check.status, app::CheckStatus::passed);
  EXPECT_NEAR(check.value, 0.015, 1e-9);
  EXPECT_NE(check.detail.find("axis Z overshoots its travel by 0.015"), std::string::npos) << check.detail;
  EXPECT_NE(check.detail.find("no alarm"), std::string::npos) << check.detail;
  actual(2, 10) = 0.101e-3;
  check = app::check_actual_within_travel(move.machine, move.setpoints.t_s, actual, "production");
  EXPECT_EQ(check.status, app::CheckStatus::warning);
}

TEST(ValidityChecks, EachSegmentIsMeasuredWithTheToolOfItsMotion) {
  // The same axis motion with a tool 30 mm longer on the second segment: the programmed poses of
  // that tool are 30 mm lower (tip = gauge point - length x axis). Measured with each segment's
  // tool the set points lie on the path; with one length for both, the last set point (10 mm
  // along x, 30 mm above the short tool's programmed end) is 30 x 10 / sqrt(10^2 + 30^2) mm from
  // the segment.
  StraightMove move;
  Eigen::VectorXd q_mid = Eigen::VectorXd::Zero(5), q_end = Eigen::VectorXd::Zero(5);
  q_mid << 0.01, 0.001, -0.1, 0.0, 0.0;
  q_end << 0.02, 0.001, -0.1, 0.0, 0.0;
  const double longer = kToolLength + 0.03;
  kinematics::PathPose end{kinematics::forward_kinematics(move.machine, q_end, longer), 1};
  end.tool_length_m = longer;
  move.path.push_back(end);
  const double length = move.path_s_m.back();
  move.path_s_m.push_back(2.0 * length);  // the new tool starts at its own tip over q_mid
  move.rapid_end.push_back(false);
  move.setpoints.q.conservativeResize(5, 201);
  for (int k = 101; k <= 200; ++k) {
    const double f = (k - 100) / 100.0;
    move.setpoints.t_s.push_back(0.01 * k);
    move.setpoints.s_m.push_back(length + f * length);
    move.setpoints.q.col(k) = (1 - f) * q_mid + f * q_end;
  }
  app::ValidityCheck check = app::check_setpoints_on_path(move.machine, move.path, move.rapid_end, move.path_s_m,
                                                          kToolLength, move.setpoints, move.block_names,
                                                          "production", 0.5e-6);
  EXPECT_EQ(check.status, app::CheckStatus::passed) << check.detail;
  EXPECT_LT(check.value, 1e-3);
  move.path.back().tool_length_m = std::numeric_limits<double>::quiet_NaN();  // one length for all
  check = app::check_setpoints_on_path(move.machine, move.path, move.rapid_end, move.path_s_m, kToolLength,
                                       move.setpoints, move.block_names, "production", 0.5e-6);
  EXPECT_EQ(check.status, app::CheckStatus::failed);
  EXPECT_NEAR(check.value, 30e3 * 10.0 / std::sqrt(1000.0), 1e-3);
}

TEST(ValidityChecks, AReferenceFarFromTheCommandedSurfaceFails) {
  EXPECT_EQ(app::check_reference_against_commanded(0.5e-6, Eigen::Vector3d::Zero(), 2e-6).status,
            app::CheckStatus::passed);
  const app::ValidityCheck check =
      app::check_reference_against_commanded(3.649e-3, Eigen::Vector3d(0.01, 0.02, -0.005), 2e-6);
  EXPECT_EQ(check.status, app::CheckStatus::failed);
  EXPECT_NEAR(check.value, 3649.0, 1e-9);
  EXPECT_NE(check.detail.find("(10.000, 20.000, -5.000) mm"), std::string::npos) << check.detail;
}

}  // namespace
}  // namespace vmsim
