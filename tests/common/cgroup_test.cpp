// The control group's limits read from files written as the kernel writes them, in a directory standing for
// /sys/fs/cgroup (cgroup v2's memory.max and cpu.max; v1's memory/ and cpu/ files), and the CPU device's
// threads fitted to a CPU quota. No device.
#include "common/cgroup.h"

#include <gtest/gtest.h>
#include <sched.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>

#include "runtime/cpu_threads.h"
#include "support/process.h"

namespace squall {
namespace {

namespace fs = std::filesystem;

void write(const std::string& path, const std::string& text) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path) << text;
}

TEST(Cgroup, TheCpuQuotaIsTheRunTimeOverThePeriod) {
  const std::string root = test::temp_dir("cgroup_cpu");
  EXPECT_EQ(cgroup_cpu_limit(root), 0.0);  // no files: no quota
  write(root + "/cpu/cpu.cfs_quota_us", "-1\n");
  write(root + "/cpu/cpu.cfs_period_us", "100000\n");
  EXPECT_EQ(cgroup_cpu_limit(root), 0.0);  // version 1's "no limit"
  write(root + "/cpu/cpu.cfs_quota_us", "150000\n");
  EXPECT_DOUBLE_EQ(cgroup_cpu_limit(root), 1.5);
  write(root + "/cpu.max", "max 100000\n");  // version 2's files, where they are, are the ones read
  EXPECT_EQ(cgroup_cpu_limit(root), 0.0);
  write(root + "/cpu.max", "250000 100000\n");
  EXPECT_DOUBLE_EQ(cgroup_cpu_limit(root), 2.5);
  write(root + "/cpu.max", "50000 200000\n");
  EXPECT_DOUBLE_EQ(cgroup_cpu_limit(root), 0.25);
  write(root + "/cpu.max", "garbage 100000\n");
  EXPECT_EQ(cgroup_cpu_limit(root), 0.0);
}

TEST(Cgroup, TheMemoryLimitIsBytesOrNone) {
  const std::string root = test::temp_dir("cgroup_memory");
  EXPECT_EQ(cgroup_memory_limit(root), 0u);
  write(root + "/memory/memory.limit_in_bytes", "9223372036854771712\n");  // version 1's "no limit"
  EXPECT_EQ(cgroup_memory_limit(root), 0u);
  write(root + "/memory/memory.limit_in_bytes", "536870912\n");
  EXPECT_EQ(cgroup_memory_limit(root), 536870912u);
  write(root + "/memory.max", "max\n");  // version 2: no limit there, version 1's is the one
  EXPECT_EQ(cgroup_memory_limit(root), 536870912u);
  write(root + "/memory.max", "1073741824\n");
  EXPECT_EQ(cgroup_memory_limit(root), 1073741824u);
}

TEST(Cgroup, ThreadsWithinAQuotaAreItRoundedUpAndAtMostTheCores) {
  EXPECT_EQ(threads_within(0, 16), 16u);  // no quota
  EXPECT_EQ(threads_within(0.25, 16), 1u);
  EXPECT_EQ(threads_within(2.5, 16), 3u);
  EXPECT_EQ(threads_within(4, 16), 4u);
  EXPECT_EQ(threads_within(64, 16), 16u);
  EXPECT_EQ(threads_within(2.5, 0), 1u);
}

// POCL_MAX_PTHREAD_COUNT as this process's environment has it, put back when the test ends.
class PoclThreadsVariable : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const char* v = std::getenv(kName)) saved_ = v;
    unsetenv(kName);
  }
  void TearDown() override {
    if (saved_)
      setenv(kName, saved_->c_str(), 1);
    else
      unsetenv(kName);
  }
  static constexpr const char* kName = "POCL_MAX_PTHREAD_COUNT";
  std::optional<std::string> saved_;
};

// A quota of one CPU, under the cores this process may run on (two or more in CI), sets PoCL's threads to 1;
// a variable already set is left as it is, and no quota sets nothing.
TEST_F(PoclThreadsVariable, AQuotaBelowTheCoresSetsPoclsThreads) {
  const std::string root = test::temp_dir("cgroup_threads");
  EXPECT_EQ(fit_cpu_threads_to_quota(root), 0u);
  EXPECT_EQ(std::getenv(kName), nullptr);
  write(root + "/cpu.max", "100000 100000\n");
  cpu_set_t mask;
  ASSERT_EQ(sched_getaffinity(0, sizeof mask, &mask), 0);
  ASSERT_GT(CPU_COUNT(&mask), 1) << "one core: no quota is below it";
  EXPECT_EQ(fit_cpu_threads_to_quota(root), 1u);
  ASSERT_NE(std::getenv(kName), nullptr);
  EXPECT_STREQ(std::getenv(kName), "1");
  setenv(kName, "7", 1);
  EXPECT_EQ(fit_cpu_threads_to_quota(root), 0u);
  EXPECT_STREQ(std::getenv(kName), "7");
}

}  // namespace
}  // namespace squall
