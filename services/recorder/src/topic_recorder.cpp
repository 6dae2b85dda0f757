#include "topic_recorder.hpp"

#include <string>

namespace hexa::recorder::cli {
namespace {

std::string DurationText(dds_duration_t d) {
  return d >= DDS_INFINITY ? "infinite" : std::to_string(d);
}

}  // namespace

void DescribeQos(const dds_qos_t* q, const std::string& prefix,
                 std::map<std::string, std::string>& out) {
  dds_reliability_kind_t rel;
  dds_duration_t blocking;
  if (dds_qget_reliability(q, &rel, &blocking))
    out[prefix + "reliability"] = rel == DDS_RELIABILITY_RELIABLE ? "reliable" : "best_effort";
  dds_history_kind_t hist;
  int32_t depth;
  if (dds_qget_history(q, &hist, &depth))
    out[prefix + "history"] =
        hist == DDS_HISTORY_KEEP_ALL ? "keep_all" : "keep_last " + std::to_string(depth);
  dds_durability_kind_t dur;
  if (dds_qget_durability(q, &dur))
    out[prefix + "durability"] = dur == DDS_DURABILITY_TRANSIENT_LOCAL ? "transient_local"
                                 : dur == DDS_DURABILITY_VOLATILE      ? "volatile"
                                                                       : "other";
  dds_duration_t deadline;
  if (dds_qget_deadline(q, &deadline)) out[prefix + "deadline_ns"] = DurationText(deadline);
  dds_liveliness_kind_t live;
  dds_duration_t lease;
  if (dds_qget_liveliness(q, &live, &lease))
    out[prefix + "liveliness"] =
        std::string(live == DDS_LIVELINESS_AUTOMATIC ? "automatic" : "manual_by_topic") +
        " lease_ns " + DurationText(lease);
  dds_ownership_kind_t own;
  if (dds_qget_ownership(q, &own))
    out[prefix + "ownership"] = own == DDS_OWNERSHIP_EXCLUSIVE ? "exclusive" : "shared";
}

dds_domainid_t ParseDomain(const Args& a) {
  const long long d = a.GetInt("domain", 0);
  if (d < 0 || d > 232) throw UsageError("--domain must be in [0, 232], got " + std::to_string(d));
  return static_cast<dds_domainid_t>(d);
}

void NoteMatchedWriters(TopicRecorderBase& t) {
  dds_instance_handle_t handles[64];
  const dds_return_t n = dds_get_matched_publications(t.reader(), handles, 64);
  for (dds_return_t i = 0; i < std::min<dds_return_t>(n, 64); ++i) {
    dds_builtintopic_endpoint_t* e = dds_get_matched_publication_data(t.reader(), handles[i]);
    if (e == nullptr) continue;
    char guid[33];
    for (int b = 0; b < 16; ++b) std::snprintf(guid + 2 * b, 3, "%02x", e->key.v[b]);
    dds_reliability_kind_t kind = DDS_RELIABILITY_BEST_EFFORT;
    dds_duration_t blocking = 0;
    if (e->qos != nullptr) dds_qget_reliability(e->qos, &kind, &blocking);
    std::string what = kind == DDS_RELIABILITY_RELIABLE ? "reliable" : "best-effort";
    dds_ownership_kind_t ownership = DDS_OWNERSHIP_SHARED;
    int32_t strength = 0;
    if (e->qos != nullptr && dds_qget_ownership(e->qos, &ownership) &&
        ownership == DDS_OWNERSHIP_EXCLUSIVE && dds_qget_ownership_strength(e->qos, &strength))
      what += " strength " + std::to_string(strength);
    t.matched_writers[guid] = what;
    dds_builtintopic_free_endpoint(e);
  }
}

void ReportIncompatibleWriters(TopicRecorderBase& t, const std::string& periodic_reliability) {
  // Partition mismatches are by design (the leg partitions' writers; status.hpp) and left out.
  const comm::StatusSnapshot st = t.Status();
  if (st.requested_incompatible_qos_not_partition_total <= t.incompatible_reported) return;
  t.incompatible_reported = st.requested_incompatible_qos_not_partition_total;
  const std::string policy = comm::QosPolicyName(st.requested_incompatible_qos_last_policy);
  std::string hint;
  if (policy == "RELIABILITY" && t.periodic && periodic_reliability == "reliable")
    hint = " A real-time session's periodic writers offer BEST_EFFORT: record it with "
           "--periodic-reliability best-effort.";
  std::fprintf(stderr,
               "record: error: %s: %u writer(s) so far do not match this recorder (incompatible QoS, "
               "last policy %s): their samples are NOT recorded.%s\n",
               t.name.c_str(), st.requested_incompatible_qos_not_partition_total, policy.c_str(), hint.c_str());
}

}  // namespace hexa::recorder::cli
