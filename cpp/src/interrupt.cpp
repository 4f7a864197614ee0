#include "pipeflex/core/interrupt.hpp"

namespace pipeflex {
namespace {

InterruptCheck installed = nullptr;
constexpr std::chrono::milliseconds kPollInterval{20};
// A counter in front of the clock: reading the clock on every call would cost more
// than some of the loops that poll.
constexpr int kCallsPerClockRead = 64;

}  // namespace

void set_interrupt_check(InterruptCheck check) { installed = check; }

void poll_interrupt() {
    if (installed == nullptr) return;
    thread_local int calls = 0;
    thread_local auto last = std::chrono::steady_clock::now();
    if (++calls < kCallsPerClockRead) return;
    calls = 0;
    const auto now = std::chrono::steady_clock::now();
    if (now - last < kPollInterval) return;
    last = now;
    if (installed()) throw Interrupted();
}

}  // namespace pipeflex
