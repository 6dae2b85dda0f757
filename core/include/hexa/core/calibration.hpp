// Kinematic calibration: the measurement model, the identifiability analysis and
// the choice of calibration poses. The least-squares fit itself runs in hexa_calibrate
// (Ceres, tools/calibrate); this part is Eigen only and shared by the supervisor (which
// visits the poses), the fit and the tests.
//
// Measurement model of leg i at a still pose X_BP (measured by an external instrument, e.g.
// a laser tracker), with the rig's geometry and potentiometer (sensor_model.hpp):
//
//   l_i    = |p_BP_B + R_BP b_i - a_i|                 (eq 46, a_i base joint, b_i platform joint)
//   read_i = l_mid + o_i + g_i (l_i - l_mid)           (potentiometer: offset o_i, gain g_i)
//
// Parameters per leg: a_i (3), b_i (3), o_i, g_i: eight, and the legs are independent given
// the measured poses (each leg's reading depends only on its own parameters), so the
// problem splits into six 8-parameter problems. The leg-axis components of a_i and b_i and
// the offset o_i all shift the reading by nearly the same amount at every pose (they differ
// only through the change of the leg direction between poses): the pose set decides whether
// they can be told apart, hence the identifiability check and the D-optimal pose choice.
#pragma once

#include <array>
#include <map>
#include <cstdint>
#include <string>
#include <vector>

#include "hexa/core/control_params.hpp"
#include "hexa/core/pose.hpp"
#include "hexa/core/rig.hpp"
#include "hexa/core/trajectory.hpp"

namespace hexa {

inline constexpr int kCalibrationParamsPerLeg = 8;  // a (3), b (3), offset, gain
using LegCalibrationVector = Eigen::Matrix<double, kCalibrationParamsPerLeg, 1>;

// One leg's kinematic calibration: joint positions and potentiometer (reading of piston
// position x = offset_m + gain * x).
struct LegCalibration {
  Eigen::Vector3d p_BA_B_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_PB_P_m = Eigen::Vector3d::Zero();
  double potentiometer_offset_m = 0.0;
  double potentiometer_gain = 1.0;

  LegCalibrationVector AsVector() const;
  static LegCalibration FromVector(const LegCalibrationVector& v);
};
using KinematicCalibration = LegArray<LegCalibration>;

// The leg length a calibrated potentiometer reading stands for (the model inverted):
// l = l_mid + (reading - l_mid - offset) / gain.
inline double CorrectedLengthM(const LegCalibration& leg, double reading_m, double mid_stroke_length_m) {
  return mid_stroke_length_m +
         (reading_m - mid_stroke_length_m - leg.potentiometer_offset_m) / leg.potentiometer_gain;
}

// The controllers' geometry with the calibrated joint positions.
GeometryParams CalibratedGeometry(const GeometryParams& nominal, const KinematicCalibration& calibration);

// The nominal calibration of a rig: its joint positions, ideal potentiometers.
KinematicCalibration NominalCalibration(const GeometryParams& geometry);

// One still pose of a calibration run: the external instrument's pose and the six
// potentiometer readings (each typically an average over the still window).
struct CalibrationSample {
  Pose pose;
  LegArray<double> reading_m{};
};

// The model's reading of leg `leg` at `pose` (the equation of the header), and its gradient
// with respect to the eight parameters (order of LegCalibrationVector).
double PredictedReadingM(const LegCalibration& leg, const Pose& pose, double mid_stroke_length_m,
                         LegCalibrationVector* gradient = nullptr);

// Identifiability of the pose set (the linearised problem at `around`).
struct CalibrationIdentifiabilityLimits {
  // 1-sigma error of one sample (reading averaged over 10 ms, 0.05 mm potentiometer noise:
  // 0.017 mm; tracker 0.02 mm and 0.005 deg at ~0.25 m: 0.03 mm)
  double reading_noise_m = 0.035e-3;
  double max_joint_std_m = 5.0e-5;   // predicted 1-sigma of every joint coordinate
  double max_offset_std_m = 2.5e-5;  // predicted 1-sigma of every potentiometer offset
  double max_gain_std = 1.0e-4;      // predicted 1-sigma of every potentiometer gain
  double max_condition = 1.0e6;      // of the column-scaled Jacobian
};

struct LegIdentifiability {
  int rank = 0;                   // numerical rank of the column-scaled Jacobian (of 8)
  double condition = 0.0;         // largest / smallest singular value (inf when rank < 8)
  LegCalibrationVector predicted_std = LegCalibrationVector::Zero();  // m, m, ..., m, 1
  std::string weakest;            // parameters with the largest part in the weakest direction
};

struct IdentifiabilityReport {
  bool identifiable = false;
  int samples = 0;
  LegArray<LegIdentifiability> legs{};
  std::string message;  // why not, naming the leg, the parameters and the limit
};

IdentifiabilityReport AnalyseIdentifiability(const KinematicCalibration& around,
                                             double mid_stroke_length_m,
                                             const std::vector<Pose>& poses,
                                             const CalibrationIdentifiabilityLimits& limits);

// Names of the parameters, in vector order ("a.x" ... "gain").
const std::array<const char*, kCalibrationParamsPerLeg>& CalibrationParameterNames();

// Calibration poses chosen for identifiability: from `candidates` random poses inside the
// box (translation +-max_translation_m about home, rotation +-max_rotation_rad per axis,
// within the norm limits) whose legs stay `stroke_margin_m` inside the stroke, a greedy D-optimal design
// (maximises the sum over legs of log det of the information matrix) picks `count`.
// Deterministic for a seed.
struct CalibrationDesignParams {
  int count = 50;
  int candidates = 1500;
  double max_translation_m = 0.10;   // per axis
  double max_rotation_rad = 0.3491;  // 20 deg per axis
  // Norm limits: inside the supervisor's workspace (0.15 m, 30 deg) with a margin.
  double max_translation_norm_m = 0.12;
  double max_rotation_angle_rad = 0.4189;  // 24 deg
  double stroke_margin_m = 0.015;
  std::uint64_t seed = 1;
};
std::vector<Vector6d> SelectCalibrationPoses(const RigParams& rig,
                                             const CalibrationDesignParams& params);

// The calibration procedure the supervisor runs (hexa_session --trajectory calibration):
// visit each pose, hold it still for dwell_s, move to the next with a quintic (C2) blend of
// move_s. The calibration fit uses the last part of every still window.
struct CalibrationProcedureParams {
  CalibrationDesignParams design;
  double move_s = 2.0;
  double dwell_s = 5.0;  // >= half the supervisor's blend: the first pose is reached still
};

class PoseSequenceMotion final : public ReferenceMotion {
 public:
  // Throws std::invalid_argument for no pose, non-finite poses, move_s <= 0 or dwell_s < 0.
  PoseSequenceMotion(std::vector<Vector6d> poses, double move_s, double dwell_s);
  void Evaluate(double tau_s, PoseVectorState& state) const noexcept override;
  double start_time_s() const noexcept override { return 0.0; }
  double end_time_s() const noexcept override;
  const std::vector<Vector6d>& poses() const { return poses_; }

 private:
  std::vector<Vector6d> poses_;
  double move_s_;
  double dwell_s_;
};

// Builds the still samples of a calibration run from its data in tick order (hexa_calibrate
// from a recording, hexa_sim in process): a still window is a run of supervisor ticks whose
// desired pose does not change for at least min_still_s; the tracker poses and the
// the last window_s of it gives one sample per tracker measurement (pose) with the
// potentiometer readings averaged over that measurement's period. Not for the
// control cycle (it keeps the run's data).
struct StillWindowParams {
  double min_still_s = 4.0;
  double window_s = 2.0;
  double tick_s = 0.001;
  double tracker_period_s = 0.01;  // readings averaged over this period around a measurement
};

class CalibrationSampleCollector {
 public:
  explicit CalibrationSampleCollector(const StillWindowParams& params) : params_(params) {}
  // The supervisor's desired pose at `tick`; `usable` false (e.g. HOLD) ends a window.
  void AddDesired(std::uint64_t tick, const Vector6d& desired_xyz_rpy, bool usable);
  void AddReading(std::uint64_t tick, std::size_t leg, double reading_m);
  void AddTracker(std::uint64_t tick, const Eigen::Vector3d& p_BP_B_m, const Eigen::Quaterniond& q_BP);
  std::vector<CalibrationSample> Samples() const;
  std::size_t tracker_count() const { return tracker_count_; }

 private:
  struct TickData {
    bool has_tracker = false;
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    LegArray<double> reading{};
    LegArray<bool> has_reading{};
  };
  struct Desired {
    std::uint64_t tick;
    Vector6d q;
    bool usable;
  };
  StillWindowParams params_;
  std::map<std::uint64_t, TickData> ticks_;
  std::vector<Desired> desired_;
  std::size_t tracker_count_ = 0;
};

Trajectory MakeCalibrationTrajectory(const RigParams& rig, const Vector6d& start_xyz_rpy,
                                     const Vector6d& rest_xyz_rpy, const TrajectoryTiming& timing,
                                     const CalibrationProcedureParams& params);

}  // namespace hexa
