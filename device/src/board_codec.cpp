// Host side of the board protocol: decoding, range checks, encoding (board_codec.hpp).
#include "hexa/device/board_codec.hpp"

#include <algorithm>
#include <cmath>

namespace hexa::device {

static_assert(static_cast<int>(FrameVerdict::kUnknownSender) == HB_FRAME_REASON_COUNT,
              "the host's verdicts extend the protocol's reasons");

const char* ToString(DeviceStatus status) {
  switch (status) {
    case DeviceStatus::kOk: return "ok";
    case DeviceStatus::kNoNewData: return "no_new_data";
    case DeviceStatus::kNotConfigured: return "not_configured";
    case DeviceStatus::kIoError: return "io_error";
    case DeviceStatus::kFault: return "fault";
  }
  return "unknown";
}

const char* ToString(FrameVerdict verdict) {
  if (verdict == FrameVerdict::kUnknownSender) return "unknown_sender";
  if (verdict == FrameVerdict::kCount) return "unknown";
  return hb_frame_reason_name(static_cast<hb_frame_reason>(verdict));
}

std::uint64_t BoardLinkCounters::refused() const {
  std::uint64_t n = 0;
  for (std::size_t i = 1; i < kFrameVerdictCount; ++i) n += frames[i];
  return n;
}

std::string BoardLinkCounters::Describe() const {
  std::string out;
  for (std::size_t i = 0; i < kFrameVerdictCount; ++i) {
    if (frames[i] == 0) continue;
    out += (out.empty() ? "" : ", ") + std::string(ToString(static_cast<FrameVerdict>(i))) + " " +
           std::to_string(frames[i]);
  }
  return out.empty() ? "none" : out;
}

std::string BoardChannelName(int channel) {
  if (channel < 0 || channel >= kBoardCheckedChannels) return "channel " + std::to_string(channel);
  if (channel < HB_NUM_LEGS) return "leg " + std::to_string(channel + 1) + " potentiometer_m";
  if (channel < HB_ADC_SUPPLY) {
    const int k = channel - HB_ADC_CHAMBER1(0);
    return "leg " + std::to_string(k / 2 + 1) + (k % 2 == 0 ? " chamber1_pressure_pa" : " chamber2_pressure_pa");
  }
  if (channel == HB_ADC_SUPPLY) return "supply_pressure_pa";
  static constexpr const char* kAxis[] = {"x", "y", "z"};
  return std::string("imu_rate_rad_s ") + kAxis[channel - HB_ADC_CHANNELS];
}

namespace {

const ChannelCalibration& AdcChannel(const BoardCalibration& c, int channel) {
  if (channel < HB_NUM_LEGS) return c.legs[static_cast<std::size_t>(channel)].potentiometer_m;
  if (channel == HB_ADC_SUPPLY) return c.supply_pressure_pa;
  const int k = channel - HB_ADC_CHAMBER1(0);
  const BoardLegCalibration& leg = c.legs[static_cast<std::size_t>(k / 2)];
  return k % 2 == 0 ? leg.chamber1_pressure_pa : leg.chamber2_pressure_pa;
}

}  // namespace

BoardSensorDecoder::BoardSensorDecoder(const BoardCalibration& calibration) : calibration_(calibration) {}

FrameVerdict BoardSensorDecoder::Judge(std::span<const std::uint8_t> datagram) {
  hb_sensor_frame f{};
  const hb_frame_reason r = hb_decode_sensor(datagram.data(), datagram.size(), &f);
  if (r != HB_FRAME_OK) return static_cast<FrameVerdict>(r);
  if (have_sequence_ && !hb_sequence_newer(f.sequence, last_sequence_)) return FrameVerdict::kOldSequence;
  have_sequence_ = true;
  last_sequence_ = f.sequence;
  frame_ = f;
  return InRange(f) ? FrameVerdict::kOk : FrameVerdict::kOutOfRange;
}

bool BoardSensorDecoder::InRange(const hb_sensor_frame& f) {
  for (int ch = 0; ch < kBoardCheckedChannels; ++ch) {
    const bool adc = ch < HB_ADC_CHANNELS;
    const ChannelCalibration& cal = adc ? AdcChannel(calibration_, ch) : calibration_.imu_rate_rad_s;
    const double counts = adc ? f.adc[ch] : f.imu_rate[ch - HB_ADC_CHANNELS];
    const double value_si = cal.ToSi(counts);
    if (!cal.InRange(value_si)) {
      out_of_range_channel_ = ch;
      out_of_range_value_si_ = value_si;
      return false;
    }
  }
  return true;
}

void BoardSensorDecoder::Calibrate(const hb_sensor_frame& f, DeviceSensors& out) {
  // The board's microsecond clock wraps every 71.6 min: unwrap by the modular difference.
  if (have_time_) board_time_us_ += static_cast<std::uint32_t>(f.board_time_us - last_board_time_us_);
  else board_time_us_ = f.board_time_us;
  have_time_ = true;
  last_board_time_us_ = f.board_time_us;
  out.device_time_s = static_cast<double>(board_time_us_) * 1e-6;

  const double supply_pa = calibration_.supply_pressure_pa.ToSi(f.adc[HB_ADC_SUPPLY]);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const BoardLegCalibration& cal = calibration_.legs[i];
    const int leg = static_cast<int>(i);
    LegSensorReading& r = out.legs[i];
    r.length_m = cal.potentiometer_m.ToSi(f.adc[HB_ADC_POT(leg)]);
    r.chamber1_pressure_pa = cal.chamber1_pressure_pa.ToSi(f.adc[HB_ADC_CHAMBER1(leg)]);
    r.chamber2_pressure_pa = cal.chamber2_pressure_pa.ToSi(f.adc[HB_ADC_CHAMBER2(leg)]);
    r.supply_pressure_pa = supply_pa;
    out.applied_valve_v[i] = cal.valve_v.ToSi(f.dac_applied[i]);
    out.at_retracted_end[i] = (f.digital_inputs & HB_DIN_RETRACTED(leg)) != 0;
    out.at_extended_end[i] = (f.digital_inputs & HB_DIN_EXTENDED(leg)) != 0;
  }
  out.imu.fresh = !have_imu_count_ || f.imu_count != last_imu_count_;
  have_imu_count_ = true;
  last_imu_count_ = f.imu_count;
  out.imu.dropped_out = false;
  if (out.imu.fresh) out.imu.sample_time_s = out.device_time_s;
  Eigen::Quaterniond q(f.imu_quat[0] / kBoardQuaternionScale, f.imu_quat[1] / kBoardQuaternionScale,
                       f.imu_quat[2] / kBoardQuaternionScale, f.imu_quat[3] / kBoardQuaternionScale);
  out.imu.q_BP_measured = q.norm() > 0.5 ? q.normalized() : Eigen::Quaterniond::Identity();
  for (int k = 0; k < 3; ++k) out.imu.angular_rate_B_rad_s(k) = calibration_.imu_rate_rad_s.ToSi(f.imu_rate[k]);

  DeviceSafety& s = out.safety;
  s.valves_safe = f.status & HB_STATUS_VALVES_SAFE;
  s.watchdog_expired = f.status & HB_STATUS_WATCHDOG;
  s.estop_latched = f.status & HB_STATUS_ESTOP_LATCHED;
  s.estop_loop_open = !(f.digital_inputs & HB_DIN_ESTOP_LOOP_CLOSED);
  s.estop_by_input = f.status & HB_STATUS_ESTOP_BY_INPUT;
  s.estop_by_host = f.status & HB_STATUS_ESTOP_BY_HOST;
  s.estop_at_power_up = f.status & HB_STATUS_ESTOP_AT_POWER_UP;
  s.reset_refused = f.status & HB_STATUS_RESET_REFUSED;
  s.host_safe = f.status & HB_STATUS_HOST_SAFE;
  s.watchdog_count = f.watchdog_count;
}

FrameVerdict BoardSensorDecoder::Decode(std::span<const std::uint8_t> datagram, DeviceSensors& out) {
  const FrameVerdict v = Judge(datagram);
  Count(v);
  if (v == FrameVerdict::kOk) Calibrate(frame_, out);
  return v;
}

BoardCommandEncoder::BoardCommandEncoder(const BoardCalibration& calibration, double valve_null_v)
    : calibration_(calibration),
      valve_null_v_(valve_null_v),
      watchdog_ms_(static_cast<std::uint16_t>(std::lround(calibration.watchdog_timeout_s * 1000.0))) {}

std::uint16_t BoardCommandEncoder::ToDac(std::size_t leg, double valve_v) const {
  const ChannelCalibration& cal = calibration_.legs[leg].valve_v;
  const double v = std::isfinite(valve_v) ? std::clamp(valve_v, cal.min_si, cal.max_si) : valve_null_v_;
  const double counts = std::round(cal.ToCounts(v));
  return static_cast<std::uint16_t>(std::clamp(counts, 0.0, static_cast<double>(calibration_.dac_max_counts())));
}

std::size_t BoardCommandEncoder::Encode(const LegArray<double>& valve_v, std::uint16_t flags,
                                        std::array<std::uint8_t, HB_COMMAND_FRAME_SIZE>& out) {
  hb_command_frame c{};
  c.sequence = ++sequence_;
  c.flags = flags;
  c.watchdog_ms = watchdog_ms_;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const ChannelCalibration& cal = calibration_.legs[i].valve_v;
    if (!std::isfinite(valve_v[i])) ++non_finite_;
    else if (valve_v[i] < cal.min_si || valve_v[i] > cal.max_si) ++clamped_;
    c.dac[i] = ToDac(i, valve_v[i]);
  }
  return hb_encode_command(&c, out.data());
}

}  // namespace hexa::device
