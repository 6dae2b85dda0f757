#include "domain_probe.hpp"

#include <time.h>

#include <algorithm>
#include <cstring>
#include <set>

#include <dds/dds.h>

#include "udp_ports.hpp"

namespace hexa::deploy {
namespace {

// Participant indices scanned: the ports of index 0..119 fill the domain's block of 250 ports.
constexpr int kMaxParticipantIndex = 119;

// A participant with a fixed index binds its unicast ports before it announces itself; a
// secured session's participants announce themselves by unicast to their peers only, so these
// ports are what shows them to a process outside the session. Read before the probe's own
// participant exists (it binds ports of its own).
void FindFixedIndexPorts(int domain, DomainProbe& result) {
  for (const auto& socket : BoundUdpSockets()) {
    // The two ports of indices 0..kMaxParticipantIndex are one contiguous range.
    if (socket.port < DiscoveryUnicastPort(domain, 0) || socket.port > UserUnicastPort(domain, kMaxParticipantIndex))
      continue;
    const SocketHolder owner = SocketOwner(socket.inode);
    // A process started for another domain holds one of these ports by chance (the kernel gave
    // one of its sockets an ephemeral port in this range): not a participant of this domain.
    const int its_domain = owner.pid > 0 ? DomainArgumentOf(owner.pid) : -1;
    if (its_domain >= 0 && its_domain != domain) continue;
    ++result.fixed_index_ports;
    auto& owners = result.port_owners;
    if (!owner.name.empty() && std::find(owners.begin(), owners.end(), owner.name) == owners.end())
      owners.push_back(owner.name);
  }
}

}  // namespace

int DiscoveryUnicastPort(int domain, int index) { return 7400 + 250 * domain + 10 + 2 * index; }
int UserUnicastPort(int domain, int index) { return 7400 + 250 * domain + 11 + 2 * index; }

DomainProbe ProbeDomain(int domain, double listen_s) {
  DomainProbe result;
  FindFixedIndexPorts(domain, result);
  const dds_entity_t participant = dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr);
  if (participant < 0) {
    result.error = std::string("cannot create a DDS participant on domain ") + std::to_string(domain) +
                   ": " + dds_strretcode(participant);
    return result;
  }
  dds_guid_t own{};
  dds_get_guid(participant, &own);
  const dds_entity_t reader = dds_create_reader(participant, DDS_BUILTIN_TOPIC_DCPSPARTICIPANT, nullptr, nullptr);
  if (reader < 0) {
    result.error = std::string("cannot read DCPSParticipant: ") + dds_strretcode(reader);
    dds_delete(DDS_CYCLONEDDS_HANDLE);
    return result;
  }
  // Discovery answers a new participant within milliseconds on loopback; the rest of the
  // window catches a slow host.
  std::set<std::string> others;
  const auto step = timespec{0, 20'000'000};
  for (double waited = 0; waited < listen_s; waited += 0.02) {
    void* samples[16] = {};
    dds_sample_info_t infos[16];
    const dds_return_t n = dds_take(reader, samples, infos, 16, 16);
    for (dds_return_t k = 0; k < n; ++k) {
      if (!infos[k].valid_data) continue;
      const auto* p = static_cast<const dds_builtintopic_participant_t*>(samples[k]);
      if (std::memcmp(p->key.v, own.v, sizeof own.v) == 0) continue;
      others.insert(std::string(reinterpret_cast<const char*>(p->key.v), sizeof p->key.v));
    }
    if (n > 0) dds_return_loan(reader, samples, n);
    nanosleep(&step, nullptr);
  }
  result.other_participants = static_cast<int>(others.size());
  dds_delete(DDS_CYCLONEDDS_HANDLE);  // every entity and Cyclone's threads
  return result;
}

}  // namespace hexa::deploy
