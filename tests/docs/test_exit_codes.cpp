// docs/exit_codes.md against hexa/services/exit_code.hpp: every code the header gives a
// program stands in that program's table with its meaning, and the tables list no code above
// 2 that the header does not have. The launcher, the generated units and the services use the
// header's constants, so the page cannot drift from what the programs do.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "hexa/services/exit_code.hpp"

namespace {

namespace ec = hexa::exit_code;

struct Row {
  std::string program;  // the program cell ("" in the launcher's table), as written
  std::set<int> codes;  // "1 / 2" -> {1, 2}
  std::string meaning;
};

std::string Trim(const std::string& s) {
  const auto a = s.find_first_not_of(" \t");
  const auto b = s.find_last_not_of(" \t");
  return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

std::vector<std::string> Cells(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream in(line.substr(1));  // past the leading '|'
  for (std::string cell; std::getline(in, cell, '|');) cells.push_back(Trim(cell));
  if (!cells.empty() && cells.back().empty()) cells.pop_back();
  return cells;
}

std::set<int> Codes(const std::string& cell) {
  std::set<int> codes;
  std::stringstream in(cell);
  for (std::string word; in >> word;)
    if (word != "/") codes.insert(std::stoi(word));
  return codes;
}

// The table rows of each "## " section of the page, header and separator rows left out.
std::map<std::string, std::vector<Row>> ReadTables(const std::string& path, std::string& text) {
  std::ifstream in(path);
  std::stringstream all;
  all << in.rdbuf();
  text = all.str();
  std::map<std::string, std::vector<Row>> tables;
  std::string section;
  std::stringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("## ", 0) == 0) section = line.substr(3);
    if (line.empty() || line[0] != '|' || line.find("---") != std::string::npos) continue;
    const auto cells = Cells(line);
    if (cells.empty() || cells[0] == "code" || cells[0] == "program") continue;
    Row row;
    if (cells.size() == 2) {
      row.codes = Codes(cells[0]);
      row.meaning = cells[1];
    } else if (cells.size() == 3) {
      row.program = cells[0];
      row.codes = Codes(cells[1]);
      row.meaning = cells[2];
    } else {
      ADD_FAILURE() << path << ": a table row of " << cells.size() << " cells: " << line;
      continue;
    }
    tables[section].push_back(row);
  }
  return tables;
}

// A code of a program, and words its meaning must contain on the page.
struct Expected {
  std::string program;  // "`hexa_plant_sim`"; "" for the launcher's table
  int code;
  std::string words;
};

class ExitCodePage : public ::testing::Test {
 protected:
  void SetUp() override {
    tables_ = ReadTables(std::string(HEXA_SOURCE_DIR) + "/docs/exit_codes.md", text_);
    ASSERT_FALSE(tables_.empty()) << "docs/exit_codes.md has no tables";
  }
  // Rows of `section` for `program` (cells naming it among others count too).
  std::vector<Row> RowsOf(const std::string& section, const std::string& program) const {
    std::vector<Row> rows;
    const auto it = tables_.find(section);
    if (it == tables_.end()) return rows;
    for (const auto& r : it->second)
      if (program.empty() || r.program.find(program) != std::string::npos) rows.push_back(r);
    return rows;
  }
  void ExpectCodes(const std::string& section, const std::vector<Expected>& expected) const {
    std::map<std::string, std::set<int>> header_codes;
    for (const auto& e : expected) {
      header_codes[e.program].insert(e.code);
      bool found = false;
      for (const auto& r : RowsOf(section, e.program)) {
        if (r.codes.count(e.code) == 0) continue;
        found = true;
        EXPECT_NE(r.meaning.find(e.words), std::string::npos)
            << section << ": " << (e.program.empty() ? "hexa_session" : e.program) << " code "
            << e.code << " says \"" << r.meaning << "\", expected it to mention \"" << e.words
            << "\"";
      }
      EXPECT_TRUE(found) << section << ": no row for " << e.program << " code " << e.code
                         << " (exit_code.hpp has it)";
    }
    // No code above 2 on the page that the header does not give the program.
    for (const auto& [program, codes] : header_codes)
      for (const auto& r : RowsOf(section, program))
        for (int code : r.codes) {
          if (code > ec::kUsage) {
            EXPECT_TRUE(codes.count(code) == 1)
                << section << ": " << program << " code " << code
                << " is on the page but not in exit_code.hpp: \"" << r.meaning << "\"";
          }
        }
  }

  std::string text_;
  std::map<std::string, std::vector<Row>> tables_;
};

TEST_F(ExitCodePage, LauncherTableMatchesTheHeader) {
  ExpectCodes("hexa_session (the launcher)",
              {{"", ec::kOk, "completed"},
               {"", ec::kRunError, "a process failed"},
               {"", ec::kUsage, "usage error"},
               {"", ec::kSessionHeld, "held the platform"},
               {"", ec::kSessionPlantStopped, "the plant stopped"},
               {"", ec::kSessionSupervisorLost, "the supervisor was lost"},
               {"", ec::kSessionStoppedByOperator, "stopped by the operator"},
               {"", ec::kSessionRecordingLoss, "lost samples"}});
  // Every row of the launcher's table is one of those eight.
  EXPECT_EQ(RowsOf("hexa_session (the launcher)", "").size(), 8u);
}

TEST_F(ExitCodePage, ServicesTableMatchesTheHeader) {
  ExpectCodes("Services",
              {{"`hexa_plant_sim`", ec::kPlantLockstepStall, "lockstep"},
               {"`hexa_plant_sim`", ec::kPlantNonFinite, "non-finite"},
               {"`hexa_plant_sim`", ec::kPlantDeviceLost, "stopped answering"},
               {"`hexa_task_space`", ec::kPeersNotMatched, "peers not matched"},
               {"`hexa_leg_ctrl`", ec::kPeersNotMatched, "peers not matched"},
               {"`hexa_task_space`", ec::kSupervisorHeld, "held the platform"},
               {"`hexa_task_space`", ec::kStoppedByOperator, "`stop`"}});
}

TEST_F(ExitCodePage, OperatorTableMatchesTheHeader) {
  ExpectCodes("Tools", {{"`hexa_operator`", ec::kOk, "accepted"},
                        {"`hexa_operator`", ec::kRunError, "no supervisor matched"},
                        {"`hexa_operator`", ec::kNotAnswered, "not acknowledged"},
                        {"`hexa_operator`", ec::kRefused, "refused"}});
}

TEST_F(ExitCodePage, UnitsDoNotRestartAUsageError) {
  // The generated units' RestartPreventExitStatus= (deploy/deployment/generate.cpp).
  EXPECT_NE(text_.find("`RestartPreventExitStatus=" + std::to_string(ec::kUsage) + "`"),
            std::string::npos);
}

}  // namespace
