#include "hexa/recording/scene.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include <Eigen/Geometry>

#include "hexa/config/rig_config.hpp"
#include "hexa/core/platform_plant.hpp"
#include "hexa/core/pose.hpp"
#include "recording.pb.h"

namespace hexa::recorder {
namespace gp = google::protobuf;

namespace {

// Sizes of the drawn parts (display only).
constexpr double kLegDiameterM = 0.024;
constexpr double kBaseJointDiameterM = 0.030;
constexpr double kPlatformJointDiameterM = 0.026;
constexpr double kOutlineThicknessM = 0.006;
constexpr double kLabelSizeM = 0.04;
constexpr double kLimitLineThicknessM = 0.003;

struct Rgba {
  double r, g, b, a;
};
constexpr Rgba kBaseColor{0.45, 0.45, 0.45, 1.0};
constexpr Rgba kPlatformColor{0.15, 0.45, 0.85, 1.0};
constexpr Rgba kPlateColor{0.15, 0.45, 0.85, 0.25};
constexpr Rgba kMeasuredColor{1.0, 0.55, 0.0, 1.0};
constexpr Rgba kDesiredColor{0.1, 0.75, 0.25, 1.0};
constexpr Rgba kTextColor{0.1, 0.1, 0.1, 1.0};
constexpr Rgba kLimitEdgeColor{0.85, 0.25, 0.1, 0.8};
constexpr Rgba kLimitFillColor{0.85, 0.25, 0.1, 0.06};

Rgba LegColor(LegDisplayState s) {
  switch (s) {
    case LegDisplayState::kOk: return {0.2, 0.7, 0.3, 1.0};             // green
    case LegDisplayState::kStandbyActive: return {0.6, 0.3, 0.85, 1.0};  // purple
    case LegDisplayState::kHold: return {1.0, 0.7, 0.0, 1.0};            // amber
    case LegDisplayState::kFault: return {0.9, 0.1, 0.1, 1.0};           // red
    case LegDisplayState::kUnknown: break;
  }
  return {0.6, 0.6, 0.6, 1.0};  // grey
}

void SetColor(foxglove::Color* c, const Rgba& v) {
  c->set_r(v.r);
  c->set_g(v.g);
  c->set_b(v.b);
  c->set_a(v.a);
}
void SetVec(foxglove::Vector3* out, const Eigen::Vector3d& v) {
  out->set_x(v.x());
  out->set_y(v.y());
  out->set_z(v.z());
}
void SetPoint(foxglove::Point3* out, const Eigen::Vector3d& v) {
  out->set_x(v.x());
  out->set_y(v.y());
  out->set_z(v.z());
}
void SetQuat(foxglove::Quaternion* out, const Eigen::Quaterniond& q) {
  out->set_x(q.x());
  out->set_y(q.y());
  out->set_z(q.z());
  out->set_w(q.w());
}
void SetPose(foxglove::Pose* out, const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  SetVec(out->mutable_position(), p);
  SetQuat(out->mutable_orientation(), q);
}
void SetStamp(gp::Timestamp* t, uint64_t ns) {
  t->set_seconds(static_cast<int64_t>(ns / 1'000'000'000ull));
  t->set_nanos(static_cast<int32_t>(ns % 1'000'000'000ull));
}
void AddMeta(foxglove::SceneEntity* e, const std::string& k, const std::string& v) {
  auto* kv = e->add_metadata();
  kv->set_key(k);
  kv->set_value(v);
}
std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6f", v);
  return buf;
}

foxglove::SceneEntity* NewEntity(foxglove::SceneUpdate& u, const char* id, const char* frame,
                                 uint64_t stamp_ns) {
  foxglove::SceneEntity* e = u.add_entities();
  SetStamp(e->mutable_timestamp(), stamp_ns);
  e->set_frame_id(frame);
  e->set_id(id);
  e->set_frame_locked(true);  // moves with its frame between updates
  return e;
}

void AddSpheres(foxglove::SceneEntity* e, const LegArray<Eigen::Vector3d>& points,
                double diameter_m, const Rgba& color) {
  for (const auto& p : points) {
    auto* s = e->add_spheres();
    SetPose(s->mutable_pose(), p, Eigen::Quaterniond::Identity());
    SetVec(s->mutable_size(), Eigen::Vector3d::Constant(diameter_m));
    SetColor(s->mutable_color(), color);
  }
}

void AddOutline(foxglove::SceneEntity* e, const LegArray<Eigen::Vector3d>& points,
                const LegArray<std::size_t>& order, const Rgba& color) {
  auto* l = e->add_lines();
  l->set_type(foxglove::LinePrimitive::LINE_LOOP);
  SetPose(l->mutable_pose(), Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity());
  l->set_thickness(kOutlineThicknessM);
  for (std::size_t i : order) SetPoint(l->add_points(), points[i]);
  SetColor(l->mutable_color(), color);
}

std::string Triple(const Vector6d& v, int first) {
  return Num(v[first]) + " " + Num(v[first + 1]) + " " + Num(v[first + 2]);
}

// The soft limits' pose box: the positions the platform origin may take (box_min..box_max x y z,
// in base), as a translucent cube and its 12 edges; the rotation bounds in the metadata.
void AddSoftLimitBox(foxglove::SceneUpdate& u, const SoftLimitsConfig& limits, uint64_t stamp_ns) {
  auto* e = NewEntity(u, "soft_limits", "base", stamp_ns);
  const Eigen::Vector3d lo = limits.box_min.head<3>(), hi = limits.box_max.head<3>();
  auto* cube = e->add_cubes();
  SetPose(cube->mutable_pose(), 0.5 * (lo + hi), Eigen::Quaterniond::Identity());
  SetVec(cube->mutable_size(), hi - lo);
  SetColor(cube->mutable_color(), kLimitFillColor);
  auto* l = e->add_lines();
  l->set_type(foxglove::LinePrimitive::LINE_LIST);
  SetPose(l->mutable_pose(), Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity());
  l->set_thickness(kLimitLineThicknessM);
  SetColor(l->mutable_color(), kLimitEdgeColor);
  const auto corner = [&](int bits) {
    return Eigen::Vector3d((bits & 1) ? hi.x() : lo.x(), (bits & 2) ? hi.y() : lo.y(),
                           (bits & 4) ? hi.z() : lo.z());
  };
  for (int a = 0; a < 8; ++a) {
    for (int axis = 1; axis < 8; axis <<= 1) {
      if ((a & axis) != 0) continue;  // each edge once: from the corner with that bit clear
      SetPoint(l->add_points(), corner(a));
      SetPoint(l->add_points(), corner(a | axis));
    }
  }
  AddMeta(e, "what", "soft limits: the pose box of the platform origin (rig file "
                     "supervisor.soft_limits, about home)");
  AddMeta(e, "position_min_m", Triple(limits.box_min, 0));
  AddMeta(e, "position_max_m", Triple(limits.box_max, 0));
  AddMeta(e, "rotation_min_rad", Triple(limits.box_min, 3));
  AddMeta(e, "rotation_max_rad", Triple(limits.box_max, 3));
}

const char* SupervisorStateName(int s) {
  if (s < 0) return "no pose report yet";
  // rec::SupervisorState_Name: "SUPERVISOR_JOGGING" -> "JOGGING"; "" for a value it lacks.
  const std::string& name = rec::SupervisorState_Name(static_cast<rec::SupervisorState>(s));
  return name.empty() ? "unknown" : name.c_str() + std::strlen("SUPERVISOR_");
}

// [x y z roll pitch yaw] -> pose; nullopt when not six finite values.
std::optional<Pose> PoseOf(const gp::RepeatedField<double>& xyz_rpy) {
  if (xyz_rpy.size() != 6) return std::nullopt;
  Vector6d v;
  for (int i = 0; i < 6; ++i) v[i] = xyz_rpy.Get(i);
  if (!v.allFinite()) return std::nullopt;
  return PoseFromVector(v);
}

// The compiled message type of `m` (a DynamicMessage from a file's own schema is re-parsed).
template <typename T>
const T* As(const gp::Message& m, T& scratch) {
  if (const auto* t = dynamic_cast<const T*>(&m)) return t;
  if (!scratch.ParseFromString(m.SerializeAsString())) return nullptr;
  return &scratch;
}

}  // namespace

void SceneOptions::Validate() const {
  if (period_ticks == 0 || period_ticks > 100000)
    throw std::invalid_argument("SceneOptions.period_ticks = " + std::to_string(period_ticks) +
                                " outside [1, 100000]");
}

SceneOptions SceneOptionsFromRig(const std::string& rig_path, const std::string& profile,
                                 std::optional<std::uint64_t> seed) {
  const config::ConfigResult loaded = config::LoadSystemConfig(rig_path);
  if (!loaded.ok) throw std::runtime_error("scene: rig file: " + loaded.error);
  SceneOptions o;
  o.nominal_geometry = loaded.config.rig.geometry;
  o.truth_geometry = o.nominal_geometry;
  if (seed) {
    const config::ProfileResult p = config::SelectProfile(loaded.config, profile);
    if (!p.ok) throw std::runtime_error("scene: " + p.error);
    o.truth_geometry = TrueGeometry(o.nominal_geometry, p.profile, *seed);
    o.geometry_note = "true joints of the simulated plant (profile " + p.name + ", seed " +
                      std::to_string(*seed) + ")";
  } else {
    o.geometry_note = "nominal joints of " + rig_path;
  }
  o.soft_limits = MakeSoftLimitsConfig(config::MakeSupervisorRig(loaded.config), loaded.config.supervisor);
  return o;
}

SceneBuilder::SceneBuilder(SceneOptions options) : options_(std::move(options)) {
  options_.Validate();
  base_order_ = OutlineOrder(options_.nominal_geometry, false);
  platform_order_ = OutlineOrder(options_.nominal_geometry, true);
}

void SceneBuilder::OnTick(std::uint64_t tick, bool from_truth) {
  last_tick_ = tick;
  if (from_truth) have_truth_stream_ = true;
  if (from_truth != have_truth_stream_) return;  // the pose report drives only without truth
  if (!next_due_tick_ || tick >= *next_due_tick_) {
    due_ = true;
    next_due_tick_ = tick - tick % options_.period_ticks + options_.period_ticks;
  }
}

bool SceneBuilder::Add(const gp::Message& message) {
  const gp::Descriptor* d = message.GetDescriptor();
  if (d == rec::LegSensors::descriptor()) return false;  // the most frequent: not used
  if (d->full_name() == "hexa.rec.ValveCommand") {
    static thread_local rec::ValveCommand scratch;
    if (const auto* v = As(message, scratch))
      legs_.OnValveCommand(v->leg_id(), v->status() == rec::LEGCTRL_OK, v->standby());
  } else if (d->full_name() == "hexa.rec.GroundTruth") {
    static thread_local rec::GroundTruth scratch;
    const auto* g = As(message, scratch);
    if (g != nullptr && g->position_m_size() == 3 && g->orientation_wxyz_size() == 4) {
      const Eigen::Quaterniond q(g->orientation_wxyz(0), g->orientation_wxyz(1),
                                 g->orientation_wxyz(2), g->orientation_wxyz(3));
      Pose p;
      p.p_BP_B_m = Eigen::Vector3d(g->position_m(0), g->position_m(1), g->position_m(2));
      // A sample that is no pose (non-finite, or not a unit quaternion) is not drawn.
      if (p.p_BP_B_m.allFinite() && q.coeffs().allFinite() && std::abs(q.norm() - 1.0) < 1e-3) {
        p.R_BP = q.normalized().toRotationMatrix();
        truth_ = p;
        truth_tick_ = g->header().tick();
      }
      OnTick(g->header().tick(), true);
    }
  } else if (d->full_name() == "hexa.rec.PoseReport") {
    static thread_local rec::PoseReport scratch;
    if (const auto* r = As(message, scratch)) {
      if (auto m = PoseOf(r->estimated_pose())) {
        measured_ = m;
        measured_tick_ = r->header().tick();
      }
      if (auto d = PoseOf(r->desired_pose())) desired_ = d;
      supervisor_state_ = r->state();
      trajectory_time_s_ = r->trajectory_time_s();
      legs_.OnSupervisorHold(r->state() == rec::SUPERVISOR_HOLD);
      OnTick(r->header().tick(), false);
    }
  } else if (d->full_name() == "hexa.rec.FaultEvent") {
    static thread_local rec::FaultEvent scratch;
    if (const auto* f = As(message, scratch); f != nullptr && f->leg_id() != 0)
      legs_.OnLegFault(f->leg_id());
  }
  const bool due = due_;
  due_ = false;
  return due;
}

void SceneBuilder::Build(std::uint64_t stamp_ns) {
  ++frames_;
  transforms_.Clear();
  auto frame = [&](const char* child, const Pose& p) {
    auto* t = transforms_.add_transforms();
    SetStamp(t->mutable_timestamp(), stamp_ns);
    t->set_parent_frame_id("base");
    t->set_child_frame_id(child);
    SetVec(t->mutable_translation(), p.p_BP_B_m);
    SetQuat(t->mutable_rotation(), Eigen::Quaterniond(p.R_BP));
  };
  if (truth_) frame("platform", *truth_);
  if (measured_) frame("platform_measured", *measured_);
  if (desired_) frame("platform_desired", *desired_);

  scene_.Clear();
  const GeometryParams& truth_g = options_.truth_geometry;
  const GeometryParams& nominal = options_.nominal_geometry;
  // Base: outline through the joints, the joints, leg numbers.
  {
    auto* e = NewEntity(scene_, "base", "base", stamp_ns);
    AddOutline(e, truth_g.p_BA_B, base_order_, kBaseColor);
    AddSpheres(e, truth_g.p_BA_B, kBaseJointDiameterM, kBaseColor);
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      auto* t = e->add_texts();
      const Eigen::Vector3d at = truth_g.p_BA_B[i] * 1.18 + Eigen::Vector3d(0, 0, 0.02);
      SetPose(t->mutable_pose(), at, Eigen::Quaterniond::Identity());
      t->set_billboard(true);
      t->set_font_size(kLabelSizeM);
      SetColor(t->mutable_color(), kTextColor);
      t->set_text(std::to_string(i + 1));
    }
  }
  // The platform the legs are drawn to: ground truth when there is one, else the measured.
  const bool on_truth = truth_.has_value();
  drawn_tick_ = on_truth ? truth_tick_ : measured_tick_;
  const std::optional<Pose>& leg_pose = on_truth ? truth_ : measured_;
  const GeometryParams& leg_geometry = on_truth ? truth_g : nominal;
  if (on_truth) {
    auto* e = NewEntity(scene_, "platform", "platform", stamp_ns);
    AddOutline(e, truth_g.p_PB_P, platform_order_, kPlatformColor);
    auto* plate = e->add_triangles();
    SetPose(plate->mutable_pose(), Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity());
    for (std::size_t k = 1; k + 1 < kNumLegs; ++k) {  // fan over the outline
      SetPoint(plate->add_points(), truth_g.p_PB_P[platform_order_[0]]);
      SetPoint(plate->add_points(), truth_g.p_PB_P[platform_order_[k]]);
      SetPoint(plate->add_points(), truth_g.p_PB_P[platform_order_[k + 1]]);
    }
    SetColor(plate->mutable_color(), kPlateColor);
    AddSpheres(e, truth_g.p_PB_P, kPlatformJointDiameterM, kPlatformColor);
    AddMeta(e, "joints", options_.geometry_note);
  }
  if (measured_) {
    auto* e = NewEntity(scene_, "platform_measured", "platform_measured", stamp_ns);
    AddOutline(e, nominal.p_PB_P, platform_order_, kMeasuredColor);
    if (!on_truth) AddSpheres(e, nominal.p_PB_P, kPlatformJointDiameterM, kMeasuredColor);
  }
  if (desired_) {
    auto* e = NewEntity(scene_, "platform_desired", "platform_desired", stamp_ns);
    AddOutline(e, nominal.p_PB_P, platform_order_, kDesiredColor);
  }
  // Legs: one entity per leg (id "leg<N>"), a cylinder from the base joint to the platform
  // joint, its state and length in the metadata.
  if (leg_pose) {
    const LegArray<LegSegment> segments = LegSegments(leg_geometry, *leg_pose);
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      const std::string id = "leg" + std::to_string(i + 1);
      auto* e = NewEntity(scene_, id.c_str(), "base", stamp_ns);
      e->set_frame_locked(false);  // drawn in base coordinates for this instant
      const LegSegment& s = segments[i];
      const Eigen::Vector3d axis = s.p_BB_B_m - s.p_BA_B_m;
      auto* c = e->add_cylinders();
      SetPose(c->mutable_pose(), 0.5 * (s.p_BA_B_m + s.p_BB_B_m),
              Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), axis));
      SetVec(c->mutable_size(), Eigen::Vector3d(kLegDiameterM, kLegDiameterM, s.length_m));
      c->set_bottom_scale(1.0);
      c->set_top_scale(1.0);
      const LegDisplayState state = legs_.State(i);
      SetColor(c->mutable_color(), LegColor(state));
      AddMeta(e, "leg", std::to_string(i + 1));
      AddMeta(e, "state", ToString(state));
      AddMeta(e, "length_m", Num(s.length_m));
      AddMeta(e, "platform", on_truth ? "platform" : "platform_measured");
      AddMeta(e, "tick", std::to_string(drawn_tick_));
    }
  }
  if (options_.soft_limits) AddSoftLimitBox(scene_, *options_.soft_limits, stamp_ns);
  // Status label above the platform.
  {
    auto* e = NewEntity(scene_, "status", "base", stamp_ns);
    auto* t = e->add_texts();
    SetPose(t->mutable_pose(), Eigen::Vector3d(0.0, 0.0, 0.85), Eigen::Quaterniond::Identity());
    t->set_billboard(true);
    t->set_font_size(kLabelSizeM);
    SetColor(t->mutable_color(), kTextColor);
    char text[160];
    std::snprintf(text, sizeof text, "supervisor %s  t %.2f s  tick %llu",
                  SupervisorStateName(supervisor_state_), trajectory_time_s_,
                  static_cast<unsigned long long>(last_tick_));
    t->set_text(text);
  }
}

SceneChannels::SceneChannels(RecordingWriter& writer, const SceneOptions& options)
    : writer_(writer) {
  char period[32];
  std::snprintf(period, sizeof period, "%g", static_cast<double>(options.period_ticks) * 1e-3);
  auto meta = [&](const char* what) {
    return std::map<std::string, std::string>{{kMetaPeriodS, period},
                                              {"hexa.scene", what},
                                              {"hexa.scene.joints", options.geometry_note}};
  };
  scene_channel_ = writer_.AddTopic(kSceneTopic, *foxglove::SceneUpdate::descriptor(),
                                    meta("legs, joints, outlines, soft limits, status (docs/foxglove.md)"));
  transforms_channel_ =
      writer_.AddTopic(kTransformsTopic, *foxglove::FrameTransforms::descriptor(),
                       meta("base -> platform, platform_measured, platform_desired"));
}

void SceneChannels::Write(std::uint64_t log_time_ns, const SceneBuilder& builder) {
  writer_.Write(transforms_channel_, log_time_ns, log_time_ns, builder.transforms());
  writer_.Write(scene_channel_, log_time_ns, log_time_ns, builder.scene());
}

bool IsSceneChannel(const McapChannel& channel) {
  return channel.topic == kSceneTopic || channel.topic == kTransformsTopic;
}

}  // namespace hexa::recorder
