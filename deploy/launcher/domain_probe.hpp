// Who else is on a DDS domain: a participant of this process listens for `listen_s` and
// counts the other participants it discovers (DCPSParticipant). Two sessions on one domain
// would read and command each other (both supervisors hold, the second plant never ticks), so
// hexa_session refuses a domain that is in use. Uses the Cyclone configuration in
// CYCLONEDDS_URI; deletes every DDS entity of this process before it returns (the launcher
// forks its children afterwards).
#pragma once

#include <string>

namespace hexa::deploy {

struct DomainProbe {
  int other_participants = 0;  // discovered participants that are not the probe's own
  std::string error;           // the probe could not run (then other_participants is 0)
};

DomainProbe ProbeDomain(int domain, double listen_s);

}  // namespace hexa::deploy
