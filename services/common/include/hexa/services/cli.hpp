// Minimal command-line parsing shared by every executable: declared options with help
// text, defaults and validation; errors name the option, the value and what was expected.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace hexa::cli {

class Parser {
 public:
  Parser(std::string program, std::string summary);

  // Options take a value ("--name value" or "--name=value") unless declared as flags.
  void AddOption(const std::string& name, const std::string& value_name,
                 const std::string& help, std::optional<std::string> default_value = {});
  void AddChoice(const std::string& name, const std::vector<std::string>& choices,
                 const std::string& help, const std::string& default_value);
  void AddFlag(const std::string& name, const std::string& help);
  // An option that may be given several times; GetAll returns every value in order.
  void AddRepeatable(const std::string& name, const std::string& value_name,
                     const std::string& help);
  // Positional arguments (words without a leading '-'): none are accepted unless declared here,
  // so that a stray word or a single-dash option ("-trajectory x") is an error, never ignored.
  void AllowPositional(const std::string& usage, std::size_t max_count);

  // Returns false on error (message in error()) or when --help was asked (help_requested()).
  bool Parse(int argc, const char* const* argv);
  bool help_requested() const { return help_requested_; }
  const std::string& error() const { return error_; }
  std::string Help() const;

  bool Has(const std::string& name) const;
  bool Flag(const std::string& name) const;
  std::string Get(const std::string& name) const;
  std::vector<std::string> GetAll(const std::string& name) const;
  // Typed getters; on a bad value they return nullopt and set error().
  std::optional<long long> GetInt(const std::string& name, long long min, long long max);
  // As GetInt, but the word `word` (e.g. "none") is accepted too and reads as `word_value`.
  std::optional<long long> GetIntOrWord(const std::string& name, const std::string& word,
                                        long long word_value, long long min, long long max);
  std::optional<double> GetDouble(const std::string& name, double min, double max);
  const std::vector<std::string>& positional() const { return positional_; }
  // Records a validation error found by the caller (e.g. a list a typed getter cannot read);
  // error() then returns it. Always returns false.
  bool Fail(const std::string& message);

 private:
  struct Spec {
    std::string value_name;
    std::string help;
    std::optional<std::string> default_value;
    std::vector<std::string> choices;
    bool is_flag = false;
    bool repeatable = false;
  };
  std::string program_;
  std::string summary_;
  std::vector<std::string> order_;
  std::map<std::string, Spec> specs_;
  std::map<std::string, std::string> values_;
  std::map<std::string, std::vector<std::string>> all_values_;  // repeatable options
  std::vector<std::string> positional_;
  std::string positional_usage_;
  std::size_t max_positional_ = 0;
  bool help_requested_ = false;
  std::string error_;
};

// Standard handling in main(): prints help (exit 0) or the error + usage hint (exit 2).
// Returns -1 when the program should continue.
int HandleParseResult(const Parser& parser, bool ok);

// A list of leg ids as given on a command line: "1-6", "1,3,5", "2", "1-2,5" -> sorted,
// unique ids 1..6. False (legs empty) on anything else.
bool ParseLegList(const std::string& text, std::vector<int>& legs);

}  // namespace hexa::cli
