// read_regular_file: the bytes of a regular file; nothing for no file; DATA_LOSS, at once, for a FIFO
// (whose open(2) would wait for a writer), a directory or a device.
#include "common/regular_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <chrono>
#include <filesystem>
#include <fstream>

#include "support/expect_error.h"
#include "support/process.h"

namespace squall {
namespace {

TEST(RegularFile, ReadsRegularFilesAndRefusesTheRestAtOnce) {
  const std::string dir = test::temp_dir("regular-file");
  std::ofstream(dir + "/plain", std::ios::binary) << std::string("a\0b", 3);
  EXPECT_EQ(read_regular_file(dir + "/plain", "plain").value(), std::string("a\0b", 3));
  EXPECT_FALSE(read_regular_file(dir + "/missing", "missing"));
  EXPECT_FALSE(read_regular_file(dir + "/plain/below", "below")) << "ENOTDIR: nothing there either";
  ASSERT_EQ(::mkfifo((dir + "/fifo").c_str(), 0600), 0);
  const auto start = std::chrono::steady_clock::now();
  test::expect_error(Code::DataLoss, "the fifo: not a regular file",
                     [&] { read_regular_file(dir + "/fifo", "the fifo"); });
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(1)) << "no wait for a writer";
  std::filesystem::create_directory(dir + "/folder");
  test::expect_error(Code::DataLoss, "folder: not a regular file",
                     [&] { read_regular_file(dir + "/folder", "folder"); });
  test::expect_error(Code::DataLoss, "zero: not a regular file", [&] { read_regular_file("/dev/zero", "zero"); });
}

}  // namespace
}  // namespace squall
