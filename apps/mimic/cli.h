// The command line of every `mimic` command, over CLI11: one CLI::App per command whose help is
// generated from the option declarations (ranges with CLI::Range, exclusions with ->excludes,
// choices with CLI::IsMember), and one mapping of the outcome to Mimic's exit codes:
//   0  done (and after --help / -h, which print the usage on stdout)
//   1  bad input or a runtime failure (failure())
//   2  a usage error: "mimic <command>: <message>" and "(see 'mimic <command> --help')" on stderr
//
//   int run(const std::vector<std::string>& argv) {
//     cli::Parser p("export", "Writes a rigged, animated glTF ...");
//     int lod = 0;
//     p.app().add_option("--lod", lod, "skin level of detail")->check(CLI::Range(0, 3));
//     if (auto exit_code = p.parse(argv)) return *exit_code;
//     ...
//   }
#pragma once

#include <CLI/CLI.hpp>

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace mimic::app::cli {

class Parser {
 public:
  // `path` is the command as typed after `mimic`: "export", "sim flock". `description` opens the
  // help after the usage line; footer() adds prose after the options.
  Parser(std::string path, std::string description);

  CLI::App& app() { return *app_; }
  CLI::App* operator->() { return app_.get(); }
  const std::string& path() const { return path_; }

  // Parses argv (the words after the command's name). std::nullopt: the command goes on;
  // otherwise the exit code to return, the help or the usage error already printed.
  std::optional<int> parse(const std::vector<std::string>& argv);

  // A usage error found after parsing (a value that only the command can judge): prints it as
  // parse() does and returns 2.
  int usage_error(const std::string& message) const;
  // A failure (bad input, a file that does not open): "mimic <command>: <message>", returns 1.
  int failure(const std::string& message) const;

  // The generated usage text, as --help prints it.
  std::string help() const;

 private:
  std::string path_;
  std::unique_ptr<CLI::App> app_;
};

// Repeated groups of options where the options after a head belong to it:
//   --source A --body B.json --place 1,0 --source C --body D.json
// is two groups {A, body=B.json, place=1,0} and {C, body=D.json}. A member before the first head
// opens a group with `implicit_head` (as if `--source sim:walk` had been typed); a member given
// twice for one head is a usage error ("two --body options for one --source").
// Construct it before parsing; it reads CLI11's parse order when parsing completes (it takes the
// App's parse_complete_callback, so a command using it does not set its own).
class OptionGroups {
 public:
  struct Group {
    std::string head;
    std::map<std::string, std::string> members;  // by long name without dashes: "body"
    bool implicit = false;                       // opened by a member before any head
    // The member's value, or "" when it was not given.
    std::string get(const std::string& name) const;
  };

  // `head` and member names are long option names with dashes: "--source".
  OptionGroups(CLI::App& app, const std::string& head, const std::string& head_description, std::string implicit_head);
  CLI::Option* head() { return head_; }
  CLI::Option* member(const std::string& name, const std::string& description);

  // The groups in command-line order (empty when no head or member was given).
  const std::vector<Group>& groups() const { return groups_; }

 private:
  void collect();

  CLI::App& app_;
  CLI::Option* head_ = nullptr;
  std::vector<std::string> head_values_;
  std::vector<const CLI::Option*> members_;
  std::map<std::string, std::vector<std::string>> member_values_;  // CLI11 fills these
  std::string implicit_head_;
  std::vector<Group> groups_;
};

// CLI::Range for floating-point values, which also refuses "nan" (it passes CLI::Range: every
// comparison with NaN is false) and "inf". max = INFINITY: no upper bound ("FLOAT >= 0").
// Bound::exclusive leaves out the bound itself: (0 - 240] for "more than 0, at most 240".
enum class Bound { inclusive, exclusive };
CLI::Validator finite_range(double min, double max, Bound min_bound = Bound::inclusive,
                            Bound max_bound = Bound::inclusive);

// A validator from one of Mimic's own parsers (anything returning a Result for a string): the value
// passes when it parses, otherwise the parser's message is the error. `shown` is what the help
// prints for the value ("4000flx|3003|2003").
template <typename Parse>
CLI::Validator parsed_by(Parse parse, std::string shown) {
  return CLI::Validator(
      [parse](std::string& input) -> std::string {
        auto parsed = parse(input);
        return parsed ? std::string() : parsed.error().message;
      },
      std::move(shown));
}

}  // namespace mimic::app::cli
