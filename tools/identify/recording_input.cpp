#include "recording_input.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include <cmath>
#include <limits>
#include <map>

#include "hexa/recording/recording.hpp"

namespace hexa::identify {
namespace {

namespace gp = google::protobuf;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::uint64_t kMaxTicks = 50'000'000;  // 14 h at 1 kHz: beyond is a broken file

// Field access by name through the schema embedded in the file (not the compiled-in types),
// so that a recording whose schema lacks a field is reported, not misread as zeros.
struct Fields {
  const gp::FieldDescriptor* leg_id = nullptr;
  const gp::FieldDescriptor* header = nullptr;
  const gp::FieldDescriptor* tick = nullptr;
  std::map<std::string, const gp::FieldDescriptor*> values;
};

const gp::FieldDescriptor* Field(const gp::Descriptor* d, const char* name) {
  return d == nullptr ? nullptr : d->FindFieldByName(name);
}

Fields Resolve(const gp::Descriptor* d, const std::vector<const char*>& names, const std::string& topic,
               const std::string& path) {
  Fields f;
  f.leg_id = Field(d, "leg_id");
  f.header = Field(d, "header");
  f.tick = f.header != nullptr && f.header->message_type() != nullptr
               ? f.header->message_type()->FindFieldByName("tick")
               : nullptr;
  if (f.leg_id == nullptr || f.tick == nullptr) {
    throw IdentificationInputError(path + ": channel " + topic + " has no leg_id / header.tick: not a "
                                   "HexaTaar session recording");
  }
  for (const char* n : names) f.values[n] = Field(d, n);
  return f;
}

double GetDouble(const gp::Message& m, const gp::FieldDescriptor* fd) {
  return fd == nullptr ? kNaN : m.GetReflection()->GetDouble(m, fd);
}

}  // namespace

IdentificationRecording ReadIdentificationRecording(
    const std::string& path,
    const std::function<void(std::uint64_t, std::uint64_t)>& progress) {
  IdentificationRecording rec;
  rec.path = path;
  struct Raw {
    std::vector<double> length, p1, p2, ps, valve;
    std::vector<std::uint8_t> have_sensor, have_command, open_loop;
  };
  LegArray<Raw> raw;
  auto grow = [&](Raw& r, std::uint64_t tick) {
    if (tick >= kMaxTicks) throw IdentificationInputError(path + ": tick " + std::to_string(tick) + " is implausible");
    if (r.length.size() <= tick) {
      const std::size_t n = tick + 1;
      for (auto* v : {&r.length, &r.p1, &r.p2, &r.ps, &r.valve}) v->resize(n, kNaN);
      for (auto* v : {&r.have_sensor, &r.have_command, &r.open_loop}) v->resize(n, 0);
    }
  };
  std::map<std::uint16_t, Fields> fields;
  bool sensors_channel = false, commands_channel = false;
  bool pressure_fields = true;
  recorder::McapScanOptions scan_options;
  scan_options.progress = progress;
  const recorder::McapScanResult scan = recorder::ReadRecording(
      path, [&](const recorder::McapChannel& ch, const recorder::McapMessageView& view,
                const gp::Message& msg) {
        const bool sensors = ch.topic == "hexa_LegSensors";
        const bool commands = ch.topic == "hexa_ValveCommand";
        if (ch.topic == "hexa_SessionInfo") {
          rec::SessionInfo s;
          if (s.ParseFromArray(view.data.data(), static_cast<int>(view.data.size()))) rec.session = s;
          return;
        }
        if (ch.topic == "hexa_PlantTruth") {
          rec::PlantTruth t;
          if (t.ParseFromArray(view.data.data(), static_cast<int>(view.data.size()))) rec.truth = t;
          return;
        }
        if (!sensors && !commands) return;
        auto it = fields.find(ch.id);
        if (it == fields.end()) {
          const std::vector<const char*> names =
              sensors ? std::vector<const char*>{"length_m", "cap_pressure_pa", "rod_pressure_pa",
                                                 "supply_pressure_pa"}
                      : std::vector<const char*>{"valve_v", "controller", "standby"};
          it = fields.emplace(ch.id, Resolve(msg.GetDescriptor(), names, ch.topic, path)).first;
          if (sensors) {
            sensors_channel = true;
            for (const char* n : {"cap_pressure_pa", "rod_pressure_pa", "supply_pressure_pa"})
              if (it->second.values[n] == nullptr) pressure_fields = false;
            if (it->second.values["length_m"] == nullptr)
              throw IdentificationInputError(path + ": " + ch.topic + " has no length_m (potentiometer) field");
          } else {
            commands_channel = true;
            if (it->second.values["valve_v"] == nullptr || it->second.values["controller"] == nullptr)
              throw IdentificationInputError(path + ": " + ch.topic + " has no valve_v / controller field");
          }
        }
        const Fields& f = it->second;
        const gp::Reflection* r = msg.GetReflection();
        const auto leg = r->GetUInt32(msg, f.leg_id);
        if (leg < 1 || leg > kNumLegs) return;
        const gp::Message& header = r->GetMessage(msg, f.header);
        const std::uint64_t tick = header.GetReflection()->GetUInt64(header, f.tick);
        Raw& w = raw[leg - 1];
        grow(w, tick);
        if (sensors) {
          if (w.have_sensor[tick]) return;  // a lockstep re-send of the same tick
          w.have_sensor[tick] = 1;
          w.length[tick] = GetDouble(msg, f.values.at("length_m"));
          w.p1[tick] = GetDouble(msg, f.values.at("cap_pressure_pa"));
          w.p2[tick] = GetDouble(msg, f.values.at("rod_pressure_pa"));
          w.ps[tick] = GetDouble(msg, f.values.at("supply_pressure_pa"));
        } else {
          const gp::FieldDescriptor* standby = f.values.at("standby");
          if (standby != nullptr && r->GetBool(msg, standby)) return;  // the primary's answer counts
          if (w.have_command[tick]) return;
          w.have_command[tick] = 1;
          w.valve[tick] = GetDouble(msg, f.values.at("valve_v"));
          // CONTROLLER_NONE = 0: open loop (identification excitation).
          w.open_loop[tick] = r->GetEnumValue(msg, f.values.at("controller")) == 0 ? 1 : 0;
        }
      },
      scan_options);
  rec.complete_file = scan.complete;
  rec.problems = scan.problems;
  if (!sensors_channel) {
    throw IdentificationInputError(path + ": no hexa_LegSensors channel: the recording has no "
                                   "potentiometer or pressure data");
  }
  if (!pressure_fields) {
    throw IdentificationInputError(path + ": hexa_LegSensors has no chamber / supply pressure "
                                   "fields (cap_pressure_pa, rod_pressure_pa, supply_pressure_pa): "
                                   "eq 7 cannot be identified without them");
  }
  if (!commands_channel) {
    throw IdentificationInputError(path + ": no hexa_ValveCommand channel: the valve voltages "
                                   "that drove the legs are missing");
  }
  std::size_t ticks = 0;
  for (const Raw& r : raw) ticks = std::max(ticks, r.length.size());
  rec.ticks = ticks;
  for (std::size_t i = 0; i < kNumLegs; ++i) {
    Raw& r = raw[i];
    grow(r, ticks == 0 ? 0 : ticks - 1);
    LegSeries& s = rec.legs[i];
    s.length_m = std::move(r.length);
    s.cap_pressure_pa = std::move(r.p1);
    s.rod_pressure_pa = std::move(r.p2);
    s.supply_pressure_pa = std::move(r.ps);
    s.valve_v = std::move(r.valve);
    s.excited = std::move(r.open_loop);
    for (std::size_t k = 0; k < s.excited.size(); ++k) {
      // A tick counts as excited only with both its sensor sample and its open-loop command.
      if (!(r.have_sensor[k] && r.have_command[k])) s.excited[k] = 0;
      rec.sensor_samples[i] += r.have_sensor[k];
      rec.command_samples[i] += r.have_command[k];
    }
    s.length_m.resize(ticks, kNaN);
  }
  return rec;
}

}  // namespace hexa::identify
