#ifndef EXCITE_COMMON_USAGE_H_
#define EXCITE_COMMON_USAGE_H_

#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "absl/flags/commandlineflag.h"
#include "absl/flags/parse.h"
#include "absl/flags/reflection.h"
#include "absl/flags/usage.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"

namespace excite {

// absl::ParseCommandLine for excite's programs, with a --help (also -help, -h,
// --helpfull) that prints `usage` and every flag of excite's own sources, then
// exits 0. (Abseil's --help of Debian 12 lists only flags of a file named like
// the program, which here is none, "No flags matched.", and exits 1.)
// Returns the positional arguments, argv[0] first.
inline std::vector<char*> ParseFlags(int argc, char** argv, absl::string_view usage) {
  absl::SetProgramUsageMessage(usage);
  for (int i = 1; i < argc; ++i) {
    const absl::string_view arg = argv[i];
    if (arg == "--") break;
    if (arg != "--help" && arg != "-help" && arg != "-h" && arg != "--helpfull") continue;
    std::string text = absl::StrCat(usage, "\n\nFlags:\n");
    std::map<std::string, std::string> lines;  // sorted by name
    for (const auto& [name, flag] : absl::GetAllFlags()) {
      if (absl::StrContains(flag->Filename(), "absl/")) continue;
      lines[std::string(name)] =
          absl::StrCat("  --", name, "  (default \"", flag->DefaultValue(), "\")\n      ",
                       flag->Help(), "\n");
    }
    for (const auto& [name, line] : lines) absl::StrAppend(&text, line);
    std::fputs(text.c_str(), stdout);
    std::exit(0);
  }
  return absl::ParseCommandLine(argc, argv);
}

}  // namespace excite

#endif  // EXCITE_COMMON_USAGE_H_
