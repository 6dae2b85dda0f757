#include "hexa/comm/reader.hpp"

namespace hexa::comm {

std::string DescribeMatchedWriter(dds_entity_t reader, dds_instance_handle_t publication) {
  dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(reader, publication);
  if (ep == nullptr) return {};
  int32_t strength = -1;
  if (ep->qos != nullptr) (void)dds_qget_ownership_strength(ep->qos, &strength);
  std::string text = "guid=" + FormatGuid(ep->key) + " participant=" +
                     FormatGuid(ep->participant_key) + " strength=" + std::to_string(strength);
  dds_builtintopic_free_endpoint(ep);
  return text;
}

int32_t MatchedWriterStrength(dds_entity_t reader, dds_instance_handle_t publication) {
  dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(reader, publication);
  if (ep == nullptr) return -1;
  int32_t strength = -1;
  if (ep->qos == nullptr || !dds_qget_ownership_strength(ep->qos, &strength)) strength = -1;
  dds_builtintopic_free_endpoint(ep);
  return strength;
}

std::optional<std::string> MatchedWriterUserData(dds_entity_t reader,
                                                 dds_instance_handle_t publication) {
  dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(reader, publication);
  if (ep == nullptr) return std::nullopt;
  std::string text;
  void* value = nullptr;
  size_t size = 0;
  if (ep->qos != nullptr && dds_qget_userdata(ep->qos, &value, &size) && value != nullptr) {
    text.assign(static_cast<const char*>(value), size);
    dds_free(value);
  }
  dds_builtintopic_free_endpoint(ep);
  return text;
}

std::string DescribeWriterIdentity(dds_entity_t reader, dds_instance_handle_t publication) {
  dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(reader, publication);
  if (ep == nullptr) return "publication " + std::to_string(publication) + " (no longer matched)";
  std::string text = "guid " + FormatGuid(ep->key);
  uint32_t n = 0;
  char** names = nullptr;
  text += " partition '";
  if (ep->qos != nullptr && dds_qget_partition(ep->qos, &n, &names)) {
    for (uint32_t i = 0; i < n; ++i) {
      text += (i > 0 ? "," : "") + std::string(names[i]);
      dds_free(names[i]);
    }
    dds_free(names);
  }
  int32_t strength = -1;
  if (ep->qos != nullptr) (void)dds_qget_ownership_strength(ep->qos, &strength);
  text += "' strength " + std::to_string(strength) + " user_data '";
  void* value = nullptr;
  size_t size = 0;
  if (ep->qos != nullptr && dds_qget_userdata(ep->qos, &value, &size) && value != nullptr) {
    // Printable bytes only: it is the writer's own text, shown in logs and fault details.
    for (size_t i = 0; i < size && i < 64; ++i) {
      const char c = static_cast<const char*>(value)[i];
      text += (c >= 0x20 && c < 0x7f) ? c : '?';
    }
    dds_free(value);
  }
  text += "'";
  dds_builtintopic_free_endpoint(ep);
  return text;
}

}  // namespace hexa::comm
