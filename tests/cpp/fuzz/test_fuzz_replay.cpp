// Replays every fuzz corpus and regression input (tests/fuzz/corpus/<target>/,
// tests/fuzz/regressions/<target>/) through the same harness the libFuzzer targets use: a reader
// must accept the input or reject it with pfm::InputError, within a time bound.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <exception>
#include <filesystem>
#include <ostream>
#include <string>
#include <typeinfo>
#include <vector>

#include "fuzz_harness.hpp"

namespace pfm::fuzz {

// Test names show the target ("GetParam() = case"), not its bytes.
void PrintTo(Target target, std::ostream* os) {
  *os << target_name(target);
}

namespace {

namespace fs = std::filesystem;

// A reader takes well under a millisecond on these inputs (at most a few kB each); libFuzzer
// calls an input a hang after 10 s. 2 s leaves room for a sanitizer build on a loaded machine.
constexpr double kBoundSeconds = 2.0;

std::vector<fs::path> inputs_of(const fs::path& dir) {
  std::vector<fs::path> files;
  if (!fs::is_directory(dir)) return files;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.is_regular_file() && entry.path().filename().string()[0] != '.') {
      files.push_back(entry.path());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

struct Tally {
  int accepted = 0, rejected = 0;
};

// Runs every input of `dir`; each failure names the file.
Tally replay(Target target, const fs::path& dir) {
  Tally tally;
  for (const fs::path& file : inputs_of(dir)) {
    const auto start = std::chrono::steady_clock::now();
    try {
      (run_file(target, file.string()) == Outcome::kAccepted ? tally.accepted : tally.rejected)++;
    } catch (const std::exception& e) {
      ADD_FAILURE() << file << ": escaped the reader: " << typeid(e).name() << ": " << e.what();
    } catch (...) {
      ADD_FAILURE() << file << ": a non-std exception escaped the reader";
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LT(seconds, kBoundSeconds) << file;
  }
  return tally;
}

class FuzzReplay : public testing::TestWithParam<Target> {};

TEST_P(FuzzReplay, CorpusAndRegressionsAreAcceptedOrRejectedWithInputError) {
  const fs::path root = fs::path(PFM_SOURCE_DIR) / "tests" / "fuzz";
  const Target target = GetParam();
  const fs::path corpus = root / "corpus" / target_name(target);
  const fs::path regressions = root / "regressions" / target_name(target);
  ASSERT_GE(inputs_of(corpus).size(), 10u) << corpus << " holds too few inputs";
  const Tally c = replay(target, corpus);
  const Tally r = replay(target, regressions);
  // The corpus must reach past the readers' first checks: some inputs are valid.
  EXPECT_GT(c.accepted, 0) << corpus << ": no input is accepted";
  EXPECT_GT(c.rejected, 0) << corpus << ": no input is rejected";
  RecordProperty("corpus_accepted", c.accepted);
  RecordProperty("corpus_rejected", c.rejected);
  RecordProperty("regressions", r.accepted + r.rejected);
}

INSTANTIATE_TEST_SUITE_P(Readers, FuzzReplay, testing::ValuesIn(kAllTargets),
                         [](const testing::TestParamInfo<Target>& param) {
                           std::string name = target_name(param.param);
                           name.erase(std::remove(name.begin(), name.end(), '_'), name.end());
                           return name;
                         });

}  // namespace
}  // namespace pfm::fuzz
