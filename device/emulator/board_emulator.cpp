// The remote I/O board emulated (board_emulator.hpp).
#include "board_emulator.hpp"

#include <algorithm>
#include <cmath>

namespace hexa::device {

namespace {

std::uint16_t ToAdc(const ChannelCalibration& cal, double value_si, std::uint32_t max_counts) {
  const double counts = std::round(cal.ToCounts(value_si));
  return static_cast<std::uint16_t>(std::clamp(counts, 0.0, static_cast<double>(max_counts)));
}

std::int16_t ToSigned16(double counts) {
  return static_cast<std::int16_t>(std::clamp(std::round(counts), -32768.0, 32767.0));
}

hb_board_config MakeBoardConfig(const BoardEmulatorConfig& c) {
  hb_board_config b{};
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const ChannelCalibration& valve = c.calibration.legs[i].valve_v;
    const double counts = std::round(valve.ToCounts(c.valve_null_v));
    b.safe_dac[i] = static_cast<std::uint16_t>(
        std::clamp(counts, 0.0, static_cast<double>(c.calibration.dac_max_counts())));
  }
  b.dac_max = static_cast<std::uint16_t>(c.calibration.dac_max_counts());
  b.watchdog_default_ms = static_cast<std::uint16_t>(std::lround(c.calibration.watchdog_timeout_s * 1000.0));
  b.watchdog_min_ms = static_cast<std::uint16_t>(std::lround(kBoardWatchdogMin_s * 1000.0));
  b.watchdog_max_ms = static_cast<std::uint16_t>(std::lround(kBoardWatchdogMax_s * 1000.0));
  return b;
}

}  // namespace

BoardEmulator::BoardEmulator(const BoardEmulatorConfig& config) : config_(config), plant_(config.plant) {
  const hb_board_config b = MakeBoardConfig(config_);
  hb_board_init(&board_, &b);
}

bool BoardEmulator::LoopClosed(std::uint64_t tick) const {
  for (const EstopOpenWindow& w : config_.estop_open) {
    if (tick >= w.open_tick && tick < w.close_tick) return false;
  }
  return true;
}

hb_board_inputs BoardEmulator::SampleInputs() const {
  const PlatformPlantOutput& out = plant_.output();
  const BoardCalibration& cal = config_.calibration;
  const std::uint32_t adc_max = cal.adc_max_counts();
  hb_board_inputs in{};
  const double half_stroke_m = 0.5 * config_.plant.rig.cylinder.stroke_m;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const int leg = static_cast<int>(i);
    const LegSensorReading& r = out.legs[i];
    in.adc[HB_ADC_POT(leg)] = ToAdc(cal.legs[i].potentiometer_m, r.length_m, adc_max);
    in.adc[HB_ADC_CHAMBER1(leg)] = ToAdc(cal.legs[i].chamber1_pressure_pa, r.chamber1_pressure_pa, adc_max);
    in.adc[HB_ADC_CHAMBER2(leg)] = ToAdc(cal.legs[i].chamber2_pressure_pa, r.chamber2_pressure_pa, adc_max);
    const double x_m = out.truth.piston_position_m[i];
    if (x_m <= -half_stroke_m + config_.end_switch_margin_m) in.digital_inputs |= HB_DIN_RETRACTED(leg);
    if (x_m >= half_stroke_m - config_.end_switch_margin_m) in.digital_inputs |= HB_DIN_EXTENDED(leg);
  }
  in.adc[HB_ADC_SUPPLY] = ToAdc(cal.supply_pressure_pa, out.legs[0].supply_pressure_pa, adc_max);
  const Eigen::Quaterniond q = out.imu.q_BP_measured.normalized();
  in.imu_quat[0] = ToSigned16(q.w() * kBoardQuaternionScale);
  in.imu_quat[1] = ToSigned16(q.x() * kBoardQuaternionScale);
  in.imu_quat[2] = ToSigned16(q.y() * kBoardQuaternionScale);
  in.imu_quat[3] = ToSigned16(q.z() * kBoardQuaternionScale);
  for (int k = 0; k < 3; ++k) in.imu_rate[k] = ToSigned16(cal.imu_rate_rad_s.ToCounts(out.imu.angular_rate_B_rad_s(k)));
  in.imu_count = imu_count_;
  if (LoopClosed(tick_)) in.digital_inputs |= HB_DIN_ESTOP_LOOP_CLOSED;
  return in;
}

hb_frame_reason BoardEmulator::Receive(std::span<const std::uint8_t> datagram) {
  return hb_board_receive(&board_, datagram.data(), datagram.size(), board_time_us());
}

std::size_t BoardEmulator::Tick(std::array<std::uint8_t, HB_SENSOR_FRAME_SIZE>& frame) {
  if (plant_.output().imu.fresh) ++imu_count_;
  const hb_board_inputs in = SampleInputs();
  std::uint16_t dac[HB_NUM_LEGS];
  hb_board_tick(&board_, &in, board_time_us(), dac);
  const std::size_t n = hb_board_frame(&board_, frame.data());
  LegArray<double> valve_v{};
  for (std::size_t i = 0; i < kNumLegs; ++i) valve_v[i] = config_.calibration.legs[i].valve_v.ToSi(dac[i]);
  plant_.Step(valve_v, kPlantTick_s);
  ++tick_;
  return n;
}

}  // namespace hexa::device
