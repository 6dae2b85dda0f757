// Who else is on a DDS domain: a participant of this process listens for `listen_s` and
// counts the other participants it discovers (DCPSParticipant). Two sessions on one domain
// would read and command each other (both supervisors hold, the second plant never ticks), so
// hexa_session refuses a domain that is in use. Uses the Cyclone configuration in
// CYCLONEDDS_URI; deletes every DDS entity of this process before it returns (the launcher
// forks its children afterwards).
#pragma once

#include <string>
#include <vector>

namespace hexa::deploy {

struct DomainProbe {
  int other_participants = 0;  // discovered participants that are not the probe's own
  // Ports of the domain's fixed participant indices bound in this network namespace, and the
  // processes holding them ("hexa_leg_ctrl (pid 1234)", each once): participants that
  // discover by unicast only (secured sessions), never met by the probe's own participant.
  int fixed_index_ports = 0;
  std::vector<std::string> port_owners;
  std::string error;           // the probe could not run (then other_participants is 0)
};

DomainProbe ProbeDomain(int domain, double listen_s);

// The UDP ports a participant with fixed participant index `index` binds on `domain`
// (DDSI-RTPS 2.2, 9.6.1.1, Cyclone's defaults: PB 7400, DG 250, PG 2, d1 10, d3 11).
int DiscoveryUnicastPort(int domain, int index);
int UserUnicastPort(int domain, int index);

}  // namespace hexa::deploy
