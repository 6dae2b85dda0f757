// A lossy recorder link must never cost a control writer anything (docs/deployment.md, "The
// lossy recorder link"). Two hosts of a NetnsLab made by this test: "ctl" runs a leg's
// ValveCommand writer with the production real-time writer QoS (hexa_recorder_link_writer);
// "rec" runs hexa_recorder, with nftables dropping 20 % of the packets arriving at "rec"
// while the writer writes 3000 samples at 1 kHz. Deterministic in what it asserts (counts,
// never times): with the real-time recorder QoS (--periodic-reliability best-effort, what
// hexa_session and hexa_deploy give a real-time recorder) the writer retransmits nothing and
// is never throttled, and the recording misses what the link dropped; with the reliable
// recorder QoS (the lockstep one, and before this change the real-time one too) the same
// writer repairs the recorder's losses: the retransmissions a 5 % lossy recorder link made
// the control processes do on the control CPU (a real-time session went to HOLD), which the
// second half shows the test can see.
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <memory>
#include <regex>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "netns_lab.hpp"
#include "process_group.hpp"
#include "scratch_dir.hpp"

namespace {

using hexa::deploy::ChildSpec;
using hexa::deploy::NetnsLab;
using hexa::deploy::ProcessGroup;
using namespace std::chrono_literals;

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string AddressOnly(const std::string& cidr) { return cidr.substr(0, cidr.find('/')); }

struct LinkRun {
  long long written = -1, write_errors = -1, rexmit_bytes = -1, throttle_count = -1;
  long long received = -1, missing = -1, gaps = -1, dds_lost = -1;
  long long dropped = -1;
  long long rcvbuf_errors = -1;  // the recorder host's kernel: receive buffer full
  std::string logs;
};

class RecorderLink : public ::testing::Test {
 protected:
  void SetUp() override {
    if (geteuid() != 0) GTEST_SKIP() << "needs root to create network namespaces";
    std::string err;
    lab_ = NetnsLab::Create("hxrl", {"ctl", "rec"}, "10.17.0", err);
    if (!lab_) GTEST_SKIP() << "no network namespaces here: " << err;
    dir_ = hexa::testing::ScratchDir(std::string("recorder_link_") +
                                     ::testing::UnitTest::GetInstance()->current_test_info()->name());
    const std::string a = AddressOnly(lab_->host("ctl").address), b = AddressOnly(lab_->host("rec").address);
    for (const char* h : {"ctl", "rec"}) {
      std::ofstream(dir_ + "/" + h + ".xml")
          << "<CycloneDDS xmlns=\"https://cdds.io/config\"><Domain id=\"any\"><General>"
             "<Interfaces><NetworkInterface name=\"" << lab_->host(h).veth << "\" multicast=\"false\"/>"
             "</Interfaces><AllowMulticast>false</AllowMulticast><DontRoute>true</DontRoute></General>"
             "<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>9</MaxAutoParticipantIndex>"
             "<Peers><Peer address=\"" << a << "\"/><Peer address=\"" << b << "\"/></Peers></Discovery>"
             "<Internal><HeartbeatInterval minsched=\"10 ms\">10 ms</HeartbeatInterval>"
             "<WriterLingerDuration>250 ms</WriterLingerDuration></Internal></Domain></CycloneDDS>\n";
    }
  }
  void TearDown() override { lab_.reset(); }

  // One recorder + writer run with the recorder's periodic topics `reliability`.
  LinkRun Run(const std::string& reliability, int loss_percent) {
    LinkRun r;
    r.logs = dir_ + "/" + reliability;
    ProcessGroup group;
    std::string err;
    const std::string domain = std::to_string(40 + getpid() % 50);
    ChildSpec rec;
    rec.name = "recorder";
    rec.argv = lab_->InHost("rec", {HEXA_RECORDER, "record", "--output", r.logs + ".mcap", "--domain", domain,
                                    "--topics", "hexa_ValveCommand", "--no-scene", "--dds-config",
                                    dir_ + "/rec.xml", "--periodic-reliability", reliability});
    rec.log_path = r.logs + "-recorder.log";
    EXPECT_GT(group.Start(rec, err), 0) << err;
    ChildSpec wr;
    wr.name = "writer";
    wr.argv = lab_->InHost("ctl", {HEXA_RECORDER_LINK_WRITER, "--domain", domain, "--leg", "3", "--samples", "3000",
                                   "--settle-s", "2", "--drain-s", "1.5"});
    wr.env = {{"CYCLONEDDS_URI", "file://" + dir_ + "/ctl.xml"}};
    wr.log_path = r.logs + "-writer.log";
    EXPECT_GT(group.Start(wr, err), 0) << err;
    // The loss starts once the writer matched the recorder (discovery is not what is tested).
    bool lossy = false;
    for (int i = 0; i < 600 && !lossy; ++i) {
      if (Slurp(wr.log_path).find("matched") != std::string::npos) {
        EXPECT_TRUE(lab_->SetInputLoss("rec", loss_percent, err)) << err;
        lossy = true;
      } else {
        group.WaitEvent(100ms);
      }
    }
    EXPECT_TRUE(lossy) << "the writer never matched the recorder; logs " << r.logs << "-*.log";
    for (int i = 0; i < 120; ++i) {
      const auto ev = group.WaitEvent(1000ms);
      if (ev.kind == ProcessGroup::Event::kChildExited && ev.exit.name == "writer") {
        EXPECT_EQ(ev.exit.exit_code, 0) << ev.exit.Describe();
        break;
      }
    }
    r.dropped = lab_->DroppedInput("rec");
    r.rcvbuf_errors = lab_->UdpReceiveBufferErrors("rec");
    lab_->SetInputLoss("rec", 0, err);
    group.Stop("writer", 3000ms);
    const auto exit = group.Stop("recorder", 10000ms);
    EXPECT_TRUE(exit && exit->exit_code == 0) << (exit ? exit->Describe() : "recorder did not stop");
    std::smatch m;
    const std::string w = Slurp(wr.log_path);
    if (std::regex_search(w, m, std::regex("written ([0-9]+) write_errors ([0-9]+) max_write_us [0-9]+ rexmit_bytes "
                                           "([0-9]+) throttle_count ([0-9]+)"))) {
      r.written = std::stoll(m[1]);
      r.write_errors = std::stoll(m[2]);
      r.rexmit_bytes = std::stoll(m[3]);
      r.throttle_count = std::stoll(m[4]);
    }
    const std::string rl = Slurp(rec.log_path);
    if (std::regex_search(rl, m, std::regex("hexa_ValveCommand +([0-9]+) +([0-9]+) +([0-9]+) +([0-9]+)"))) {
      r.received = std::stoll(m[1]);
      r.missing = std::stoll(m[2]);
      r.gaps = std::stoll(m[3]);
      r.dds_lost = std::stoll(m[4]);
    }
    std::printf("[ %s ] writer: %s", reliability.c_str(), w.substr(std::min(w.size(), w.rfind("statistics"))).c_str());
    std::printf("[ %s ] recorder: received %lld missing %lld in %lld gaps (dds_lost %lld); nftables dropped %lld packets "
                "at 'rec', its kernel %lld (receive buffer full)\n",
                reliability.c_str(), r.received, r.missing, r.gaps, r.dds_lost, r.dropped, r.rcvbuf_errors);
    return r;
  }

  std::unique_ptr<NetnsLab> lab_;
  std::string dir_;
};

TEST_F(RecorderLink, LossyRecorderLinkCostsTheControlWriterNothing) {
  const LinkRun be = Run("best-effort", 20);
  // The writer did its job and never repaired or waited for the recorder.
  EXPECT_EQ(be.written, 3000);
  EXPECT_EQ(be.write_errors, 0);
  EXPECT_EQ(be.rexmit_bytes, 0) << "the control writer retransmitted for the recorder; logs " << be.logs;
  EXPECT_EQ(be.throttle_count, 0);
  // What the link dropped is missing in the recording, not repaired (counted from tick gaps
  // between the samples that arrived, so a loss at either end is not seen). Every gap starts
  // with a packet dropped by nftables (which also counts discovery and liveliness traffic to
  // the recorder's host) or by the recorder host's kernel because the recorder's socket
  // buffer was full (a recorder descheduled on a loaded machine: its own loss, and again
  // nothing the writer repairs). Each such packet costs the recording up to two samples, not
  // one: Debian's Cyclone DDS 0.10.2 keeps a best-effort reader of a reliable writer "out of
  // sync" and discards the sample after a lost one as too old (eclipse-cyclonedds issue 1561,
  // fixed upstream in 11.0 by commit 011f80a6 "Unreliable readers are always in sync with
  // pwr"; docs/deployment.md, "The lossy recorder link"). Measured here: 1000-1050 samples
  // missing in 367-390 gaps for 690-750 dropped packets; with a best-effort writer (an
  // experiment of hexa_recorder_link_writer) 573 in 470 gaps for 718.
  EXPECT_GT(be.dropped, 300);
  EXPECT_GT(be.missing, 300);
  ASSERT_GE(be.rcvbuf_errors, 0);
  EXPECT_LE(be.gaps, be.dropped + be.rcvbuf_errors);
  EXPECT_LE(be.missing, 2 * (be.dropped + be.rcvbuf_errors));
  EXPECT_LE(be.received + be.missing, 3000);
  EXPECT_GE(be.received + be.missing, 2980);  // P(20 losses in a row at 20 %) ~ 1e-14
}

TEST_F(RecorderLink, ReliableRecorderMakesTheControlWriterRepairItsLosses) {
  // The lockstep recorder QoS (and the real-time one before the change): the same lossy
  // link makes the control writer retransmit, and the recording misses nothing. This is what
  // the test above rules out, shown to be visible to it.
  const LinkRun rel = Run("reliable", 20);
  EXPECT_EQ(rel.written, 3000);
  EXPECT_GT(rel.dropped, 300);
  EXPECT_GT(rel.rexmit_bytes, 0) << "logs " << rel.logs;
  EXPECT_EQ(rel.missing, 0);
}

}  // namespace
