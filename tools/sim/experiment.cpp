#include "experiment.hpp"

#include <cmath>
#include <cstdio>

#include "hexa/core/excitation.hpp"
#include "hexa/recording/plant_truth.hpp"
#include "hexa/recording/recording.hpp"
#include "recording.pb.h"

namespace hexa::sim {
namespace {

// Runs `sim` for `duration_s` and records what the recorder records of a DDS session for
// identification: every leg's sensor sample and valve command per tick, with the session
// description and the plant's truth.
int Record(LockstepSimulation& sim, const config::SystemConfig& config, const ExperimentOptions& o,
           const rec::SessionInfo& info, double duration_s) {
  recorder::McapWriterConfig wc;
  wc.sync = recorder::McapSyncMode::kFflush;
  recorder::RecordingWriter writer(wc);
  writer.Open(o.record_path);
  const uint16_t sensors_ch = writer.AddTopic("hexa_LegSensors", *rec::LegSensors::descriptor(),
                                              {{recorder::kMetaPeriodS, "0.001"}, {"source", "hexa_sim"}});
  const uint16_t valve_ch = writer.AddTopic("hexa_ValveCommand", *rec::ValveCommand::descriptor(),
                                            {{recorder::kMetaPeriodS, "0.001"}, {"source", "hexa_sim"}});
  const rec::PlantTruth truth = recorder::MakePlantTruth(sim.plant(), config.rig_name, o.profile);
  const uint16_t info_ch = writer.AddTopic(recorder::kSessionInfoTopic, *rec::SessionInfo::descriptor(),
                                           {{recorder::kMetaPeriodS, "0"}});
  const uint16_t truth_ch = writer.AddTopic(recorder::kPlantTruthTopic, *rec::PlantTruth::descriptor(),
                                            {{recorder::kMetaPeriodS, "0"}});
  writer.Write(info_ch, 0, 0, info);
  writer.Write(truth_ch, 0, 0, truth);

  const double tick_s = sim.config().tick_s;
  const auto ticks = static_cast<std::uint64_t>(std::llround(duration_s / tick_s));
  const rec::ControllerKind closed_loop =
      sim.config().controller == LegControllerKind::kPi ? rec::CONTROLLER_PI : rec::CONTROLLER_BSSMC;
  rec::LegSensors s;
  rec::ValveCommand c;
  for (std::uint64_t n = 0; n < ticks; ++n) {
    const PlantStatus status = sim.Tick();
    if (status != PlantStatus::kOk) {
      std::fprintf(stderr, "error: plant failed at tick %llu: %s\n", static_cast<unsigned long long>(n),
                   ToString(status));
      writer.Close();
      return 1;
    }
    const double t = static_cast<double>(n) * tick_s;
    const auto log_ns = static_cast<uint64_t>(n) * 1'000'000ULL;
    const PlatformPlantOutput& before = sim.plant_before_step();
    for (std::size_t i = 0; i < kNumLegs; ++i) {
      s.Clear();
      s.set_leg_id(static_cast<std::uint32_t>(i + 1));
      s.mutable_header()->set_tick(n);
      s.mutable_header()->set_sim_time_s(t);
      s.set_length_m(before.legs[i].length_m);
      s.set_cap_pressure_pa(before.legs[i].chamber1_pressure_pa);
      s.set_rod_pressure_pa(before.legs[i].chamber2_pressure_pa);
      s.set_supply_pressure_pa(before.legs[i].supply_pressure_pa);
      writer.Write(sensors_ch, log_ns, log_ns, s);
      const LegControllerOutput& out = sim.leg_outputs()[i];
      c.Clear();
      c.set_leg_id(static_cast<std::uint32_t>(i + 1));
      c.mutable_header()->set_tick(n);
      c.mutable_header()->set_sim_time_s(t);
      c.set_valve_v(sim.applied_valve_v()[i]);
      c.set_controller(out.open_loop ? rec::CONTROLLER_NONE : closed_loop);
      c.set_status(static_cast<rec::LegCtrlStatus>(static_cast<int>(out.status)));
      c.set_setpoint_tick(out.setpoint_tick);
      c.set_desired_length_m(out.desired_length_m);
      c.set_sliding_surface_m_s(out.sliding_surface_m_s);
      c.set_friction_scale(out.friction_scale);
      writer.Write(valve_ch, log_ns, log_ns, c);
    }
    if (n % 10000 == 0) {
      std::printf("\r  t = %6.1f / %.1f s", t, duration_s);
      std::fflush(stdout);
    }
  }
  writer.Close();
  std::printf("\r  t = %6.1f / %.1f s: recorded %s\n", duration_s, duration_s, o.record_path.c_str());
  return 0;
}

rec::SessionInfo Info(const config::SystemConfig& config, const LockstepConfig& lockstep,
                      const ExperimentOptions& o, const char* experiment) {
  rec::SessionInfo info;
  info.set_rig_name(config.rig_name);
  info.set_rig_file(o.rig_path);
  info.set_experiment(experiment);
  info.set_profile(o.profile);
  info.set_seed(lockstep.seed);
  info.set_command(o.command_line);
  return info;
}

}  // namespace

int RunIdentifyExperiment(const config::SystemConfig& config, LockstepConfig lockstep,
                          const ExperimentOptions& o) {
  const ExcitationPlan plan = PlanIdentificationExperiment(o.legs, o.per_leg_s, lockstep.seed);
  lockstep.controller = LegControllerKind::kExcitation;
  lockstep.excitation = plan.legs;
  lockstep.supervisor.outer_loop.enabled = false;  // the excited leg moves the platform
  LockstepSimulation sim(lockstep);
  rec::SessionInfo info = Info(config, lockstep, o, "identify");
  info.set_excitation_per_leg_s(o.per_leg_s);
  for (int leg : o.legs) {
    info.add_excited_legs(static_cast<std::uint32_t>(leg));
    info.add_excitation_start_s(plan.legs[static_cast<std::size_t>(leg - 1)].start_s);
  }
  std::printf("identification experiment: legs");
  for (int leg : o.legs) std::printf(" %d", leg);
  std::printf(", %.1f s each, %.1f s simulated, profile %s, seed %llu\n", o.per_leg_s,
              plan.total_duration_s, o.profile.c_str(), static_cast<unsigned long long>(lockstep.seed));
  return Record(sim, config, o, info, plan.total_duration_s);
}

int RunFreeFallExperiment(const config::SystemConfig& config, LockstepConfig lockstep,
                          const ExperimentOptions& o, double load_kg) {
  constexpr double kReleaseS = 0.5, kAfterS = 1.0;  // as hexa_session --experiment free-fall
  lockstep.plant_free_fall.enabled = true;
  lockstep.plant_free_fall.load_kg = load_kg;
  lockstep.plant_free_fall.release_s = kReleaseS;
  lockstep.supervisor.outer_loop.enabled = false;
  LockstepSimulation sim(lockstep);
  rec::SessionInfo info = Info(config, lockstep, o, "free-fall");
  info.set_free_fall_load_kg(load_kg);
  info.set_free_fall_release_s(kReleaseS);
  std::printf("free-fall experiment: %.2f kg on each rod, released at %.1f s, profile %s, seed %llu\n",
              load_kg, kReleaseS, o.profile.c_str(), static_cast<unsigned long long>(lockstep.seed));
  return Record(sim, config, o, info, kReleaseS + kAfterS);
}

}  // namespace hexa::sim
