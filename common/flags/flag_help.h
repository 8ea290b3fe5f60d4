// `--help` and `--version` for the binaries whose flags are Abseil flags
// (impostor-server, impostor-worker), written for people: a usage line, then
// every registered flag under a heading, dashed, with its value type, its
// default and its help text (which states the range), and no source paths or
// Abseil boilerplate.
//
// The text is generated from the flag registry itself, so a flag defined
// anywhere in the binary shows up without editing a help table: a flag goes
// under the first group one of whose name prefixes it starts with, else
// under "Other". Abseil's own parsing flags (--flagfile, --fromenv, ...) are
// listed last; its help variants (--helpfull, --helpshort, ...) print this
// same text. Man pages are made from the same text (tools/help_to_man.py).
#ifndef IMPOSTOR_COMMON_FLAGS_FLAG_HELP_H_
#define IMPOSTOR_COMMON_FLAGS_FLAG_HELP_H_

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace impostor {

struct FlagGroup {
  std::string title;                  // e.g. "Network"
  std::vector<std::string> prefixes;  // underscored name prefixes, e.g. "tls_" or a whole name
};

struct ProgramHelp {
  std::string program;               // "impostor-server"
  std::vector<std::string> usage;    // usage lines, without the program name
  std::string summary;               // one paragraph: what the program is
  std::vector<FlagGroup> groups;     // in display order; unmatched flags go to "Other"
  std::string footer;                // optional closing paragraph(s), verbatim
};

// The --help text (ends with a newline).
std::string FlagHelpText(const ProgramHelp& help);

// "PROGRAM VERSION (baker BAKER_VERSION)".
std::string VersionLine(std::string_view program);

// Handles --help, -h, --helpfull, --helpshort and --version anywhere before
// a bare "--" (dashed or underscored spellings): prints the text on stdout
// and returns exit status 0. nullopt: none of them was given. Call it before
// absl::ParseCommandLine.
std::optional<int> HandleHelpAndVersion(int argc, char** argv, const ProgramHelp& help);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_FLAGS_FLAG_HELP_H_
