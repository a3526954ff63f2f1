#ifndef EXCITE_SERVER_WEB_WEB_ASSETS_H_
#define EXCITE_SERVER_WEB_WEB_ASSETS_H_

#include <string_view>

namespace excite::web {

// The live view's files (server/web/assets), embedded at build time by
// embed_assets.cmake.
struct WebAsset {
  std::string_view path;  // "/", "/app.js", ...
  std::string_view content_type;
  std::string_view body;
};
// Every asset; ends with an entry whose path is empty.
const WebAsset* WebAssets();

}  // namespace excite::web

#endif  // EXCITE_SERVER_WEB_WEB_ASSETS_H_
