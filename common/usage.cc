#include "common/usage.h"

#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

#include "absl/flags/commandlineflag.h"
#include "absl/flags/parse.h"
#include "absl/flags/reflection.h"
#include "absl/flags/usage.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "common/build_info.h"

namespace excite {
namespace {

void PrintHelpAndExit(absl::string_view usage) {
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

}  // namespace

std::vector<char*> ParseFlags(int argc, char** argv, absl::string_view usage) {
  absl::SetProgramUsageMessage(usage);
  for (int i = 1; i < argc; ++i) {
    const absl::string_view arg = argv[i];
    if (arg == "--") break;
    if (arg == "--help" || arg == "-help" || arg == "-h" || arg == "--helpfull") {
      PrintHelpAndExit(usage);
    }
    if (arg == "--version" || arg == "-version") {
      std::string program = argc > 0 ? argv[0] : "excite";
      if (const size_t slash = program.rfind('/'); slash != std::string::npos) {
        program.erase(0, slash + 1);
      }
      std::printf("%s %s (commit %s)\n", program.c_str(), BuildVersion(), BuildCommit());
      std::exit(0);
    }
  }
  return absl::ParseCommandLine(argc, argv);
}

}  // namespace excite
