// docs/topics.md against comm/src/qos.cpp: one row per TopicKind and nothing else, and in each
// row the type, the rate, the deadline, the durability and the writer history the code gives
// the topic. A topic added to the code, or a QoS changed, fails here until the table says so.
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <dds/dds.h>
#include <gtest/gtest.h>

#include "hexa/comm/qos.hpp"

namespace {

using hexa::comm::TopicKind;

std::vector<std::string> Cells(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream in(line.substr(1));
  std::string cell;
  while (std::getline(in, cell, '|')) {
    const auto b = cell.find_first_not_of(' ');
    const auto e = cell.find_last_not_of(' ');
    cells.push_back(b == std::string::npos ? "" : cell.substr(b, e - b + 1));
  }
  return cells;
}

// Rows of the table whose first cell is a topic name in backquotes, by topic name.
std::map<std::string, std::vector<std::string>> TopicRows() {
  std::ifstream in(std::string(HEXA_SOURCE_DIR) + "/docs/topics.md");
  std::map<std::string, std::vector<std::string>> rows;
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("| `hexa_", 0) != 0) continue;
    auto cells = Cells(line);
    const std::string name = cells[0].substr(1, cells[0].size() - 2);
    rows[name] = cells;
  }
  return rows;
}

std::string Rate(TopicKind kind) {
  const auto period = hexa::comm::NominalPeriod_s(kind);
  if (!period) return "";
  const long hz = std::lround(1.0 / *period);
  return hz >= 1000 ? std::to_string(hz / 1000) + " kHz" : std::to_string(hz) + " Hz";
}

std::string Deadline(TopicKind kind) {
  const auto period = hexa::comm::NominalPeriod_s(kind);
  return period ? std::to_string(std::lround(*period * 1000.0)) + " ms" : "none";
}

std::string Durability(TopicKind kind) {
  const hexa::comm::Qos qos = hexa::comm::MakeTopicQos(kind);
  dds_durability_kind_t d{};
  EXPECT_TRUE(dds_qget_durability(qos.get(), &d));
  return d == DDS_DURABILITY_TRANSIENT_LOCAL ? "transient-local" : "volatile";
}

std::string History(TopicKind kind) {
  const int32_t depth = hexa::comm::WriterHistoryDepth(kind);
  return depth == 0 ? "keep-all" : "keep-last " + std::to_string(depth);
}

TEST(TopicTable, EveryTopicHasOneRowThatMatchesTheCode) {
  const auto rows = TopicRows();
  ASSERT_EQ(rows.size(), static_cast<std::size_t>(hexa::comm::kTopicKindCount))
      << "docs/topics.md has " << rows.size() << " topic rows, the code "
      << hexa::comm::kTopicKindCount << " topics";
  for (int k = 0; k < hexa::comm::kTopicKindCount; ++k) {
    const auto kind = static_cast<TopicKind>(k);
    const std::string name(hexa::comm::TopicName(kind));
    SCOPED_TRACE(name);
    const auto it = rows.find(name);
    ASSERT_NE(it, rows.end()) << name << " has no row in docs/topics.md";
    const auto& c = it->second;
    ASSERT_GE(c.size(), 13u);
    EXPECT_EQ(c[1], "`" + name.substr(5) + "`") << "type";  // hexa_X -> X (idl/hexa.idl)
    if (const std::string rate = Rate(kind); !rate.empty()) EXPECT_EQ(c[6], rate) << "rate";
    else EXPECT_TRUE(c[6].find("on ") == 0 || c[6].find("10 Hz") == 0) << "rate: " << c[6];
    EXPECT_EQ(c[7], Deadline(kind)) << "deadline";
    EXPECT_EQ(c[9], Durability(kind)) << "durability";
    EXPECT_EQ(c[10], History(kind)) << "writer history";
  }
}

}  // namespace
