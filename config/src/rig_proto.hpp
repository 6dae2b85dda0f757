// The rig file's messages <-> the core's parameter structs (rig_proto.cpp; not installed).
#pragma once

#include "hexa/config/rig_config.hpp"
#include "rig.pb.h"

namespace hexa::config::internal {

// A checked file (every field present, six legs with ids 1..6, unique profiles) -> structs.
// The values are not validated here (validate.cpp).
SystemConfig FromRigFile(const pb::RigFile& f);
// Structs -> the file's message: every field written, the board block when there is one.
pb::RigFile ToRigFile(const SystemConfig& c);

}  // namespace hexa::config::internal
