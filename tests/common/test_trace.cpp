// The trace format (shared/spec/trace-format.md): round trip and every kind of bad input.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/trace.hpp"
#include "../temp_folder.hpp"

namespace vmsim {
namespace {

std::string error_of(const std::string& text, const TraceReadOptions& options = {}) {
  try {
    parse_trace(text, "run.csv", options);
  } catch (const InputError& error) {
    return error.what();
  }
  return "";
}

TEST(Trace, ReadsTheSpecExample) {
  const std::string text =
      "# source: bench run 2026-03-02, X axis, reversal test\n"
      "# machine: samples/machines/example.yaml\n"
      "t,X.cmd,X.pos,X.cur\n"
      "0.000,0.000000,0.000000,0.412\n"
      "0.001,0.000120,0.000051,0.988\n"
      "0.002,0.000480,0.000260,1.503\n";
  const Trace trace = parse_trace(text, "example.csv");
  EXPECT_EQ(trace.sample_count(), 3u);
  EXPECT_EQ(trace.columns, (std::vector<std::string>{"t", "X.cmd", "X.pos", "X.cur"}));
  EXPECT_DOUBLE_EQ(trace.column("X.cur")[2], 1.503);
  EXPECT_EQ(trace.metadata_value("machine").value(), "samples/machines/example.yaml");
  EXPECT_EQ(trace.metadata_value("source").value(), "bench run 2026-03-02, X axis, reversal test");
  double period = 0.0;
  EXPECT_TRUE(uniform_period(trace.column("t"), 1e-9, period));
  EXPECT_NEAR(period, 0.001, 1e-15);
}

TEST(Trace, RoundTripIsExact) {
  Trace trace;
  trace.metadata = {{"source", "test"}};
  trace.add_column("t", {0.0, 0.004, 0.008});
  trace.add_column("A.cmd", {0.1, 1.0 / 3.0, -2.5e-7});
  const std::string path = test::fresh_temp_folder("trace_roundtrip") / "trace.csv";
  write_trace(path, trace);
  const Trace back = read_trace(path);
  std::remove(path.c_str());
  EXPECT_EQ(back.columns, trace.columns);
  EXPECT_EQ(back.values, trace.values);  // bit for bit
  EXPECT_EQ(back.metadata, trace.metadata);
}

TEST(Trace, NonUniformPeriodIsSaid) {
  double period = 0.0;
  EXPECT_FALSE(uniform_period({0.0, 0.001, 0.003}, 1e-6, period));
}

TEST(TraceErrors, EachKindOfBadInputNamesFileAndLine) {
  EXPECT_NE(error_of("").find("run.csv: the trace is empty"), std::string::npos);
  EXPECT_NE(error_of("# only a comment\n").find("empty"), std::string::npos);
  EXPECT_NE(error_of("t,X.cmd\n").find("no samples"), std::string::npos);
  EXPECT_NE(error_of("X.cmd,X.pos\n1,2\n").find("run.csv:1: the header has no column 't'"),
            std::string::npos);
  EXPECT_NE(error_of("t,X.cmd,X.cmd\n0,1,2\n").find("run.csv:1: header column 'X.cmd' appears twice"),
            std::string::npos);
  EXPECT_NE(error_of("t,X.cmd\n0,1\n0.1,2,3\n").find("run.csv:3: row has 3 fields, the header 2"),
            std::string::npos);
  EXPECT_NE(error_of("t,X.cmd\n0,1\n0.1\n").find("run.csv:3: row has 1 fields"), std::string::npos);
  EXPECT_NE(error_of("t,X.cmd\n0,abc\n").find("run.csv:2: column 'X.cmd': 'abc' is not a finite"),
            std::string::npos);
  EXPECT_NE(error_of("t,X.cmd\n0,nan\n").find("'nan' is not a finite number"), std::string::npos);
  EXPECT_NE(error_of("t,X.cmd\n0,inf\n").find("'inf' is not a finite number"), std::string::npos);
  EXPECT_NE(error_of("t,X.cmd\n0,\n").find("'' is not a finite number"), std::string::npos);
  EXPECT_NE(error_of("t,X.cmd\n0,1\n0,2\n").find("run.csv:3: t = 0 does not increase"),
            std::string::npos);
  EXPECT_NE(error_of("t,X.cmd\n0.2,1\n0.1,2\n").find("does not increase"), std::string::npos);
  EXPECT_NE(error_of("t,X.speed\n0,1\n").find("unknown signal 'speed'"), std::string::npos);
  TraceReadOptions machine_axes;
  machine_axes.known_axes = std::set<std::string>{"X", "Y"};
  EXPECT_NE(error_of("t,Q.cmd\n0,1\n", machine_axes).find("no axis 'Q'"), std::string::npos);
  EXPECT_EQ(error_of("t,X.cmd,note\n0,1,2\n", machine_axes), "");  // other names are kept
}

}  // namespace
}  // namespace vmsim
