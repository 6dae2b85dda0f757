// Coupled leg feedback, a study of the in-process lockstep simulation (docs/measurements/
// control_coupled_feedback.md "Coupled leg feedback"; not in the system: the leg services do not see each
// other). Every tick the six BS-SMC feedback parts f_j (and their rates) are mixed, leg i
// applying sum_j W_ij f_j with W = M_ls(q) / M_i: M_ls the leg-space mass matrix
// (platform_dynamics.hpp) of the supervisor's rig at its pose estimate, refreshed every
// supervisor tick (home until the first valid estimate), M_i leg i's
// bssmc.effective_mass_kg; each leg's observer is driven by m_obs (M_ls^-1 F)_i, F the six
// measured pneumatic forces (BsSmcInput::observer_force_n).
#pragma once

#include "hexa/core/lockstep_simulation.hpp"

namespace hexa::study {

struct CoupledLegFeedbackParams {
  bool enabled = false;
  // Reference mass, W = M_ls / m_ref; 0: each leg's bssmc.effective_mass_kg (the paper's M
  // of eq 25 replaced by M_ls).
  double reference_mass_kg = 0.0;
  // The feedback parts' velocity from the (coupled) leg observers
  // (BsSmcInput::feedback_velocity_from_observer).
  bool observer_velocity = false;
  // W = V diag(max(m_k, m_ref)) V^T / m_ref (M_ls = V diag(m_k) V^T): modes heavier than
  // m_ref get the single-mass loop, lighter ones keep the uncoupled gain.
  bool raise_only = false;
  void Validate() const;  // throws std::invalid_argument naming the field and value
};

// The runner for LockstepConfig::leg_runner (validates `params`, throws). Unset when
// !params.enabled: the system's independent legs.
LegRunnerFactory CoupledLegRunnerFactory(const CoupledLegFeedbackParams& params);

// The system's coupled leg feedback (LegControllerParams::coupled: gain, low-pass, raise_only;
// CoupledFeedbackMix's increment on the plant's relay) with W = M_ls(q) / M refreshed every
// supervisor tick at q = the supervisor's desired pose (`kDesired`) or pose estimate
// (`kEstimate`); `kHome`: W at home as in the system (a check of this runner: the system's
// figures up to rounding, the fall-back runs Finish with the own part, not FinishOwn). Study
// only: in the system W is fixed at home. At its end the runner prints to stderr what the
// coupling adds at the platform over the tracking window: the RMS of the wrench J(q)^T of the
// applied increments against that of the legs' own parts (q: the pose estimate).
enum class CouplingPose { kHome, kDesired, kEstimate };
LegRunnerFactory PoseCouplingRowRunnerFactory(CouplingPose pose);

}  // namespace hexa::study
