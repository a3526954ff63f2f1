#ifndef EXCITE_COMMON_USAGE_H_
#define EXCITE_COMMON_USAGE_H_

#include <vector>

#include "absl/strings/string_view.h"

namespace excite {

// absl::ParseCommandLine for excite's programs, with
//  - a --help (also -help, -h, --helpfull) that prints `usage` and every flag of
//    excite's own sources, then exits 0 (Abseil's --help of Debian 12 lists only
//    flags of a file named like the program, which here is none, "No flags
//    matched.", and exits 1);
//  - a --version that prints the program's name, excite's version and the commit
//    it was built from, then exits 0 (Abseil's prints "Debug build (NDEBUG not
//    #defined)" whatever the build).
// Returns the positional arguments, argv[0] first.
std::vector<char*> ParseFlags(int argc, char** argv, absl::string_view usage);

}  // namespace excite

#endif  // EXCITE_COMMON_USAGE_H_
