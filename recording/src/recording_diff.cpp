// hexa_recorder diff: the ValveCommand streams of two recordings compared per leg and tick.

#include "hexa/recording/recording.hpp"

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>

namespace hexa::recorder {
namespace gp = google::protobuf;

DiffReport DiffValveCommands(const std::string& path_a, const std::string& path_b,
                             double tolerance_v) {
  using Series = std::map<uint32_t, std::vector<std::pair<uint64_t, double>>>;
  auto load = [](const std::string& path) {
    Series s;
    uint64_t n = 0;
    ReadRecording(path, [&](const McapChannel&, const McapMessageView&, const gp::Message& msg) {
      const gp::Descriptor* d = msg.GetDescriptor();
      if (d->full_name() != "hexa.rec.ValveCommand") return;
      const gp::Reflection* r = msg.GetReflection();
      const auto* leg = d->FindFieldByName("leg_id");
      const auto* v = d->FindFieldByName("valve_v");
      const auto tick = MessageTick(msg);
      if (leg == nullptr || v == nullptr || !tick) return;
      s[r->GetUInt32(msg, leg)].emplace_back(*tick, r->GetDouble(msg, v));
      ++n;
    });
    if (n == 0) throw McapError("'" + path + "' holds no hexa.rec.ValveCommand messages");
    for (auto& [leg, v] : s)
      std::stable_sort(v.begin(), v.end(),
                       [](const auto& a, const auto& b) { return a.first < b.first; });
    return s;
  };
  const Series a = load(path_a), b = load(path_b);
  std::set<uint32_t> legs;
  for (const auto& [l, v] : a) legs.insert(l);
  for (const auto& [l, v] : b) legs.insert(l);
  DiffReport report;
  static const std::vector<std::pair<uint64_t, double>> kEmpty;
  for (uint32_t leg : legs) {
    const auto& va = a.count(leg) ? a.at(leg) : kEmpty;
    const auto& vb = b.count(leg) ? b.at(leg) : kEmpty;
    LegDiff d;
    d.leg_id = leg;
    double sum_sq = 0.0;
    size_t i = 0, j = 0;
    auto mark = [&](uint64_t tick) {
      if (!d.differs || tick < d.first_diff_tick) d.first_diff_tick = tick;
      d.differs = true;
    };
    while (i < va.size() || j < vb.size()) {
      // Duplicate ticks within one file: the first sample counts.
      if (i > 0 && i < va.size() && va[i].first == va[i - 1].first) { ++i; continue; }
      if (j > 0 && j < vb.size() && vb[j].first == vb[j - 1].first) { ++j; continue; }
      if (j >= vb.size() || (i < va.size() && va[i].first < vb[j].first)) {
        ++d.only_a;
        mark(va[i].first);
        ++i;
      } else if (i >= va.size() || vb[j].first < va[i].first) {
        ++d.only_b;
        mark(vb[j].first);
        ++j;
      } else {
        const double diff = std::fabs(va[i].second - vb[j].second);
        // NaN in one file and not the other is a difference.
        if (diff > tolerance_v || (std::isnan(va[i].second) != std::isnan(vb[j].second)))
          mark(va[i].first);
        if (std::isfinite(diff)) {
          d.max_abs_diff_v = std::max(d.max_abs_diff_v, diff);
          sum_sq += diff * diff;
        }
        ++d.common_ticks;
        ++i;
        ++j;
      }
    }
    d.rms_diff_v = d.common_ticks ? std::sqrt(sum_sq / static_cast<double>(d.common_ticks)) : 0.0;
    report.identical = report.identical && !d.differs;
    report.legs.push_back(d);
  }
  return report;
}

std::string FormatDiff(const DiffReport& report) {
  std::ostringstream o;
  char line[256];
  std::snprintf(line, sizeof line, "%-4s %12s %8s %8s %14s %14s %18s\n", "leg", "common_ticks",
                "only_a", "only_b", "max_abs_diff_v", "rms_diff_v", "first_diff_tick");
  o << line;
  for (const auto& d : report.legs) {
    std::string first = d.differs ? std::to_string(d.first_diff_tick) : "-";
    std::snprintf(line, sizeof line, "%-4u %12" PRIu64 " %8" PRIu64 " %8" PRIu64 " %14.6g %14.6g %18s\n",
                  d.leg_id, d.common_ticks, d.only_a, d.only_b, d.max_abs_diff_v, d.rms_diff_v,
                  first.c_str());
    o << line;
  }
  o << (report.identical ? "valve command streams are identical\n"
                         : "valve command streams differ\n");
  return o.str();
}

}  // namespace hexa::recorder
