#include "operator_forward.hpp"

#include <cstdio>

#include "hexa/comm/qos.hpp"
#include "hexa/comm/time.hpp"

namespace hexa::bridge {

OperatorForwarder::OperatorForwarder(const comm::Participant& participant,
                                     comm::GuardCondition& wake,
                                     std::shared_ptr<spdlog::logger> log)
    : topic_(participant), writer_(participant, topic_), wake_(wake), log_(std::move(log)) {
  // Sequence numbers of this writer start from the clock, as hexa_operator's do, so that two
  // bridges (or a restarted one) do not repeat each other's numbers in the supervisor's log.
  sequence_ = static_cast<uint32_t>(comm::RealtimeNow_ns() & 0xffffffff);
}

std::string OperatorForwarder::Submit(uint64_t client_id, const std::string& remote,
                                      const OperatorInput& input) {
  const int supervisors =
      comm::CountMatchedReadersWithUserData(writer_.get(), comm::kSupervisorCommandReader);
  if (supervisors == 0) {
    log_->warn("client {} ({}): operator input {} not forwarded: no supervisor's command reader "
               "is matched", client_id, remote, CommandName(input.command));
    return "";
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (pending_.size() >= kMaxPending) {
      log_->warn("client {} ({}): operator input {} not forwarded: {} inputs wait to be written",
                 client_id, remote, CommandName(input.command), pending_.size());
      return "";
    }
    pending_.push_back({client_id, remote, input});
  }
  wake_.Set(true);
  std::string what = CommandName(input.command);
  if (input.command == OperatorInput::Command::kStart) what += " (" + input.trajectory + ")";
  return what + " forwarded to the supervisor";
}

void OperatorForwarder::WritePending() {
  std::deque<Item> items;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    items.swap(pending_);
  }
  for (const Item& item : items) {
    hexa_msg_OperatorCommand cmd{};
    switch (item.input.command) {
      case OperatorInput::Command::kStart: cmd.kind = hexa_msg_OPERATOR_START; break;
      case OperatorInput::Command::kStop: cmd.kind = hexa_msg_OPERATOR_STOP; break;
      case OperatorInput::Command::kReset: cmd.kind = hexa_msg_OPERATOR_RESET; break;
      case OperatorInput::Command::kHome: cmd.kind = hexa_msg_OPERATOR_HOME; break;
      case OperatorInput::Command::kJog: cmd.kind = hexa_msg_OPERATOR_JOG; break;
      case OperatorInput::Command::kGoal: cmd.kind = hexa_msg_OPERATOR_GOAL; break;
      case OperatorInput::Command::kStream: cmd.kind = hexa_msg_OPERATOR_STREAM; break;
      case OperatorInput::Command::kFrames: cmd.kind = hexa_msg_OPERATOR_FRAMES; break;
    }
    const OperatorInput& in = item.input;
    cmd.jog_frame = in.tool_frame ? hexa_msg_JOG_FRAME_TOOL : hexa_msg_JOG_FRAME_WORK;
    for (int k = 0; k < 3; ++k) {
      cmd.jog_velocity_m_s[k] = in.velocity_m_s[k];
      cmd.jog_angular_velocity_rad_s[k] = in.angular_velocity_rad_s[k];
      cmd.goal_position_m[k] = in.position_m[k];
      cmd.pivot_m[k] = in.pivot_m[k];
      cmd.tool_position_m[k] = in.tool_position_m[k];
      cmd.work_position_m[k] = in.work_position_m[k];
    }
    for (int k = 0; k < 4; ++k) {
      cmd.goal_orientation_wxyz[k] = in.orientation_wxyz[k];
      cmd.tool_orientation_wxyz[k] = in.tool_orientation_wxyz[k];
      cmd.work_orientation_wxyz[k] = in.work_orientation_wxyz[k];
    }
    std::snprintf(cmd.trajectory, sizeof cmd.trajectory, "%s", item.input.trajectory.c_str());
    cmd.sequence = ++sequence_;
    const dds_return_t rc = writer_.WriteNow(cmd);
    if (rc == DDS_RETCODE_OK && cmd.kind == hexa_msg_OPERATOR_JOG)
      log_->debug("client {} ({}): operator command #{} jog written", item.client_id, item.remote,
                  cmd.sequence);  // a stream: tens a second
    else if (rc == DDS_RETCODE_OK)
      log_->info("client {} ({}): operator command #{} {}{} written", item.client_id, item.remote,
                 cmd.sequence, CommandName(item.input.command),
                 cmd.kind == hexa_msg_OPERATOR_START ? " " + item.input.trajectory : "");
    else
      log_->error("client {} ({}): operator command {} NOT written: {}", item.client_id,
                  item.remote, CommandName(item.input.command), dds_strretcode(rc));
  }
}

}  // namespace hexa::bridge
