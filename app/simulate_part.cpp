#include "simulate_part.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <ctime>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <span>
#include <sstream>

#include "banded_removal.hpp"
#include "chain_inputs.hpp"
#include "mpi_ranks.hpp"
#include "tool_table.hpp"
#include "json_text.hpp"
#include "nc_modes.hpp"
#include "report_3d.hpp"
#include "report_html.hpp"
#include "report_marks.hpp"
#include "part_file.hpp"
#include "surface_views.hpp"
#include "following_errors.hpp"
#include "validity_checks.hpp"
#include "view_deviation.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/memory.hpp"
#include "vmsim/common/output_folder.hpp"
#include "vmsim/common/streamed_file.hpp"
#include "vmsim/common/trace.hpp"
#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"
#include "vmsim/removal/marks.hpp"
#include "vmsim/removal/marks_stream.hpp"
#include "vmsim/removal/nbuffer.hpp"
#include "vmsim/removal/output.hpp"
#include "vmsim/removal/trajectory.hpp"
#include "vmsim/servo/servo.hpp"
#include "vmsim/viz/display.hpp"
#include "vmsim/viz/plot.hpp"
#include "vmsim/viz/surface.hpp"

namespace vmsim::app {
namespace {

using Clock = std::chrono::steady_clock;
using Json = nlohmann::json;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// CPU time of the process (user + system, all threads) [s].
double cpu_seconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

// The process's peak resident memory so far [MiB] (the kernel's high-water mark).
double peak_rss_mib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

// Rounded to a multiple of step (a power of ten): divided by 1 / step, so that 18.9 prints as
// 18.9 and not as 189 * 0.1 = 18.900000000000002.
double round_to(double value, double step) { return std::round(value / step) / std::round(1.0 / step); }

// Everything one run (one feed setting) produces.
struct Run {
  Run(std::string run_name, const FeedSetting& setting) : name(std::move(run_name)), feed(setting) {}
  std::string name;
  FeedSetting feed;
  /// The largest feed of a cutting move in this run [m/s] (the fixed feed where one is set).
  double feed_m_per_s = 0.0;
  planner::FeedratePlan plan;
  /// Servo sample times and the commanded and actual positions per axis (rows), per servo
  /// sample (SI): kept for the production run only (marks are related to them and plotted);
  /// the reference run's are consumed window by window as the servo makes them (ChainSink:
  /// checks, following errors, direct kinematics and thinning) and never held.
  std::vector<double> t_s;
  Eigen::MatrixXd q_cmd, q_actual;
  Json summary;                         ///< following errors over all moves and while cutting
  std::vector<removal::Pose> trajectory;  ///< actual tool poses, thinned
  std::vector<double> trajectory_t_s;   ///< the time of each kept pose
  std::size_t samples = 0;              ///< servo samples before thinning
  std::size_t poses_cut = 0;            ///< poses its removal cut (the planned path's, for that reference)
  std::vector<removal::NBuffer> buffers;  ///< one per surface view (Context::views)
  std::vector<removal::CutStatistics> cuts;  ///< one per surface view
  std::map<std::string, double> stage_seconds;
  std::map<std::string, double> stage_cpu_seconds;   ///< user + system, all threads
  std::map<std::string, double> stage_peak_rss_mib;  ///< the process's peak so far, at the stage's end
  std::vector<ValidityCheck> checks;    ///< set points on the path and within travel, actual positions
  /// The reference run: how far its actual tool strays from its commanded path (an upper bound
  /// of the Hausdorff distance of the swept volumes, CommandedPathDeviation) [m], where (time)
  /// and how many poses were matched.
  double path_deviation_m = 0.0;
  double path_deviation_t_s = 0.0;
  std::size_t path_deviation_poses = 0;
};

// The servo samples a chord of at most `max_chord_m` at the feed, at a whole multiple of every
// axis's fastest loop period, never longer than the interpolation period.
double record_period_s(const kinematics::MachineModel& machine, double feed_m_per_s,
                       double max_chord_m) {
  double base = 0.0;
  for (const auto& axis : machine.axes) base = std::max(base, servo::base_period_s(axis.controller));
  const double wanted = max_chord_m / feed_m_per_s;
  const double multiple = std::max(1.0, std::floor(wanted / base + 1e-9));
  const double ipo_multiple = std::max(1.0, std::floor(machine.interpolation_period_s / base + 1e-9));
  return base * std::min(multiple, ipo_multiple);
}


double from_trace_unit(const kinematics::Axis& axis, double value) {
  return axis.type == kinematics::AxisType::linear ? value * 1e-3 : value * std::numbers::pi / 180.0;
}

class StageTimer {
 public:
  StageTimer(Run& run, std::string stage, const ProgressSink& progress)
      : run_(run), stage_(std::move(stage)), start_(Clock::now()), cpu_start_(cpu_seconds()) {
    progress(run.name + ": " + stage_ + " ...");
  }
  ~StageTimer() {
    run_.stage_seconds[stage_] += seconds_since(start_);
    run_.stage_cpu_seconds[stage_] += cpu_seconds() - cpu_start_;
    run_.stage_peak_rss_mib[stage_] = peak_rss_mib();
  }

 private:
  Run& run_;
  std::string stage_;
  Clock::time_point start_;
  double cpu_start_;
};

struct Context {
  const SimulatePartOptions& options;
  const ProgressSink& progress;
  PartDescription part;
  ChainInputs inputs;
  kinematics::PathKinematics path;
  removal::Tool tool;  ///< the part's tool (PathPoint::tool_number -1)
  /// Per point of inputs.path, the removal tool of its motion (the T selected there).
  std::vector<removal::Tool> point_tools;
  StockShape stock;
  std::vector<SurfaceView> views;
  /// The uncut buffer of each view, made once (over a mesh stock that takes a while): every run
  /// starts from a copy, so that all runs cut identical lines.
  std::vector<removal::NBuffer> uncut;
  /// Several ranks (mpi_ranks.hpp): each view's bands; rank 0 keeps the whole `uncut` buffers
  /// (it gathers into copies of them), the others only their bands.
  const Ranks& ranks;
  std::vector<ViewBands> bands;
  /// The NC modes the runs apply (the program's, or the command line's) and, where the
  /// feedforward is switched, the machine the servo simulates.
  NcModes nc;
  std::optional<kinematics::MachineModel> servo_machine;
  /// Set by a run whose third-order plan failed and fell back to second order (the context
  /// line then says so).
  mutable bool third_order_fell_back = false;
  std::vector<double> point_length_m;  ///< per point of inputs.path, its tool's length (gauge to tip)
};

// s of the plan at time t (linear interpolation in the set points, made from the plan's law:
// the reference run holds no set points).
double plan_s_at(const planner::FeedratePlan& plan, double t_s) { return plan.law.s_at_time(t_s); }

// The tool poses along the planner's path (its spline through the program's points and the ones
// it added: the geometry both runs' set points follow), sampled as the servo samples a run (a
// chord of at most max_sample_chord_m of the tip, or of the tool's length where the tool axis
// turns) and thinned as a run's trajectory is; per pose, the program's point its motion runs
// towards (for the tool in the spindle).
void commanded_poses(const Context& context, const kinematics::PathKinematics& planned,
                     std::vector<removal::Pose>& poses, std::vector<std::size_t>& pose_point) {
  const kinematics::MachineModel& machine = context.inputs.machine;
  const planner::PathSpline spline(planned);
  const double chord_m = context.options.max_sample_chord_m;
  std::vector<double> sample_s;
  removal::TrajectoryThinner thinner(context.tool.length_m, context.options.trajectory_tolerance_m,
                                     [&](std::size_t k, const removal::Pose& pose) {
                                       poses.push_back(pose);
                                       const auto& s_points = context.path.s_m;
                                       const auto i = static_cast<std::size_t>(
                                           std::lower_bound(s_points.begin(), s_points.end(), sample_s[k]) -
                                           s_points.begin());
                                       pose_point.push_back(std::min(i, s_points.size() - 1));
                                     });
  ToolPoseStream stream(machine, context.point_length_m, context.path.s_m, thinner);
  const auto length_at = [&](double s) { return context.point_length_m[motion_point_at(context.path.s_m, s)]; };
  kinematics::ToolPose previous = kinematics::forward_kinematics(machine, spline.position(planned.s_m.front()), length_at(planned.s_m.front()));
  sample_s.push_back(planned.s_m.front());
  stream.push(spline.position(planned.s_m.front()), planned.s_m.front());
  for (std::size_t i = 0; i + 1 < planned.s_m.size(); ++i) {
    const double s0 = planned.s_m[i], s1 = planned.s_m[i + 1];
    const kinematics::ToolPose end = kinematics::forward_kinematics(machine, planned.q.col(static_cast<Eigen::Index>(i + 1)), length_at(s1));
    const double turn_rad = std::atan2(previous.axis_W.cross(end.axis_W).norm(), previous.axis_W.dot(end.axis_W));
    const double travel_m = std::max((end.tip_W_m - previous.tip_W_m).norm(), turn_rad * context.tool.length_m);
    const auto steps = static_cast<std::size_t>(std::max(1.0, std::ceil(travel_m / chord_m)));
    for (std::size_t k = 1; k <= steps; ++k) {
      const double s = k == steps ? s1 : s0 + (s1 - s0) * static_cast<double>(k) / static_cast<double>(steps);
      sample_s.push_back(s);
      stream.push(spline.position(s), s);
    }
    previous = end;
  }
  thinner.finish();
}

// The planned tool path's surface in view v: each rank cuts its band, rank 0 gathers the whole
// view (the others keep their band). `statistics` (optional): the cut's, summed over the ranks.
removal::NBuffer cut_commanded_view(const Context& context, const std::vector<removal::Pose>& poses,
                                    const std::vector<std::size_t>& pose_point, std::size_t v,
                                    removal::CutStatistics* statistics) {
  removal::CutOptions cut_options;
  cut_options.threads = context.options.threads;
  removal::NBuffer commanded = rank_share(context.uncut[v], context.bands[v], context.ranks);
  removal::CutStatistics cut =
      cut_with_tools(commanded, context.point_tools, poses, pose_point, cut_options, context.point_length_m,
                     [&](removal::NBuffer& buffer) { exchange_tile_bounds(buffer, context.bands[v], context.ranks); });
  if (statistics) {
    cut.tiles_visited = context.ranks.sum(cut.tiles_visited);
    cut.lines_lowered = context.ranks.sum(cut.lines_lowered);
    *statistics = cut;
  }
  return gather_bands(std::move(commanded), context.uncut[v], context.bands[v], context.ranks,
                      context.options.gather_piece_lines);
}

std::string method_name(planner::FeedrateMethod method) {
  return method == planner::FeedrateMethod::kinematic ? "kinematic" : "dynamic";
}

// Whether the motion at time t of the plan is a cutting move (not a rapid).
bool cutting_at(const Context& context, const planner::FeedratePlan& plan, double t_s) {
  const auto& s_points = context.path.s_m;
  const double s = plan_s_at(plan, t_s);
  std::size_t i = static_cast<std::size_t>(std::upper_bound(s_points.begin(), s_points.end(), s) - s_points.begin());
  i = std::min(std::max<std::size_t>(i, 1), s_points.size() - 1);
  const auto& point = context.inputs.toolpath.points[context.inputs.toolpath_point[i]];
  return point.kind != toolpath::MotionKind::rapid;
}

// Per kept servo sample of the run: whether its motion is a cutting move (not a rapid).
std::vector<bool> cutting_samples(const Context& context, const Run& run) {
  std::vector<bool> cutting(run.t_s.size(), false);
  for (std::size_t k = 0; k < run.t_s.size(); ++k) cutting[k] = cutting_at(context, run.plan, run.t_s[k]);
  return cutting;
}

// What consumes a run's servo samples as they come, window by window (issue 21: nothing holds
// the run's trace): the production disturbance, the actual positions' and the drives' checks,
// the following errors, and the direct kinematics into the trajectory's thinning. With
// `keep_signals` the samples (t_s, q_cmd, q_actual) are also kept (the production run: its marks
// are related to them).
class ChainSink {
 public:
  // `expected_samples`: about how many samples will come (with keep_signals, the kept ones are
  // written in place: no copy of the whole run at the end).
  // `deviation_window_samples` > 0: measure the actual tool's deviation from the commanded path
  // (the reference run), searched that many samples either side; `thin`: thin the actual poses
  // into run.trajectory (what a removal cuts).
  ChainSink(const Context& context, Run& run, bool keep_signals, bool motor_side, std::size_t expected_samples,
            std::size_t deviation_window_samples = 0, bool thin = true)
      : context_(context),
        thin_(thin),
        run_(run),
        keep_(keep_signals),
        travel_(context.inputs.machine, run.name),
        saturation_(context.inputs.machine, run.name),
        errors_(context.inputs.machine, context.inputs.tool_length_m, !context.options.perfect_drives, motor_side),
        thinner_(context.tool.length_m, context.options.trajectory_tolerance_m,
                 [this](std::size_t k, const removal::Pose& pose) {
                   run_.trajectory.push_back(pose);
                   run_.trajectory_t_s.push_back(sample_t_s_[k - sample_first_]);
                 }),
        tool_poses_(context.inputs.machine, context.point_length_m, context.path.s_m, thinner_) {
    if (keep_) {
      run_.t_s.reserve(expected_samples);
      run_.q_cmd.resize(static_cast<Eigen::Index>(context.inputs.machine.axes.size()), static_cast<Eigen::Index>(expected_samples));
      run_.q_actual.resize(run_.q_cmd.rows(), run_.q_cmd.cols());
    }
    if (deviation_window_samples > 0) {
      // The largest cutting body over the program's tools.
      double radius = context.tool.diameter_m / 2, length = context.tool.length_m;
      for (const removal::Tool& tool : context.point_tools) {
        radius = std::max(radius, tool.diameter_m / 2);
        length = std::max(length, tool.length_m);
      }
      deviation_.emplace(std::hypot(radius, length), radius, length, context.stock.bounds, deviation_window_samples);
    }
  }

  // One sample; `current_A` empty with perfect drives (no drive check).
  void add(double t_s, const Eigen::VectorXd& q_cmd, Eigen::VectorXd q_actual, const Eigen::VectorXd& q_motor,
           const Eigen::VectorXd& current_A) {
    if (run_.name == "production" && context_.options.production_disturbance) {
      context_.options.production_disturbance(t_s, q_actual);
    }
    const bool cutting = cutting_at(context_, run_.plan, t_s);
    travel_.add(t_s, q_actual);
    if (current_A.size() > 0) saturation_.add(t_s, current_A, cutting);
    // One direct kinematics of each position for every tool length read below.
    const Eigen::Isometry3d spindle_cmd_W = spindle_frame_W(context_.inputs.machine, q_cmd);
    const Eigen::Isometry3d spindle_actual_W = spindle_frame_W(context_.inputs.machine, q_actual);
    errors_.add(t_s, q_cmd, q_actual, q_motor, cutting, spindle_cmd_W, spindle_actual_W);
    if (keep_) {
      const auto k = static_cast<Eigen::Index>(run_.t_s.size());
      if (k == run_.q_cmd.cols()) {  // more than expected: grow
        run_.q_cmd.conservativeResize(Eigen::NoChange, 2 * k + 1);
        run_.q_actual.conservativeResize(Eigen::NoChange, 2 * k + 1);
      }
      run_.t_s.push_back(t_s);
      run_.q_cmd.col(k) = q_cmd;
      run_.q_actual.col(k) = q_actual;
    }
    if (deviation_) {
      const std::vector<double>& lengths = context_.point_length_m;
      const double length_m = lengths.empty()            ? 0.0
                              : tool_poses_.one_length() ? lengths.front()
                                                         : lengths[motion_point_at(context_.path.s_m, plan_s_at(run_.plan, t_s))];
      deviation_->add(t_s, {tool_tip_W_m(spindle_cmd_W, length_m), spindle_cmd_W.linear().col(2)},
                      {tool_tip_W_m(spindle_actual_W, length_m), spindle_actual_W.linear().col(2)});
    }
    ++run_.samples;
    if (!thin_) return;
    // The thinning holds a window of poses: the times of the samples it may still keep.
    sample_t_s_.push_back(t_s);
    // The tool in the spindle at this sample (its length: the path point its motion runs to).
    tool_poses_.push(spindle_actual_W, tool_poses_.one_length() ? 0.0 : plan_s_at(run_.plan, t_s));
    if (sample_t_s_.size() > 4096) {
      // Beyond the thinner's window (at most 257 poses) no sample is kept any more.
      const std::size_t drop = sample_t_s_.size() - 1024;
      sample_t_s_.erase(sample_t_s_.begin(), sample_t_s_.begin() + static_cast<std::ptrdiff_t>(drop));
      sample_first_ += drop;
    }
  }

  // After the last sample: the checks (in the order the report gives them), the summary and,
  // kept, the samples.
  void finish(bool drive_check) {
    thinner_.finish();
    if (deviation_) {
      deviation_->finish();
      run_.path_deviation_m = deviation_->deviation_m();
      run_.path_deviation_t_s = deviation_->worst_t_s();
      run_.path_deviation_poses = deviation_->poses_matched();
    }
    run_.checks.push_back(travel_.result());
    context_.progress(check_line(run_.checks.back()));
    if (drive_check) {
      run_.checks.push_back(saturation_.result());
      context_.progress(check_line(run_.checks.back()));
    }
    run_.summary = errors_.finish([&](double t_s) { return plan_s_at(run_.plan, t_s); });
    if (keep_) {
      const auto n = static_cast<Eigen::Index>(run_.t_s.size());
      run_.q_cmd.conservativeResize(Eigen::NoChange, n);
      run_.q_actual.conservativeResize(Eigen::NoChange, n);
    }
  }

 private:
  const Context& context_;
  bool thin_;
  Run& run_;
  bool keep_;
  std::optional<CommandedPathDeviation> deviation_;
  ActualTravelCheck travel_;
  DriveSaturationCheck saturation_;
  FollowingErrorSummary errors_;
  std::vector<double> sample_t_s_;  ///< times of the samples from sample_first_ on
  std::size_t sample_first_ = 0;
  removal::TrajectoryThinner thinner_;
  ToolPoseStream tool_poses_;  ///< after thinner_: it feeds it
};

// Whether the servo tells a load position apart from the motor's on some axis (backlash,
// compliance, pitch error: its `.pos2`).
bool servo_has_motor_side(const Context& context) {
  const kinematics::MachineModel& machine = context.servo_machine ? *context.servo_machine : context.inputs.machine;
  for (const auto& axis : machine.axes) {
    const kinematics::DriveEffects& fx = axis.effects;
    if (fx.backlash.enabled || fx.compliance.enabled || fx.pitch_error.enabled) return true;
  }
  return false;
}

// File units of a position (mm or deg) per joint unit, as servo::simulate_machine scales.
double servo_trace_scale(const kinematics::Axis& axis) {
  return axis.type == kinematics::AxisType::linear ? 1e3 : 180.0 / std::numbers::pi;
}

// The run's servo along its set points in windows of `window_s` of machine time, each window's
// samples into `sink` as they come (issue 21: memory bounded by the window). The values take
// the same round trip through the trace units (mm, deg) as a set-point trace through
// servo::simulate_machine, so that the results are those of the whole-run trace, bit for bit.
void stream_servo(const Context& context, Run& run, ChainSink& sink, double record_s, double window_s) {
  const kinematics::MachineModel& machine = context.inputs.machine;
  // FFWON / FFWOF: the servo runs the machine with its feedforward as the NC mode says.
  const kinematics::MachineModel& servo_machine = context.servo_machine ? *context.servo_machine : machine;
  // The set points window by window from the plan (the reference run holds none).
  planner::SetPointGenerator generator(run.plan);
  planner::SetPoints setpoints;
  const std::size_t n = generator.size();
  if (n < 2) throw InputError(run.name + " set points: at least two set points are needed, got " + std::to_string(n));
  generator.fill(0, 1, setpoints);
  const double t_front = setpoints.t_s.front();
  const double period = (run.plan.law.sample_t_s(n - 1) - t_front) / static_cast<double>(n - 1);
  const std::size_t axes = machine.axes.size();
  std::vector<int> simulated(axes);
  std::vector<double> reference(axes), to_servo(axes), scale(axes);
  bool elastic = false;
  for (std::size_t j = 0; j < axes; ++j) {
    simulated[j] = static_cast<int>(j);
    scale[j] = servo_trace_scale(servo_machine.axes[j]);
    to_servo[j] = 1.0 / scale[j];
    reference[j] = to_trace_unit(machine.axes[j], setpoints.q(static_cast<Eigen::Index>(j), 0)) / scale[j];
    const kinematics::DriveEffects& fx = servo_machine.axes[j].effects;
    elastic = elastic || fx.backlash.enabled || fx.compliance.enabled || fx.pitch_error.enabled;
  }
  servo::SimulationOptions servo_options;
  servo_options.record_period_s = record_s;
  servo::MachineSimulator simulator(servo_machine, simulated, reference, t_front, period, servo_options);
  double servo_seconds = 0.0, servo_cpu = 0.0, sink_seconds = 0.0, sink_cpu = 0.0;
  Eigen::VectorXd q_cmd(static_cast<Eigen::Index>(axes)), q_actual(static_cast<Eigen::Index>(axes));
  Eigen::VectorXd q_motor(elastic ? static_cast<Eigen::Index>(axes) : 0), current(static_cast<Eigen::Index>(axes));
  const auto consume = [&](const std::vector<servo::AxisSignals>& records) {
    const auto start = Clock::now();
    const double cpu_start = cpu_seconds();
    const std::size_t count = records.empty() ? 0 : records[0].t.size();
    for (std::size_t k = 0; k < count; ++k) {
      for (std::size_t j = 0; j < axes; ++j) {
        const servo::AxisSignals& s = records[j];
        const kinematics::Axis& axis = machine.axes[j];
        const auto i = static_cast<Eigen::Index>(j);
        // The load position where the servo distinguishes it (backlash, compliance, pitch error).
        const kinematics::DriveEffects& fx = servo_machine.axes[j].effects;
        const bool load = fx.backlash.enabled || fx.compliance.enabled || fx.pitch_error.enabled;
        q_cmd[i] = from_trace_unit(axis, s.cmd[k] * scale[j]);
        q_actual[i] = from_trace_unit(axis, (load ? s.load_pos[k] : s.pos[k]) * scale[j]);
        // The motor side where the load is told apart; the load itself elsewhere.
        if (elastic) q_motor[i] = load ? from_trace_unit(axis, s.pos[k] * scale[j]) : q_actual[i];
        current[i] = s.current[k];
      }
      sink.add(records[0].t[k], q_cmd, q_actual, q_motor, current);
    }
    sink_seconds += seconds_since(start);
    sink_cpu += cpu_seconds() - cpu_start;
  };
  const auto window = static_cast<std::size_t>(std::max(1.0, std::round(window_s / period)));
  Eigen::MatrixXd q_window;
  for (std::size_t first = 0; first < n; first += window) {
    const auto start = Clock::now();
    const double cpu_start = cpu_seconds();
    const std::size_t count = std::min(window, n - first);
    generator.fill(first, count, setpoints);
    q_window.resize(static_cast<Eigen::Index>(axes), static_cast<Eigen::Index>(count));
    for (std::size_t k = 0; k < count; ++k) {
      for (std::size_t j = 0; j < axes; ++j) {
        const double q = setpoints.q(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(k));
        q_window(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(k)) = to_trace_unit(machine.axes[j], q) * to_servo[j];
      }
    }
    std::vector<servo::AxisSignals> records = simulator.advance(q_window);
    servo_seconds += seconds_since(start);
    servo_cpu += cpu_seconds() - cpu_start;
    consume(records);
  }
  {
    const auto start = Clock::now();
    const double cpu_start = cpu_seconds();
    std::vector<servo::AxisSignals> records = simulator.finish();
    servo_seconds += seconds_since(start);
    servo_cpu += cpu_seconds() - cpu_start;
    consume(records);
  }
  run.stage_seconds["servo"] += servo_seconds;
  run.stage_cpu_seconds["servo"] += servo_cpu;
  run.stage_peak_rss_mib["servo"] = peak_rss_mib();
  run.stage_seconds["direct kinematics"] += sink_seconds;
  run.stage_cpu_seconds["direct kinematics"] += sink_cpu;
}

// How far either way (machine time) the reference run's actual tool is matched with its
// commanded path: the drives' lag along the path (1 / Kv, some 30 ms without feedforward) and
// their settling at a stop lie well within it; a nearest point beyond it only makes the bound
// larger (CommandedPathDeviation).
constexpr double kDeviationSearch_s = 0.2;
constexpr std::size_t kDeviationSearchMaxSamples = 512;

// A run's plan, set-point checks, servo (or perfect drives) and direct kinematics, streamed;
// `measure_deviation`: the actual tool's deviation from the commanded path (Run::path_deviation_m);
// `thin`: the actual poses thinned into run.trajectory (for cut_run).
Run simulate_path_stages(const Context& context, const std::string& name, const FeedSetting& feed,
                         planner::FeedrateMethod method, bool keep_signals, bool measure_deviation = false,
                         bool thin = true) {
  const kinematics::MachineModel& machine = context.inputs.machine;
  Run run(name, feed);
  const std::vector<double> point_feeds = point_feeds_m_per_s(context.inputs, context.path, feed);
  double feed_m_per_s = 0.0;
  for (double f : point_feeds) feed_m_per_s = std::max(feed_m_per_s, f);
  // A path of rapids only: the servo records at its finest period.
  if (!(feed_m_per_s > 0.0)) feed_m_per_s = feed.fixed_m_per_s > 0.0 ? feed.fixed_m_per_s : 1.0;
  run.feed_m_per_s = feed_m_per_s;
  {
    StageTimer timer(run, "plan", context.progress);
    planner::FeedrateOptions plan_options;
    plan_options.method = method;
    plan_options.limits = context.options.limits;
    plan_options.effects = context.options.effects;
    plan_options.third_order = context.nc.third_order;
    plan_options.path_tolerance_m = context.options.setpoint_path_tolerance_m;
    plan_options.turning_path_tolerance_m = context.options.setpoint_turning_path_tolerance_m;
    // The run's feed setting on cutting moves (a fixed feed, or the programmed one times an
    // override); rapids and turns about a fixed tip keep no feed limit and go as fast as the
    // axes allow, identically in both runs.
    plan_options.point_feed_m_per_s = point_feeds;
    plan_options.rapid_end = rapid_ends(context.inputs);
    plan_options.point_path_tolerance_m = context.inputs.contour_tolerance_m;
    plan_options.point_dwell_s = context.inputs.point_dwell_s;
    // The reference run holds no set points (issue 21): they are made again window by window
    // from the plan (planner::SetPointGenerator) for the checks and the servo.
    plan_options.keep_setpoints = keep_signals;
    try {
      run.plan = planner::plan_feedrate(machine, context.path, plan_options);
      if (!plan_options.third_order) {
        run.plan.notes.push_back("jerk / torque-rate limits not applied (" + context.nc.jerk.source +
                                 ": an NC in its acceleration-only mode, e.g. BRISK on a Siemens 840D; "
                                 "--third-order applies the axis jerk / torque-rate limits)");
      }
    } catch (const InfeasibleError& error) {
      if (!plan_options.third_order) throw;
      // The third-order (jerk / torque-rate) planner does not yet hold on every path: plan with
      // velocity, acceleration (or torque) limits only, and say so in the report.
      plan_options.third_order = false;
      context.third_order_fell_back = true;
      run.plan = planner::plan_feedrate(machine, context.path, plan_options);
      run.plan.notes.push_back(std::string("jerk / torque-rate limits NOT applied: the third-order "
                                           "planner failed on this path (") + error.what() +
                               "); planned with velocity and acceleration (or torque) limits only");
      context.progress(name + ": warning: third-order planning failed, jerk limits not applied");
    }
  }
  // The set points are checked before anything is simulated on them: within the travel, and on
  // the programmed path (through the direct kinematics, independently of the planner's spline).
  {
    const std::vector<bool> rapid_end = rapid_ends(context.inputs);
    SetpointsWithinTravelCheck within_travel(machine, context.inputs.path, context.path.s_m,
                                             context.inputs.block_names, name);
    SetpointsOnPathCheck on_path(machine, context.inputs.path, rapid_end, context.path.s_m,
                                 context.inputs.tool_length_m, context.inputs.block_names, name,
                                 context.options.setpoint_path_tolerance_m, context.inputs.contour_tolerance_m,
                                 context.options.setpoint_turning_path_tolerance_m);
    planner::SetPointGenerator generator(run.plan);
    planner::SetPoints window;
    const auto window_count = static_cast<std::size_t>(
        std::max(1.0, std::round(context.options.servo_window_s / run.plan.law.period_s)));
    for (std::size_t first = 0; first < generator.size(); first += window_count) {
      generator.fill(first, window_count, window);
      for (std::size_t k = 0; k < window.t_s.size(); ++k) {
        within_travel.add(window.s_m[k], window.q.col(static_cast<Eigen::Index>(k)));
        on_path.add(window.s_m[k], window.q.col(static_cast<Eigen::Index>(k)));
      }
    }
    run.checks.push_back(within_travel.result());
    run.checks.push_back(on_path.result());
  }
  for (const ValidityCheck& check : run.checks) {
    context.progress(check_line(check));
    if (check.status == CheckStatus::failed) {
      throw InfeasibleError(check_line(check) +
                            " -- the simulation would run on set points the program does not ask for");
    }
  }
  const double record_s = record_period_s(machine, feed_m_per_s, context.options.max_sample_chord_m);
  const std::size_t deviation_window =
      measure_deviation ? std::clamp<std::size_t>(static_cast<std::size_t>(std::ceil(kDeviationSearch_s / record_s)), 2,
                                                  kDeviationSearchMaxSamples)
                        : 0;
  if (context.options.perfect_drives) {
    std::optional<ChainSink> sink;
    {
      StageTimer timer(run, "perfect drives", context.progress);
      const planner::PathSpline spline(run.plan.path);  // with the points the planner added
      const double duration = run.plan.law.sample_t_s(run.plan.law.samples - 1);
      const auto n = static_cast<std::size_t>(std::ceil(duration / record_s)) + 1;
      run.q_cmd.resize(static_cast<Eigen::Index>(machine.axes.size()), static_cast<Eigen::Index>(n));
      for (std::size_t k = 0; k < n; ++k) {
        run.t_s.push_back(std::min(duration, static_cast<double>(k) * record_s));
        run.q_cmd.col(static_cast<Eigen::Index>(k)) = spline.position(plan_s_at(run.plan, run.t_s.back()));
      }
    }
    StageTimer timer(run, "direct kinematics", context.progress);
    const std::vector<double> t_s = std::move(run.t_s);
    const Eigen::MatrixXd q = std::move(run.q_cmd);
    run.t_s.clear();
    run.q_cmd.resize(0, 0);
    sink.emplace(context, run, keep_signals, false, t_s.size(), deviation_window, thin);
    for (std::size_t k = 0; k < t_s.size(); ++k) {
      sink->add(t_s[k], q.col(static_cast<Eigen::Index>(k)), q.col(static_cast<Eigen::Index>(k)), Eigen::VectorXd(),
                Eigen::VectorXd());
    }
    sink->finish(false);
  } else {
    context.progress(name + ": servo and direct kinematics in windows of " +
                     format_double(context.options.servo_window_s) + " s ...");
    // The servo's records: one every record_s from the first set point to the last, and the one
    // there (an upper bound: a record period is a whole number of ticks).
    const planner::SetPointLaw& law = run.plan.law;
    const auto expected =
        static_cast<std::size_t>(std::ceil((law.sample_t_s(law.samples - 1) - law.sample_t_s(0)) / record_s)) + 2;
    ChainSink sink(context, run, keep_signals, servo_has_motor_side(context), expected, deviation_window, thin);
    stream_servo(context, run, sink, record_s, context.options.servo_window_s);
    const auto start = Clock::now();
    const double cpu_start = cpu_seconds();
    sink.finish(true);
    run.stage_seconds["direct kinematics"] += seconds_since(start);
    run.stage_cpu_seconds["direct kinematics"] += cpu_seconds() - cpu_start;
    run.stage_peak_rss_mib["direct kinematics"] = peak_rss_mib();
  }
  return run;
}

// The run's thinned actual poses cut into every view (each rank its band, gathered on rank 0).
void cut_run(const Context& context, Run& run) {
  const std::string& name = run.name;
  {
    StageTimer timer(run, "removal", context.progress);
    // Per kept pose, the path point its motion runs towards (for the tool in the spindle).
    std::vector<std::size_t> trajectory_point(run.trajectory.size(), 0);
    const auto& s_points = context.path.s_m;
    for (std::size_t k = 0; k < run.trajectory.size(); ++k) {
      const double s = plan_s_at(run.plan, run.trajectory_t_s[k]);
      const auto i = static_cast<std::size_t>(std::lower_bound(s_points.begin(), s_points.end(), s) - s_points.begin());
      trajectory_point[k] = std::min(i, s_points.size() - 1);
    }
    run.poses_cut = run.trajectory.size();
    removal::CutOptions cut_options;
    cut_options.threads = context.options.threads;
    for (const SurfaceView& view : context.views) {
      double reported = 0.0;
      cut_options.interrupted = [&](double fraction) {
        if (fraction >= reported + 0.25) {
          reported = std::floor(fraction * 4) / 4;
          context.progress(name + ": removal (" + view.id + ") " +
                           std::to_string(static_cast<int>(reported * 100)) + " %");
        }
        return false;
      };
      // Every rank has the same trajectory (the stages above are deterministic) and cuts its
      // band of the view; rank 0 gathers the bands (banded_removal.hpp).
      const std::size_t v = static_cast<std::size_t>(&view - context.views.data());
      removal::NBuffer share = rank_share(context.uncut[v], context.bands[v], context.ranks);
      removal::CutStatistics cut = cut_with_tools(share, context.point_tools, run.trajectory, trajectory_point,
                                                  cut_options, context.point_length_m, [&](removal::NBuffer& buffer) {
                                                    exchange_tile_bounds(buffer, context.bands[v], context.ranks);
                                                  });
      cut.tiles_visited = context.ranks.sum(cut.tiles_visited);
      cut.lines_lowered = context.ranks.sum(cut.lines_lowered);
      run.buffers.push_back(gather_bands(std::move(share), context.uncut[v], context.bands[v], context.ranks,
                                         context.options.gather_piece_lines));
      run.cuts.push_back(cut);
    }
  }
}

Run simulate_run(const Context& context, const std::string& name, const FeedSetting& feed,
                 planner::FeedrateMethod method, bool keep_signals) {
  Run run = simulate_path_stages(context, name, feed, method, keep_signals);
  cut_run(context, run);
  return run;
}

std::size_t nearest_path_point(const kinematics::PathKinematics& path, double s_m) {
  const auto it = std::lower_bound(path.s_m.begin(), path.s_m.end(), s_m);
  std::size_t i = static_cast<std::size_t>(it - path.s_m.begin());
  if (i >= path.s_m.size()) i = path.s_m.size() - 1;
  if (i > 0 && std::abs(path.s_m[i - 1] - s_m) < std::abs(path.s_m[i] - s_m)) --i;
  return i;
}

// Curvature of the commanded tip path at each point [1/m]: turning angle over the mean length
// of the two segments around it.
std::vector<double> tip_curvature(const std::vector<kinematics::PathPose>& path) {
  std::vector<double> curvature(path.size(), 0.0);
  for (std::size_t i = 1; i + 1 < path.size(); ++i) {
    const Eigen::Vector3d a = path[i].pose.tip_W_m - path[i - 1].pose.tip_W_m;
    const Eigen::Vector3d b = path[i + 1].pose.tip_W_m - path[i].pose.tip_W_m;
    if (a.norm() < 1e-12 || b.norm() < 1e-12) continue;
    const double angle = std::atan2(a.cross(b).norm(), a.dot(b));
    curvature[i] = angle / (0.5 * (a.norm() + b.norm()));
  }
  return curvature;
}

Json relate_mark(const Context& context, const Run& production, const removal::Mark& mark,
                 const std::vector<double>& curvature) {
  const kinematics::MachineModel& machine = context.inputs.machine;
  // The sample whose tool surface came closest to the deepest point cut it: the distance from
  // the point to the tool's axis (from the centre of the corner radius up) minus the tool
  // radius is 0 on the flank of a flat end, on a ball, and near the bottom of a bull nose.
  const double radius = context.tool.diameter_m / 2;
  const double centre_offset = context.tool.corner_radius_m;
  std::size_t best = 0;
  double best_distance = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < production.trajectory.size(); ++k) {
    const removal::Pose& pose = production.trajectory[k];
    const Eigen::Vector3d centre = pose.tip_W_m + centre_offset * pose.axis_W;
    const double along = std::clamp((mark.deepest_point_W_m - centre).dot(pose.axis_W), 0.0,
                                    context.tool.length_m - centre_offset);
    const double distance =
        std::abs((centre + along * pose.axis_W - mark.deepest_point_W_m).norm() - radius);
    if (distance < best_distance) {
      best_distance = distance;
      best = k;
    }
  }
  const double t = production.trajectory_t_s[best];
  const double s = plan_s_at(production.plan, t);
  const std::size_t point = nearest_path_point(context.path, s);
  const int block = context.inputs.path[point].block;
  Json related;
  related["time_s"] = t;
  related["s_mm"] = s * 1e3;
  // The block by file name and line (report.json holds no absolute path).
  related["block"] = "";
  if (block >= 0) {
    const toolpath::SourceBlock& source = context.inputs.toolpath.blocks[static_cast<std::size_t>(block)];
    related["block"] = std::filesystem::path(source.file).filename().string() + ":" + std::to_string(source.line) +
                       (source.block_number >= 0 ? " N" + std::to_string(source.block_number) : "");
  }
  related["line"] = block >= 0 ? context.inputs.toolpath.blocks[static_cast<std::size_t>(block)].line : 0;
  if (block >= 0) {
    // The block as written and its neighbours: the report links each mark to the program.
    const auto& blocks = context.inputs.toolpath.blocks;
    const auto b = static_cast<std::size_t>(block);
    related["block_text"] = blocks[b].text;
    Json excerpt = Json::array();
    for (std::size_t i = b >= 3 ? b - 3 : 0; i < std::min(blocks.size(), b + 4); ++i) {
      if (blocks[i].file != blocks[b].file) continue;
      excerpt.push_back({{"line", blocks[i].line}, {"text", blocks[i].text}});
    }
    related["excerpt"] = excerpt;
  }

  // Each axis's following error at that time, and the tool-tip deviation it alone causes
  // (the direct kinematics with that one axis at its actual position, the others commanded).
  const auto k_servo = static_cast<Eigen::Index>(
      std::lower_bound(production.t_s.begin(), production.t_s.end(), t) - production.t_s.begin());
  const Eigen::VectorXd q_cmd = production.q_cmd.col(std::min<Eigen::Index>(k_servo, production.q_cmd.cols() - 1));
  const Eigen::VectorXd q_act = production.q_actual.col(std::min<Eigen::Index>(k_servo, production.q_actual.cols() - 1));
  const double tool_length_m = context.point_length_m[motion_point_at(context.path.s_m, s)];
  const kinematics::ToolPose commanded = kinematics::forward_kinematics(machine, q_cmd, tool_length_m);
  Json axes = Json::array();
  std::vector<std::pair<double, std::string>> contributions;
  for (std::size_t j = 0; j < machine.axes.size(); ++j) {
    Eigen::VectorXd q = q_cmd;
    q[static_cast<Eigen::Index>(j)] = q_act[static_cast<Eigen::Index>(j)];
    const kinematics::ToolPose moved = kinematics::forward_kinematics(machine, q, tool_length_m);
    const double tip_um = (moved.tip_W_m - commanded.tip_W_m).norm() * 1e6;
    const auto& axis = machine.axes[j];
    const double error = q_cmd[static_cast<Eigen::Index>(j)] - q_act[static_cast<Eigen::Index>(j)];
    Json entry{{"axis", axis.name}, {"tip_deviation_um", tip_um}};
    if (axis.type == kinematics::AxisType::linear) {
      entry["following_error_um"] = error * 1e6;
    } else {
      entry["following_error_mdeg"] = error * 180.0 / std::numbers::pi * 1e3;
    }
    axes.push_back(entry);
    contributions.emplace_back(tip_um, axis.name);
  }
  std::sort(contributions.rbegin(), contributions.rend());
  related["axes"] = axes;
  Json responsible = Json::array();
  for (const auto& [tip_um, axis_name] : contributions) {
    if (tip_um >= 0.25 * contributions.front().first && tip_um > 0.1) responsible.push_back(axis_name);
  }
  related["responsible_axes"] = responsible;

  // The kind of place: within one tool radius of the mark along the path.
  const double window_m = std::max(context.tool.diameter_m / 2, 1e-3);
  Json places = Json::array();
  for (const auto& corner : context.path.corners) {
    if (std::abs(corner.s_m - s) <= window_m) {
      places.push_back("corner");
      break;
    }
  }
  double kappa_min = std::numeric_limits<double>::infinity(), kappa_max = 0.0;
  for (std::size_t i = 0; i < context.path.s_m.size(); ++i) {
    if (std::abs(context.path.s_m[i] - s) > window_m) continue;
    kappa_min = std::min(kappa_min, curvature[i]);
    kappa_max = std::max(kappa_max, curvature[i]);
  }
  // A change of curvature of 10 1/m (a radius of 100 mm appearing or vanishing) or more.
  if (kappa_max - kappa_min >= 10.0) places.push_back("tangency_or_curvature_change");
  const auto& q_plan = production.plan.setpoints.q;
  const auto& s_plan = production.plan.setpoints.s_m;
  for (Eigen::Index j = 0; j < q_plan.rows(); ++j) {
    int last_sign = 0;
    bool reversal = false;
    for (std::size_t k = 1; k < s_plan.size() && !reversal; ++k) {
      if (std::abs(s_plan[k] - s) > window_m) continue;
      const double dq = q_plan(j, static_cast<Eigen::Index>(k)) - q_plan(j, static_cast<Eigen::Index>(k - 1));
      if (std::abs(dq) < 1e-9) continue;
      const int sign = dq > 0 ? 1 : -1;
      reversal = last_sign != 0 && sign != last_sign;
      last_sign = sign;
    }
    if (reversal) {
      places.push_back("reversal of " + machine.axes[static_cast<std::size_t>(j)].name);
    }
  }
  related["place"] = places;
  return related;
}

// One view's comparison: production minus reference, line by line (on demand: nothing is held
// per line of the view), and its marks.
struct ViewComparison {
  const SurfaceView* view = nullptr;
  std::size_t index = 0;  ///< in Context::views and Run::buffers
  std::optional<ViewDeviation> deviation;
  std::size_t steep_lines_excluded = 0;
  // Over every line, row-major: the smallest and largest deviation (and 0) [m], the sum of squares.
  double deviation_min_m = 0.0, deviation_max_m = 0.0, sum_squares_m2 = 0.0;
  removal::StreamedMarkMap marks;
};

Json stage_times(const Run& run) {
  Json times;
  for (const auto& [stage, seconds] : run.stage_seconds) times[stage] = seconds;
  return times;
}

// For each servo sample: true while the plan is on a cutting (non-rapid) move, i.e. the path
// segment that holds s(t) ends at a point that is not a rapid.

Json run_summary(const Run& run) {
  Json summary;
  // Rounded to 1e-6 mm/min: a programmed 3000 mm/min x 10 % is 300, not 300.00000000000006.
  summary["feed_mm_per_min"] = round_to(run.feed_m_per_s * 60e3, 1e-6);
  summary["feed_setting"] =
      run.feed.fixed_m_per_s > 0.0
          ? "every cutting move at feed_mm_per_min"
          : "the programmed feed x " + format_double(run.feed.programmed_factor * 100.0) +
                " % (feed_mm_per_min: the largest)";
  summary["duration_s"] = run.plan.duration_s;
  summary["lower_bound_s"] = run.plan.lower_bound_s;
  summary["setpoint_check_worst_ratio"] = run.plan.check.worst();
  summary["servo_samples"] = run.samples;
  summary["trajectory_poses_cut"] = run.poses_cut;
  summary["stage_seconds"] = stage_times(run);
  Json cuts = Json::array();
  for (const removal::CutStatistics& cut : run.cuts) {
    cuts.push_back({{"segments", cut.segments}, {"sub_segments", cut.sub_segments},
                    {"tiles_visited", cut.tiles_visited}, {"lines_lowered", cut.lines_lowered}});
  }
  summary["removal_per_view"] = cuts;
  summary["plan_notes"] = run.plan.notes;
  summary["axes"] = run.summary["axes"];
  summary["axes_while_cutting"] = run.summary["axes_while_cutting"];
  return summary;
}


// The per-node mark outline mask of a (strided) view.
std::vector<std::uint8_t> mark_mask(const ViewComparison& comparison,
                                    int i0, int i1, int j0, int j1, int stride, int only_label) {
  std::vector<std::uint8_t> mask;
  for (int j = j0; j <= j1; j += stride) {
    for (int i = i0; i <= i1; i += stride) {
      const int label = comparison.marks.labels.at(i, j);
      mask.push_back(only_label < 0 ? (label >= 0 ? 1 : 0) : (label == only_label ? 1 : 0));
    }
  }
  return mask;
}

// A production run against the reference on every view: deviations (steep lines excluded, at
// the view's own line spacing: sphere and cylinder views are coarser than the grid) and marks.
std::vector<ViewComparison> compare_views(const Context& context, const Run& production,
                                          const Run& reference) {
  removal::MarkOptions mark_options;
  mark_options.threshold_m = context.options.mark_threshold_m;
  std::vector<ViewComparison> comparisons(context.views.size());
  for (std::size_t v = 0; v < context.views.size(); ++v) {
    ViewComparison& comparison = comparisons[v];
    comparison.view = &context.views[v];
    comparison.index = v;
    // Steep in either run: a line in the plane of a tool face (a view's row at the floor's
    // height under a flat end) is cut whole or not at all by a rounding of the tool's height.
    comparison.deviation.emplace(production.buffers[v], reference.buffers[v], context.views[v].spacing_m);
    // The marks' row pass also counts the steep lines and sums the view's figures.
    DeviationRows rows(*comparison.deviation);
    removal::DeviationReader reader;
    reader.row = [&](int iv, std::span<double> row_m) {
      const std::span<const double> values = rows.row(iv);
      const std::span<const std::uint8_t> steep = rows.steep_row();
      for (std::size_t iu = 0; iu < values.size(); ++iu) {
        const double d = values[iu];
        row_m[iu] = d;
        comparison.steep_lines_excluded += steep[iu];
        comparison.deviation_min_m = std::min(comparison.deviation_min_m, d);
        comparison.deviation_max_m = std::max(comparison.deviation_max_m, d);
        comparison.sum_squares_m2 += d * d;
      }
    };
    reader.at = [&comparison](int iu, int iv) { return comparison.deviation->at(iu, iv); };
    comparison.marks = removal::find_marks_streamed(production.buffers[v], reader, mark_options);
  }
  return comparisons;
}

// One method's line of the method comparison: cycle time and marks.
Json method_summary(const Context& context, planner::FeedrateMethod method, const Run& production,
                    const std::vector<ViewComparison>& comparisons, const std::vector<double>& curvature) {
  Json summary{{"method", method_name(method)},
               {"duration_s", production.plan.duration_s},
               {"lower_bound_s", production.plan.lower_bound_s},
               {"plan_notes", production.plan.notes}};
  std::size_t count = 0;
  const removal::Mark* deepest = nullptr;
  std::string deepest_view;
  for (const ViewComparison& comparison : comparisons) {
    count += comparison.marks.marks.size();
    if (comparison.marks.marks.empty()) continue;
    if (!deepest || comparison.marks.marks.front().depth_m > deepest->depth_m) {
      deepest = &comparison.marks.marks.front();
      deepest_view = comparison.view->id;
    }
  }
  summary["marks"] = count;
  if (deepest) {
    const Json related = relate_mark(context, production, *deepest, curvature);
    summary["deepest_mark"] = {{"view", deepest_view},
                               {"kind", deepest->kind == removal::MarkKind::gouge ? "gouge" : "excess"},
                               {"depth_um", deepest->depth_m * 1e6},
                               {"area_mm2", deepest->area_m2 * 1e6},
                               {"s_mm", related["s_mm"]},
                               {"place", related["place"]},
                               {"responsible_axes", related["responsible_axes"]}};
  }
  return summary;
}

std::string view_file_suffix(const SurfaceView& view) { return view.zmap ? "" : "_" + view.id; }

// Each view's deviation, marks outlined; the report's first marks on the view labelled with
// their rank, placed without overlap (viz::SurfaceLabel); the ranks labelled and left out go to
// report["renders"]["view_labels"][image] for the caption.
void render_view_surfaces(const Context& context, const Run& production,
                          const std::vector<ViewComparison>& comparisons,
                          const std::filesystem::path& folder, std::vector<std::string>& images, Json& report) {
  constexpr std::size_t kLabelledMarks = 20;  // of the report's order (deepest first)
  for (const ViewComparison& comparison : comparisons) {
    const SurfaceView& view = *comparison.view;
    const removal::NBuffer& buffer = production.buffers[comparison.index];
    const int stride = std::max(1, static_cast<int>(std::ceil(std::sqrt(
                                       static_cast<double>(buffer.line_count()) / 400000.0))));
    const viz::HeightField field = view_height_field(view, buffer, &*comparison.deviation, stride);
    viz::SurfaceRenderOptions options;
    options.title = context.part.name + ": production minus reference" +
                    (view.zmap ? "" : " (" + view.id + ")");
    options.region_mask = mark_mask(comparison, 0, (field.nx - 1) * stride, 0,
                                    (field.ny - 1) * stride, stride, -1);
    if (!view.zmap) options.camera = viz::CameraPreset::top;  // the wall seen along its normal
    std::vector<int> ranks;
    const std::size_t listed = report.contains("marks") ? std::min(report["marks"].size(), kLabelledMarks) : 0;
    for (std::size_t m = 0; m < listed; ++m) {
      const Json& entry = report["marks"][m];
      const auto index = entry["view_mark_index"].get<std::size_t>();
      if (entry["view"].get<std::string>() != view.id || index >= comparison.marks.marks.size()) continue;
      // At the mark's deepest line (the bounding box's centre may lie off an L-shaped mark).
      const removal::Mark& mark = comparison.marks.marks[index];
      int deepest_iu = (mark.iu_min + mark.iu_max) / 2, deepest_iv = (mark.iv_min + mark.iv_max) / 2;
      double deepest = -1.0;
      for (int iv = mark.iv_min; iv <= mark.iv_max; ++iv) {
        for (int iu = mark.iu_min; iu <= mark.iu_max; ++iu) {
          if (comparison.marks.labels.at(iu, iv) != static_cast<int>(index)) continue;
          const double depth_m = std::abs(comparison.deviation->at(iu, iv));
          if (depth_m > deepest) {
            deepest = depth_m;
            deepest_iu = iu, deepest_iv = iv;
          }
        }
      }
      const int rank = entry.value("rank", static_cast<int>(m + 1));
      options.labels.push_back({field.origin_x_m + deepest_iu * view.spacing_m,
                                field.origin_y_m + deepest_iv * view.spacing_m, std::to_string(rank)});
      ranks.push_back(rank);
    }
    const std::string name = "surface_deviation" + view_file_suffix(view) + ".png";
    const viz::SurfaceRenderResult result = viz::render_surface_png((folder / name).string(), field, options);
    images.push_back(name);
    if (!ranks.empty()) {
      Json left_out = Json::array();
      for (std::size_t k : result.labels_left_out) left_out.push_back(ranks[k]);
      report["renders"]["view_labels"][name] = {{"labelled", ranks}, {"left_out", left_out}};
    }
  }
}

// A close-up of the deepest mark over all views (the first of `comparisons` that holds it).
// A close-up of one mark: its region outlined, the tool's size around it.
void render_mark(const Context& context, const Run& production, const ViewComparison& comparison,
                 const removal::Mark& mark, const std::string& title, const viz::ImageSize& size,
                 const std::filesystem::path& png_path) {
  const SurfaceView& view = *comparison.view;
  const removal::NBuffer& buffer = production.buffers[comparison.index];
  // The mark's whole bounding box and the tool's size around it, however large the mark.
  const LineWindow window = mark_close_up_window(mark.iu_min, mark.iu_max, mark.iv_min, mark.iv_max, buffer.nu(),
                                                 buffer.nv(), view.spacing_m,
                                                 std::max(2e-3, 2 * context.tool.diameter_m));
  const int i0 = window.iu_first, i1 = window.iu_last, j0 = window.iv_first, j1 = window.iv_last;
  // At most 4 M nodes (about 400 MB in the render), several times the image's pixels.
  const int stride = close_up_stride(window, 4.0e6);
  const viz::HeightField crop = view_height_field_window(view, buffer, *comparison.deviation, window, stride);
  viz::SurfaceRenderOptions options;
  options.title = title;
  options.size = size;
  // This mark's outline (its label is its place in the view's list), not the view's deepest.
  const int label = static_cast<int>(&mark - comparison.marks.marks.data());
  options.region_mask = mark_mask(comparison, i0, i1, j0, j1, stride, label);
  viz::render_surface_png(png_path.string(), crop, options);
}

void render_worst_mark(const Context& context, const Run& production, const ViewComparison& comparison,
                       const std::filesystem::path& folder, std::vector<std::string>& images) {
  const removal::Mark& worst = comparison.marks.marks.front();
  render_mark(context, production, comparison, worst,
              "Deepest mark: " + format_double(round_to(worst.depth_m * 1e6, 0.1)) + " um" +
                  (comparison.view->zmap ? "" : " (" + comparison.view->id + ")"),
              {1000, 800}, folder / "worst_mark.png");
  images.push_back("worst_mark.png");
}

// A small close-up of each of the first marks of the report (mark_<rank>.png), shown in the
// marks table; the mark's report entry gets its "thumbnail".
void render_mark_thumbnails(const Context& context, const Run& production,
                            const std::vector<ViewComparison>& comparisons, const std::filesystem::path& folder,
                            Json& report) {
  constexpr std::size_t kThumbnails = 5;
  if (!report.contains("marks")) return;
  for (std::size_t m = 0; m < std::min<std::size_t>(report["marks"].size(), kThumbnails); ++m) {
    Json& entry = report["marks"][m];
    const std::string view_id = entry["view"].get<std::string>();
    const std::size_t index = entry["view_mark_index"].get<std::size_t>();
    for (const ViewComparison& comparison : comparisons) {
      if (comparison.view->id != view_id || index >= comparison.marks.marks.size()) continue;
      const std::string name = "mark_" + std::to_string(m + 1) + ".png";
      render_mark(context, production, comparison, comparison.marks.marks[index],
                  "Mark " + std::to_string(m + 1) + ": " + format_double(round_to(entry["depth_um"].get<double>(), 0.1)) +
                      " um",
                  {480, 360}, folder / name);
      entry["thumbnail"] = name;
    }
  }
}

// Whether the reference run cut any line of any view (stops at the first).
bool any_line_machined(const Context& context, const Run& reference, const std::vector<ViewComparison>& comparisons) {
  for (const ViewComparison& comparison : comparisons) {
    const removal::NBuffer& uncut = context.uncut[comparison.index];
    const removal::NBuffer& cut = reference.buffers[comparison.index];
    for (int iv = 0; iv < cut.nv(); ++iv) {
      for (int iu = 0; iu < cut.nu(); ++iu) {
        if (cut.length(iu, iv) < uncut.length(iu, iv) - 1e-9) return true;
      }
    }
  }
  return false;
}

void write_renders(const Context& context, const Run& production, const Run& reference,
                   const std::vector<ViewComparison>& comparisons, const std::filesystem::path& folder,
                   Json& report, std::vector<std::string>& images) {
  std::string why_not;
  if (!context.options.renders) {
    report["renders"]["skipped"] = "--no-renders";
    return;
  }
  if (!viz::display_available(why_not)) {
    report["renders"]["skipped"] = why_not;
    context.progress("renders skipped: " + why_not);
    return;
  }
  render_view_surfaces(context, production, comparisons, folder, images, report);
  const ViewComparison* worst = nullptr;
  for (const ViewComparison& comparison : comparisons) {
    if (comparison.marks.marks.empty()) continue;
    if (!worst || comparison.marks.marks.front().depth_m > worst->marks.marks.front().depth_m) {
      worst = &comparison;
    }
  }
  if (worst) render_worst_mark(context, production, *worst, folder, images);
  render_mark_thumbnails(context, production, comparisons, folder, report);
  // Where the marks are along the path (the first ones in the report's order), for markers.
  std::vector<double> mark_s_m;
  if (report.contains("marks")) {
    for (const auto& mark : report["marks"]) {
      if (mark_s_m.size() == 10) break;
      mark_s_m.push_back(mark["s_mm"].get<double>() * 1e-3);
    }
  }
  // Feedrate along s: programmed, limit, planned and actual (production run), over the whole
  // path (decimated to about 20 000 points a curve) and zoomed on each of the three deepest marks.
  const auto& profile = production.plan.profile;
  const auto feed_plot = [&](double s_from, double s_to, const std::string& title, const std::string& name) {
    viz::FeedratePlotInput feed;
    feed.title = title;
    auto in_window = [&](double s) { return s >= s_from && s <= s_to; };
    std::size_t inside = 0;
    for (double s_m : profile.s_m) inside += in_window(s_m) ? 1 : 0;
    const std::size_t step = std::max<std::size_t>(1, inside / 20000);
    std::size_t counter = 0;
    for (std::size_t i = 0; i < profile.s_m.size(); ++i) {
      if (!in_window(profile.s_m[i]) || counter++ % step != 0) continue;
      feed.limit.x.push_back(profile.s_m[i]);
      feed.limit.y.push_back(std::min(profile.sd_lim[i], 2 * production.feed_m_per_s));
      feed.planned.x.push_back(profile.s_m[i]);
      feed.planned.y.push_back(profile.sd[i]);
    }
    if (feed.planned.x.empty()) return;
    feed.programmed.x = {std::max(profile.s_m.front(), s_from), std::min(profile.s_m.back(), s_to)};
    feed.programmed.y = {production.feed_m_per_s, production.feed_m_per_s};
    std::size_t actual_inside = 0;
    for (double t : production.trajectory_t_s) actual_inside += in_window(plan_s_at(production.plan, t)) ? 1 : 0;
    const std::size_t actual_step = std::max<std::size_t>(1, actual_inside / 20000);
    counter = 0;
    for (std::size_t k = 1; k < production.trajectory.size(); ++k) {
      const double dt = production.trajectory_t_s[k] - production.trajectory_t_s[k - 1];
      if (dt <= 0) continue;
      const double s_actual = plan_s_at(production.plan, production.trajectory_t_s[k]);
      if (!in_window(s_actual) || counter++ % actual_step != 0) continue;
      feed.actual.x.push_back(s_actual);
      feed.actual.y.push_back((production.trajectory[k].tip_W_m - production.trajectory[k - 1].tip_W_m).norm() / dt);
    }
    viz::plot_feedrate((folder / name).string(), feed);
    images.push_back(name);
  };
  feed_plot(-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
            context.part.name + ": feedrate along the whole path (production run)", "feedrate.png");
  for (std::size_t m = 0; m < std::min<std::size_t>(mark_s_m.size(), 3); ++m) {
    feed_plot(mark_s_m[m] - 0.03, mark_s_m[m] + 0.03,
              context.part.name + ": feedrate within 30 mm of mark " + std::to_string(m + 1) + " (at s = " +
                  format_double(std::round(mark_s_m[m] * 1e4) / 10) + " mm)",
              "feedrate_mark_" + std::to_string(m + 1) + ".png");
  }

  // Following error of each axis along s, cutting moves only (rapids run at the axes' own limits,
  // alike in both runs); a rotary axis whose error stays at the level of numerical noise while
  // cutting is left out (its scale would show nothing but that noise).
  const auto& machine = context.inputs.machine;
  const std::vector<bool> cutting = cutting_samples(context, production);
  std::size_t cutting_count = 0;
  for (bool c : cutting) cutting_count += c ? 1 : 0;
  if (cutting_count > 1) {
    viz::AlongPathPlotInput along;
    along.title = "Following error while cutting (production run)";
    const std::size_t step = std::max<std::size_t>(1, cutting_count / 20000);
    std::vector<std::string> quiet_axes;
    bool any_linear = false, any_rotary = false;
    for (std::size_t j = 0; j < machine.axes.size(); ++j) {
      const bool rotary = machine.axes[j].type == kinematics::AxisType::rotary;
      const double to_display = rotary ? 180.0 / std::numbers::pi * 1e3 : 1e6;  // mdeg or um
      viz::Series series;
      series.name = machine.axes[j].name + (rotary ? " [mdeg]" : " [um]");
      series.style = rotary ? viz::LineStyle::dashed : viz::LineStyle::solid;
      series.right_axis = rotary;
      double peak = 0.0;
      std::size_t counter = 0;
      for (std::size_t k = 0; k < production.samples; ++k) {
        if (!cutting[k] || counter++ % step != 0) continue;
        const double error = production.q_cmd(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(k)) -
                             production.q_actual(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(k));
        peak = std::max(peak, std::abs(error * to_display));
        series.x.push_back(plan_s_at(production.plan, production.t_s[k]));
        series.y.push_back(error * to_display);
      }
      if (rotary && peak < 1e-3) {
        quiet_axes.push_back(machine.axes[j].name);
        continue;
      }
      any_linear = any_linear || !rotary;
      any_rotary = any_rotary || rotary;
      along.series.push_back(std::move(series));
    }
    if (!any_linear) {
      for (viz::Series& series : along.series) series.right_axis = false;
    }
    along.y_title = any_linear ? "linear axes [um]" : "rotary axes [mdeg]";
    if (any_linear && any_rotary) along.y2_title = "rotary axes [mdeg]";
    if (!quiet_axes.empty()) {
      std::string names;
      for (const std::string& name : quiet_axes) names += (names.empty() ? "" : ", ") + name;
      along.title += "; " + names + ": below 0.001 mdeg, not shown";
    }
    along.markers_s_m = mark_s_m;
    if (!along.series.empty()) {
      viz::plot_along_path((folder / "following_error.png").string(), along);
      images.push_back("following_error.png");
    }
    // The production surface's deviation from the reference at the tool tip (the Z-map line
    // under it): where along the program the floor and 3-axis surfaces are marked.
    const removal::NBuffer& zmap = production.buffers[0];
    if (zmap.is_zmap() && context.views[0].zmap) {
      viz::AlongPathPlotInput deviation;
      deviation.title = "Production minus reference surface under the tool tip (Z-map)";
      deviation.y_title = "deviation [um]";
      viz::Series series;
      series.name = "under the tip";
      const std::size_t pose_step = std::max<std::size_t>(1, production.trajectory.size() / 20000);
      const Eigen::Vector3d origin = zmap.zmap_origin_m();
      for (std::size_t k = 0; k < production.trajectory.size(); k += pose_step) {
        const Eigen::Vector3d& tip = production.trajectory[k].tip_W_m;
        const long iu = std::lround((tip.x() - origin.x()) / zmap.spacing_m());
        const long iv = std::lround((tip.y() - origin.y()) / zmap.spacing_m());
        if (iu < 0 || iv < 0 || iu >= zmap.nu() || iv >= zmap.nv()) continue;
        const double d = comparisons[0].deviation->at(static_cast<int>(iu), static_cast<int>(iv));
        if (!std::isfinite(d)) continue;
        series.x.push_back(plan_s_at(production.plan, production.trajectory_t_s[k]));
        series.y.push_back(d * 1e6);
      }
      deviation.series.push_back(std::move(series));
      deviation.markers_s_m = mark_s_m;
      if (deviation.series.front().x.size() > 1) {
        viz::plot_along_path((folder / "deviation_along_path.png").string(), deviation);
        images.push_back("deviation_along_path.png");
      }
    }
  }
  // Histogram over the lines the reference run cut, in every view (walked twice, row by row).
  const auto machined_deviations_m = [&](const std::function<void(double)>& visit) {
    for (const ViewComparison& comparison : comparisons) {
      const removal::NBuffer& uncut = context.uncut[comparison.index];
      const removal::NBuffer& cut = reference.buffers[comparison.index];
      DeviationRows rows(*comparison.deviation);
      for (int iv = 0; iv < cut.nv(); ++iv) {
        const std::span<const double> row_m = rows.row(iv);
        for (int iu = 0; iu < cut.nu(); ++iu) {
          if (cut.length(iu, iv) < uncut.length(iu, iv) - 1e-9) visit(row_m[static_cast<std::size_t>(iu)]);
        }
      }
    }
  };
  if (any_line_machined(context, reference, comparisons)) {
    viz::plot_walked_deviation_histogram((folder / "deviation_histogram.png").string(), machined_deviations_m, 60,
                                  context.part.name + ": production minus reference, machined lines",
                                  {}, true);
    images.push_back("deviation_histogram.png");
  }
  report["renders"]["images"] = images;
}

}  // namespace

// Paths in the report (it is forwarded: no absolute path). The part file as given when relative
// and inside the current folder, else its folder's name and its own; the files the part file
// names, relative to the part file's folder when inside it, else by their names.
std::string part_path_for_report(const std::string& part_path) {
  const std::filesystem::path given(part_path);
  const std::filesystem::path normal = given.lexically_normal();
  if (given.is_relative() && !normal.empty() && *normal.begin() != "..") return normal.string();
  const std::filesystem::path absolute = std::filesystem::absolute(given).lexically_normal();
  return (absolute.parent_path().filename() / absolute.filename()).string();
}

std::string path_for_report(const std::string& path, const std::string& part_path) {
  if (path.empty()) return path;
  const std::filesystem::path part_folder = std::filesystem::absolute(part_path).lexically_normal().parent_path();
  const std::filesystem::path relative =
      std::filesystem::absolute(path).lexically_normal().lexically_relative(part_folder);
  // A file outside the part's folder: its name (the path above it says where the sender keeps
  // it, nothing about the part).
  if (relative.empty() || *relative.begin() == "..") return std::filesystem::path(path).filename().string();
  return relative.string();
}

std::string millimetres_text(double metres) { return format_double(std::round(metres * 1e7) / 1e4); }

// What the report's 3-D view shows: every view's production surface, its deviation and marks,
// and the programmed path to name the nearest block of a picked point.
View3dInputs view3d_inputs(const Context& context, const Run& production,
                           const std::vector<ViewComparison>& comparisons, const Json& curated) {
  View3dInputs inputs;
  for (std::size_t v = 0; v < context.views.size(); ++v) {
    const removal::NBuffer& buffer = production.buffers[v];
    const removal::NBuffer& uncut = context.uncut[v];
    View3dInput view;
    view.id = context.views[v].id;
    view.title = context.views[v].title;
    view.nu = buffer.nu();
    view.nv = buffer.nv();
    view.surface_point_W_m = [&buffer](int iu, int iv) { return buffer.surface_point(iu, iv); };
    const ViewDeviation& deviation = *comparisons[v].deviation;
    view.deviation_m_at = [&deviation](int iu, int iv) { return deviation.at(iu, iv); };
    // Usable where the stock ever reached.
    auto rows = std::make_shared<DeviationRows>(deviation);
    view.rows = [rows, &uncut](int iv, std::span<double> row_m, std::span<std::uint8_t> usable) {
      const std::span<const double> values = rows->row(iv);
      std::copy(values.begin(), values.end(), row_m.begin());
      for (std::size_t iu = 0; iu < usable.size(); ++iu) usable[iu] = uncut.length(static_cast<int>(iu), iv) > 0.0 ? 1 : 0;
    };
    const removal::SparseMarkLabels& labels = comparisons[v].marks.labels;
    view.mark_label_at = [&labels](int iu, int iv) { return labels.at(iu, iv); };
    inputs.views.push_back(std::move(view));
  }
  const std::vector<bool> rapid_end = rapid_ends(context.inputs);
  for (std::size_t k = 0; k < context.inputs.path.size(); ++k) {
    const kinematics::ToolPose& pose = context.inputs.path[k].pose;
    const double corner_radius_m = k < context.point_tools.size() ? context.point_tools[k].corner_radius() : 0.0;
    inputs.path_centre_W_m.push_back(pose.tip_W_m + corner_radius_m * pose.axis_W);
    inputs.path_block.push_back(context.inputs.path[k].block);
    inputs.path_cutting.push_back(k < rapid_end.size() ? !rapid_end[k] : true);
  }
  for (const toolpath::SourceBlock& block : context.inputs.toolpath.blocks) {
    inputs.blocks.push_back({std::filesystem::path(block.file).filename().string(), block.line, block.block_number,
                             block.text});
  }
  inputs.curated_marks = curated;
  inputs.mark_threshold_um = context.options.mark_threshold_m * 1e6;
  return inputs;
}

// What the run was: the report's "context" (shown at the top of report.html).
Json report_context(const Context& context, const FeedSetting& production_feed, const FeedSetting& reference_feed) {
  const SimulatePartOptions& options = context.options;
  Json out;
  out["part_file"] = part_path_for_report(options.part_path);
  out["machine"] = context.inputs.machine.name + " (" +
                   path_for_report(context.inputs.machine.source_file, options.part_path) + ")";
  out["toolpath"] = path_for_report(context.part.toolpath_path, options.part_path);
  const char* type = context.tool.type == removal::ToolType::ball           ? "ball-end"
                     : context.tool.type == removal::ToolType::flat         ? "flat-end"
                     : context.tool.type == removal::ToolType::bull         ? "bull-nose"
                     : context.tool.type == removal::ToolType::v            ? "V"
                     : context.tool.type == removal::ToolType::tapered_flat ? "tapered flat-end"
                                                                            : "tapered ball-end";
  out["tool"] = std::string(type) + " mill, diameter " + millimetres_text(context.tool.diameter_m) +
                " mm, corner radius " + millimetres_text(context.tool.corner_radius()) + " mm, length " +
                millimetres_text(context.part.tool.length_m) + " mm (cutting body " +
                millimetres_text(context.tool.length_m) + " mm)";
  const auto corner = [](const Eigen::Vector3d& v) {
    return "(" + millimetres_text(v.x()) + ", " + millimetres_text(v.y()) + ", " + millimetres_text(v.z()) + ")";
  };
  out["stock"] = (context.stock.mesh ? "mesh " + path_for_report(context.part.stock_stl_path, options.part_path) +
                                           ", within the box "
                                     : std::string("box ")) +
                 corner(context.stock.bounds.min_W_m) + " to " + corner(context.stock.bounds.max_W_m) + " mm";
  // A fixed feed, or the program's feeds times a factor, and where that came from.
  const auto feed_text = [](const FeedSetting& feed, bool from_command_line, const char* option) {
    const std::string source = from_command_line ? std::string(option) : std::string("part file");
    if (feed.fixed_m_per_s > 0) {
      return format_double(std::round(feed.fixed_m_per_s * 60e4) / 10.0) + " mm/min on every cutting move (" +
             source + ")";
    }
    return "the program's feeds x " + format_double(std::round(feed.programmed_factor * 1e5) / 1e3) +
           " % (part file; rapids at the axes' limits)";
  };
  out["production_feed"] = feed_text(production_feed, options.production_feed_m_per_s > 0, "--feed-mm-per-min");
  out["reference_feed"] =
      feed_text(reference_feed, options.reference_feed_m_per_s > 0, "--reference-feed-mm-per-min");
  out["planning"] = method_name(options.method) + std::string(context.nc.third_order ? ", jerk / torque-rate limits"
                                                                                      : ", no jerk limit") +
                    " (" + context.nc.jerk.source + ")" +
                    (context.third_order_fell_back ? "; the third-order planner failed: planned without jerk limits "
                                                     "(see the runs' notes)"
                                                   : "") +
                    (options.perfect_drives ? ", perfect drives (no servo)" : "");
  out["corners"] = !options.corner_tolerance_override
                       ? std::string("as the program asks (G61 / G9 exact stop, G64 P / G5.1 / G187 blending; "
                                     "840D G60 / G9, G641 ADIS, G642 / CYCLE832), exact stop where it says nothing")
                   : options.corner_tolerance_m > 0
                       ? "blended within " + millimetres_text(options.corner_tolerance_m) + " mm at every corner"
                       : std::string("exact stop at every corner");
  out["grid"] = format_double(options.grid_m * 1e6) + " um line spacing; marks deeper than " +
                format_double(options.mark_threshold_m * 1e6) + " um";
  const std::time_t now = std::time(nullptr);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M:%S UTC", std::gmtime(&now));
  out["date_utc"] = date;
  out["vmsim_version"] = VMSIM_VERSION;
  out["command_line"] = options.command_line;
  out["nc_modes"] = context.nc.lines();
  return out;
}

Json simulate_part(const SimulatePartOptions& options, const ProgressSink& progress) {
  const Clock::time_point start = Clock::now();
  Json report;
  Json stage_seconds;
  auto stage_clock = Clock::now();
  // CPU (user + system) and the peak resident memory so far at each stage's end, beside the
  // wall times (bench/scaling: the growth law of each stage).
  Json stage_cpu_seconds, stage_peak_rss_mib;
  const double cpu_start = cpu_seconds();
  double stage_cpu = cpu_start;
  const auto end_stage = [&](const std::string& stage) {
    stage_seconds[stage] = seconds_since(stage_clock);
    stage_cpu_seconds[stage] = cpu_seconds() - stage_cpu;
    stage_peak_rss_mib[stage] = peak_rss_mib();
  };

  ChainInputOptions chain_options;
  chain_options.part_path = options.part_path;
  chain_options.corner_tolerance_m = options.corner_tolerance_m;
  chain_options.corner_tolerance_override = options.corner_tolerance_override;
  chain_options.compressor_tolerance_override_m = options.compressor_tolerance_override_m;
  const Ranks& ranks = Ranks::world();
  Context context{options, progress, load_part(options.part_path), load_chain_inputs(chain_options), {}, {}, {}, {}, {}, {}, ranks, {}, {}, {}, false, {}};
  NcModeCommandLine nc_command_line;
  nc_command_line.third_order = options.third_order;
  nc_command_line.third_order_option = options.third_order && *options.third_order ? "--third-order" : "--no-third-order";
  nc_command_line.feedforward = options.feedforward;
  nc_command_line.corner_override = options.corner_tolerance_override;
  nc_command_line.corner_tolerance_m = options.corner_tolerance_m;
  nc_command_line.compressor_override = !std::isnan(options.compressor_tolerance_override_m);
  nc_command_line.compressor_tolerance_m = nc_command_line.compressor_override ? options.compressor_tolerance_override_m : 0.0;
  nc_command_line.compression = context.inputs.compression;
  context.nc = decide_nc_modes(context.inputs.toolpath, nc_command_line);
  if (context.nc.feedforward) context.servo_machine = with_feedforward(context.inputs.machine, *context.nc.feedforward);
  for (const std::string& line : context.nc.lines()) progress("NC mode: " + line);
  // The output folder is checked (and its staging folder made) before any computation: a bad
  // --out fails at once, and nothing the user owns is ever replaced.
  // Only rank 0 touches the output folder (mpi_ranks.hpp).
  std::optional<OutputFolder> output;
  if (ranks.root()) {
    output.emplace(options.out_dir,
                   std::vector<std::string>{options.part_path, context.part.machine_path, context.part.toolpath_path,
                                            context.part.stock_stl_path, context.inputs.machine.source_file},
                   ResultOrigin{"simulate-part", VMSIM_VERSION});
  }
  if (context.part.stock_mesh) {
    context.stock = {context.part.stock_mesh->bounds(), &*context.part.stock_mesh};
  } else if (context.part.stock) {
    context.stock = {{context.part.stock->min_W_m, context.part.stock->max_W_m}, nullptr};
  } else if (const auto& box = context.inputs.toolpath.stock_box) {
    context.stock = {{box->min_W_m, box->max_W_m}, nullptr};  // the program's (Heidenhain BLK FORM)
  } else {
    throw InputError(options.part_path +
                     ": simulate-part needs a stock (stock: {box: {min_mm, max_mm}} or {stl: <file>}, "
                     "or a BLK FORM in a Heidenhain program)");
  }
  context.tool = removal_tool(context.part.tool);
  context.point_tools = point_tools(context.part, context.inputs);
  context.point_length_m = point_tool_lengths_m(context.inputs);
  for (const std::string& warning : context.inputs.warnings) progress("warning: " + warning);
  const FeedSetting production_feed = options.production_feed_m_per_s > 0
                                          ? FeedSetting{options.production_feed_m_per_s, 0.0}
                                          : context.part.production_feed;
  const FeedSetting reference_feed = options.reference_feed_m_per_s > 0
                                         ? FeedSetting{options.reference_feed_m_per_s, 0.0}
                                         : context.part.reference_feed;
  if (!context.inputs.tool_roll.empty()) progress(context.inputs.tool_roll);
  progress("part " + context.part.name + ": " + std::to_string(context.inputs.path.size()) +
           " path points; inverse kinematics ...");
  context.path = kinematics::solve_path_kinematics(context.inputs.machine, context.inputs.path,
                                                   context.inputs.q_start,
                                                   context.inputs.tool_length_m,
                                                   context.inputs.block_names,
                                                   context.inputs.path_kinematics);
  end_stage("load_and_inverse_kinematics");

  stage_clock = Clock::now();
  stage_cpu = cpu_seconds();
  progress("stock" + std::string(context.stock.mesh ? " (" + context.part.stock_stl_path + ")" : "") + " ...");
  std::vector<Eigen::Vector3d> cutting_tips;
  for (std::size_t i = 0; i < context.inputs.path.size(); ++i) {
    const auto& point = context.inputs.toolpath.points[context.inputs.toolpath_point[i]];
    if (point.kind != toolpath::MotionKind::rapid) cutting_tips.push_back(point.tip_W_m);
  }
  context.views = surface_views(context.part, context.stock.bounds, options.grid_m, cutting_tips,
                                context.tool.diameter_m);
  removal::MeshZmapReport mesh_report;
  for (const SurfaceView& view : context.views) {  // the Z-map first: the others clip to it
    if (view.zmap && !context.stock.mesh) {
      // A box stock's Z-map that will be held compact is made so at once: never 8 B a line on
      // the way (3.2 GB for the 80 x 500 mm die at 10 um, on every MPI rank).
      removal::NBuffer zmap = removal::NBuffer::compact_zmap(context.stock.bounds, view.spacing_m);
      context.uncut.push_back(zmap.line_count() > options.compact_zmap_above_lines ? std::move(zmap)
                                                                                    : view.fresh_buffer(context.stock));
      continue;
    }
    context.uncut.push_back(view.fresh_buffer(context.stock, view.zmap ? &mesh_report : nullptr,
                                              context.uncut.empty() ? nullptr : &context.uncut.front()));
  }
  // A large Z-map keeps compact heights (every run's copy too), made after the other views
  // were clipped to it (a mesh stock's; a box stock's is made compact above).
  if (context.views.front().zmap && context.uncut.front().line_count() > options.compact_zmap_above_lines) {
    context.uncut.front().make_compact();
  }
  // Several ranks: each view split into bands of tile rows (the Z-map's balanced by the cutting
  // moves over its rows); ranks other than 0 keep only their band of the uncut buffers.
  for (std::size_t v = 0; v < context.views.size(); ++v) {
    const removal::NBuffer& uncut = context.uncut[v];
    context.bands.push_back(
        ranks.distributed()
            ? view_bands(uncut, ranks,
                         uncut.is_zmap() ? zmap_row_weights(uncut, cutting_tips, context.tool.diameter_m / 2)
                                         : std::vector<double>{})
            : ViewBands{});
    if (ranks.distributed() && !ranks.root()) context.uncut[v] = rank_share(uncut, context.bands[v], ranks);
  }
  const auto millimetres = [](const Eigen::Vector3d& v) { return Json{v.x() * 1e3, v.y() * 1e3, v.z() * 1e3}; };
  report["stock"] = {{"min_mm", millimetres(context.stock.bounds.min_W_m)},
                     {"max_mm", millimetres(context.stock.bounds.max_W_m)}};
  report["removal_tool_length_mm"] = context.tool.length_m * 1e3;
  if (context.stock.mesh) {
    report["stock"]["stl"] = path_for_report(context.part.stock_stl_path, options.part_path);
    report["stock"]["triangles"] = context.stock.mesh->triangles.size();
    report["stock"]["zmap_lines_outside_the_mesh"] = mesh_report.lines_missing;
    report["stock"]["zmap_lines_filled_below"] = mesh_report.lines_filled;
  }
  end_stage("stock");

  // The reference run's path stages (plan, servo, direct kinematics: streamed, a few per cent
  // of the job), its actual tool's deviation from the commanded path measured on the way
  // (README, "A cheaper reference"). Where that bounds the line heights closely enough, the
  // planned tool path's surface is the reference and the reference run is never cut.
  const ReferenceMode mode = options.reference_mode;
  Run reference = simulate_path_stages(context, "reference", reference_feed, options.method, false, true,
                                       mode != ReferenceMode::commanded);
  // Its traces and set points are gone: their memory goes back to the system, or it would
  // stay under every later stage (vmsim keeps freed memory in the process, common/memory.hpp).
  return_freed_memory_to_system();
  {
    // Rank 0's figures on every rank (the same stages give the same figures; all decide alike).
    std::vector<double> figures{reference.path_deviation_m, reference.path_deviation_t_s};
    ranks.broadcast(figures);
    reference.path_deviation_m = figures[0], reference.path_deviation_t_s = figures[1];
  }
  const double steep_factor = steep_line_factor(kSteepStepPerSpacing);
  const double surface_bound_m = steep_factor * reference.path_deviation_m;
  const double commanded_limit_m = options.commanded_reference_fraction * options.mark_threshold_m;
  const bool use_commanded = mode == ReferenceMode::commanded ||
                             (mode == ReferenceMode::automatic && surface_bound_m <= commanded_limit_m);
  const auto um_text = [](double metres) { return format_double(std::round(metres * 1e9) / 1e3); };
  const std::string bound_text =
      "the reference run's tool stays within " + um_text(reference.path_deviation_m) +
      " um of the planned tool path (tip, and axis turn x tool reach; largest at s = " +
      format_double(std::round(plan_s_at(reference.plan, reference.path_deviation_t_s) * 1e6) / 1e3) +
      " mm): line heights within " + format_double(std::round(steep_factor * 1e3) / 1e3) + " x that = " +
      um_text(surface_bound_m) + " um where not steep";
  std::string why = mode == ReferenceMode::commanded   ? "--reference commanded"
                    : mode == ReferenceMode::simulated ? "--reference simulated"
                    : use_commanded ? "bound " + um_text(surface_bound_m) + " um within " +
                                          format_double(options.commanded_reference_fraction * 100) +
                                          " % of the mark threshold (" + um_text(commanded_limit_m) + " um)"
                                    : "bound " + um_text(surface_bound_m) + " um above " +
                                          format_double(options.commanded_reference_fraction * 100) +
                                          " % of the mark threshold (" + um_text(commanded_limit_m) +
                                          " um): the reference run is cut";
  report["reference"] = {{"used", use_commanded ? "commanded" : "simulated"},
                         {"option", mode == ReferenceMode::commanded   ? "commanded"
                                    : mode == ReferenceMode::simulated ? "simulated"
                                                                       : "auto"},
                         {"why", why},
                         {"path_deviation_um", reference.path_deviation_m * 1e6},
                         {"path_deviation_at_s_mm", plan_s_at(reference.plan, reference.path_deviation_t_s) * 1e3},
                         {"poses_matched", reference.path_deviation_poses},
                         {"steep_factor", steep_factor},
                         {"surface_bound_um", surface_bound_m * 1e6},
                         {"commanded_limit_um", commanded_limit_m * 1e6},
                         {"commanded_limit_fraction", options.commanded_reference_fraction}};
  progress("reference: " + std::string(use_commanded ? "the planned tool path's surface" : "the simulated run") +
           " (" + why + "); " + bound_text);
  // The reference is checked at once, before the production run: a reference that is no valid
  // reference stops the job before the rest is computed, and the commanded path's buffers are
  // gone before the production run's are made (two Z-maps alive at once, not three).
  ValidityCheck reference_check;
  Json commanded_figures = Json::object();
  if (!use_commanded) {
    cut_run(context, reference);
    // Its thinned poses are cut: nothing later reads them (the die at 10 um: 161 252 s of
    // reference machine time).
    reference.trajectory = {};
    reference.trajectory_t_s = {};
  }
  if (use_commanded) {
    // One removal: the planned tool path's, which is the reference (within the bound) and so
    // needs no check against itself; the bound is the check.
    reference.trajectory = {};
    reference.trajectory_t_s = {};
    {
      StageTimer timer(reference, "removal", progress);
      std::vector<removal::Pose> poses;
      std::vector<std::size_t> pose_point;
      commanded_poses(context, reference.plan.path, poses, pose_point);
      reference.poses_cut = poses.size();
      for (std::size_t v = 0; v < context.views.size(); ++v) {
        removal::CutStatistics cut;
        reference.buffers.push_back(cut_commanded_view(context, poses, pose_point, v, &cut));
        reference.cuts.push_back(cut);
      }
    }
    reference_check = check_reference_by_bound(
        surface_bound_m, options.mark_threshold_m, "the planned tool path's surface is the reference: " + bound_text);
    if (reference_check.status == CheckStatus::passed && surface_bound_m > commanded_limit_m) {
      reference_check.status = CheckStatus::warning;
      reference_check.detail += "; above " + format_double(options.commanded_reference_fraction * 100) +
                                " % of the threshold: marks within the bound of it may be misjudged "
                                "(--reference simulated cuts the reference run)";
    }
    commanded_figures["reference_vs_commanded_max_um"] = surface_bound_m * 1e6;
    progress(check_line(reference_check));
    if (reference_check.status == CheckStatus::failed) {
      throw InfeasibleError("the planned tool path's surface is no valid reference: " + check_line(reference_check) +
                            ". Lower the reference feed (--reference-feed-mm-per-min) or cut the reference run "
                            "(--reference simulated or auto)");
    }
  } else if (options.commanded_check && surface_bound_m <= options.mark_threshold_m) {
    // The bound settles the check: no removal of the planned path.
    reference_check = check_reference_by_bound(surface_bound_m, options.mark_threshold_m,
                                               "from the bound, the planned path not cut: " + bound_text);
    commanded_figures["reference_vs_commanded_max_um"] = surface_bound_m * 1e6;
    progress(check_line(reference_check));
  } else if (options.commanded_check) {
    // The reference against the planned tool path's own surface: what the low feed changes.
    // A reference that differs from it by more than the mark threshold is no reference: marks
    // (or a path error common to both runs) could hide in it.
    stage_clock = Clock::now();
    stage_cpu = cpu_seconds();
    progress("planned tool path surface (check of the reference) ...");
    // The commanded path is the planner's: its spline through the program's points and the ones
    // it added, which the set-point check has held to the program (within the path tolerance,
    // or the program's contour tolerance where it gives one). Both runs share this geometry;
    // only its timing differs. Cutting the programmed polyline instead charged the planner's
    // allowed deviation to the reference: 3.6 um under CYCLE832(0.005) showed as 10.6 um on a
    // steep flank and stopped a valid program.
    std::vector<removal::Pose> poses;
    std::vector<std::size_t> pose_point;
    commanded_poses(context, reference.plan.path, poses, pose_point);
    // Judged as marks are: regions of at least MarkOptions::min_lines connected lines beyond the
    // threshold; lines beyond it on their own (a tool grazing a line's end) are counted apart.
    removal::MarkOptions mark_options;
    mark_options.threshold_m = options.mark_threshold_m;
    double worst = 0.0, worst_isolated = 0.0;
    std::size_t isolated_lines = 0;
    Eigen::Vector3d worst_at = Eigen::Vector3d::Zero();
    for (std::size_t v = 0; v < context.views.size(); ++v) {
      removal::NBuffer commanded = cut_commanded_view(context, poses, pose_point, v, nullptr);
      if (!ranks.root()) continue;  // (rank 0 compares: it alone holds the whole buffers)
      // Steep in either surface: a line in the plane of a tool face (a wall view's row at the
      // floor's height) is cut whole or not at all by a rounding of the tool's height. A NaN
      // difference reads as infinitely far.
      const ViewDeviation reference_vs_commanded(reference.buffers[v], commanded, context.views[v].spacing_m, true);
      const removal::StreamedMarkMap regions =
          removal::find_marks_streamed(commanded, reference_vs_commanded.reader(), mark_options);
      DeviationRows rows(reference_vs_commanded);
      for (int iv = 0; iv < commanded.nv(); ++iv) {
        const std::span<const double> row_m = rows.row(iv);
        for (int iu = 0; iu < commanded.nu(); ++iu) {
          const double size = std::abs(row_m[static_cast<std::size_t>(iu)]);
          if (size > options.mark_threshold_m && regions.labels.at(iu, iv) < 0) {
            ++isolated_lines;
            worst_isolated = std::max(worst_isolated, size);
            continue;
          }
          if (size > worst) {
            worst = size;
            worst_at = commanded.surface_point(iu, iv);
          }
        }
      }
    }
    {
      // Rank 0's figures on every rank: all decide alike on the reference.
      std::vector<double> figures{worst, worst_isolated, static_cast<double>(isolated_lines), worst_at.x(),
                                  worst_at.y(), worst_at.z()};
      ranks.broadcast(figures);
      worst = figures[0], worst_isolated = figures[1], isolated_lines = static_cast<std::size_t>(figures[2]);
      worst_at = Eigen::Vector3d(figures[3], figures[4], figures[5]);
    }
    commanded_figures["reference_vs_commanded_max_um"] = worst * 1e6;
    end_stage("commanded_check");
    commanded_figures["reference_vs_commanded_isolated_lines"] = isolated_lines;
    reference_check = check_reference_against_commanded(worst, worst_at, options.mark_threshold_m);
    if (isolated_lines > 0) {
      reference_check.detail += "; " + std::to_string(isolated_lines) + " lines beyond the limit on their own (up to " +
                              format_double(std::round(worst_isolated * 1e9) / 1e3) +
                              " um, in groups too small to be a mark) not counted";
    }
    progress(check_line(reference_check));
    if (reference_check.status == CheckStatus::failed) {
      throw InfeasibleError(
          "the reference run is not a valid reference: " + check_line(reference_check) +
          ". Its surface must match the planned tool path's own surface to within the mark threshold, "
          "or marks would hide in it; lower the reference feed (--reference-feed-mm-per-min) or look for "
          "the cause at that place");
    }
  } else {
    reference_check = {"reference_vs_commanded", "reference surface against the surface of the planned tool path (the set points' geometry)",
                       0.0, options.mark_threshold_m * 1e6, "um", CheckStatus::not_done,
                       "--no-commanded-check: the reference was not checked"};
    progress(check_line(reference_check));
  }

  // Only rank 0 compares: the other ranks are done with the reference (their band of it, its
  // plan and its thinned poses), which they would otherwise hold through the production run.
  if (!ranks.root()) reference = Run(reference.name, reference.feed);
  // Only rank 0 relates the marks to the production run's signals: the other ranks keep none
  // (their trajectory is the same bit for bit: the planner and the servo stream alike).
  Run production = simulate_run(context, "production", production_feed, options.method, ranks.root());
  if (!ranks.root()) {
    // The other ranks' part ends with their bands gathered: rank 0 compares and writes. They
    // cut the other method's production run too, then send rank 0 their clocks.
    if (options.compare_methods) {
      simulate_run(context, "production (other method)", production_feed,
                   options.method == planner::FeedrateMethod::kinematic ? planner::FeedrateMethod::dynamic
                                                                        : planner::FeedrateMethod::kinematic,
                   false);
    }
    ranks.gather_to_root({seconds_since(start), cpu_seconds() - cpu_start, peak_rss_mib()},
                         [](int, std::vector<double>&&) {});
    return Json::object();
  }

  stage_clock = Clock::now();
  stage_cpu = cpu_seconds();
  progress("comparison ...");
  const std::vector<double> curvature = tip_curvature(context.inputs.path);
  std::vector<ViewComparison> comparisons = compare_views(context, production, reference);
  std::vector<std::pair<double, Json>> marks_by_depth;
  Json views = Json::array();
  for (std::size_t v = 0; v < context.views.size(); ++v) {
    const ViewComparison& comparison = comparisons[v];
    for (std::size_t k = 0; k < comparison.marks.marks.size(); ++k) {
      const removal::Mark& mark = comparison.marks.marks[k];
      Json entry = relate_mark(context, production, mark, curvature);
      entry["view"] = comparison.view->id;
      // The surface in words for the verdict ("Z-map", "wall 2", "cylinder 1"): the title's
      // name, before its geometry.
      const std::string& title = comparison.view->title;
      entry["surface"] = title.substr(0, std::min(title.find(':'), title.find(" (")));
      entry["view_mark_index"] = k;  // the mark's place in its view's mark map (the renders)
      // The design surface it lies on, and that surface's own tolerance (report_marks.hpp).
      if (const auto patch = design_patch_of_mark(
              context.part, *comparison.view, mark.deepest_point_W_m, 2.0 * comparison.view->spacing_m,
              options.tolerance_m > 0 ? options.tolerance_m : context.part.tolerance_m)) {
        const DesignPatch& design = context.part.design_patches[*patch];
        entry["design_surface"] = design.name;
        if (design.tolerance_m > 0) entry["tolerance_um"] = design.tolerance_m * 1e6;
      }
      entry["kind"] = mark.kind == removal::MarkKind::gouge ? "gouge" : "excess";
      entry["depth_um"] = mark.depth_m * 1e6;
      entry["area_mm2"] = mark.area_m2 * 1e6;
      entry["lines"] = mark.line_count;
      entry["deepest_point_mm"] = {mark.deepest_point_W_m.x() * 1e3, mark.deepest_point_W_m.y() * 1e3,
                                   mark.deepest_point_W_m.z() * 1e3};
      entry["centroid_mm"] = {mark.centroid_W_m.x() * 1e3, mark.centroid_W_m.y() * 1e3,
                              mark.centroid_W_m.z() * 1e3};
      marks_by_depth.emplace_back(mark.depth_m, entry);
    }
    views.push_back({{"id", comparison.view->id},
                     {"title", comparison.view->title},
                     {"lines", production.buffers[v].line_count()},
                     {"nu", production.buffers[v].nu()},
                     {"nv", production.buffers[v].nv()},
                     {"steep_lines_not_assessed", comparison.steep_lines_excluded},
                     {"marks", comparison.marks.marks.size()},
                     {"deviation_min_um", comparison.deviation_min_m * 1e6},
                     {"deviation_max_um", comparison.deviation_max_m * 1e6},
                     {"deviation_rms_um", std::sqrt(comparison.sum_squares_m2 /
                                                    static_cast<double>(comparison.deviation->line_count())) * 1e6}});
  }
  std::stable_sort(marks_by_depth.begin(), marks_by_depth.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  Json mark_list = Json::array();
  for (auto& [depth, entry] : marks_by_depth) mark_list.push_back(std::move(entry));
  // The Z-map's figures stay at the top level of "surface" (every part has a Z-map view).
  Json surface{{"grid_um", options.grid_m * 1e6},
               {"lines", views[0]["lines"]},
               {"nx", views[0]["nu"]},
               {"ny", views[0]["nv"]},
               {"mark_threshold_um", options.mark_threshold_m * 1e6},
               {"trajectory_tolerance_um", options.trajectory_tolerance_m * 1e6},
               {"deviation_min_um", views[0]["deviation_min_um"]},
               {"deviation_max_um", views[0]["deviation_max_um"]},
               {"deviation_rms_um", views[0]["deviation_rms_um"]},
               {"steep_step_per_spacing", kSteepStepPerSpacing},
               {"views", views}};
  for (const auto& [key, value] : commanded_figures.items()) surface[key] = value;
  {
    // How the Z-map's heights were held (NBuffer::make_compact) and what they took.
    const removal::NBuffer& zmap = production.buffers[0];
    Json heights{{"storage", zmap.is_compact() ? "compact" : "plain"},
                 {"tiles", zmap.tile_count()},
                 {"tiles_allocated_production", zmap.allocated_tiles()},
                 {"tiles_allocated_reference", reference.buffers[0].allocated_tiles()},
                 {"bytes_production", zmap.length_bytes()}};
    heights["exactness"] = zmap.is_compact()
                               ? "float offsets from a double base a tile: within 2^-24 of the depth below "
                                 "the tile's top (0.6 nm at 10 mm), exact where uncut"
                               : "one double a line: exact";
    // Compact offsets past the memory budget went to memory-mapped files (removal/tile_store.hpp).
    const removal::SpillFigures spill = removal::spill_figures();
    heights["spilled_to_disk_peak_mib"] = static_cast<double>(spill.spilled_peak_bytes) / (1 << 20);
    surface["zmap_heights"] = heights;
  }
  end_stage("comparison");

  if (options.compare_methods) {
    const planner::FeedrateMethod other = options.method == planner::FeedrateMethod::kinematic
                                              ? planner::FeedrateMethod::dynamic
                                              : planner::FeedrateMethod::kinematic;
    Run alternative = simulate_run(context, "production (" + method_name(other) + ")", production_feed, other, true);
    stage_clock = Clock::now();
    stage_cpu = cpu_seconds();
    const std::vector<ViewComparison> alternative_comparisons = compare_views(context, alternative, reference);
    report["method_comparison"] = {method_summary(context, options.method, production, comparisons, curvature),
                                   method_summary(context, other, alternative, alternative_comparisons, curvature)};
    stage_seconds["production_" + method_name(other)] = stage_times(alternative);
    end_stage("method_comparison");
  }

  std::vector<ValidityCheck> checks = reference.checks;
  checks.insert(checks.end(), production.checks.begin(), production.checks.end());
  checks.push_back(reference_check);
  Json check_list = Json::array();
  for (const ValidityCheck& check : checks) check_list.push_back(check_json(check));
  report["validity_checks"] = check_list;

  report["part"] = {{"name", context.part.name}, {"description", context.part.description},
                    {"file", part_path_for_report(options.part_path)}};
  if (!context.inputs.tool_roll.empty()) report["tool_roll"] = context.inputs.tool_roll;
  if (const auto& roll = context.inputs.roll_profile) {
    constexpr double kDeg = 180.0 / std::numbers::pi;
    report["tool_roll_along_path"] = {{"applied", context.inputs.roll_profile_applied},
                                      {"roll_min_deg", roll->roll_min_rad * kDeg},
                                      {"roll_max_deg", roll->roll_max_rad * kDeg},
                                      {"roll_rate_max_deg_per_mm", roll->max_rate_rad_per_m * kDeg / 1000.0},
                                      {"min_score", roll->min_score},
                                      {"min_score_at_s_mm", roll->min_score_s_m * 1e3},
                                      {"min_score_without_choice", roll->min_score_free},
                                      {"min_score_without_choice_at_s_mm", roll->min_score_free_s_m * 1e3},
                                      {"samples", roll->samples},
                                      {"rolls_per_sample", roll->rolls}};
  }
  report["machine"] = context.inputs.machine.name + " (" +
                      path_for_report(context.inputs.machine.source_file, options.part_path) + ")";
  report["toolpath"] = path_for_report(context.part.toolpath_path, options.part_path);
  report["method"] = method_name(options.method);
  report["runs"]["production"] = run_summary(production);
  report["runs"]["reference"] = run_summary(reference);
  report["surface"] = surface;
  // The marks a machinist acts on, deepest first; specks counted apart (report_marks.hpp).
  const Json curated =
      curate_marks(mark_list, min_mark_area_mm2(options.grid_m * 1e6, context.tool.diameter_m * 1e3));
  report["marks"] = curated["marks"];
  report["specks"] = curated["specks"];
  Tolerance tolerance;
  if (options.tolerance_m > 0) {
    tolerance = {options.tolerance_m * 1e6, "--tolerance-um"};
  } else if (context.part.tolerance_m > 0) {
    tolerance = {context.part.tolerance_m * 1e6, "part file"};
  }
  report["verdict"] = make_verdict(curated, check_list, tolerance);
  report["context"] = report_context(context, production_feed, reference_feed);
  report["nc_modes"] = context.nc.to_json();
  report["corners"] = context.path.corners.size();
  report["singular_zones"] = context.path.singular_zones.size();
  report["renders"] = Json::object();

  // Everything goes into the staging folder, swapped in whole at the end (a failure before
  // that leaves the previous results as they were).
  if (ranks.distributed()) {
    // What each rank did (its band of each view, its clocks and peak memory).
    Json processes{{"ranks", ranks.size()}};
    Json view_bands = Json::array();
    for (std::size_t v = 0; v < context.views.size(); ++v) {
      // Each rank's lines of the view's index rows [first, end).
      Json per_rank = Json::array();
      const int rows = context.uncut[v].nv(), tile = removal::NBuffer::kTile;
      for (const auto& [begin, end] : context.bands[v].per_rank) {
        per_rank.push_back({begin * tile, std::min(end * tile, rows)});
      }
      view_bands.push_back({{"view", context.views[v].id}, {"rows_per_rank", per_rank}});
    }
    processes["bands"] = view_bands;
    Json per_rank = Json::array();
    ranks.gather_to_root({seconds_since(start), cpu_seconds() - cpu_start, peak_rss_mib()},
                         [&](int rank, std::vector<double>&& values) {
                           per_rank.push_back({{"rank", rank}, {"seconds_so_far", values[0]},
                                               {"cpu_seconds_so_far", values[1]}, {"peak_rss_mib", values[2]}});
                         });
    processes["per_rank"] = per_rank;
    report["processes"] = processes;
  }
  const std::filesystem::path& staging = output->staging();
  stage_clock = Clock::now();
  stage_cpu = cpu_seconds();
  progress("writing surfaces ...");
  for (std::size_t v = 0; v < context.views.size(); ++v) {
    const SurfaceView& view = context.views[v];
    const std::string suffix = view_file_suffix(view);
    // Row by row: a view's file is 8 bytes a line (20 GB for a 500 mm die at 10 um).
    for (const auto& [name, run] : {std::pair{"production_heights", &production}, std::pair{"reference_heights", &reference}}) {
      const removal::NBuffer& buffer = run->buffers[v];
      write_file_atomically((staging / (name + suffix + ".bin")).string(),
                            [&buffer](std::ostream& out) { removal::write_heights_binary(buffer, out); });
    }
    // .vtp at most about 1 M points (the exact lengths are in the .bin files).
    const int stride = std::max(1, static_cast<int>(std::ceil(std::sqrt(
                                       static_cast<double>(production.buffers[v].line_count()) / 1.0e6))));
    viz::write_surface_vtp((staging / ("production" + suffix + ".vtp")).string(),
                           view_height_field(view, production.buffers[v], &*comparisons[v].deviation, stride));
    viz::write_surface_vtp((staging / ("reference" + suffix + ".vtp")).string(),
                           view_height_field(view, reference.buffers[v], nullptr, stride));
    surface["views"][v]["vtp_stride"] = stride;
  }
  surface["vtp_stride"] = surface["views"][0]["vtp_stride"];
  report["surface"] = surface;
  std::vector<std::string> images;
  write_renders(context, production, reference, comparisons, staging, report, images);
  const auto view3d_start = Clock::now();
  report["view_3d"] = write_view3d(staging, view3d_inputs(context, production, comparisons, curated), vtkjs_bundle());
  report["view_3d"]["seconds"] = seconds_since(view3d_start);
  if (report["view_3d"].value("available", false)) {
    progress("3-D view: " + std::to_string(report["view_3d"]["vertices"].get<std::size_t>()) + " vertices, " +
             format_double(std::round(report["view_3d"]["data_bytes"].get<double>() / 1e4) / 1e2) + " MB of data");
  } else {
    progress("3-D view skipped: " + report["view_3d"].value("reason", ""));
  }
  end_stage("outputs");
  stage_seconds["production"] = stage_times(production);
  stage_seconds["reference"] = stage_times(reference);
  stage_seconds["total"] = seconds_since(start);
  report["stage_seconds"] = stage_seconds;
  stage_cpu_seconds["total"] = cpu_seconds() - cpu_start;
  stage_peak_rss_mib["total"] = peak_rss_mib();
  for (const Run* run : {&production, &reference}) {
    for (const auto& [stage, value] : run->stage_cpu_seconds) stage_cpu_seconds[run->name][stage] = value;
    for (const auto& [stage, value] : run->stage_peak_rss_mib) stage_peak_rss_mib[run->name][stage] = value;
  }
  report["stage_cpu_seconds"] = stage_cpu_seconds;
  report["stage_peak_rss_mib"] = stage_peak_rss_mib;
  write_file_atomically((staging / "report.json").string(), json_file_text(report));
  write_file_atomically((staging / "report.html").string(), html_report(report, images));
  write_file_atomically((staging / "marks.csv").string(), marks_csv(curated));
  output->commit();
  return report;
}

}  // namespace vmsim::app
