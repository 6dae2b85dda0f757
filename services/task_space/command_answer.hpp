// The operator command's answer on NodeStatus: one format for every node
// (hexa/services/command_answer.hpp), named here as the supervisor and hexa_operator use it.
#pragma once

#include "hexa/services/command_answer.hpp"

namespace hexa::task_space {

using services::CommandAnswer;
using services::FormatCommandAnswer;
using services::ParseCommandAnswer;

}  // namespace hexa::task_space
