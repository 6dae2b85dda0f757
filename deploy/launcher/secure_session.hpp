// hexa_session --secure: the DDS Security files of a one-machine session. A deployment of one
// host on loopback is generated (hexa_deploy's generator) into <out>/security, signed by a new
// project CA (deploy/make_security.sh), and every identity is verified before any process
// starts. Returns the Cyclone configuration every process uses (each sets HEXA_IDENTITY).
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace hexa::deploy {

// `identities`: plant, supervisor, leg1..leg6, legN_standby, recorder. On failure: nullopt and
// an error naming the file or step.
std::optional<std::string> MakeSecureSession(const std::string& out_dir, int domain,
                                             const std::vector<std::string>& identities,
                                             const std::string& make_security_script,
                                             std::string& error);

}  // namespace hexa::deploy
