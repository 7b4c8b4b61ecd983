// common/base/huge_pages.cpp: the replaced operator new asks the kernel for huge pages on large
// blocks. The kernel's own account of the mapping (/proc/self/smaps, VmFlags "hg" is
// MADV_HUGEPAGE) is the check, not anything palp records.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

namespace {

// The VmFlags of the mapping holding `address`, or "" when smaps has none.
std::string vm_flags_at(const void* address) {
  std::ifstream smaps("/proc/self/smaps");
  const auto at = reinterpret_cast<std::uintptr_t>(address);
  std::string line;
  bool inside = false;
  while (std::getline(smaps, line)) {
    std::uintptr_t lo = 0, hi = 0;
    char dash = 0;
    std::istringstream head(line);
    if (head >> std::hex >> lo >> dash >> hi && dash == '-') {
      inside = lo <= at && at < hi;
      continue;
    }
    if (inside && line.rfind("VmFlags:", 0) == 0) return line;
  }
  return "";
}

bool kernel_has_thp() {
  return std::filesystem::exists("/sys/kernel/mm/transparent_hugepage/enabled");
}

TEST(HugePages, ALargeBlockIsAdvisedBeforeUse) {
  if (!kernel_has_thp()) GTEST_SKIP() << "this kernel has no transparent huge pages";
  constexpr std::size_t kBytes = std::size_t{64} << 20;
  const std::unique_ptr<std::uint8_t[]> block(new std::uint8_t[kBytes]);
  // the middle of the block: the advice covers its whole 2 MiB-aligned inside
  const std::string flags = vm_flags_at(block.get() + kBytes / 2);
  ASSERT_FALSE(flags.empty()) << "no mapping found for the block";
  EXPECT_NE(flags.find(" hg"), std::string::npos) << flags;
}

TEST(HugePages, SmallBlocksAreLeftAlone) {
  if (!kernel_has_thp()) GTEST_SKIP() << "this kernel has no transparent huge pages";
  // 6 MiB (under the 8 MiB threshold) is served by its own mapping (above glibc's mmap
  // threshold in a process that set none): nothing asks for huge pages there
  constexpr std::size_t kBytes = std::size_t{6} << 20;
  const std::unique_ptr<std::uint8_t[]> block(new std::uint8_t[kBytes]);
  const std::string flags = vm_flags_at(block.get() + kBytes / 2);
  ASSERT_FALSE(flags.empty()) << "no mapping found for the block";
  EXPECT_EQ(flags.find(" hg"), std::string::npos) << flags;
}

}  // namespace
