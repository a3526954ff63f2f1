#include "server/service/process_metrics.h"

#include <dirent.h>
#include <sys/resource.h>
#include <unistd.h>

#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <utility>

#include "absl/strings/numbers.h"
#include "absl/strings/str_split.h"
#include "absl/strings/string_view.h"
#include "common/build_info.h"
#include "server/plan/ipopt_library_calls.h"

namespace excite::service {
namespace {

std::optional<std::string> ReadFile(const char* path) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The fields of /proc/self/stat after the command name, which may hold spaces
// and parentheses: fields[0] is field 3 (state) of proc(5).
std::vector<std::string> StatFieldsAfterName() {
  std::optional<std::string> stat = ReadFile("/proc/self/stat");
  if (!stat) return {};
  const size_t name_end = stat->rfind(')');
  if (name_end == std::string::npos) return {};
  return absl::StrSplit(absl::string_view(*stat).substr(name_end + 1), ' ',
                        absl::SkipEmpty());
}

// Field `number` of proc(5)'s /proc/[pid]/stat (1-based), if present and numeric.
std::optional<double> StatField(const std::vector<std::string>& fields, int number) {
  const size_t index = static_cast<size_t>(number - 3);
  double value = 0;
  if (index >= fields.size() || !absl::SimpleAtod(fields[index], &value)) {
    return std::nullopt;
  }
  return value;
}

// Seconds since the epoch at boot (/proc/stat's btime).
std::optional<double> BootTime() {
  std::optional<std::string> stat = ReadFile("/proc/stat");
  if (!stat) return std::nullopt;
  for (absl::string_view line : absl::StrSplit(*stat, '\n')) {
    if (absl::ConsumePrefix(&line, "btime ")) {
      double value = 0;
      if (absl::SimpleAtod(line, &value)) return value;
    }
  }
  return std::nullopt;
}

std::optional<double> OpenFds() {
  DIR* dir = opendir("/proc/self/fd");
  if (dir == nullptr) return std::nullopt;
  double count = 0;
  while (const dirent* entry = readdir(dir)) {
    if (entry->d_name[0] != '.') ++count;
  }
  closedir(dir);
  return count - 1;  // the directory stream's own descriptor
}

void Add(std::vector<prometheus::MetricFamily>* families, const char* name,
         const char* help, prometheus::MetricType type, std::optional<double> value) {
  if (!value) return;
  prometheus::MetricFamily family;
  family.name = name;
  family.help = help;
  family.type = type;
  prometheus::ClientMetric& metric = family.metric.emplace_back();
  if (type == prometheus::MetricType::Counter) {
    metric.counter.value = *value;
  } else {
    metric.gauge.value = *value;
  }
  families->push_back(std::move(family));
}

}  // namespace

std::vector<prometheus::MetricFamily> ProcessCollector::Collect() const {
  using prometheus::MetricType;
  const std::vector<std::string> stat = StatFieldsAfterName();
  const double ticks = static_cast<double>(sysconf(_SC_CLK_TCK));
  const double page = static_cast<double>(sysconf(_SC_PAGESIZE));
  std::optional<double> cpu;
  if (auto user = StatField(stat, 14), system = StatField(stat, 15); user && system) {
    cpu = (*user + *system) / ticks;
  }
  std::optional<double> start;
  if (auto boot = BootTime(), since_boot = StatField(stat, 22); boot && since_boot) {
    start = *boot + *since_boot / ticks;
  }
  std::optional<double> rss = StatField(stat, 24);
  if (rss) *rss *= page;
  std::optional<double> max_fds;
  if (rlimit limit{};
      getrlimit(RLIMIT_NOFILE, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY) {
    max_fds = static_cast<double>(limit.rlim_cur);
  }

  std::vector<prometheus::MetricFamily> families;
  Add(&families, "process_cpu_seconds_total", "User and system CPU time spent, seconds.",
      MetricType::Counter, cpu);
  Add(&families, "process_resident_memory_bytes", "Resident memory size in bytes.",
      MetricType::Gauge, rss);
  Add(&families, "process_virtual_memory_bytes", "Virtual memory size in bytes.",
      MetricType::Gauge, StatField(stat, 23));
  Add(&families, "process_start_time_seconds",
      "Start time of the process since the Unix epoch, seconds.", MetricType::Gauge,
      start);
  Add(&families, "process_open_fds", "Open file descriptors.", MetricType::Gauge,
      OpenFds());
  Add(&families, "process_max_fds", "Limit of open file descriptors.", MetricType::Gauge,
      max_fds);
  Add(&families, "process_threads", "Threads of the process.", MetricType::Gauge,
      StatField(stat, 20));
  return families;
}

std::vector<prometheus::MetricFamily> BuildAndLockCollector::Collect() const {
  using prometheus::MetricType;
  std::vector<prometheus::MetricFamily> families;
  prometheus::MetricFamily info;
  info.name = "excite_build_info";
  info.help = "Always 1; the labels say which build is running.";
  info.type = MetricType::Gauge;
  prometheus::ClientMetric& metric = info.metric.emplace_back();
  metric.label = {{"commit", BuildCommit()}, {"version", BuildVersion()}};  // by name
  metric.gauge.value = 1;
  families.push_back(std::move(info));

  const plan::MumpsLockTotals lock = plan::ReadMumpsLockTotals();
  Add(&families, "excite_mumps_lock_acquisitions_total",
      "Calls of Ipopt's solves into MUMPS, each under the lock of the copy of MUMPS "
      "its instance runs on.",
      MetricType::Counter, static_cast<double>(lock.acquisitions));
  Add(&families, "excite_mumps_lock_wait_seconds_total",
      "Time MUMPS calls waited for their copy's lock, summed over calls.",
      MetricType::Counter, lock.wait_seconds);
  Add(&families, "excite_mumps_lock_held_seconds_total",
      "Time spent inside MUMPS, summed over its copies; its rate is the cores "
      "planning spends in MUMPS.",
      MetricType::Counter, lock.held_seconds);
  Add(&families, "excite_mumps_copies",
      "Copies of MUMPS loaded (the process's own and one per further concurrent "
      "solve, at most 8); solves on different copies factorise in parallel.",
      MetricType::Gauge, static_cast<double>(lock.copies));
  return families;
}

}  // namespace excite::service
