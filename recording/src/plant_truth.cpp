#include "hexa/recording/plant_truth.hpp"

#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>

#include "hexa/recording/mcap.hpp"
#include "hexa/recording/recording.hpp"

namespace hexa::recorder {
namespace {

void Set(const FrictionDirectionParams& f, rec::TrueFrictionDirection* out) {
  out->set_stribeck_velocity_m_s(f.stribeck_velocity_m_s);
  out->set_viscous_n_s_m(f.viscous_n_s_m);
  out->set_static_n(f.static_n);
  out->set_coulomb_n(f.coulomb_n);
}

void Set(const PolytropicParams& g, rec::TruePolytropic* out) {
  out->set_inflow(g.inflow);
  out->set_outflow(g.outflow);
  out->set_volume(g.volume);
}

}  // namespace

rec::PlantTruth MakePlantTruth(const PlatformPlant& plant, const std::string& rig_name,
                               const std::string& profile) {
  const PlatformPlantConfig& c = plant.config();
  const LegModelParams& leg = plant.leg_model().params();
  rec::PlantTruth t;
  t.set_rig_name(rig_name);
  t.set_profile(profile);
  t.set_seed(c.seed);
  t.set_friction_model(leg.friction_model == LegModelParams::FrictionModel::kLugre ? "lugre" : "static");
  t.set_payload_scale(c.disturbance.payload_scale);
  t.set_platform_mass_kg(plant.platform_mass_kg());
  for (int k = 0; k < 3; ++k)
    t.add_platform_inertia_diag_kg_m2(c.rig.platform.inertia_diag_kg_m2[k] * c.disturbance.payload_scale);
  t.set_supply_pressure_pa(c.rig.air.supply_pressure_pa);
  t.set_supply_ripple_amplitude_pa(c.disturbance.supply_ripple_amplitude_pa);
  t.set_supply_ripple_frequency_hz(c.disturbance.supply_ripple_frequency_hz);
  t.set_sensor_noise(c.disturbance.sensor_noise);
  const PotentiometerCalibration& pot = plant.sensors().calibration();
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    rec::LegTruth* l = t.add_leg();
    l->set_leg_id(static_cast<std::uint32_t>(i + 1));
    // One LegModel drives all six legs in this plant: the same values per leg.
    Set(leg.friction.extend, l->mutable_friction_extend());
    Set(leg.friction.retract, l->mutable_friction_retract());
    Set(leg.polytropic.extend, l->mutable_polytropic_extend());
    Set(leg.polytropic.retract, l->mutable_polytropic_retract());
    l->set_discharge_coefficient(leg.valve.discharge_coefficient);
    for (int k = 0; k < 3; ++k) {
      l->add_p_ba_b_m(plant.true_geometry().p_BA_B[i][k]);
      l->add_p_pb_p_m(plant.true_geometry().p_PB_P[i][k]);
    }
    l->set_potentiometer_offset_m(pot.offset_m[i]);
    l->set_potentiometer_gain(1.0 + pot.gain_error[i]);
    if (leg.friction_model == LegModelParams::FrictionModel::kLugre) {
      l->set_bristle_stiffness_n_m(leg.friction.bristle_stiffness_n_m);
      l->set_bristle_damping_n_s_m(leg.friction.bristle_damping_n_s_m);
    }
  }
  return t;
}

std::uint64_t AttachMessages(const std::string& path,
                             const std::vector<std::pair<std::string, const google::protobuf::Message*>>& messages) {
  // Pass 1: first log time, and no clash with an existing channel.
  uint64_t first_log = std::numeric_limits<uint64_t>::max();
  {
    McapReader reader;
    reader.Open(path);
    McapVisitor v;
    v.on_channel = [&](const McapChannel& ch) {
      for (const auto& [topic, msg] : messages) {
        if (ch.topic == topic) throw McapError(path + ": already has a channel " + topic);
      }
    };
    v.on_message = [&](const McapMessageView& m) { first_log = std::min(first_log, m.log_time_ns); };
    reader.Scan(v);
  }
  if (first_log == std::numeric_limits<uint64_t>::max()) first_log = 0;
  // Pass 2: copy every schema, channel and message, then the new channels.
  const std::string tmp = path + ".attach.tmp";
  McapWriterConfig wc;
  wc.sync = McapSyncMode::kFflush;
  RecordingWriter writer(wc);
  writer.Open(tmp);
  std::map<uint16_t, uint16_t> schema_id, channel_id;
  std::uint64_t copied = 0;
  {
    McapReader reader;
    reader.Open(path);
    McapVisitor v;
    v.on_schema = [&](const McapSchema& s) {
      schema_id[s.id] = writer.mcap().AddSchema(s.name, s.encoding, s.data);
    };
    v.on_channel = [&](const McapChannel& ch) {
      channel_id[ch.id] = writer.mcap().AddChannel(schema_id.at(ch.schema_id), ch.topic,
                                                   ch.message_encoding, ch.metadata);
    };
    v.on_message = [&](const McapMessageView& m) {
      writer.mcap().WriteWithSequence(channel_id.at(m.channel_id), m.sequence, m.log_time_ns,
                                      m.publish_time_ns, m.data);
      ++copied;
    };
    reader.Scan(v);
  }
  for (const auto& [topic, msg] : messages) {
    const uint16_t ch = writer.AddTopic(topic, *msg->GetDescriptor(), {{kMetaPeriodS, "0"}});
    writer.Write(ch, first_log, first_log, *msg);
  }
  writer.Close();
  std::filesystem::rename(tmp, path);
  return copied;
}

}  // namespace hexa::recorder
