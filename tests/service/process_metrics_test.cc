// The process_* metrics against what the process knows of itself by other means
// (getrusage, getrlimit, descriptors and threads it opens), and excite_build_info.

#include "server/service/process_metrics.h"

#include <fcntl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace excite::service {
namespace {

// name -> value of every single-valued family.
std::map<std::string, double> Values(const prometheus::Collectable& collector) {
  std::map<std::string, double> values;
  for (const prometheus::MetricFamily& family : collector.Collect()) {
    EXPECT_EQ(family.metric.size(), 1u) << family.name;
    const prometheus::ClientMetric& metric = family.metric.front();
    values[family.name] = family.type == prometheus::MetricType::Counter
                              ? metric.counter.value
                              : metric.gauge.value;
  }
  return values;
}

double RusageCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + usage.ru_utime.tv_usec * 1e-6 + usage.ru_stime.tv_sec +
         usage.ru_stime.tv_usec * 1e-6;
}

TEST(ProcessMetricsTest, AgreeWithWhatTheProcessKnowsOfItself) {
  // Some CPU time first, so that the comparison is not 0 against 0: counted in CPU
  // time, since other tests may share the cores.
  volatile double sink = 0;
  while (RusageCpuSeconds() < 0.3) {
    for (int i = 0; i < 100000; ++i) sink = sink + 1;
  }

  ProcessCollector collector;
  const double cpu_before = RusageCpuSeconds();
  std::map<std::string, double> v = Values(collector);
  const double cpu_after = RusageCpuSeconds();
  ASSERT_EQ(v.size(), 7u);
  // /proc counts in clock ticks (10 ms).
  EXPECT_GE(v["process_cpu_seconds_total"], cpu_before - 0.02);
  EXPECT_LE(v["process_cpu_seconds_total"], cpu_after + 0.02);
  EXPECT_GT(v["process_cpu_seconds_total"], 0.2);

  rlimit limit{};
  ASSERT_EQ(getrlimit(RLIMIT_NOFILE, &limit), 0);
  EXPECT_EQ(v["process_max_fds"], static_cast<double>(limit.rlim_cur));

  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  EXPECT_GT(v["process_resident_memory_bytes"], 1 << 20);
  EXPECT_LE(v["process_resident_memory_bytes"], usage.ru_maxrss * 1024.0);  // peak, KiB
  EXPECT_GT(v["process_virtual_memory_bytes"], v["process_resident_memory_bytes"]);

  const double now = static_cast<double>(std::time(nullptr));
  EXPECT_LE(v["process_start_time_seconds"], now + 1);
  EXPECT_GT(v["process_start_time_seconds"], now - 3600);  // this test started lately
}

TEST(ProcessMetricsTest, CountDescriptorsAndThreadsAsTheyComeAndGo) {
  ProcessCollector collector;
  const std::map<std::string, double> before = Values(collector);
  std::vector<int> fds;
  for (int i = 0; i < 3; ++i) fds.push_back(open("/dev/null", O_RDONLY | O_CLOEXEC));
  std::atomic<bool> stop{false};
  std::thread parked([&stop] {
    while (!stop) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  });
  std::map<std::string, double> during = Values(collector);
  stop = true;
  parked.join();
  for (int fd : fds) close(fd);
  std::map<std::string, double> after = Values(collector);

  EXPECT_EQ(during["process_open_fds"] - before.at("process_open_fds"), 3);
  EXPECT_EQ(during["process_threads"] - before.at("process_threads"), 1);
  EXPECT_EQ(after["process_open_fds"], before.at("process_open_fds"));
  EXPECT_EQ(after["process_threads"], before.at("process_threads"));
}

// What git says the source tree's commit is, asked now; "unknown" without git or
// outside a checkout (a tarball, as `git archive` makes).
std::string CheckoutCommit() {
  const std::string command =
      "git -C '" EXCITE_SOURCE_DIR "' rev-parse --short=12 HEAD 2>/dev/null";
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return "unknown";
  char buffer[64] = {};
  const bool read = fgets(buffer, sizeof(buffer), pipe) != nullptr;
  const int status = pclose(pipe);
  std::string commit = read ? std::string(buffer) : "";
  while (!commit.empty() && (commit.back() == '\n' || commit.back() == '\r'))
    commit.pop_back();
  return status == 0 && commit.size() == 12 ? commit : "unknown";
}

TEST(ProcessMetricsTest, BuildInfoNamesTheVersionAndCommit) {
  BuildAndLockCollector collector;
  bool found = false;
  for (const prometheus::MetricFamily& family : collector.Collect()) {
    if (family.name != "excite_build_info") continue;
    found = true;
    ASSERT_EQ(family.metric.size(), 1u);
    EXPECT_EQ(family.metric[0].gauge.value, 1);
    std::map<std::string, std::string> labels;
    for (const auto& label : family.metric[0].label) labels[label.name] = label.value;
    EXPECT_EQ(labels["version"], EXCITE_PROJECT_VERSION);
    EXPECT_EQ(labels["commit"].substr(0, 12), CheckoutCommit());
    EXPECT_THAT(labels["commit"],
                ::testing::MatchesRegex("([0-9a-f]{12}(-dirty)?)|unknown"));
  }
  EXPECT_TRUE(found);
}

}  // namespace
}  // namespace excite::service
