// Numbers in error messages: 6 significant digits, as Python's "{:g}" prints them, so that
// the messages of the core and of the Python layer read alike.
#pragma once

#include <sstream>
#include <string>

namespace pipeflex {

inline std::string fmt(double x) {
    std::ostringstream os;
    os.precision(6);
    os << x;
    return os.str();
}

}  // namespace pipeflex
