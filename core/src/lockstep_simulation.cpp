#include "hexa/core/lockstep_simulation.hpp"

#include <cstdio>
#include <cstdlib>
#include <optional>
#include <stdexcept>
#include <string>

namespace hexa {

void LockstepConfig::Validate() const {
  if (!(tick_s > 0.0 && tick_s <= 0.01)) {
    throw std::invalid_argument("LockstepConfig.tick_s = " + std::to_string(tick_s) +
                                " s: must be in (0, 0.01]");
  }
  if (supervisor_every_ticks < 1) {
    throw std::invalid_argument("LockstepConfig.supervisor_every_ticks = " +
                                std::to_string(supervisor_every_ticks) + ": must be >= 1");
  }
}

LockstepSimulation::LockstepSimulation(const LockstepConfig& config) : config_(config) {
  config_.Validate();
  PlatformPlantConfig plant_config;
  plant_config.rig = config_.rig;
  plant_config.disturbance = config_.disturbance;
  plant_config.seed = config_.seed;
  plant_config.tracker = config_.tracker;
  plant_config.friction_model = config_.plant_friction_model;
  plant_config.free_fall = config_.plant_free_fall;
  plant_ = std::make_unique<PlatformPlant>(plant_config);
  const ControllerModel model = config_.controllers
                                    ? *config_.controllers
                                    : ControllerModel::FromRig(config_.rig, config_.leg_controller);
  LegArray<PotentiometerCalibrationParams> potentiometer{};
  for (std::size_t i = 0; i < kNumLegs; ++i) potentiometer[i] = model.legs[i].potentiometer;
  supervisor_ = std::make_unique<Supervisor>(model.SupervisorRig(config_.rig), config_.supervisor,
                                             potentiometer);
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    LegControllerConfig leg = LegControllerConfig::FromModel(model, i, config_.controller);
    leg.excitation = config_.excitation[i];
    AssignCouplingRow(supervisor_->rig(), i, leg);
    legs_[i] = std::make_unique<LegController>(leg);
  }
  leg_runner_ = config_.leg_runner ? config_.leg_runner(*supervisor_, legs_)
                                   : std::make_unique<IndependentLegRunner>();
  ArbitrationParams arbitration;
  arbitration.hygiene = CommandHygieneParams::FromValve(config_.rig.valve, 0);
  arbitration_ = std::make_unique<CommandArbitration>(arbitration);
  schedule_.supervisor_every_ticks = config_.supervisor_every_ticks;
}


PlantStatus LockstepSimulation::Tick(OperatorCommandKind command, const StartRequest* start,
                                     const JogRequest* jog, const Pose* goal_X_BP,
                                     const StreamPacket* stream_packets,
                                     std::size_t stream_packet_count,
                                     const UserFramesConfig* frames) {
  plant_before_ = plant_->output();
  const double now_s = time_s();
  // The clock's barrier, as the plant service runs it (answers arrive here in call order;
  // no time passes, so it never asks again or times out).
  barrier_.Begin(tick_, kAllLegs, 0);

  // Supervisor: sensors and IMU of this tick.
  supervisor_ran_ = supervisor_due();
  if (supervisor_ran_) {
    SupervisorInput in;
    in.time_s = now_s;
    for (std::size_t i = 0; i < kNumLegs; ++i) in.length_m[i] = plant_before_.legs[i].length_m;
    const auto& q = plant_before_.imu.q_BP_measured;
    in.orientation_wxyz = {q.w(), q.x(), q.y(), q.z()};
    in.command = command;
    in.start = start;
    if (jog != nullptr) in.jog = *jog;
    if (goal_X_BP != nullptr) in.goal_X_BP = *goal_X_BP;
    if (frames != nullptr) in.frames = *frames;
    in.stream_packets = stream_packets;
    in.stream_packet_count = stream_packet_count;
    supervisor_->Update(in, sup_out_);
    for (std::size_t i = 0; i < kNumLegs; ++i)
      setpoints_[i].Add(IssuedSetpoint{tick_, now_s, sup_out_.setpoint[i]});
  }

  // Legs: sensor sample of this tick, the setpoint the protocol assigns to it.
  LegArray<LegControllerInput> leg_in{};
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    LegControllerInput& in = leg_in[i];
    in.tick = tick_;
    in.time_s = now_s;
    const LegSensorReading& s = plant_before_.legs[i];
    in.length_m = plant_before_.legs[i].length_m;
    in.cap_pressure_pa = s.chamber1_pressure_pa;
    in.rod_pressure_pa = s.chamber2_pressure_pa;
    in.supply_pressure_pa = s.supply_pressure_pa;
    SetSetpointInput(setpoints_[i].ForTick(tick_, schedule_.supervisor_every_ticks), in);
    in.relayed = relayed_;  // the plant relays the previous tick's feedback parts
  }
  leg_runner_->Run(supervisor_ran_ ? &sup_out_ : nullptr, legs_, leg_in, leg_out_);
  // The commands reach the plant's arbitration as the service's do: each leg's one writer
  // (alive: it just answered), its answer to this tick, then the tick's arbitration.
  ArbitrationEvents events;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    const int leg = static_cast<int>(i) + 1;
    CommandSample sample;
    sample.leg = leg;
    sample.writer = static_cast<std::uint64_t>(leg);
    sample.answered_tick = leg_out_[i].tick;
    sample.valve_v = leg_out_[i].valve_v;
    if (arbitration_->Offer(sample, tick_, [](std::uint64_t) { return SourceLiveliness::kAlive; }, events)) {
      barrier_.Answer(leg, leg_out_[i].tick);
      relay_.Offer(leg, leg_out_[i].tick, leg_out_[i].feedback);
    }
  }
  ArbitrationInput arbitration_in;
  arbitration_in.tick = tick_;
  arbitration_->Update(arbitration_in, arbitration_out_);
  relayed_ = relay_.For(tick_, arbitration_out_.forced);
  const LegArray<double>& valve_v = arbitration_out_.valve_v;
  applied_v_ = valve_v;
  // Every leg controller answers the tick it was given (LegController::Update): an internal
  // invariant, checked always.
  if (!barrier_.complete()) {
    std::fprintf(stderr, "LockstepSimulation: tick %llu incomplete after every leg ran\n",
                 static_cast<unsigned long long>(tick_));
    std::abort();
  }
  const PlantStatus status = plant_->Step(valve_v, config_.tick_s);
  if (status == PlantStatus::kOk) ++tick_;
  return status;
}

void IndependentLegRunner::Run(const SupervisorOutput* /*supervisor_output*/,
                               LegArray<std::unique_ptr<LegController>>& legs,
                               const LegArray<LegControllerInput>& in,
                               LegArray<LegControllerOutput>& out) {
  for (std::size_t i = 0; i < kNumLegs; ++i) legs[i]->Update(in[i], out[i]);
}

PaperSessionResult RunPaperSession(const LockstepConfig& config, PaperMotion motion,
                                   int periods, double max_time_s) {
  PaperSessionResult result;
  LockstepSimulation sim(config);
  // Tick 0: the supervisor latches the rest pose.
  result.plant_status = sim.Tick();
  if (result.plant_status != PlantStatus::kOk) return result;
  const StartRequest start = sim.supervisor().PreparePaperStart(motion, periods);
  bool started = false;
  bool left_idle = false;
  SupervisorState state = SupervisorState::kIdle;
  while (sim.time_s() < max_time_s) {
    const bool due = sim.supervisor_due();
    OperatorCommandKind cmd = OperatorCommandKind::kNone;
    if (due && !started) cmd = OperatorCommandKind::kStart;
    result.plant_status = sim.Tick(cmd, cmd == OperatorCommandKind::kStart ? &start : nullptr);
    if (result.plant_status != PlantStatus::kOk) break;
    if (due) {
      started = true;
      const SupervisorOutput& out = sim.supervisor_output();
      state = out.state;
      if (state == SupervisorState::kTracking) {
        result.metrics.AddPose(out.desired_xyz_rpy, out.estimate.xyz_rpy,
                               VectorFromPose(sim.plant_before_step().truth.pose));
      }
      if (state != SupervisorState::kIdle) left_idle = true;
      if (state == SupervisorState::kHold || (left_idle && state == SupervisorState::kIdle)) break;
    }
    if (state == SupervisorState::kTracking) {
      for (std::size_t i = 0; i < kNumLegs; ++i) {
        result.metrics.leg_length[i].Add(sim.leg_outputs()[i].desired_length_m,
                                         sim.plant_before_step().legs[i].length_m);
      }
    }
  }
  result.final_state = state;
  result.completed = left_idle && state == SupervisorState::kIdle &&
                     result.plant_status == PlantStatus::kOk;
  result.ticks = sim.tick();
  return result;
}

}  // namespace hexa
