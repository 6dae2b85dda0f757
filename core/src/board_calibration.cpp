// Per-channel calibration of the remote I/O board: reference values and rules.
#include "hexa/core/board_calibration.hpp"

#include <algorithm>
#include <cmath>

namespace hexa {

namespace {

// Gain, order of the range, the range within what the counts can express, and the span the
// channel must cover (`need_lo`..`need_hi`, named by `need`).
struct CountRange {
  double lo = 0.0, hi = 0.0;
  std::string Text() const { return "[" + FormatParam(lo) + ", " + FormatParam(hi) + "]"; }
};
CountRange Unsigned(std::uint32_t max_counts) { return {0.0, static_cast<double>(max_counts)}; }

void CheckChannel(ParamChecker& c, const ChannelCalibration& ch, CountRange counts,
                  const std::string& path, double need_lo, double need_hi, const std::string& need) {
  const bool finite = c.Finite(path + ".offset_si", ch.offset_si) &
                      c.Finite(path + ".gain_si_per_count", ch.gain_si_per_count) &
                      c.Finite(path + ".min_si", ch.min_si) & c.Finite(path + ".max_si", ch.max_si);
  if (!finite) return;
  if (!(ch.gain_si_per_count != 0.0)) {
    c.Fail(path + ".gain_si_per_count", "channel gain must not be zero", FormatParam(ch.gain_si_per_count), "!= 0");
    return;
  }
  if (!(ch.min_si < ch.max_si)) {
    c.Fail(path + ".max_si", "plausible range is empty", FormatParam(ch.max_si),
           "> " + path + ".min_si (" + FormatParam(ch.min_si) + ")");
    return;
  }
  const double a = ch.ToSi(counts.lo);
  const double b = ch.ToSi(counts.hi);
  const double lo = std::min(a, b), hi = std::max(a, b);
  if (!(ch.min_si >= lo)) {
    c.Fail(path + ".min_si", "plausible range starts below what the counts can express", FormatParam(ch.min_si),
           ">= " + FormatDerived(lo) + " (offset_si + gain_si_per_count * " + counts.Text() + ")");
  }
  if (!(ch.max_si <= hi)) {
    c.Fail(path + ".max_si", "plausible range ends above what the counts can express", FormatParam(ch.max_si),
           "<= " + FormatDerived(hi) + " (offset_si + gain_si_per_count * " + counts.Text() + ")");
  }
  if (!(ch.min_si <= need_lo)) {
    c.Fail(path + ".min_si", "plausible range must cover " + need, FormatParam(ch.min_si),
           "<= " + FormatDerived(need_lo));
  }
  if (!(ch.max_si >= need_hi)) {
    c.Fail(path + ".max_si", "plausible range must cover " + need, FormatParam(ch.max_si),
           ">= " + FormatDerived(need_hi));
  }
}

}  // namespace

BoardCalibration MakeReferenceBoardCalibration(const RigParams& rig) {
  BoardCalibration b;
  const double short_m = rig.cylinder.mid_stroke_length_m - 0.5 * rig.cylinder.stroke_m;
  const double long_m = rig.cylinder.mid_stroke_length_m + 0.5 * rig.cylinder.stroke_m;
  for (BoardLegCalibration& leg : b.legs) {
    // 4 um per count: 0.262 m over the 16 bits, from 5 mm below the short end.
    leg.potentiometer_m = {short_m - 0.005, 4.0e-6, short_m - 0.004, long_m + 0.004};
    leg.chamber1_pressure_pa = {0.0, 15.0, 0.5e5, 0.98e6};  // 0-983 kPa absolute
    leg.chamber2_pressure_pa = leg.chamber1_pressure_pa;
    leg.valve_v = {0.0, 1.526e-4, rig.valve.min_voltage_v, rig.valve.max_voltage_v};  // 0-10.0006 V
  }
  b.supply_pressure_pa = {0.0, 15.0, 0.5e5, 0.98e6};
  b.imu_rate_rad_s = {0.0, 0.001, -30.0, 30.0};
  return b;
}

void CheckBoardCalibration(ParamChecker& c, const BoardCalibration& b, const RigParams& rig,
                           const std::string& path) {
  c.IntInClosed(path + ".adc_bits", b.adc_bits, 8, 16, "ADC resolution");
  c.IntInClosed(path + ".dac_bits", b.dac_bits, 8, 16, "DAC resolution");
  if (c.Finite(path + ".watchdog_timeout_s", b.watchdog_timeout_s)) {
    c.InClosed(path + ".watchdog_timeout_s", b.watchdog_timeout_s, std::max(kBoardWatchdogMin_s, 2 * kPlantTick_s),
               kBoardWatchdogMax_s, "board watchdog time");
  }
  if (b.adc_bits < 8 || b.adc_bits > 16 || b.dac_bits < 8 || b.dac_bits > 16) return;
  const CylinderParams& y = rig.cylinder;
  const double short_m = y.mid_stroke_length_m - 0.5 * y.stroke_m;
  const double long_m = y.mid_stroke_length_m + 0.5 * y.stroke_m;
  const double p_lo = rig.air.atmosphere_pressure_pa, p_hi = rig.air.supply_pressure_pa;
  const std::string pressures = "atmosphere to supply (air.atmosphere_pressure_pa, air.supply_pressure_pa)";
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const std::string leg = path + ".leg[id=" + std::to_string(i + 1) + "]";
    const BoardLegCalibration& l = b.legs[i];
    CheckChannel(c, l.potentiometer_m, Unsigned(b.adc_max_counts()), leg + ".potentiometer_m", short_m, long_m,
                 "the stroke (cylinder.mid_stroke_length_m +- cylinder.stroke_m / 2)");
    CheckChannel(c, l.chamber1_pressure_pa, Unsigned(b.adc_max_counts()), leg + ".chamber1_pressure_pa", p_lo, p_hi, pressures);
    CheckChannel(c, l.chamber2_pressure_pa, Unsigned(b.adc_max_counts()), leg + ".chamber2_pressure_pa", p_lo, p_hi, pressures);
    CheckChannel(c, l.valve_v, Unsigned(b.dac_max_counts()), leg + ".valve_v", rig.valve.min_voltage_v,
                 rig.valve.max_voltage_v, "the valve's voltages (valve.min_voltage_v, valve.max_voltage_v)");
  }
  CheckChannel(c, b.supply_pressure_pa, Unsigned(b.adc_max_counts()), path + ".supply_pressure_pa", p_lo, p_hi, pressures);
  CheckChannel(c, b.imu_rate_rad_s, CountRange{-32768.0, 32767.0}, path + ".imu_rate_rad_s", 0.0, 0.0, "zero rate");
}

}  // namespace hexa
