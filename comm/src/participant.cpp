#include "hexa/comm/participant.hpp"

#include <cstdio>
#include <cstdlib>

#include "hexa/comm/error.hpp"
#include "hexa/comm/writer.hpp"

namespace hexa::comm {

Participant::Participant(dds_domainid_t domain_id, WriteBatching batching) : domain_id_(domain_id) {
  const dds_entity_t p = dds_create_participant(domain_id, nullptr, nullptr);
  if (p < 0) {
    const char* uri = std::getenv("CYCLONEDDS_URI");
    throw DdsError("cannot create DDS participant on domain " + std::to_string(domain_id) +
                       " with CYCLONEDDS_URI=" + (uri != nullptr ? uri : "<unset>") +
                       " (Cyclone printed the configuration error, if any, on stderr)",
                   p);
  }
  entity_ = OwnedEntity(p);
  if (batching == WriteBatching::kOn) EnableWriteBatching();
}

std::string Participant::Guid() const { return EntityGuid(entity_.get()); }

std::string FormatGuid(const dds_guid_t& guid) {
  char text[40];
  const uint8_t* v = guid.v;
  std::snprintf(text, sizeof text,
                "%02x%02x%02x%02x:%02x%02x%02x%02x:%02x%02x%02x%02x:%02x%02x%02x%02x", v[0],
                v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], v[9], v[10], v[11], v[12], v[13],
                v[14], v[15]);
  return text;
}

std::string EntityGuid(dds_entity_t entity) {
  dds_guid_t guid;
  if (dds_get_guid(entity, &guid) < 0) return {};
  return FormatGuid(guid);
}

}  // namespace hexa::comm
