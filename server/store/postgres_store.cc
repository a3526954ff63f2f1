#include "server/store/postgres_store.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <pqxx/pqxx>
#include <set>
#include <thread>
#include <utility>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "server/store/double_blob.h"
#include "server/store/sample_rows.h"

namespace excite::store {
namespace {

using Clock = std::chrono::steady_clock;

// Serialises schema creation between replicas starting at once (any constant:
// "excite" in ASCII).
constexpr int64_t kSchemaLockKey = 0x657863697465;

// Rows per INSERT of an import (each row is 6 array elements of one statement).
constexpr size_t kImportChunk = 2000;

constexpr char kCreateTables[] = R"sql(
CREATE TABLE schema_version (version INTEGER NOT NULL);
CREATE TABLE sessions (
  id TEXT COLLATE "C" PRIMARY KEY,
  config BYTEA NOT NULL,
  created_unix_ms BIGINT NOT NULL,
  hyperparameters BYTEA NOT NULL DEFAULT ''::bytea,
  model_version BIGINT NOT NULL DEFAULT 0,
  display_name TEXT NOT NULL DEFAULT '',
  owner TEXT,
  fence BIGINT NOT NULL DEFAULT 0,
  lease_expires TIMESTAMPTZ,
  handoff_wanted_by TEXT
);
CREATE TABLE session_labels (
  session_id TEXT COLLATE "C" NOT NULL REFERENCES sessions (id) ON DELETE CASCADE,
  key TEXT NOT NULL,
  value TEXT NOT NULL,
  PRIMARY KEY (session_id, key)
);
CREATE TABLE samples (
  session_id TEXT COLLATE "C" NOT NULL REFERENCES sessions (id) ON DELETE CASCADE,
  sequence BIGINT NOT NULL,
  state BYTEA NOT NULL,
  input BYTEA NOT NULL,
  next_state BYTEA NOT NULL,
  timestamp_s DOUBLE PRECISION NOT NULL,
  PRIMARY KEY (session_id, sequence)
);
)sql";

// The record columns, in RecordFromRow's order.
constexpr char kSelectRecord[] =
    "SELECT id, config, created_unix_ms, hyperparameters, model_version, display_name "
    "FROM sessions";

// The lease's expiry, `$n` milliseconds from now on the database's clock.
std::string ExpiryIn(int param) {
  return absl::StrCat("clock_timestamp() + make_interval(secs => $", param,
                      "::double precision / 1000)");
}

std::string Bytes(const pqxx::field& field) { return pqxx::binarystring(field).str(); }

SessionRecord RecordFromRow(const pqxx::row& row) {
  SessionRecord record;
  record.id = row[0].as<std::string>();
  record.config = Bytes(row[1]);
  record.created_unix_ms = row[2].as<int64_t>();
  record.hyperparameters = Bytes(row[3]);
  record.model_version = row[4].as<int64_t>();
  record.display_name = row[5].as<std::string>();
  return record;
}

// Array literals for the unnest() of a batch: PostgreSQL's text syntax, every
// element double-quoted. Doubles with 17 significant digits round-trip exactly;
// bytea in hex.
std::string QuotedElement(absl::string_view text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out.push_back('\\');
    out.push_back(c);
  }
  out.push_back('"');
  return out;
}

std::string TextArray(const std::vector<std::string>& values) {
  std::vector<std::string> quoted;
  quoted.reserve(values.size());
  for (const std::string& v : values) quoted.push_back(QuotedElement(v));
  return absl::StrCat("{", absl::StrJoin(quoted, ","), "}");
}

std::string ByteaHex(const std::vector<double>& values) {
  return absl::StrCat("\\x", absl::BytesToHexString(EncodeDoubles(values)));
}

struct SampleArrays {
  std::string sequences;
  std::string states;
  std::string inputs;
  std::string next_states;
  std::string timestamps;
};

SampleArrays ArraysOf(const std::vector<SampleRecord>& samples, size_t begin,
                      size_t end) {
  std::vector<std::string> sequences;
  std::vector<std::string> states;
  std::vector<std::string> inputs;
  std::vector<std::string> next_states;
  std::vector<std::string> timestamps;
  for (size_t i = begin; i < end; ++i) {
    const SampleRecord& s = samples[i];
    sequences.push_back(absl::StrCat(s.sequence));
    states.push_back(ByteaHex(s.state));
    inputs.push_back(ByteaHex(s.input));
    next_states.push_back(ByteaHex(s.next_state));
    timestamps.push_back(absl::StrFormat("%.17g", s.timestamp_s));
  }
  return {TextArray(sequences), TextArray(states), TextArray(inputs),
          TextArray(next_states), TextArray(timestamps)};
}

// Inserts rows [begin, end) of `samples`; with `ignore_duplicates`, rows whose
// sequence is stored already are skipped and the stored sequences returned.
pqxx::result InsertSampleRows(pqxx::work& tx, const std::string& session_id,
                              const std::vector<SampleRecord>& samples, size_t begin,
                              size_t end, bool ignore_duplicates) {
  const SampleArrays a = ArraysOf(samples, begin, end);
  return tx.exec_params(
      absl::StrCat("INSERT INTO samples (session_id, sequence, state, input, "
                   "next_state, timestamp_s) SELECT $1, t.sequence, t.state, t.input, "
                   "t.next_state, t.timestamp_s FROM unnest($2::bigint[], $3::bytea[], "
                   "$4::bytea[], $5::bytea[], $6::double precision[]) WITH ORDINALITY "
                   "AS t(sequence, state, input, next_state, timestamp_s, ord) ORDER BY "
                   "t.ord",
                   ignore_duplicates ? " ON CONFLICT DO NOTHING RETURNING sequence" : ""),
      session_id, a.sequences, a.states, a.inputs, a.next_states, a.timestamps);
}

void InsertLabels(pqxx::work& tx, const SessionRecord& session) {
  if (session.labels.empty()) return;
  std::vector<std::string> keys;
  std::vector<std::string> values;
  for (const auto& [key, value] : session.labels) {
    keys.push_back(key);
    values.push_back(value);
  }
  tx.exec_params(
      "INSERT INTO session_labels (session_id, key, value) SELECT $1, k, v FROM "
      "unnest($2::text[], $3::text[]) AS t(k, v)",
      session.id, TextArray(keys), TextArray(values));
}

void InsertSessionRow(pqxx::work& tx, const SessionRecord& session) {
  tx.exec_params(
      "INSERT INTO sessions (id, config, created_unix_ms, hyperparameters, "
      "model_version, display_name) VALUES ($1, $2, $3, $4, $5, $6)",
      session.id, pqxx::binarystring(session.config), session.created_unix_ms,
      pqxx::binarystring(session.hyperparameters), session.model_version,
      session.display_name);
  InsertLabels(tx, session);
}

// Fills the labels of `records` (one query).
void LoadLabels(pqxx::work& tx, std::vector<SessionRecord>* records) {
  if (records->empty()) return;
  std::vector<std::string> ids;
  std::map<std::string, SessionRecord*> by_id;
  for (SessionRecord& r : *records) {
    ids.push_back(r.id);
    by_id[r.id] = &r;
  }
  const pqxx::result rows = tx.exec_params(
      "SELECT session_id, key, value FROM session_labels WHERE session_id = "
      "ANY($1::text[])",
      TextArray(ids));
  for (const pqxx::row& row : rows) {
    by_id[row[0].as<std::string>()]->labels[row[1].as<std::string>()] =
        row[2].as<std::string>();
  }
}

absl::Status NotFound(const std::string& id) {
  return absl::NotFoundError(absl::StrCat("session sessions/", id, " not found"));
}

}  // namespace

absl::StatusOr<std::unique_ptr<PostgresStore>> PostgresStore::Open(
    const PostgresStoreOptions& options) {
  if (options.owner.empty()) {
    return absl::InvalidArgumentError("a PostgreSQL store needs an owner name");
  }
  if (options.lease_ttl < std::chrono::milliseconds(500)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the lease must last at least 500 ms, got ", options.lease_ttl.count(), " ms"));
  }
  absl::StatusOr<PostgresTarget> target = ParsePostgresTarget(
      options.url, options.password, absl::StrCat("excite-server ", options.owner));
  if (!target.ok()) return target.status();
  std::string location = target->location;
  // A write or takeover never waits long for a lock, and a transaction left
  // open by a replica that stopped (SIGSTOP, a hung host) is ended by the
  // server before that replica's leases expire, so it cannot block the next
  // owner.
  const int64_t idle_ms = std::max<int64_t>(250, options.lease_ttl.count() / 2);
  std::vector<std::string> settings = {
      "SET lock_timeout = 2000",
      absl::StrCat("SET idle_in_transaction_session_timeout = ", idle_ms),
      "SET statement_timeout = 120000",
  };
  auto connections = std::make_unique<PostgresConnections>(
      *std::move(target), options.connections, std::move(settings));
  std::unique_ptr<PostgresStore> store(
      new PostgresStore(options, std::move(location), std::move(connections)));
  const Clock::time_point give_up = Clock::now() + options.connect_timeout;
  while (true) {
    absl::Status status = store->InitSchema();
    if (status.ok()) return store;
    if (!absl::IsUnavailable(status) || Clock::now() >= give_up) return status;
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
}

PostgresStore::PostgresStore(PostgresStoreOptions options, std::string location,
                             std::unique_ptr<PostgresConnections> connections)
    : options_(std::move(options)),
      location_(std::move(location)),
      connections_(std::move(connections)) {}

absl::Status PostgresStore::InitSchema() {
  return connections_->Run([&](pqxx::connection_base& conn) -> absl::Status {
    pqxx::work tx(conn);
    tx.exec_params("SELECT pg_advisory_xact_lock($1)", kSchemaLockKey);
    const pqxx::row found = tx.exec1(
        "SELECT to_regclass('schema_version') IS NOT NULL, "
        "(to_regclass('sessions') IS NOT NULL OR to_regclass('samples') IS NOT NULL OR "
        "to_regclass('session_labels') IS NOT NULL)");
    if (!found[0].as<bool>()) {
      if (found[1].as<bool>()) {
        return absl::FailedPreconditionError(absl::StrCat(
            location_,
            " has tables named sessions, samples or session_labels but no "
            "schema_version: they were not written by excite-server; use another "
            "database"));
      }
      tx.exec(kCreateTables);
      tx.exec_params("INSERT INTO schema_version (version) VALUES ($1)", kSchemaVersion);
      tx.commit();
      return absl::OkStatus();
    }
    const pqxx::result versions = tx.exec("SELECT version FROM schema_version");
    if (versions.size() != 1) {
      return absl::DataLossError(absl::StrCat(location_, ": schema_version has ",
                                              versions.size(), " rows; expected 1"));
    }
    const int version = versions[0][0].as<int>();
    if (version > kSchemaVersion) {
      return absl::FailedPreconditionError(
          absl::StrCat(location_, " has schema version ", version,
                       ", newer than this excite-server understands (", kSchemaVersion,
                       "): it was written by a newer excite-server; upgrade this one"));
    }
    if (version != kSchemaVersion) {
      return absl::FailedPreconditionError(
          absl::StrCat(location_, ": unknown schema version ", version,
                       " (this excite-server "
                       "understands version ",
                       kSchemaVersion, ")"));
    }
    tx.commit();
    return absl::OkStatus();
  });
}

absl::Status PostgresStore::CreateSession(const SessionRecord& session) {
  absl::Status status = connections_->Run([&](pqxx::connection_base& conn) {
    pqxx::work tx(conn);
    InsertSessionRow(tx, session);
    tx.commit();
    return absl::OkStatus();
  });
  if (absl::IsAlreadyExists(status)) {
    return absl::AlreadyExistsError(
        absl::StrCat("session sessions/", session.id, " already exists"));
  }
  return status;
}

absl::Status PostgresStore::ImportSession(const SessionRecord& session,
                                          const std::vector<SampleRecord>& samples) {
  absl::Status status = connections_->Run([&](pqxx::connection_base& conn) {
    pqxx::work tx(conn);
    InsertSessionRow(tx, session);
    for (size_t begin = 0; begin < samples.size(); begin += kImportChunk) {
      InsertSampleRows(tx, session.id, samples, begin,
                       std::min(samples.size(), begin + kImportChunk),
                       /*ignore_duplicates=*/false);
    }
    tx.commit();
    return absl::OkStatus();
  });
  if (absl::IsAlreadyExists(status)) {
    // The session's id, or two samples with one sequence number.
    return absl::AlreadyExistsError(
        absl::StrCat("importing session sessions/", session.id, ": ", status.message()));
  }
  return status;
}

absl::StatusOr<int64_t> PostgresStore::CountSessions() {
  int64_t count = 0;
  absl::Status status = connections_->Run([&](pqxx::connection_base& conn) {
    pqxx::work tx(conn);
    count = tx.exec1("SELECT count(*) FROM sessions")[0].as<int64_t>();
    tx.commit();
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  return count;
}

namespace {

// Sessions with their sample counts: `where` selects them (parameters $1, $2).
template <typename... Params>
std::vector<SessionListing> SelectListings(pqxx::work& tx, const std::string& where,
                                           Params&&... params) {
  const pqxx::result rows = tx.exec_params(
      absl::StrCat("SELECT s.id, s.config, s.created_unix_ms, s.hyperparameters, "
                   "s.model_version, s.display_name, c.n, c.last FROM sessions s CROSS "
                   "JOIN LATERAL (SELECT count(*) AS n, coalesce(max(p.sequence), -1) AS "
                   "last FROM samples p WHERE p.session_id = s.id) c ",
                   where),
      std::forward<Params>(params)...);
  std::vector<SessionRecord> records;
  for (const pqxx::row& row : rows) records.push_back(RecordFromRow(row));
  LoadLabels(tx, &records);
  std::vector<SessionListing> listings;
  for (size_t i = 0; i < records.size(); ++i) {
    SessionListing listing;
    listing.record = std::move(records[i]);
    listing.sample_count = rows[static_cast<int>(i)][6].as<int64_t>();
    listing.last_sequence = rows[static_cast<int>(i)][7].as<int64_t>();
    listings.push_back(std::move(listing));
  }
  return listings;
}

}  // namespace

absl::StatusOr<std::vector<SessionListing>> PostgresStore::ListSessions(
    const std::string& after_id, int limit) {
  std::vector<SessionListing> listings;
  absl::Status status = connections_->Run([&](pqxx::connection_base& conn) {
    pqxx::work tx(conn);
    listings =
        SelectListings(tx, "WHERE s.id > $1 ORDER BY s.id LIMIT $2", after_id, limit);
    tx.commit();
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  return listings;
}

absl::StatusOr<SessionListing> PostgresStore::ListSession(const std::string& id) {
  std::vector<SessionListing> one;
  absl::Status status = connections_->Run([&](pqxx::connection_base& conn) {
    pqxx::work tx(conn);
    one = SelectListings(tx, "WHERE s.id = $1", id);
    tx.commit();
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  if (one.empty()) return NotFound(id);
  return std::move(one.front());
}

absl::StatusOr<SessionRecord> PostgresStore::LoadSession(const std::string& id) {
  std::vector<SessionRecord> one;
  absl::Status status = connections_->Run([&](pqxx::connection_base& conn) {
    one.clear();
    pqxx::work tx(conn);
    const pqxx::result rows =
        tx.exec_params(absl::StrCat(kSelectRecord, " WHERE id = $1"), id);
    for (const pqxx::row& row : rows) one.push_back(RecordFromRow(row));
    LoadLabels(tx, &one);
    tx.commit();
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  if (one.empty()) return NotFound(id);
  return std::move(one.front());
}

absl::StatusOr<std::vector<SampleRecord>> PostgresStore::LoadSamples(
    const std::string& session_id, std::vector<int64_t>* unreadable) {
  std::vector<SampleRecord> samples;
  absl::Status status =
      connections_->Run([&](pqxx::connection_base& conn) -> absl::Status {
        samples.clear();
        if (unreadable != nullptr) unreadable->clear();
        pqxx::work tx(conn);
        const pqxx::result rows = tx.exec_params(
            "SELECT sequence, state, input, next_state, timestamp_s FROM samples WHERE "
            "session_id = $1 ORDER BY sequence",
            session_id);
        tx.commit();
        samples.reserve(rows.size());
        for (const pqxx::row& row : rows) {
          if (absl::Status s = AppendSampleRow(
                  session_id, row[0].as<int64_t>(), Bytes(row[1]), Bytes(row[2]),
                  Bytes(row[3]), row[4].as<double>(), &samples, unreadable);
              !s.ok()) {
            return s;
          }
        }
        return absl::OkStatus();
      });
  if (!status.ok()) return status;
  return samples;
}

namespace {

// Why a fenced write of `id` found no row it may change: NOT_FOUND, or the
// lease is no longer `owner`'s under `fence`.
absl::Status FencedWriteRefused(pqxx::work& tx, const std::string& id,
                                const std::string& owner, int64_t fence) {
  const pqxx::result rows = tx.exec_params(
      "SELECT owner, fence, lease_expires > clock_timestamp() FROM sessions WHERE id = "
      "$1",
      id);
  if (rows.empty()) return NotFound(id);
  const pqxx::row& row = rows[0];
  const std::string holder = row[0].is_null() ? "" : row[0].as<std::string>();
  const bool live = !row[2].is_null() && row[2].as<bool>();
  const bool taken = holder != owner || row[1].as<int64_t>() != fence;
  return absl::UnavailableError(absl::StrCat(
      "this replica (", owner, ") no longer owns session sessions/", id, ": ",
      taken ? absl::StrCat("it was taken over by ",
                           holder.empty() ? "no replica yet" : holder)
            : std::string(live ? "its lease changed" : "its lease expired"),
      "; nothing was written. Retry: the session is served again by whichever "
      "replica takes it"));
}

// Takes the session row FOR SHARE and checks that `owner` holds its lease
// under `fence`: OK, NOT_FOUND, or UNAVAILABLE (FencedWriteRefused).
absl::Status CheckLease(pqxx::work& tx, const std::string& id, const std::string& owner,
                        int64_t fence) {
  const pqxx::result rows = tx.exec_params(
      "SELECT 1 FROM sessions WHERE id = $1 AND owner = $2 AND fence = $3 AND "
      "lease_expires > clock_timestamp() FOR SHARE",
      id, owner, fence);
  if (!rows.empty()) return absl::OkStatus();
  return FencedWriteRefused(tx, id, owner, fence);
}

}  // namespace

absl::StatusOr<InsertResult> PostgresStore::InsertSamples(
    const std::string& session_id, int64_t fence,
    const std::vector<SampleRecord>& batch) {
  InsertResult result;
  absl::Status status = connections_->Run([&](pqxx::connection_base& conn) {
    pqxx::work tx(conn);
    if (absl::Status s = CheckLease(tx, session_id, options_.owner, fence); !s.ok()) {
      return s;
    }
    std::set<int64_t> stored;
    if (!batch.empty()) {
      const pqxx::result rows = InsertSampleRows(tx, session_id, batch, 0, batch.size(),
                                                 /*ignore_duplicates=*/true);
      for (const pqxx::row& row : rows) stored.insert(row[0].as<int64_t>());
    }
    tx.commit();
    // The first of several samples with one sequence number is the stored one.
    result = InsertResult();
    for (const SampleRecord& sample : batch) {
      const bool is_new = stored.erase(sample.sequence) > 0;
      result.stored.push_back(is_new);
      ++(is_new ? result.stored_count : result.duplicate_count);
    }
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  return result;
}

absl::Status PostgresStore::SaveModelState(const std::string& session_id, int64_t fence,
                                           const std::string& hyperparameters,
                                           int64_t model_version) {
  return connections_->Run([&](pqxx::connection_base& conn) {
    pqxx::work tx(conn);
    const pqxx::result rows = tx.exec_params(
        "UPDATE sessions SET hyperparameters = $4, model_version = $5 WHERE id = $1 AND "
        "owner = $2 AND fence = $3 AND lease_expires > clock_timestamp() RETURNING 1",
        session_id, options_.owner, fence, pqxx::binarystring(hyperparameters),
        model_version);
    if (rows.empty()) return FencedWriteRefused(tx, session_id, options_.owner, fence);
    tx.commit();
    return absl::OkStatus();
  });
}

absl::Status PostgresStore::DeleteSession(const std::string& id, int64_t fence) {
  return connections_->Run([&](pqxx::connection_base& conn) {
    pqxx::work tx(conn);
    const pqxx::result rows = tx.exec_params(
        "DELETE FROM sessions WHERE id = $1 AND owner = $2 AND fence = $3 AND "
        "lease_expires > clock_timestamp() RETURNING 1",
        id, options_.owner, fence);
    if (rows.empty()) return FencedWriteRefused(tx, id, options_.owner, fence);
    tx.commit();
    return absl::OkStatus();
  });
}

absl::StatusOr<int64_t> PostgresStore::AcquireLease(const std::string& session_id) {
  int64_t fence = 0;
  absl::Status status = connections_->Run([&](pqxx::connection_base& conn) {
    pqxx::work tx(conn);
    // Each statement sees what was committed before it (READ COMMITTED): a lease
    // released between the take and the hand-over request is taken on the next
    // round.
    for (int round = 0; round < 3; ++round) {
      // Ours already: same fence. Free or expired: the next fence, and whatever
      // handoff was asked of the previous owner is void.
      const pqxx::result taken = tx.exec_params(
          absl::StrCat(
              "UPDATE sessions SET fence = CASE WHEN owner = $2 THEN fence ELSE fence + "
              "1 END, handoff_wanted_by = CASE WHEN owner = $2 THEN handoff_wanted_by "
              "ELSE NULL END, owner = $2, lease_expires = ",
              ExpiryIn(3),
              " WHERE id = $1 AND (owner = $2 OR owner IS NULL OR lease_expires IS NULL "
              "OR lease_expires <= clock_timestamp()) RETURNING fence"),
          session_id, options_.owner, options_.lease_ttl.count());
      if (!taken.empty()) {
        fence = taken[0][0].as<int64_t>();
        tx.commit();
        return absl::OkStatus();
      }
      const pqxx::result held = tx.exec_params(
          "UPDATE sessions SET handoff_wanted_by = $2 WHERE id = $1 RETURNING owner, "
          "extract(epoch FROM lease_expires - clock_timestamp())",
          session_id, options_.owner);
      if (held.empty()) return NotFound(session_id);
      if (held[0][0].is_null() || held[0][1].is_null()) continue;  // just released
      tx.commit();
      const double left_s = std::max(0.0, held[0][1].as<double>());
      return absl::UnavailableError(absl::StrFormat(
          "session sessions/%s is served by replica %s (its lease runs %.1f s more "
          "unless renewed; it was asked to hand the session over): retry, through the "
          "proxy that routes the session's calls to one replica",
          session_id, held[0][0].as<std::string>(), left_s));
    }
    return absl::UnavailableError(absl::StrFormat(
        "the lease of session sessions/%s is changing hands: retry", session_id));
  });
  if (!status.ok()) return status;
  return fence;
}

absl::StatusOr<LeaseRenewal> PostgresStore::RenewLeases(
    const std::vector<HeldLease>& held) {
  LeaseRenewal renewal;
  if (held.empty()) return renewal;
  std::vector<std::string> ids;
  std::vector<std::string> fences;
  for (const HeldLease& lease : held) {
    ids.push_back(lease.session_id);
    fences.push_back(absl::StrCat(lease.fence));
  }
  absl::Status status = connections_->Run([&](pqxx::connection_base& conn) {
    pqxx::work tx(conn);
    const pqxx::result rows = tx.exec_params(
        absl::StrCat("UPDATE sessions AS s SET lease_expires = ", ExpiryIn(4),
                     " FROM unnest($2::text[], $3::bigint[]) AS h(id, fence) WHERE "
                     "s.id = h.id AND s.fence = h.fence AND s.owner = $1 RETURNING "
                     "s.id, s.handoff_wanted_by IS NOT NULL"),
        options_.owner, TextArray(ids), TextArray(fences), options_.lease_ttl.count());
    tx.commit();
    std::set<std::string> kept;
    renewal = LeaseRenewal();
    for (const pqxx::row& row : rows) {
      const std::string id = row[0].as<std::string>();
      kept.insert(id);
      if (row[1].as<bool>()) renewal.wanted.push_back(id);
    }
    for (const std::string& id : ids) {
      if (kept.count(id) == 0) renewal.lost.push_back(id);
    }
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  return renewal;
}

absl::Status PostgresStore::ReleaseLease(const std::string& session_id, int64_t fence) {
  return connections_->Run([&](pqxx::connection_base& conn) {
    pqxx::work tx(conn);
    tx.exec_params(
        "UPDATE sessions SET owner = NULL, lease_expires = NULL, handoff_wanted_by = "
        "NULL WHERE id = $1 AND owner = $2 AND fence = $3",
        session_id, options_.owner, fence);
    tx.commit();
    return absl::OkStatus();
  });
}

}  // namespace excite::store
