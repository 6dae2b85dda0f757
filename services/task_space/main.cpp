// hexa_task_space: the task-space supervisor (trajectory, GQFK pose estimate, Jacobian outer
// loop, safety state machine) at 5 ms.
#include "hexa/services/runtime.hpp"
#include "supervisor_node.hpp"

int main(int argc, char** argv) {
  hexa::task_space::SupervisorNodeOptions options;
  if (const int rc = hexa::task_space::ParseOptions(argc, argv, options); rc >= 0) return rc;
  return hexa::services::RunControlService(
      {"supervisor", hexa::task_space::kRealtimePriority}, options.common,
      [&](const hexa::config::SystemConfig& config, std::shared_ptr<spdlog::logger> log) {
        return hexa::task_space::SupervisorNode(options, config, std::move(log)).Run();
      });
}
