// A node outside the control loop that reports one fault, as an external safety device or a
// monitoring node would: publishes one FaultEvent (leg 0) on the domain and keeps its writer
// until the supervisor's fault reader and the recorder's have acknowledged it.
// Usage: fault_event_writer DOMAIN SOURCE_NODE DETAIL. Exit 0 acknowledged, 1 not.
#include <cstdio>
#include <cstdlib>
#include <exception>

#include "hexa/comm/comm.hpp"
#include "hexa/services/node.hpp"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: fault_event_writer DOMAIN SOURCE_NODE DETAIL\n");
    return 2;
  }
  try {
    hexa::comm::EnsureDdsConfig();
    hexa::comm::Participant participant(static_cast<dds_domainid_t>(std::atoi(argv[1])));
    hexa::comm::Topic<hexa_msg_FaultEvent> topic(participant);
    hexa::comm::Writer<hexa_msg_FaultEvent> writer(participant, topic);
    const std::int64_t end = hexa::node::MonotonicNow_ns() + 10'000'000'000;
    while (writer.Snapshot().publication_matched_current < 2 && hexa::node::MonotonicNow_ns() < end)
      dds_sleepfor(DDS_MSECS(20));
    hexa_msg_FaultEvent event{};
    hexa::node::CopyBounded(event.source_node, argv[2]);
    event.leg_id = 0;
    event.reason = hexa_msg_FAULT_HOST_OVERLOAD;
    hexa::node::CopyBounded(event.detail, argv[3]);
    writer.WriteNow(event);
    const bool acked = dds_wait_for_acks(writer.get(), DDS_SECS(5)) == DDS_RETCODE_OK;
    std::printf("FaultEvent from '%s' written to %u reader(s), %s\n", argv[2],
                writer.Snapshot().publication_matched_current, acked ? "acknowledged" : "NOT acknowledged");
    return acked ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fault_event_writer: %s\n", e.what());
    return 1;
  }
}
