#ifndef EXCITE_COMMON_BUILD_INFO_H_
#define EXCITE_COMMON_BUILD_INFO_H_

namespace excite {

// What was built: the project's version (CMakeLists.txt) and the git commit the
// build was made from, 12 hex digits plus "-dirty" if the tree had uncommitted
// changes; $EXCITE_COMMIT at build time if set (the container build has no .git),
// else "unknown". Written at every build, so it is never stale.
const char* BuildVersion();
const char* BuildCommit();

}  // namespace excite

#endif  // EXCITE_COMMON_BUILD_INFO_H_
