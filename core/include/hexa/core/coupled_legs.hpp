// Coupled leg feedback across the six leg controllers, as the distributed system runs it
// (docs/controller_additions.md "Coupled leg feedback"). Each BS-SMC leg publishes its own feedback
// part f_j (BsSmcFeedback) with its valve command; the plant, which gathers the six commands
// of every tick anyway, relays the six parts of tick n - 1 with each leg's sensor sample of
// tick n (FeedbackRelay); leg i then applies (CoupledFeedbackMix)
//   f_i(n) + g LPF( sum_j W_ij f_j(n - 1) - f_i(n - 1) ),   W = M_ls / M,
// M_ls the leg-space mass matrix at home (eq 48, platform_dynamics.hpp), M the BS-SMC's
// effective mass (eq 25). A leg needs nothing from the others but what comes with its own
// sensor sample: a leg that crashes, hangs or goes silent is missing from the relay the tick
// after, and every other leg runs its decoupled law (f_i alone) until all six are back.
// Pure: Eigen only.
#pragma once

#include <cstdint>

#include "hexa/core/bssmc_controller.hpp"
#include "hexa/core/control_params.hpp"
#include "hexa/core/pose.hpp"
#include "hexa/core/rig.hpp"

namespace hexa {

// One leg's own feedback part of one tick, as its valve command carries it. Not valid: the
// leg held, ran open loop or the PI, or does not take part in the coupling.
struct FeedbackPart {
  bool valid = false;
  double force_n = 0.0;
  double rate_n_s = 0.0;
};

// The six legs' parts of tick `tick` as the plant relays them with the sensor samples of
// tick + 1. `present` false: no relay (nothing couples).
struct RelayedFeedback {
  bool present = false;
  std::uint64_t tick = 0;
  LegArray<FeedbackPart> parts{};
  bool AllValid() const;
};

// W of leg-space mass matrix `m_ls` with each row's reference mass `mass_kg`; `raise_only`:
// W = V diag(max(m_k, M_i)) V^T / M_i (M_ls = V diag(m_k) V^T).
Matrix6d CouplingMatrix(const Matrix6d& m_ls, const LegArray<double>& mass_kg, bool raise_only);

// Row `leg_index` of W at `rig`'s home pose with reference mass `mass_kg` (the rig the
// supervisor uses: rig file + overlay geometry). Throws std::invalid_argument when the home
// pose has no mass matrix (degenerate geometry; config validation rejects such rigs).
LegArray<double> CouplingRowAtHome(const RigParams& rig, std::size_t leg_index, double mass_kg,
                                   bool raise_only);

// Leg i's side: mixes its own part with the relayed ones. No allocation, no throw.
class CoupledFeedbackMix {
 public:
  CoupledFeedbackMix(const CoupledLegsParams& params, const LegArray<double>& row,
                     std::size_t leg_index, double period_s);
  // `own`: this tick's own part; `relay`: the parts of the previous tick. True and `applied`
  // the coupled part when every leg's part of tick `own_tick` - 1 is there; else false,
  // `applied` = `own` (the decoupled law) and the low-pass restarts from zero (a return to
  // the coupling ramps in through it).
  bool Apply(const BsSmcFeedback& own, std::uint64_t own_tick, const RelayedFeedback& relay,
             BsSmcFeedback& applied);
  void Reset();

 private:
  CoupledLegsParams params_;
  LegArray<double> row_{};
  std::size_t leg_ = 0;
  double alpha_ = 1.0;  // low-pass step: 1 = none
  double force_n_ = 0.0, rate_n_s_ = 0.0;  // low-passed increment
};

// The plant's side: the newest accepted command's part per leg, relayed for the next tick.
class FeedbackRelay {
 public:
  // Leg `leg` (1..6)'s command that answered `answered_tick` became its command.
  void Offer(int leg, std::uint64_t answered_tick, const FeedbackPart& part);
  // The relay of tick `tick` (after its arbitration): leg j's part is valid when its command
  // answered `tick`, said its part is valid and the leg is not forced (dead or interlocked).
  RelayedFeedback For(std::uint64_t tick, const LegArray<bool>& forced) const;

 private:
  LegArray<std::uint64_t> answered_tick_{};
  LegArray<bool> offered_{};
  LegArray<FeedbackPart> parts_{};
};

}  // namespace hexa
