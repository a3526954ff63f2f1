#ifndef EXCITE_TESTS_STORE_STORE_TEST_RECORDS_H_
#define EXCITE_TESTS_STORE_STORE_TEST_RECORDS_H_

#include <cstdint>
#include <string>

#include "server/store/store_records.h"

namespace excite::store::testing {

// A sample whose values depend on its sequence number (and one tiny value, to
// check exact round trips).
inline SampleRecord Sample(int64_t sequence) {
  SampleRecord s;
  s.sequence = sequence;
  s.state = {0.1 * static_cast<double>(sequence), -1.5};
  s.input = {2.0 + static_cast<double>(sequence)};
  s.next_state = {0.25, 1e-300};
  s.timestamp_s = 1700000000.5 + static_cast<double>(sequence);
  return s;
}

// A session record with arbitrary config bytes (a NUL among them).
inline SessionRecord Session(const std::string& id) {
  SessionRecord r;
  r.id = id;
  r.config = std::string("\x08\x02\x10\x01\0bytes", 10);
  r.created_unix_ms = 1700000000123;
  return r;
}

}  // namespace excite::store::testing

#endif  // EXCITE_TESTS_STORE_STORE_TEST_RECORDS_H_
