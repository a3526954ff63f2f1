#ifndef EXCITE_SERVER_STORE_STORE_RECORDS_H_
#define EXCITE_SERVER_STORE_STORE_RECORDS_H_

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace excite::store {

// One session as the store keeps it. The store does not interpret the bytes.
struct SessionRecord {
  std::string id;
  // Serialized excite.v1.SessionConfig (validated, defaults filled).
  std::string config;
  // Creation time, milliseconds since the Unix epoch.
  int64_t created_unix_ms = 0;
  // Opaque bytes of the last fitted hyperparameters (empty if never fitted).
  std::string hyperparameters;
  // Model version at the time `hyperparameters` were saved (0 if never).
  int64_t model_version = 0;
  // What a person calls the session (may be empty).
  std::string display_name;
  // key -> value; validated by the service, stored as given.
  std::map<std::string, std::string> labels;
};

// One measured transition (x_k, u_k, x_{k+1}) with its per-session sequence number.
struct SampleRecord {
  int64_t sequence = 0;
  std::vector<double> state;
  std::vector<double> input;
  std::vector<double> next_state;
  // Seconds since the Unix epoch (informative).
  double timestamp_s = 0.0;
};

// What InsertSamples() did: stored[i] is true if batch[i] was new, false if a
// sample with its sequence number was already stored (or earlier in the batch).
struct InsertResult {
  std::vector<bool> stored;
  int64_t stored_count = 0;
  int64_t duplicate_count = 0;
};

// A session as ListSessions gives it: its record and what its samples are.
struct SessionListing {
  SessionRecord record;
  int64_t sample_count = 0;
  int64_t last_sequence = -1;  // -1: no sample
};

// A lease a replica holds: the session and the fence it was granted.
struct HeldLease {
  std::string session_id;
  int64_t fence = 0;
};

// What RenewLeases found.
struct LeaseRenewal {
  // Sessions of the request that this replica no longer owns: taken over by
  // another replica after the lease expired, or deleted.
  std::vector<std::string> lost;
  // Sessions still owned that another replica asked for (AcquireLease failed
  // there): release them once idle.
  std::vector<std::string> wanted;
};

}  // namespace excite::store

#endif  // EXCITE_SERVER_STORE_STORE_RECORDS_H_
