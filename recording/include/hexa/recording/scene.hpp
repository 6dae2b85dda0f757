// The 3-D scene of a recording or a live session as Foxglove messages (docs/foxglove.md):
// foxglove.FrameTransforms (frames base, platform = ground truth, platform_measured = GQFK +
// IMU, platform_desired) and foxglove.SceneUpdate (legs as cylinders between their joints,
// coloured by leg state; joints as spheres; base and platform outlines; the soft limits' pose
// box; a status label), at a
// display rate (default every 20 ticks = 50 Hz), built from the hexa.rec messages the
// recorder and the bridge already have. No DDS, no clock: the caller stamps each frame.
#pragma once

#include <google/protobuf/message.h>

#include <cstdint>
#include <optional>
#include <string>

#include "foxglove/FrameTransforms.pb.h"
#include "foxglove/SceneUpdate.pb.h"
#include "hexa/core/rig.hpp"
#include "hexa/core/scene.hpp"
#include "hexa/core/soft_limits.hpp"
#include "hexa/recording/recording.hpp"

namespace hexa::recorder {

inline constexpr const char* kSceneTopic = "hexa_Scene";
inline constexpr const char* kTransformsTopic = "hexa_FrameTransforms";

struct SceneOptions {
  // Joints of the platform drawn at the ground-truth pose: the simulated plant's true joints
  // when its profile and seed are known (TrueGeometry), else the nominal ones.
  GeometryParams truth_geometry;
  // The controllers' model: joints of the measured and desired platforms.
  GeometryParams nominal_geometry;
  std::string geometry_note = "nominal joints";  // written to the channel metadata
  // The supervisor's soft limits (rig file supervisor.soft_limits, MakeSoftLimitsConfig): their
  // pose box is drawn as entity "soft_limits" (the box the platform origin stays in, in base).
  // Unset: not drawn.
  std::optional<SoftLimitsConfig> soft_limits;
  std::uint64_t period_ticks = 20;               // one frame per 20 plant ticks = 50 Hz
  void Validate() const;                         // throws std::invalid_argument
};

// Rig file (docs/config.md) -> options. With `seed`, the ground-truth platform gets the plant's
// true joints for that profile and seed ("" = the file's default profile); without, nominal.
// The soft limits are the supervisor's for that file.
// Throws std::runtime_error naming the file and the problem.
SceneOptions SceneOptionsFromRig(const std::string& rig_path, const std::string& profile,
                                 std::optional<std::uint64_t> seed);

class SceneBuilder {
 public:
  explicit SceneBuilder(SceneOptions options);
  // Takes any recorded message (hexa.rec.GroundTruth, PoseReport, ValveCommand, FaultEvent are
  // used; the rest is ignored, cheaply). True when a frame is due: the driving tick (ground
  // truth, or the pose report when there is no ground truth) reached the next display tick.
  bool Add(const google::protobuf::Message& message);
  // Fills scene() and transforms() from the newest state; every timestamp is `stamp_ns`.
  void Build(std::uint64_t stamp_ns);
  const foxglove::SceneUpdate& scene() const { return scene_; }
  const foxglove::FrameTransforms& transforms() const { return transforms_; }
  const SceneOptions& options() const { return options_; }
  std::uint64_t frames() const { return frames_; }

 private:
  void OnTick(std::uint64_t tick, bool from_truth);

  SceneOptions options_;
  LegStateTracker legs_;
  std::optional<Pose> truth_, measured_, desired_;
  int supervisor_state_ = -1;
  double trajectory_time_s_ = 0.0;
  std::uint64_t last_tick_ = 0;   // newest tick seen (any input)
  std::uint64_t drawn_tick_ = 0;  // tick of the pose the legs are drawn at
  std::uint64_t truth_tick_ = 0, measured_tick_ = 0;
  bool have_truth_stream_ = false;
  bool due_ = false;
  std::optional<std::uint64_t> next_due_tick_;
  std::uint64_t frames_ = 0;
  foxglove::SceneUpdate scene_;
  foxglove::FrameTransforms transforms_;
  LegArray<std::size_t> base_order_{}, platform_order_{};
};

// The two scene channels of a recording: added to `writer` at construction, one message each
// per Write.
class SceneChannels {
 public:
  SceneChannels(RecordingWriter& writer, const SceneOptions& options);
  void Write(std::uint64_t log_time_ns, const SceneBuilder& builder);

 private:
  RecordingWriter& writer_;
  std::uint16_t scene_channel_ = 0, transforms_channel_ = 0;
};

// True for the channels SceneChannels writes (annotate replaces them).
bool IsSceneChannel(const McapChannel& channel);

}  // namespace hexa::recorder
