// Cooperative interruption of long loops (Ctrl-C). The core knows nothing of Python:
// the bindings install a check (PyErr_CheckSignals) and translate Interrupted into the
// pending KeyboardInterrupt. Loops call poll_interrupt() as often as they like; the
// check itself runs at most every kPollInterval so it costs nothing measurable.
#pragma once

#include <chrono>
#include <stdexcept>

namespace pipeflex {

class Interrupted : public std::runtime_error {
   public:
    Interrupted() : std::runtime_error("interrupted") {}
};

using InterruptCheck = bool (*)();  // true: stop now

void set_interrupt_check(InterruptCheck check);

// Throws Interrupted when the installed check reports an interrupt.
void poll_interrupt();

}  // namespace pipeflex
