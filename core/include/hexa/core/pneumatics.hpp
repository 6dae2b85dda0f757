// Pneumatics of one leg: valve spool (eq 42), orifice area (eq 6, 43), mass flow through
// the orifice, choked and unchoked (eq 4, 5), supply/exhaust routing per spool sign
// (Tables 4, 5), chamber volumes (eq 64) and the chamber pressure dynamics (eq 7, 65). Pure
// functions, no allocation, no throw. docs/plant.md derives every formula and lists the
// deviations from the paper.
//
// The ONE implementation of these equations: the plant (LegModel), the BS-SMC's valve
// inversion (eq 44) and the identification's model (eq 8 residuals, hexa_identify) all call
// these functions, so that an identified parameter means the same thing in all three.
#pragma once

#include <algorithm>
#include <cmath>

#include "hexa/core/rig.hpp"

namespace hexa {

// Eq 5: critical pressure ratio P_d / P_u below which the orifice is choked (0.528 for
// k = 1.4).
inline double CriticalPressureRatio(double heat_ratio) {
  return std::pow(2.0 / (heat_ratio + 1.0), heat_ratio / (heat_ratio - 1.0));
}

// Eq 42: steady spool position commanded by the valve voltage, X_spool = a u + b, limited
// to the spool travel. Positive = extend routing (Table 4).
// a u + b at the null voltage is ~1e-19 m in floating point, not 0: openings below 1e-12 m
// (a picometre) are snapped to exactly closed so that "null" means zero flow.
inline double SpoolTargetM(const ValveParams& valve, double valve_v) {
  const double u = std::clamp(valve_v, valve.min_voltage_v, valve.max_voltage_v);
  const double x = std::clamp(valve.spool_gain_m_v * u + valve.spool_offset_m,
                              -valve.max_spool_m, valve.max_spool_m);
  return std::abs(x) < 1e-12 ? 0.0 : x;
}

// Eq 6, 43: the orifice area grows with the square of the spool opening; A_max at full
// travel (the paper's effective area 15e-6 m2).
inline double OrificeAreaM2(const ValveParams& valve, double spool_m) {
  const double s = std::min(std::abs(spool_m) / valve.max_spool_m, 1.0);
  return valve.max_orifice_area_m2 * s * s;
}

// Eq 64: chamber volumes for piston position x (x = 0 at mid-stroke, x > 0 extends, so
// chamber 1 (cap) grows and chamber 2 (rod side) shrinks).
inline double Chamber1VolumeM3(const CylinderParams& c, double position_m) {
  return c.dead_volume_m3 + c.cap_area_m2 * (0.5 * c.stroke_m + position_m);
}
inline double Chamber2VolumeM3(const CylinderParams& c, double position_m) {
  return c.dead_volume_m3 + c.annulus_area_m2 * (0.5 * c.stroke_m - position_m);
}

// Orifice flow of eq 4 with its constants precomputed (pow and sqrt of constants would
// otherwise dominate the plant's cost).
//
// Deviation (docs/plant.md): for P_d / P_u above `laminar_pressure_ratio` (default 0.995)
// the flow is continued linearly in (P_u - P_d) down to zero at equal pressures. Eq 4 has
// an infinite slope d(m_dot)/d(P_d) at P_d = P_u (m_dot ~ sqrt(P_u - P_d)), which makes the
// pressure ODE non-Lipschitz and chatter under any fixed-step integrator. The band changes
// the flow only when the pressures are within 0.5 % of each other.
class OrificeFlowModel {
 public:
  OrificeFlowModel() : OrificeFlowModel(AirParams{}, 0.6) {}
  OrificeFlowModel(const AirParams& air, double discharge_coefficient,
                   double laminar_pressure_ratio = 0.995) {
    const double k = air.heat_ratio;
    const double R = air.gas_constant_j_kg_k;
    const double sqrt_t = std::sqrt(air.temperature_k);
    inv_k_ = 1.0 / k;
    critical_ratio_ = CriticalPressureRatio(k);  // eq 5
    // eq 4, unchoked: C_f A_v sqrt(k/R * 2/(k-1)) P_u/sqrt(T) r^(1/k) sqrt(1 - r^((k-1)/k))
    unchoked_coeff_ = discharge_coefficient * std::sqrt(k / R * 2.0 / (k - 1.0)) / sqrt_t;
    // eq 4, choked: C_f A_v P_u/sqrt(T) sqrt(k/R (2/(k+1))^((k+1)/(k-1)))
    choked_coeff_ = discharge_coefficient *
                    std::sqrt(k / R * std::pow(2.0 / (k + 1.0), (k + 1.0) / (k - 1.0))) /
                    sqrt_t;
    laminar_ratio_ = std::max(laminar_pressure_ratio, critical_ratio_);
    laminar_slope_ = laminar_ratio_ < 1.0
                         ? UnchokedShape(laminar_ratio_) / (1.0 - laminar_ratio_)
                         : 0.0;
  }

  // Eq 4 for P_u >= P_d >= 0 (mass flow from upstream to downstream, >= 0). Inlined into
  // the plant's derivative (called twice per leg and RK stage).
  [[gnu::always_inline]] double ForwardKgS(double area_m2, double upstream_pa,
                                           double downstream_pa) const {
    if (!(upstream_pa > 0.0) || area_m2 <= 0.0) return 0.0;
    const double r = std::max(downstream_pa, 0.0) / upstream_pa;
    if (r <= critical_ratio_) return choked_coeff_ * area_m2 * upstream_pa;
    if (r >= laminar_ratio_) {
      // linear continuation: unchoked value at the band edge times (1 - r)/(1 - r_lin)
      return unchoked_coeff_ * area_m2 * upstream_pa * laminar_slope_ * (1.0 - r);
    }
    return unchoked_coeff_ * area_m2 * upstream_pa * UnchokedShape(r);
  }

  // Signed flow through an orifice between ports a and b: > 0 from a to b. The side with
  // the higher pressure is the upstream of eq 4 (Tables 4, 5 name the usual direction;
  // backflow, e.g. a chamber compressed above supply, is physical and kept).
  [[gnu::always_inline]] double SignedKgS(double area_m2, double a_pa, double b_pa) const {
    return a_pa >= b_pa ? ForwardKgS(area_m2, a_pa, b_pa) : -ForwardKgS(area_m2, b_pa, a_pa);
  }

  // Upper bound of |d m_dot / d P| (kg/s/Pa) over both pressures for the orifice area: the
  // steepest point of the flow curve is the laminar band (secant to the band edge), twice
  // the slope of eq 4 just below it. Used to bound the pressure ODE's stiffness.
  double MaxPressureSlopeKgSPa(double area_m2) const {
    return unchoked_coeff_ * area_m2 * laminar_slope_;
  }
  double critical_ratio() const { return critical_ratio_; }
  double laminar_ratio() const { return laminar_ratio_; }

 private:
  // r^(1/k) sqrt(1 - r^((k-1)/k)), with r^((k-1)/k) = r / r^(1/k): one pow per call.
  double UnchokedShape(double r) const {
    const double r_inv_k = std::pow(r, inv_k_);
    const double r_km1_k = r / r_inv_k;
    return r_inv_k * std::sqrt(std::max(1.0 - r_km1_k, 0.0));
  }

  double inv_k_ = 1.0 / 1.4;
  double critical_ratio_ = 0.528;
  double unchoked_coeff_ = 0.0;
  double choked_coeff_ = 0.0;
  double laminar_ratio_ = 0.995;
  double laminar_slope_ = 0.0;
};

// The discharge coefficient C_f and the laminar band of the plant's default: the controller
// and the identification build their OrificeFlowModel with the same band.
inline constexpr double kDefaultLaminarPressureRatio = 0.995;

// Mass flows of one valve into the two chambers (> 0 = into the chamber), routed by the
// spool sign (Tables 4, 5):
//   spool > 0 (extend, Table 4):  supply -> chamber 1,   chamber 2 -> atmosphere
//   spool < 0 (retract, Table 5): supply -> chamber 2,   chamber 1 -> atmosphere
//   spool = 0: both ports closed, zero flow.
// Both metering edges of the 5/3 valve open by the same area (eq 43 uses one (a u + b)^2).
struct ChamberMassFlows {
  double chamber1_kg_s = 0.0;
  double chamber2_kg_s = 0.0;
};
inline ChamberMassFlows ValveMassFlows(const OrificeFlowModel& orifice, double area_m2,
                                       double spool_m, double supply_pa,
                                       double atmosphere_pa, double chamber1_pa,
                                       double chamber2_pa) {
  ChamberMassFlows flows;
  if (spool_m > 0.0) {
    flows.chamber1_kg_s = orifice.SignedKgS(area_m2, supply_pa, chamber1_pa);
    flows.chamber2_kg_s = -orifice.SignedKgS(area_m2, chamber2_pa, atmosphere_pa);
  } else if (spool_m < 0.0) {
    flows.chamber2_kg_s = orifice.SignedKgS(area_m2, supply_pa, chamber2_pa);
    flows.chamber1_kg_s = -orifice.SignedKgS(area_m2, chamber1_pa, atmosphere_pa);
  }
  return flows;
}

// Eq 7 / 65 (Appendix A eq 59 / 62, Table 8 coefficients) for one chamber:
//   dP/dt = (R T w(m) - gamma_k P dV/dt) / V,   w(m) = gamma_i m if m >= 0 (into the chamber)
//                                                      gamma_o m otherwise (out of it)
// with dV/dt the true volume rate (A1 x' for chamber 1, -A2 x' for chamber 2; the paper's
// "+ gamma_k P2/V2 V2'" means the magnitude, docs/plant.md). Affine in each coefficient.
inline double ChamberPressureRatePaS(double gas_rt_j_kg, const PolytropicParams& gamma,
                                     double mass_flow_kg_s, double pressure_pa,
                                     double volume_m3, double volume_rate_m3_s) {
  const double w = mass_flow_kg_s >= 0.0 ? gamma.inflow * mass_flow_kg_s
                                         : gamma.outflow * mass_flow_kg_s;
  return (gas_rt_j_kg * w - gamma.volume * pressure_pa * volume_rate_m3_s) / volume_m3;
}

}  // namespace hexa
