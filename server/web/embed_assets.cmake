# Writes OUTPUT, a C++ source defining excite::web::WebAssets() with the files of
# ASSETS_DIR (index.html served as "/", the others under their names) as raw
# string literals. cmake -DASSETS_DIR=... -DOUTPUT=... -P embed_assets.cmake
set(entries "")
foreach(name index.html app.js style.css)
  file(READ ${ASSETS_DIR}/${name} body)
  string(FIND "${body}" ")excite_asset\"" clash)
  if(NOT clash EQUAL -1)
    message(FATAL_ERROR "${name} contains the raw-string delimiter")
  endif()
  if(name STREQUAL "index.html")
    set(path "/")
    set(type "text/html; charset=utf-8")
  elseif(name MATCHES "\\.js$")
    set(path "/${name}")
    set(type "text/javascript; charset=utf-8")
  else()
    set(path "/${name}")
    set(type "text/css; charset=utf-8")
  endif()
  string(APPEND entries "    {\"${path}\", \"${type}\", R\"excite_asset(${body})excite_asset\"},\n")
endforeach()
file(WRITE ${OUTPUT}.tmp "// Generated from server/web/assets by embed_assets.cmake; do not edit.
#include \"server/web/web_assets.h\"

namespace excite::web {

const WebAsset* WebAssets() {
  static const WebAsset kAssets[] = {
${entries}    {\"\", \"\", \"\"},
  };
  return kAssets;
}

}  // namespace excite::web
")
file(COPY_FILE ${OUTPUT}.tmp ${OUTPUT} ONLY_IF_DIFFERENT)
file(REMOVE ${OUTPUT}.tmp)
