#include "sim/plants/mujoco_model.h"

#include <cstring>
#include <memory>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/synchronization/mutex.h"

namespace excite::sim {
namespace {

// An mjVFS (about 2 MB of fixed-size name tables, so on the heap) that frees the
// files it holds.
struct VfsDeleter {
  void operator()(mjVFS* vfs) const {
    mj_deleteVFS(vfs);
    delete vfs;
  }
};

absl::Mutex& LoadMutex() {
  static absl::Mutex* const mutex = new absl::Mutex();
  return *mutex;
}

}  // namespace

absl::StatusOr<MjModelPtr> LoadMjcfFromString(absl::string_view name,
                                              absl::string_view mjcf) {
  const std::string file_name = absl::StrCat(name, ".xml");
  if (mjcf.empty()) {
    return absl::InvalidArgumentError(absl::StrCat("MuJoCo model ", name, " is empty"));
  }
  std::unique_ptr<mjVFS, VfsDeleter> vfs(new mjVFS);
  mj_defaultVFS(vfs.get());
  if (mj_makeEmptyFileVFS(vfs.get(), file_name.c_str(), static_cast<int>(mjcf.size())) !=
      0) {
    return absl::InternalError(
        absl::StrCat("cannot create the in-memory file ", file_name));
  }
  const int index = mj_findFileVFS(vfs.get(), file_name.c_str());
  if (index < 0) {
    return absl::InternalError(absl::StrCat("in-memory file ", file_name, " not found"));
  }
  std::memcpy(vfs->filedata[index], mjcf.data(), mjcf.size());

  char error[1024] = "";
  MjModelPtr model;
  {
    absl::MutexLock lock(&LoadMutex());
    model.reset(mj_loadXML(file_name.c_str(), vfs.get(), error, sizeof(error)));
  }
  if (model == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat("MuJoCo could not load model ", name, ": ", error));
  }
  return model;
}

}  // namespace excite::sim
