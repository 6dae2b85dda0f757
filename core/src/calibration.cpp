#include "hexa/core/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "hexa/core/kinematics.hpp"
#include "hexa/core/sensor_model.hpp"

namespace hexa {

LegCalibrationVector LegCalibration::AsVector() const {
  LegCalibrationVector v;
  v << p_BA_B_m, p_PB_P_m, potentiometer_offset_m, potentiometer_gain;
  return v;
}

LegCalibration LegCalibration::FromVector(const LegCalibrationVector& v) {
  LegCalibration c;
  c.p_BA_B_m = v.segment<3>(0);
  c.p_PB_P_m = v.segment<3>(3);
  c.potentiometer_offset_m = v[6];
  c.potentiometer_gain = v[7];
  return c;
}

KinematicCalibration NominalCalibration(const GeometryParams& geometry) {
  KinematicCalibration c;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    c[i].p_BA_B_m = geometry.p_BA_B[i];
    c[i].p_PB_P_m = geometry.p_PB_P[i];
  }
  return c;
}

GeometryParams CalibratedGeometry(const GeometryParams& nominal,
                                  const KinematicCalibration& calibration) {
  GeometryParams g = nominal;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    g.p_BA_B[i] = calibration[i].p_BA_B_m;
    g.p_PB_P[i] = calibration[i].p_PB_P_m;
  }
  return g;
}

const std::array<const char*, kCalibrationParamsPerLeg>& CalibrationParameterNames() {
  static const std::array<const char*, kCalibrationParamsPerLeg> names{
      "base joint x", "base joint y", "base joint z", "platform joint x",
      "platform joint y", "platform joint z", "potentiometer offset", "potentiometer gain"};
  return names;
}

double PredictedReadingM(const LegCalibration& leg, const Pose& pose, double mid_stroke_length_m,
                         LegCalibrationVector* gradient) {
  const Eigen::Vector3d d = pose.p_BP_B_m + pose.R_BP * leg.p_PB_P_m - leg.p_BA_B_m;  // eq 46
  const double l = d.norm();
  const double x = l - mid_stroke_length_m;
  if (gradient != nullptr) {
    const Eigen::Vector3d s = d / l;
    gradient->segment<3>(0) = -leg.potentiometer_gain * s;
    gradient->segment<3>(3) = leg.potentiometer_gain * (pose.R_BP.transpose() * s);
    (*gradient)[6] = 1.0;
    (*gradient)[7] = x;
  }
  return mid_stroke_length_m + leg.potentiometer_offset_m + leg.potentiometer_gain * x;
}

IdentifiabilityReport AnalyseIdentifiability(const KinematicCalibration& around,
                                             double mid_stroke_length_m,
                                             const std::vector<Pose>& poses,
                                             const CalibrationIdentifiabilityLimits& limits) {
  IdentifiabilityReport report;
  report.samples = static_cast<int>(poses.size());
  report.identifiable = true;
  const auto& names = CalibrationParameterNames();
  const int n = kCalibrationParamsPerLeg;
  char buf[320];
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    LegIdentifiability& li = report.legs[i];
    Eigen::MatrixXd J(std::max<std::size_t>(poses.size(), 1), n);
    J.setZero();
    for (std::size_t k = 0; k < poses.size(); ++k) {
      LegCalibrationVector g;
      PredictedReadingM(around[i], poses[k], mid_stroke_length_m, &g);
      J.row(static_cast<Eigen::Index>(k)) = g.transpose();
    }
    // Column scaling: the condition number then does not depend on the units.
    LegCalibrationVector scale;
    for (int c = 0; c < n; ++c) {
      const double norm = J.col(c).norm();
      scale[c] = norm > 0.0 ? 1.0 / norm : 1.0;
    }
    const Eigen::MatrixXd Js = J * scale.asDiagonal();
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(Js, Eigen::ComputeFullV);
    const Eigen::VectorXd sv = svd.singularValues();
    const double smax = sv.size() > 0 ? sv[0] : 0.0;
    li.rank = 0;
    for (Eigen::Index k = 0; k < sv.size(); ++k) li.rank += sv[k] > smax * 1e-10 ? 1 : 0;
    const bool full_rank = static_cast<int>(poses.size()) >= n && li.rank == n;
    li.condition = full_rank ? smax / sv[n - 1] : std::numeric_limits<double>::infinity();
    // Weakest direction: the parameters carrying most of the last right singular vector.
    const Eigen::VectorXd weak = svd.matrixV().col(std::min<Eigen::Index>(n, sv.size()) - 1);
    li.weakest.clear();
    for (int c = 0; c < n; ++c) {
      if (std::abs(weak[c]) > 0.3) {
        if (!li.weakest.empty()) li.weakest += ", ";
        li.weakest += names[static_cast<std::size_t>(c)];
      }
    }
    if (full_rank) {
      // Covariance sigma^2 (J^T J)^-1, via the scaled SVD: J^T J = S^-1 V D^2 V^T S^-1.
      const Eigen::MatrixXd V = svd.matrixV();
      for (int c = 0; c < n; ++c) {
        double var = 0.0;
        for (int k = 0; k < n; ++k) var += V(c, k) * V(c, k) / (sv[k] * sv[k]);
        li.predicted_std[c] = limits.reading_noise_m * scale[c] * std::sqrt(var);
      }
    } else {
      li.predicted_std.setConstant(std::numeric_limits<double>::infinity());
    }
    if (!report.identifiable) continue;  // report the first failing leg only
    const int leg = static_cast<int>(i) + 1;
    if (!full_rank) {
      std::snprintf(buf, sizeof(buf),
                    "leg %d: the %d poses do not determine the 8 parameters (rank %d of 8); "
                    "not separable: %s. Visit poses that change the leg direction (rotations "
                    "and translations in every axis)",
                    leg, report.samples, li.rank, li.weakest.c_str());
      report.identifiable = false;
      report.message = buf;
      continue;
    }
    for (int c = 0; c < n && report.identifiable; ++c) {
      const double limit = c < 6 ? limits.max_joint_std_m
                                 : (c == 6 ? limits.max_offset_std_m : limits.max_gain_std);
      if (li.predicted_std[c] > limit) {
        std::snprintf(buf, sizeof(buf),
                      "leg %d: %s would be known to %.3g %s (1 sigma at %.3g mm of reading "
                      "noise), limit %.3g: pose set too weak (condition %.3g; weakest "
                      "direction: %s)",
                      leg, names[static_cast<std::size_t>(c)],
                      c < 7 ? li.predicted_std[c] * 1e3 : li.predicted_std[c], c < 7 ? "mm" : "",
                      limits.reading_noise_m * 1e3, c < 7 ? limit * 1e3 : limit, li.condition,
                      li.weakest.c_str());
        report.identifiable = false;
        report.message = buf;
      }
    }
    if (report.identifiable && li.condition > limits.max_condition) {
      std::snprintf(buf, sizeof(buf), "leg %d: condition number %.3g exceeds %.3g (weakest: %s)",
                    leg, li.condition, limits.max_condition, li.weakest.c_str());
      report.identifiable = false;
      report.message = buf;
    }
  }
  if (report.identifiable) report.message = "identifiable";
  return report;
}

std::vector<Vector6d> SelectCalibrationPoses(const RigParams& rig,
                                             const CalibrationDesignParams& params) {
  const Vector6d home = (Vector6d() << rig.geometry.home_position_m, 0.0, 0.0, 0.0).finished();
  const double mid = rig.cylinder.mid_stroke_length_m;
  const double usable = 0.5 * rig.cylinder.stroke_m - params.stroke_margin_m;
  const KinematicCalibration nominal = NominalCalibration(rig.geometry);
  std::mt19937_64 rng(DeriveSeed(params.seed, 11));
  std::uniform_real_distribution<double> unit(-1.0, 1.0);

  // Candidates inside the stroke, with each leg's gradient row (8 values per leg).
  std::vector<Vector6d> candidate;
  std::vector<LegArray<LegCalibrationVector>> rows;
  const int max_draws = 50 * std::max(params.candidates, 1);
  for (int draw = 0; draw < max_draws && static_cast<int>(candidate.size()) < params.candidates;
       ++draw) {
    Vector6d q = home;
    for (int k = 0; k < 3; ++k) q[k] += params.max_translation_m * unit(rng);
    for (int k = 3; k < 6; ++k) q[k] += params.max_rotation_rad * unit(rng);
    const Pose pose = PoseFromVector(q);
    if ((q.head<3>() - home.head<3>()).norm() > params.max_translation_norm_m ||
        Eigen::AngleAxisd(pose.R_BP).angle() > params.max_rotation_angle_rad) {
      continue;
    }
    LegArray<double> length;
    InverseKinematics(rig.geometry, pose, length);
    bool inside = true;
    for (double l : length) inside = inside && std::abs(l - mid) <= usable;
    if (!inside) continue;
    LegArray<LegCalibrationVector> r;
    for (std::size_t i = 0; i < kNumLegs; ++i) PredictedReadingM(nominal[i], pose, mid, &r[i]);
    candidate.push_back(q);
    rows.push_back(r);
  }
  // Greedy D-optimal: add the candidate with the largest sum over legs of
  // log(1 + r^T M^-1 r) (= the increase of log det M), M the information so far.
  using Matrix8d = Eigen::Matrix<double, kCalibrationParamsPerLeg, kCalibrationParamsPerLeg>;
  LegArray<Matrix8d> info;
  for (auto& m : info) m = 1e-12 * Matrix8d::Identity();
  std::vector<bool> used(candidate.size(), false);
  std::vector<Vector6d> chosen;
  for (int k = 0; k < params.count && k < static_cast<int>(candidate.size()); ++k) {
    LegArray<Eigen::LDLT<Matrix8d>> factor;
    for (std::size_t i = 0; i < kNumLegs; ++i) factor[i].compute(info[i]);
    double best_gain = -std::numeric_limits<double>::infinity();
    std::size_t best = 0;
    for (std::size_t c = 0; c < candidate.size(); ++c) {
      if (used[c]) continue;
      double gain = 0.0;
      for (std::size_t i = 0; i < kNumLegs; ++i) {
        gain += std::log1p(rows[c][i].dot(factor[i].solve(rows[c][i])));
      }
      if (gain > best_gain) {
        best_gain = gain;
        best = c;
      }
    }
    used[best] = true;
    chosen.push_back(candidate[best]);
    for (std::size_t i = 0; i < kNumLegs; ++i) info[i] += rows[best][i] * rows[best][i].transpose();
  }
  return chosen;
}

PoseSequenceMotion::PoseSequenceMotion(std::vector<Vector6d> poses, double move_s, double dwell_s)
    : poses_(std::move(poses)), move_s_(move_s), dwell_s_(dwell_s) {
  if (poses_.empty()) throw std::invalid_argument("PoseSequenceMotion: no pose");
  for (const Vector6d& q : poses_) {
    if (!q.allFinite()) throw std::invalid_argument("PoseSequenceMotion: non-finite pose");
  }
  if (!(move_s_ > 0.0) || !std::isfinite(move_s_)) {
    throw std::invalid_argument("PoseSequenceMotion: move_s = " + std::to_string(move_s_) +
                                " must be finite and > 0");
  }
  if (!(dwell_s_ >= 0.0) || !std::isfinite(dwell_s_)) {
    throw std::invalid_argument("PoseSequenceMotion: dwell_s = " + std::to_string(dwell_s_) +
                                " must be finite and >= 0");
  }
}

double PoseSequenceMotion::end_time_s() const noexcept {
  const double n = static_cast<double>(poses_.size());
  return n * dwell_s_ + (n - 1.0) * move_s_;
}

void PoseSequenceMotion::Evaluate(double tau_s, PoseVectorState& state) const noexcept {
  state.q_dot.setZero();
  state.q_ddot.setZero();
  const double segment = dwell_s_ + move_s_;
  const double t = std::max(tau_s, 0.0);
  const std::size_t k = static_cast<std::size_t>(std::floor(t / segment));
  if (k + 1 >= poses_.size()) {
    state.q = poses_.back();
    return;
  }
  const double u = t - static_cast<double>(k) * segment - dwell_s_;
  if (u <= 0.0) {  // still at pose k
    state.q = poses_[k];
    return;
  }
  // Quintic minimum-jerk move from pose k to pose k + 1 (C2 at both ends).
  const double s = u / move_s_;
  const double s2 = s * s, s3 = s2 * s;
  const double sigma = s3 * (10.0 - 15.0 * s + 6.0 * s2);
  const double dsigma = 30.0 * s2 * (1.0 - 2.0 * s + s2) / move_s_;
  const double ddsigma = 60.0 * s * (1.0 - 3.0 * s + 2.0 * s2) / (move_s_ * move_s_);
  const Vector6d delta = poses_[k + 1] - poses_[k];
  state.q = poses_[k] + sigma * delta;
  state.q_dot = dsigma * delta;
  state.q_ddot = ddsigma * delta;
}

void CalibrationSampleCollector::AddDesired(std::uint64_t tick, const Vector6d& desired_xyz_rpy,
                                            bool usable) {
  desired_.push_back(Desired{tick, desired_xyz_rpy, usable});
}

void CalibrationSampleCollector::AddReading(std::uint64_t tick, std::size_t leg, double reading_m) {
  if (leg >= kNumLegs) return;
  TickData& d = ticks_[tick];
  d.reading[leg] = reading_m;
  d.has_reading[leg] = true;
}

void CalibrationSampleCollector::AddTracker(std::uint64_t tick, const Eigen::Vector3d& p_BP_B_m,
                                            const Eigen::Quaterniond& q_BP) {
  TickData& d = ticks_[tick];
  d.has_tracker = true;
  d.p = p_BP_B_m;
  d.q = q_BP;
  ++tracker_count_;
}

std::vector<CalibrationSample> CalibrationSampleCollector::Samples() const {
  std::vector<CalibrationSample> samples;
  const auto min_ticks = static_cast<std::uint64_t>(std::llround(params_.min_still_s / params_.tick_s));
  const auto window_ticks = static_cast<std::uint64_t>(std::llround(params_.window_s / params_.tick_s));
  std::size_t begin = 0;
  for (std::size_t k = 1; k <= desired_.size(); ++k) {
    const bool same = k < desired_.size() && desired_[k].usable && desired_[k].q == desired_[begin].q;
    if (same) continue;
    const std::uint64_t first = desired_[begin].tick, last = desired_[k - 1].tick;
    if (desired_[begin].usable && last >= first + min_ticks) {
      // One sample per tracker measurement in the window: its pose, and each leg's readings
      // averaged over the ticks of that measurement's period around it (the platform is
      // still on that scale; it may wander by a millimetre over the whole window, so poses
      // and readings are never averaged separately over the window).
      const auto half = static_cast<std::uint64_t>(
          std::max<long long>(0, std::llround(0.5 * params_.tracker_period_s / params_.tick_s)));
      for (auto it = ticks_.lower_bound(last - window_ticks); it != ticks_.end() && it->first <= last;
           ++it) {
        if (!it->second.has_tracker) continue;
        LegArray<double> sum{};
        LegArray<int> n_read{};
        const std::uint64_t t0 = it->first >= half ? it->first - half : 0;
        for (auto jt = ticks_.lower_bound(t0); jt != ticks_.end() && jt->first < it->first + half + (half == 0 ? 1 : 0);
             ++jt) {
          for (std::size_t i = 0; i < kNumLegs; ++i) {
            if (jt->second.has_reading[i]) {
              sum[i] += jt->second.reading[i];
              ++n_read[i];
            }
          }
        }
        bool complete = true;
        for (int n : n_read) complete = complete && n > 0;
        if (!complete) continue;
        CalibrationSample s;
        s.pose.p_BP_B_m = it->second.p;
        s.pose.R_BP = it->second.q.normalized().toRotationMatrix();
        for (std::size_t i = 0; i < kNumLegs; ++i) s.reading_m[i] = sum[i] / n_read[i];
        samples.push_back(s);
      }
    }
    begin = k;
  }
  return samples;
}

Trajectory MakeCalibrationTrajectory(const RigParams& rig, const Vector6d& start_xyz_rpy,
                                     const Vector6d& rest_xyz_rpy, const TrajectoryTiming& timing,
                                     const CalibrationProcedureParams& params) {
  auto motion = std::make_shared<const PoseSequenceMotion>(
      SelectCalibrationPoses(rig, params.design), params.move_s, params.dwell_s);
  return Trajectory(motion, start_xyz_rpy, rest_xyz_rpy, timing);
}

}  // namespace hexa
