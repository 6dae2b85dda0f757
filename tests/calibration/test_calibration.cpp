// Kinematic calibration: the fit recovers known joint and potentiometer errors from a
// noise-free synthetic data set at the designed poses; an unidentifiable pose set is refused
// with a message naming the leg and the parameters; the design's poses are inside the
// stroke; the tracker is off by default and, when on, leaves every other output unchanged.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "calibration_fit.hpp"
#include "hexa/core/kinematics.hpp"
#include "hexa/core/platform_plant.hpp"

namespace hexa {
namespace {

// A rig whose joints and potentiometers are off by the realistic profile's amounts.
KinematicCalibration PerturbedTruth(const RigParams& rig, std::uint64_t seed) {
  KinematicCalibration truth = NominalCalibration(rig.geometry);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (auto& leg : truth) {
    for (int k = 0; k < 3; ++k) {
      leg.p_BA_B_m[k] += 1.2e-3 * u(rng);
      leg.p_PB_P_m[k] += 1.2e-3 * u(rng);
    }
    leg.potentiometer_offset_m = 1.0e-3 * u(rng);
    leg.potentiometer_gain = 1.0 + 0.005 * u(rng);
  }
  return truth;
}

std::vector<CalibrationSample> Synthetic(const KinematicCalibration& truth, double mid,
                                         const std::vector<Vector6d>& poses) {
  std::vector<CalibrationSample> samples;
  for (const Vector6d& q : poses) {
    CalibrationSample s;
    s.pose = PoseFromVector(q);
    for (std::size_t i = 0; i < kNumLegs; ++i) s.reading_m[i] = PredictedReadingM(truth[i], s.pose, mid);
    samples.push_back(s);
  }
  return samples;
}

TEST(Calibration, DesignedPosesStayInsideTheStroke) {
  const RigParams rig = MakeReferenceRig();
  const CalibrationDesignParams design;
  const auto poses = SelectCalibrationPoses(rig, design);
  ASSERT_EQ(static_cast<int>(poses.size()), design.count);
  const double usable = 0.5 * rig.cylinder.stroke_m - design.stroke_margin_m;
  for (const Vector6d& q : poses) {
    LegArray<double> l;
    InverseKinematics(rig.geometry, PoseFromVector(q), l);
    for (double x : l) EXPECT_LE(std::abs(x - rig.cylinder.mid_stroke_length_m), usable + 1e-12);
  }
  // Deterministic for a seed.
  EXPECT_EQ(poses, SelectCalibrationPoses(rig, design));
}

TEST(Calibration, FitRecoversKnownErrorsFromNoiseFreeSyntheticData) {
  const RigParams rig = MakeReferenceRig();
  const double mid = rig.cylinder.mid_stroke_length_m;
  const KinematicCalibration truth = PerturbedTruth(rig, 3);
  const auto samples = Synthetic(truth, mid, SelectCalibrationPoses(rig, CalibrationDesignParams{}));
  calib::FitOptions options;
  options.limits.reading_noise_m = 2e-6;  // one sample per pose (an average of a window)
  const calib::FitResult fit =
      calib::FitKinematicCalibration(samples, mid, NominalCalibration(rig.geometry), options);
  ASSERT_TRUE(fit.ok) << fit.message;
  ASSERT_TRUE(fit.identifiability.identifiable) << fit.identifiability.message;
  double worst_before = 0.0, worst_after = 0.0;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const LegCalibrationVector before = NominalCalibration(rig.geometry)[i].AsVector() - truth[i].AsVector();
    const LegCalibrationVector after = fit.calibration[i].AsVector() - truth[i].AsVector();
    worst_before = std::max(worst_before, before.head<7>().cwiseAbs().maxCoeff());
    worst_after = std::max(worst_after, after.head<7>().cwiseAbs().maxCoeff());
    EXPECT_LT(after.head<7>().cwiseAbs().maxCoeff(), 1e-9) << "leg " << i + 1 << " (m)";
    EXPECT_LT(std::abs(after[7]), 1e-9) << "leg " << i + 1 << " gain";
    EXPECT_TRUE(fit.legs[i].converged) << fit.legs[i].ceres_report;
    EXPECT_LT(fit.legs[i].final_rms_m, 1e-12);
  }
  EXPECT_GT(worst_before, 5e-4);  // the errors were there to begin with
  std::printf("worst parameter error: nominal %.3f mm -> fitted %.2e mm\n", 1e3 * worst_before,
              1e3 * worst_after);
}

TEST(Calibration, UnidentifiablePoseSetsAreRefusedWithAClearMessage) {
  const RigParams rig = MakeReferenceRig();
  const double mid = rig.cylinder.mid_stroke_length_m;
  const KinematicCalibration truth = PerturbedTruth(rig, 4);
  const Vector6d home = (Vector6d() << rig.geometry.home_position_m, 0, 0, 0).finished();
  // (a) Fewer poses than parameters.
  {
    std::vector<Vector6d> poses(5, home);
    for (int k = 0; k < 5; ++k) poses[static_cast<std::size_t>(k)][k] += 0.02;
    const auto fit = calib::FitKinematicCalibration(Synthetic(truth, mid, poses), mid,
                                                    NominalCalibration(rig.geometry), {});
    EXPECT_FALSE(fit.ok);
    EXPECT_NE(fit.message.find("rank"), std::string::npos) << fit.message;
    EXPECT_NE(fit.message.find("leg 1"), std::string::npos) << fit.message;
  }
  // (b) Many poses, translations along z only: the legs' directions barely change, the joint
  // components and the offset along the leg cannot be told apart.
  {
    std::vector<Vector6d> poses;
    for (int k = 0; k < 40; ++k) {
      Vector6d q = home;
      q[2] += -0.06 + 0.003 * k;
      poses.push_back(q);
    }
    const auto fit = calib::FitKinematicCalibration(Synthetic(truth, mid, poses), mid,
                                                    NominalCalibration(rig.geometry), {});
    EXPECT_FALSE(fit.ok);
    EXPECT_NE(fit.message.find("not identifiable"), std::string::npos) << fit.message;
    std::printf("refusal message: %s\n", fit.message.c_str());
  }
}

TEST(Calibration, PredictedUncertaintyOfTheDesignMeetsTheTargets) {
  // The designed 50 poses, 200 tracker samples of 0.035 mm each per pose (2 s at 100 Hz,
  // equivalent to one sample of 0.035 / sqrt(200) mm per pose), pin every joint
  // coordinate and offset well inside the targets of 0.2 mm (joints) and 0.1 mm (offsets).
  const RigParams rig = MakeReferenceRig();
  std::vector<Pose> poses;
  for (const Vector6d& q : SelectCalibrationPoses(rig, CalibrationDesignParams{})) {
    poses.push_back(PoseFromVector(q));
  }
  CalibrationIdentifiabilityLimits limits;
  limits.reading_noise_m = 0.035e-3 / std::sqrt(200.0);
  const IdentifiabilityReport r = AnalyseIdentifiability(
      NominalCalibration(rig.geometry), rig.cylinder.mid_stroke_length_m, poses, limits);
  ASSERT_TRUE(r.identifiable) << r.message;
  for (const auto& leg : r.legs) {
    EXPECT_EQ(leg.rank, 8);
    EXPECT_LT(leg.predicted_std.head<6>().maxCoeff(), 0.2e-3 / 3.0);
    EXPECT_LT(leg.predicted_std[6], 0.1e-3 / 3.0);
  }
}

TEST(Tracker, OffByDefaultAndOnChangesNothingElse) {
  PlatformPlantConfig off;
  PlatformPlantConfig on = off;
  on.tracker.enabled = true;
  PlatformPlant a(off), b(on);
  LegArray<double> u;
  u.fill(4.6);
  int fresh = 0;
  double worst_position = 0.0;
  for (int k = 0; k < 300; ++k) {
    ASSERT_EQ(a.Step(u, 1e-3), PlantStatus::kOk);
    ASSERT_EQ(b.Step(u, 1e-3), PlantStatus::kOk);
    EXPECT_FALSE(a.output().tracker.fresh);
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      ASSERT_EQ(a.output().legs[i].length_m, b.output().legs[i].length_m);  // bit-identical
    }
    ASSERT_EQ(a.output().imu.q_BP_measured.coeffs(), b.output().imu.q_BP_measured.coeffs());
    if (b.output().tracker.fresh) {
      ++fresh;
      worst_position = std::max(
          worst_position, (b.output().tracker.p_BP_B_m - b.truth().pose.p_BP_B_m).cwiseAbs().maxCoeff());
    }
  }
  EXPECT_EQ(fresh, 30);  // 100 Hz over 0.3 s
  EXPECT_GT(worst_position, 0.0);
  EXPECT_LT(worst_position, 5 * 0.02e-3);  // 0.02 mm per axis, 5 sigma
}

}  // namespace
}  // namespace hexa
