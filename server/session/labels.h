#ifndef EXCITE_SERVER_SESSION_LABELS_H_
#define EXCITE_SERVER_SESSION_LABELS_H_

#include <map>
#include <string>

namespace excite::session {

// A session's labels, key -> value (validated by the API layer), in key order.
using Labels = std::map<std::string, std::string>;

}  // namespace excite::session

#endif  // EXCITE_SERVER_SESSION_LABELS_H_
