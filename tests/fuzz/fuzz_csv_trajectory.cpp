// libFuzzer target: the CSV trajectory parser (config/csv_trajectory.hpp) on arbitrary bytes.
// Invariants: a rejection is a CsvTrajectoryError whose message is bounded, starts with the
// file name and holds no control character or byte that is not UTF-8 (it goes into
// FaultEvent.detail and log lines); an accepted trajectory has finite rows within the limits,
// and its spline, blend and feasibility check evaluate without crashing.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "hexa/config/csv_trajectory.hpp"
#include "hexa/core/feasibility.hpp"
#include "hexa/core/trajectory.hpp"
#include "hexa/services/text.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  hexa::config::CsvTrajectoryLimits limits;
  limits.max_span_s = 20.0;  // the feasibility check below samples the whole span
  try {
    const auto motion = hexa::config::ParseCsvTrajectory(text, "fuzz.csv", limits);
    if (motion->size() < 2) __builtin_trap();
    const double span = motion->end_time_s() - motion->start_time_s();
    if (!(span > 0.0 && span <= limits.max_span_s)) __builtin_trap();
    hexa::PoseVectorState s;
    for (double f : {0.0, 0.25, 0.5, 0.999, 1.0}) motion->Evaluate(motion->start_time_s() + f * span, s);
    const hexa::RigParams rig = hexa::MakeReferenceRig();
    const hexa::Vector6d home = hexa::HomePoseVector(rig.geometry.home_position_m);
    const hexa::Trajectory traj = hexa::MakeCsvTrajectory(motion, home, home, hexa::TrajectoryTiming{});
    (void)hexa::CheckFeasibility(rig, hexa::SupervisorParams{}, traj, 0.01);
  } catch (const hexa::config::CsvTrajectoryError& e) {
    const std::string what = e.what();
    if (what.size() > 2000 || what.rfind("fuzz.csv:", 0) != 0) __builtin_trap();
    if (!hexa::text::IsClean(what, 2000, hexa::text::Newlines::kReplace)) __builtin_trap();
  }
  return 0;
}
