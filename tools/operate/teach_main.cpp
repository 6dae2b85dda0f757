// hexa_teach: teach and replay (docs/operate.md "Teach and replay"): the poses of a recording
// turned into a trajectory CSV that hexa_session / hexa_operator --trajectory replay, blended in
// from the platform's current pose.
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "hexa/config/csv_trajectory.hpp"
#include "hexa/core/teach.hpp"
#include "hexa/recording/recording.hpp"
#include "hexa/services/cli.hpp"
#include "recording.pb.h"

namespace {

template <typename T>
bool Parse(const hexa::recorder::McapMessageView& view, T& msg) {
  return msg.ParseFromArray(view.data.data(), static_cast<int>(view.data.size()));
}

hexa::Pose FromVector(const google::protobuf::RepeatedField<double>& v) {
  hexa::Vector6d q;
  for (int k = 0; k < 6; ++k) q[k] = v.Get(k);
  return hexa::PoseFromVector(q);
}

}  // namespace

int main(int argc, char** argv) {
  hexa::cli::Parser cli("hexa_teach",
                        "Turns the poses of a recording into a trajectory CSV (time_s,x_m,...): "
                        "replay it with --trajectory FILE.csv; it blends in from the current pose.");
  cli.AllowPositional("recording.mcap", 1);
  cli.AddOption("output", "file.csv", "the trajectory CSV to write");
  cli.AddChoice("source", {"desired", "estimated", "truth"},
                "desired: the supervisor's setpoints (PoseReport, 200 Hz: a jog session as "
                "commanded); estimated: its pose estimate; truth: the plant's ground truth "
                "(simulation, 1 kHz). A measured pose carries the closed loop's own oscillation, "
                "which a replay excites again (docs/operate.md \"Teach and replay\")",
                "desired");
  cli.AddOption("from-s", "s", "first sample time (simulated time of the recording)", "0");
  cli.AddOption("to-s", "s", "last sample time (-1: the end)", "-1");
  cli.AddOption("row-period-s", "s", "time between CSV rows", "0.02");
  cli.AddOption("smoothing-s", "s", "centred moving-average window (0: off)", "0.05");
  const bool ok = cli.Parse(argc, argv);
  if (int rc = hexa::cli::HandleParseResult(cli, ok); rc >= 0) return rc;
  auto from_s = cli.GetDouble("from-s", 0.0, 1e7);
  auto to_s = cli.GetDouble("to-s", -1.0, 1e7);
  auto row = cli.GetDouble("row-period-s", 0.001, 1.0);
  auto smoothing = cli.GetDouble("smoothing-s", 0.0, 2.0);
  if (!from_s || !to_s || !row || !smoothing || cli.positional().size() != 1 || !cli.Has("output")) {
    std::fprintf(stderr, "error: %s\n", cli.error().empty()
                                            ? "a recording and --output FILE.csv are required"
                                            : cli.error().c_str());
    return 2;
  }
  const std::string source = cli.Get("source");
  std::vector<hexa::TeachSample> samples;
  try {
    hexa::recorder::ReadRecording(
        cli.positional()[0], [&](const hexa::recorder::McapChannel& ch,
                                 const hexa::recorder::McapMessageView& view,
                                 const google::protobuf::Message&) {
          hexa::TeachSample s;
          if (source != "truth" && ch.topic == "hexa_PoseReport") {
            hexa::rec::PoseReport m;
            const auto& pose = source == "desired" ? m.desired_pose() : m.estimated_pose();
            if (!Parse(view, m) || pose.size() != 6) return;
            s.time_s = m.header().sim_time_s();
            s.pose = FromVector(pose);
          } else if (source == "truth" && ch.topic == "hexa_GroundTruth") {
            hexa::rec::GroundTruth m;
            if (!Parse(view, m) || m.position_m_size() != 3 || m.orientation_wxyz_size() != 4) return;
            s.time_s = m.header().sim_time_s();
            s.pose.p_BP_B_m = {m.position_m(0), m.position_m(1), m.position_m(2)};
            s.pose.R_BP = Eigen::Quaterniond(m.orientation_wxyz(0), m.orientation_wxyz(1),
                                             m.orientation_wxyz(2), m.orientation_wxyz(3))
                              .normalized()
                              .toRotationMatrix();
          } else {
            return;
          }
          if (s.time_s < *from_s || (*to_s >= 0.0 && s.time_s > *to_s)) return;
          samples.push_back(s);
        });
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s: %s\n", cli.positional()[0].c_str(), e.what());
    return 1;
  }
  hexa::TeachConfig config;
  config.row_period_s = *row;
  config.smoothing_window_s = *smoothing;
  const hexa::TeachResult rows = hexa::TrajectoryRowsFromSamples(samples, config);
  if (!rows.ok) {
    std::fprintf(stderr, "error: %s (%s poses): %s\n", cli.positional()[0].c_str(), source.c_str(),
                 rows.message.c_str());
    return 1;
  }
  std::ofstream out(cli.Get("output"), std::ios::binary);
  out << hexa::config::FormatCsvTrajectory(
      rows.time_s, rows.xyz_rpy,
      "taught by hexa_teach from " + cli.positional()[0] + " (" + source + " poses)");
  if (!out) {
    std::fprintf(stderr, "error: cannot write %s\n", cli.Get("output").c_str());
    return 1;
  }
  std::printf("hexa_teach: %zu %s poses (%zu not finite, left out) -> %zu rows over %.3f s in %s\n",
              samples.size(), source.c_str(), rows.dropped_not_finite, rows.time_s.size(),
              rows.time_s.back(), cli.Get("output").c_str());
  return 0;
}
