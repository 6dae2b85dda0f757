// The whole control system in one process, in lockstep, without DDS: the plant, six leg
// controllers and the supervisor exchange exactly what the services exchange over DDS and
// follow the same protocol (docs/architecture.md, "Lockstep"):
//   tick n: the supervisor (every 5th tick) sees the sensors of tick n and the IMU sample
//   of tick n; leg i sees its sensor sample of tick n and the newest setpoint issued at a
//   tick strictly before n; the plant then advances one tick with the six valve voltages.
// A DDS lockstep session with the same configuration and seed must produce the same
// numbers (tests/integration checks it). Used for batch studies, tuning and tests. Pure:
// no clock, no I/O; randomness from the seed only.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>

#include "hexa/core/calibration.hpp"
#include "hexa/core/command_arbitration.hpp"
#include "hexa/core/control_params.hpp"
#include "hexa/core/controller_model.hpp"
#include "hexa/core/leg_controller.hpp"
#include "hexa/core/lockstep_protocol.hpp"
#include "hexa/core/metrics.hpp"
#include "hexa/core/platform_dynamics.hpp"
#include "hexa/core/platform_plant.hpp"
#include "hexa/core/supervisor.hpp"

namespace hexa {

class LegRunner;
// Makes the leg runner of one simulation from its supervisor (its rig) and its six leg
// controllers (their configurations); called once, before tick 0.
using LegRunnerFactory = std::function<std::unique_ptr<LegRunner>(
    const Supervisor& supervisor, const LegArray<std::unique_ptr<LegController>>& legs)>;

struct LockstepConfig {
  RigParams rig = MakeReferenceRig();
  LegControllerParams leg_controller;
  SupervisorParams supervisor;
  DisturbanceProfile disturbance = MakeRealisticDisturbanceProfile();
  std::uint64_t seed = 1;
  LegControllerKind controller = LegControllerKind::kBsSmc;
  TrackerParams tracker;  // the plant's external pose instrument (calibration runs only)
  // The controllers' and supervisor's per-leg view of the rig (rig file + overlays, exactly
  // as the services build it: config::MakeControllerModel). Unset: every leg uses `rig` and
  // `leg_controller`. The plant always simulates `rig` + `disturbance`.
  std::optional<ControllerModel> controllers;
  // controller == kExcitation (identification experiment): each leg's excitation window.
  LegArray<ExcitationParams> excitation{};
  // The plant's friction model (PlatformPlantConfig::friction_model).
  LegModelParams::FrictionModel plant_friction_model = LegModelParams::FrictionModel::kLugre;
  FreeFallBenchParams plant_free_fall;  // enabled: the free-fall bench instead of the platform
  // Runs the six leg controllers every tick; unset: the system's runner (each leg its own
  // LegController::Update, as the six leg services do). A study supplies another (see
  // LegRunner).
  LegRunnerFactory leg_runner;
  double tick_s = 0.001;
  int supervisor_every_ticks = 5;
  void Validate() const;  // throws std::invalid_argument naming the field and value
};

// How the six leg controllers of one tick run. The system's legs are independent processes:
// each leg's LegController::Update on its own input (IndependentLegRunner). A study may
// replace it in process only, e.g. one that mixes the legs' feedback
// (studies/coupled_leg_feedback/). Pure, like the simulation.
class LegRunner {
 public:
  virtual ~LegRunner() = default;
  // Tick n, after the supervisor and before the plant step: `supervisor_output` is the
  // supervisor's output of this tick when it ran, null otherwise; `in` the six legs' inputs
  // of this tick; writes the six outputs.
  virtual void Run(const SupervisorOutput* supervisor_output,
                   LegArray<std::unique_ptr<LegController>>& legs,
                   const LegArray<LegControllerInput>& in, LegArray<LegControllerOutput>& out) = 0;
};

class IndependentLegRunner final : public LegRunner {
 public:
  void Run(const SupervisorOutput* supervisor_output, LegArray<std::unique_ptr<LegController>>& legs,
           const LegArray<LegControllerInput>& in, LegArray<LegControllerOutput>& out) override;
};

class LockstepSimulation {
 public:
  explicit LockstepSimulation(const LockstepConfig& config);  // validates (throws)

  // Runs tick n = tick(): supervisor (when due, with `command`/`start`), the six leg
  // controllers, command hygiene, one plant step. Returns the plant status.
  // `jog` with kJog, `goal_X_BP` with kGoal, `frames` with kFrames (operator_motion.hpp);
  // `stream_packets`: the motion stream's packets received since the previous supervisor tick
  // (used in STREAMING, ignored when the supervisor does not run this tick: pass them at a
  // due tick).
  PlantStatus Tick(OperatorCommandKind command = OperatorCommandKind::kNone,
                   const StartRequest* start = nullptr, const JogRequest* jog = nullptr,
                   const Pose* goal_X_BP = nullptr, const StreamPacket* stream_packets = nullptr,
                   std::size_t stream_packet_count = 0, const UserFramesConfig* frames = nullptr);

  std::uint64_t tick() const { return tick_; }
  double time_s() const { return static_cast<double>(tick_) * config_.tick_s; }
  bool supervisor_due() const { return schedule_.SupervisorDue(tick_); }

  // Results of the last Tick(): sensors/truth it used (before the step), leg outputs, and
  // the supervisor output (valid when supervisor_ran()).
  const PlatformPlantOutput& plant_before_step() const { return plant_before_; }
  const LegArray<LegControllerOutput>& leg_outputs() const { return leg_out_; }
  const LegArray<double>& applied_valve_v() const { return applied_v_; }
  bool supervisor_ran() const { return supervisor_ran_; }
  const SupervisorOutput& supervisor_output() const { return sup_out_; }

  const PlatformPlant& plant() const { return *plant_; }
  const Supervisor& supervisor() const { return *supervisor_; }
  const LockstepConfig& config() const { return config_; }

 private:
  LockstepConfig config_;
  std::unique_ptr<PlatformPlant> plant_;
  std::unique_ptr<Supervisor> supervisor_;
  LegArray<std::unique_ptr<LegController>> legs_;
  // The plant service's command arbitration (hygiene, sources, episodes), fed as it is.
  std::unique_ptr<CommandArbitration> arbitration_;
  ArbitrationOutput arbitration_out_;
  LockstepSchedule schedule_;
  LockstepBarrier barrier_;
  std::uint64_t tick_ = 0;
  LegArray<SetpointRing<IssuedSetpoint, 2>> setpoints_{};  // the last two issued per leg
  PlatformPlantOutput plant_before_;
  LegArray<LegControllerOutput> leg_out_{};
  LegArray<double> applied_v_{};
  bool supervisor_ran_ = false;
  SupervisorOutput sup_out_;
  std::unique_ptr<LegRunner> leg_runner_;
  // The plant service's relay of the legs' feedback parts (coupled_legs.hpp), as it runs it.
  FeedbackRelay relay_;
  RelayedFeedback relayed_;  // what the legs get with the next tick's samples
};

// Figures of merit of a session (paper Tables 9, 10), accumulated over the supervisor's
// TRACKING window: task-space error against ground truth and against the measured pose
// (GQFK + IMU, as the paper did), and leg-length error (desired incl. correction vs the
// potentiometer) per leg.
struct SessionMetrics {
  AxisErrorAccumulator vs_truth;
  AxisErrorAccumulator vs_measured;
  LegArray<ScalarErrorAccumulator> leg_length;
  void AddPose(const Vector6d& desired, const Vector6d& measured, const Vector6d& truth) {
    vs_truth.Add(desired, truth);
    vs_measured.Add(desired, measured);
  }
};

struct PaperSessionResult {
  bool completed = false;          // trajectory ran to its end and the supervisor is idle
  SupervisorState final_state = SupervisorState::kIdle;
  PlantStatus plant_status = PlantStatus::kOk;
  std::uint64_t ticks = 0;
  SessionMetrics metrics;
};

// Runs a paper trajectory from rest to rest: initialise (one supervisor tick), start, run
// until the supervisor is idle again or `max_time_s`. Metrics over the TRACKING window.
PaperSessionResult RunPaperSession(const LockstepConfig& config, PaperMotion motion,
                                   int periods = 0, double max_time_s = 600.0);

}  // namespace hexa
