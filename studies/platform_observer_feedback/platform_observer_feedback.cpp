#include "platform_observer_feedback.hpp"

namespace hexa::study {
namespace {

class PlatformObserverLegRunner final : public LegRunner {
 public:
  PlatformObserverLegRunner(const PlatformObserverFeedbackParams& params, const Supervisor& supervisor,
                            const LegArray<std::unique_ptr<LegController>>& legs)
      : observer_(MakeConfig(params, supervisor)) {
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      potentiometer_[i] = legs[i]->config().potentiometer;
      mid_stroke_m_[i] = legs[i]->config().model.cylinder.mid_stroke_length_m;
    }
  }

  void Run(const SupervisorOutput* supervisor_output, LegArray<std::unique_ptr<LegController>>& legs,
           const LegArray<LegControllerInput>& in, LegArray<LegControllerOutput>& out) override {
    if (supervisor_output != nullptr && supervisor_output->estimate.status == KinStatus::kOk) {
      const Eigen::Quaterniond q(supervisor_output->estimate.pose.R_BP);
      obs_in_.orientation_wxyz = {q.w(), q.x(), q.y(), q.z()};
    }
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      // The leg's potentiometer calibration (reading = offset + gain x, LegController).
      obs_in_.length_m[i] = mid_stroke_m_[i] +
                            (in[i].length_m - mid_stroke_m_[i] - potentiometer_[i].offset_m) /
                                potentiometer_[i].gain;
      obs_in_.cap_pressure_pa[i] = in[i].cap_pressure_pa;
      obs_in_.rod_pressure_pa[i] = in[i].rod_pressure_pa;
    }
    observer_.Update(obs_in_, obs_out_);
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      if (obs_out_.valid) {
        legs[i]->Update(in[i], out[i], obs_out_.velocity_m_s[i]);
      } else {
        legs[i]->Update(in[i], out[i]);
      }
    }
  }

 private:
  static PlatformStateObserverConfig MakeConfig(const PlatformObserverFeedbackParams& params,
                                                const Supervisor& supervisor) {
    PlatformStateObserverConfig c = PlatformStateObserverConfig::FromRig(supervisor.rig());
    c.disturbance_rate_m_s3 = params.disturbance_rate_m_s3;
    return c;
  }

  PlatformStateObserver observer_;
  PlatformStateObserverInput obs_in_;
  PlatformStateObserverOutput obs_out_;
  LegArray<PotentiometerCalibrationParams> potentiometer_{};
  LegArray<double> mid_stroke_m_{};
};

}  // namespace

LegRunnerFactory PlatformObserverLegRunnerFactory(const PlatformObserverFeedbackParams& params) {
  if (!params.enabled) return {};
  PlatformStateObserverConfig check = PlatformStateObserverConfig::FromRig(MakeReferenceRig());
  check.disturbance_rate_m_s3 = params.disturbance_rate_m_s3;
  check.Validate();  // throws naming the field and value
  return [params](const Supervisor& supervisor, const LegArray<std::unique_ptr<LegController>>& legs) {
    return std::make_unique<PlatformObserverLegRunner>(params, supervisor, legs);
  };
}

}  // namespace hexa::study
