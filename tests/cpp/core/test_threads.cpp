// The default thread count follows the machine's load (provenance.hpp): a busy job beside the
// process takes a core from it.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include "mpm/core/provenance.hpp"

namespace pfm {
namespace {

TEST(Threads, CoresLeftByTheBusyJobsAtLeastOne) {
  EXPECT_EQ(threads_for_load(2, 0), 2);
  EXPECT_EQ(threads_for_load(2, 1), 1);
  EXPECT_EQ(threads_for_load(2, 5), 1);
  EXPECT_EQ(threads_for_load(8, 3), 5);
  EXPECT_EQ(threads_for_load(1, 0), 1);
}

// A child that spins is a runnable thread of another process whenever it is looked at (the
// machine's other jobs may add to the count, never take from it).
TEST(Threads, ABusyChildIsCountedAsAnotherRunnableThread) {
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    volatile unsigned long spin = 0;
    for (;;) spin = spin + 1;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const int others = other_runnable_threads();
  kill(child, SIGKILL);
  waitpid(child, nullptr, 0);
  std::printf("runnable threads of other processes with a busy child: %d\n", others);
  EXPECT_GE(others, 1);
}

}  // namespace
}  // namespace pfm
