// hexa::json (services/common/include/hexa/services/json.hpp): what every JSON file of the
// system is written with. A non-finite number is null (JSON has no NaN or infinity), every
// string survives quotes, backslashes, control characters and invalid UTF-8, and the fields
// keep the order they were written in.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "hexa/services/json.hpp"

namespace {

using hexa::json::Value;

TEST(Json, NonFiniteNumbersAreWrittenAsNull) {
  Value v = {{"nan", std::nan("")},
             {"inf", std::numeric_limits<double>::infinity()},
             {"minus_inf", -std::numeric_limits<double>::infinity()},
             {"rmse", {0.25, std::nan(""), 1e-9}}};
  const std::string text = hexa::json::Dump(v);
  EXPECT_EQ(text, R"({"nan":null,"inf":null,"minus_inf":null,"rmse":[0.25,null,1e-09]})");
  const Value parsed = Value::parse(text);  // throws on invalid JSON
  EXPECT_TRUE(parsed["nan"].is_null());
  EXPECT_DOUBLE_EQ(parsed["rmse"][0].get<double>(), 0.25);
}

TEST(Json, StringsWithQuotesBackslashesAndControlCharactersRoundTrip) {
  const std::string path = "/tmp/a \"quoted\" dir\\with\\backslashes/\ttab\nnewline\x01.json";
  const Value v = {{"path", path}};
  const Value parsed = Value::parse(hexa::json::Dump(v, 2));
  EXPECT_EQ(parsed["path"].get<std::string>(), path);
}

TEST(Json, InvalidUtf8BecomesTheReplacementCharacter) {
  const Value v = {{"text", std::string("ok \xff\xfe end")}};
  const std::string text = hexa::json::Dump(v);  // must not throw
  const Value parsed = Value::parse(text);
  EXPECT_EQ(parsed["text"].get<std::string>(), "ok \xEF\xBF\xBD\xEF\xBF\xBD end");
}

TEST(Json, FieldsKeepTheirWrittenOrder) {
  Value v;
  v["seed"] = 1;
  v["profile"] = "realistic";
  v["controller"] = "bssmc";
  EXPECT_EQ(hexa::json::Dump(v), R"({"seed":1,"profile":"realistic","controller":"bssmc"})");
}

TEST(Json, WriteFileSaysWhichFileItCannotWrite) {
  std::string error;
  EXPECT_FALSE(hexa::json::WriteFile("/nonexistent-dir/x.json", Value::object(), 2, error));
  EXPECT_NE(error.find("/nonexistent-dir/x.json"), std::string::npos) << error;
  const std::string path =
      (std::filesystem::temp_directory_path() / ("hexa_json_" + std::to_string(::getpid()) + ".json")).string();
  ASSERT_TRUE(hexa::json::WriteFile(path, Value{{"a", 1}}, 2, error)) << error;
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), "{\n  \"a\": 1\n}\n");
  std::filesystem::remove(path);
}

}  // namespace
