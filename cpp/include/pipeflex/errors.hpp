// Typed solver failures, translated by the bindings to pipeflex.errors.ConvergenceError
// and SingularMatrixError with these fields as attributes (NaN / -1: not known -> None).
// Input errors are std::invalid_argument (ValueError in Python).
#pragma once

#include <limits>
#include <stdexcept>
#include <string>

namespace pipeflex {

class ConvergenceError : public std::runtime_error {
   public:
    static constexpr double unknown = std::numeric_limits<double>::quiet_NaN();

    struct Where {
        double time = unknown;         // simulated time t [s] of the failure
        int iteration = -1;            // Newton iterations done when it failed
        double residual = unknown;     // residual norm at the failure [N]
        double load_factor = unknown;  // [-]
        double mass_flow = unknown;    // mdot [kg/s]
    };

    ConvergenceError(const std::string& message, const Where& where)
        : std::runtime_error(message), where(where) {}

    Where where;
};

// The iteration matrix (or the mass matrix) could not be factorised.
class SingularMatrixError : public ConvergenceError {
   public:
    using ConvergenceError::ConvergenceError;
};

}  // namespace pipeflex
