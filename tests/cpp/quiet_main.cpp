// The tests' main: GoogleTest's, except that what a test writes to its standard output and
// error (the figures it measured, for a reader chasing a failure) is held back and shown only
// when the test fails, or always with PFM_TEST_VERBOSE=1. A test that passes prints nothing but
// GoogleTest's own lines. Under the sanitizers a report that ends the process is shown with
// what the test had written before it.
#include <gtest/gtest.h>
#include <unistd.h>
#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/common_interface_defs.h>
#endif

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>

namespace {

class HoldOutput : public testing::EmptyTestEventListener {
 public:
  HoldOutput() { instance_ = this; }
  /// A sanitizer's report (written to the held stderr) ends the process before OnTestEnd: the
  /// held file goes to the real stderr first, the report with what the test had written (its
  /// output still buffered in stdio after the report).
  static void release_on_death() {
    const HoldOutput* self = instance_;
    if (self == nullptr || self->held_ == nullptr || self->saved_err_ < 0) return;
    flush();
    const int held = fileno(self->held_);
    if (lseek(held, 0, SEEK_SET) < 0) return;
    char buffer[4096];
    ssize_t n = 0;
    while ((n = read(held, buffer, sizeof buffer)) > 0) {
      if (write(self->saved_err_, buffer, static_cast<std::size_t>(n)) < 0) return;
    }
  }
  // GoogleTest calls the listeners in order at a test's start and in reverse order at its end:
  // its printer's "[ RUN ]" comes before the hold, its "[ OK ]" after the release.
  void OnTestStart(const testing::TestInfo&) override {
    flush();
    held_ = std::tmpfile();
    if (held_ == nullptr) return;  // no temporary file: the output goes through
    saved_out_ = dup(STDOUT_FILENO);
    saved_err_ = dup(STDERR_FILENO);
    if (saved_out_ < 0 || saved_err_ < 0 || dup2(fileno(held_), STDOUT_FILENO) < 0 ||
        dup2(fileno(held_), STDERR_FILENO) < 0) {
      restore();
    }
  }
  void OnTestEnd(const testing::TestInfo& info) override {
    if (held_ == nullptr) return;
    flush();
    std::FILE* held = held_;
    held_ = nullptr;
    restore_descriptors();
    if (info.result()->Failed()) {
      std::rewind(held);
      char buffer[4096];
      std::size_t n = 0;
      while ((n = std::fread(buffer, 1, sizeof buffer, held)) > 0)
        std::fwrite(buffer, 1, n, stdout);
      std::fflush(stdout);
    }
    std::fclose(held);
  }

 private:
  static void flush() {
    std::cout.flush();
    std::cerr.flush();
    std::fflush(stdout);
    std::fflush(stderr);
  }
  void restore_descriptors() {
    if (saved_out_ >= 0) {
      dup2(saved_out_, STDOUT_FILENO);
      close(saved_out_);
    }
    if (saved_err_ >= 0) {
      dup2(saved_err_, STDERR_FILENO);
      close(saved_err_);
    }
    saved_out_ = saved_err_ = -1;
  }
  void restore() {
    restore_descriptors();
    std::fclose(held_);
    held_ = nullptr;
  }
  std::FILE* held_ = nullptr;
  int saved_out_ = -1, saved_err_ = -1;
  static inline const HoldOutput* instance_ = nullptr;
};

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  const char* verbose = std::getenv("PFM_TEST_VERBOSE");
  if (verbose == nullptr || std::string(verbose).empty() || std::string(verbose) == "0") {
    testing::UnitTest::GetInstance()->listeners().Append(new HoldOutput);
#if defined(__SANITIZE_ADDRESS__)
    __sanitizer_set_death_callback(&HoldOutput::release_on_death);
#endif
  }
  return RUN_ALL_TESTS();
}
