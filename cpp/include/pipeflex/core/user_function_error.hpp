// Failures of a user's function (a Python load function): not convergence failures.
// The solvers pass them on unchanged; IDA's callbacks, which must not throw through
// SUNDIALS, keep the exception and rethrow it once IDASolve has returned.
#pragma once

#include <exception>
#include <stdexcept>

namespace pipeflex {

// The function raised (Python: RuntimeError with its type and message).
class UserFunctionError : public std::runtime_error {
   public:
    using std::runtime_error::runtime_error;
};

// The function returned a value of the wrong shape or not finite (Python: ValueError).
class UserFunctionValueError : public std::invalid_argument {
   public:
    using std::invalid_argument::invalid_argument;
};

inline bool is_user_function_error(const std::exception& e) {
    return dynamic_cast<const UserFunctionError*>(&e) != nullptr ||
           dynamic_cast<const UserFunctionValueError*>(&e) != nullptr;
}

}  // namespace pipeflex
