// The main of palp's GoogleTest executables: GoogleTest's own, and one more exit code. A run in
// which every test that ran was skipped (GTEST_SKIP: the shared CT absent, no display, no root)
// exits 77, which CTest reports as skipped (SKIP_RETURN_CODE 77); a run in which some passed and
// some were skipped passes, and lists the skipped ones in its output.
#include <gtest/gtest.h>

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  const int status = RUN_ALL_TESTS();
  const ::testing::UnitTest& run = *::testing::UnitTest::GetInstance();
  const bool all_skipped =
      run.test_to_run_count() > 0 && run.skipped_test_count() == run.test_to_run_count();
  return status == 0 && all_skipped ? 77 : status;
}
