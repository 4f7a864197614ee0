#include "pipeflex/core/interrupt.hpp"
#include "pipeflex/solvers/equations.hpp"
#include "pipeflex/solvers/sparse_lu.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pipeflex {

namespace {
// a correction this many model sizes long means the tangent is (nearly) singular
constexpr double kDivergence = 10.0;
}  // namespace

StaticNewtonResult static_newton(Equations& eq, double t, Eigen::VectorXd& lam, double tol, int max_iterations) {
    const int n = eq.n_coordinates(), nc = eq.n_constraints();
    const double L = eq.length_scale();
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
    Eigen::VectorXd r, rhs(n + nc), x, v = zero, a = zero;
    Triplets J;
    FixedPatternLU lu(kDenseLuBelow);
    StaticNewtonResult out;
    double last = std::numeric_limits<double>::infinity();
    for (int it = 1; it <= max_iterations; ++it) {
        poll_interrupt();
        eq.set(zero, zero, zero, lam, t);
        eq.evaluate(1.0, 0.0, 0.0, r, &J);
        out.iterations = it;
        out.residual = r.head(n).norm();
        if (!r.allFinite()) return out;
        // constraint rows and columns scaled by the stiffness block's size (as the integrator's)
        double s = scale_constraints(J, n, 1.0);
        s = s > 0.0 ? s : 1.0;
        scale_constraints(J, n, s);
        if (!lu.factorize(n + nc, J.rows, J.cols, J.values)) {
            out.singular = true;
            return out;
        }
        rhs.head(n) = -r.head(n);
        rhs.tail(nc) = -s * r.tail(nc);
        lu.solve(rhs, x);
        if (!x.allFinite()) {
            out.singular = true;
            return out;
        }
        const double size = x.head(n).lpNorm<Eigen::Infinity>();
        const double violation = nc > 0 ? r.tail(nc).lpNorm<Eigen::Infinity>() : 0.0;
        out.correction = size;
        lam += s * x.tail(nc);
        const bool satisfied = violation <= 1e-6 * L;
        // converged: the correction (round-off here) is not applied, so that an exact state,
        // such as a straight pipe under flow, keeps its exact symmetry
        if (satisfied && size <= tol * L) {
            out.converged = true;
            return out;
        }
        if (size > kDivergence * L) {  // a correction beyond the model: a (nearly) singular tangent
            out.diverged = true;
            return out;
        }
        eq.set(x.head(n), zero, zero, lam, t);
        eq.rebase(v, a);
        if (satisfied && size >= 0.5 * last && size <= 1e3 * tol * L) {  // stalled at round-off
            out.converged = true;
            return out;
        }
        last = size;
    }
    return out;
}

}  // namespace pipeflex
