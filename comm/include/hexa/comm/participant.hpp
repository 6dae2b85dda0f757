// RAII ownership of Cyclone entities. Every wrapper is move-only and dds_delete()s its
// entity in the destructor; deleting a participant deletes everything created from it, so
// wrappers must be destroyed before (declared after) the Participant they came from.
#pragma once

#include <dds/dds.h>

#include <string>
#include <utility>

namespace hexa::comm {

// Move-only owner of one dds_entity_t.
class OwnedEntity {
 public:
  OwnedEntity() = default;
  explicit OwnedEntity(dds_entity_t entity) : entity_(entity) {}
  ~OwnedEntity() { Reset(); }
  OwnedEntity(OwnedEntity&& other) noexcept : entity_(std::exchange(other.entity_, 0)) {}
  OwnedEntity& operator=(OwnedEntity&& other) noexcept {
    if (this != &other) {
      Reset();
      entity_ = std::exchange(other.entity_, 0);
    }
    return *this;
  }
  OwnedEntity(const OwnedEntity&) = delete;
  OwnedEntity& operator=(const OwnedEntity&) = delete;

  dds_entity_t get() const { return entity_; }
  explicit operator bool() const { return entity_ > 0; }
  void Reset() {
    if (entity_ > 0) dds_delete(entity_);
    entity_ = 0;
  }

 private:
  dds_entity_t entity_ = 0;
};

// Write batching (Writer<T>::WriteDeferred + Flush, writer.hpp): process-wide in Cyclone, and
// it reaches only writers created after it is switched on, so it is chosen with the
// participant, before any writer exists.
enum class WriteBatching : bool { kOff = false, kOn = true };

class Participant {
 public:
  // Creates a participant on `domain_id`. Call EnsureDdsConfig() first. Throws DdsError with
  // the domain id, the CYCLONEDDS_URI in use and Cyclone's reason (a config error is also
  // written to stderr by Cyclone itself).
  explicit Participant(dds_domainid_t domain_id, WriteBatching batching = WriteBatching::kOff);

  dds_entity_t get() const { return entity_.get(); }
  dds_domainid_t domain_id() const { return domain_id_; }
  // Hex GUID of this participant ("0110abcd...").
  std::string Guid() const;

 private:
  OwnedEntity entity_;
  dds_domainid_t domain_id_;
};

// "xxxxxxxx:xxxxxxxx:xxxxxxxx:xxxxxxxx" of a GUID (16 bytes).
std::string FormatGuid(const dds_guid_t& guid);
// GUID of a local entity (participant, reader, writer); empty on error.
std::string EntityGuid(dds_entity_t entity);

}  // namespace hexa::comm
