#include "pipeflex/solvers/linear_matrices.hpp"

namespace pipeflex {

namespace {
// The n x n block of a KKT tangent's triplets (and, if Cq is given, its constraint rows).
void split(const Triplets& J, int n, Triplets& A, Triplets* Cq) {
    const std::size_t m = J.values.size();  // at most; a large model's regrowth copies cost more than the split
    A.rows.reserve(m);
    A.cols.reserve(m);
    A.values.reserve(m);
    for (std::size_t k = 0; k < J.values.size(); ++k) {
        const int r = J.rows[k], c = J.cols[k];
        if (c >= n) continue;
        if (r < n)
            A.add(r, c, J.values[k]);
        else if (Cq)
            Cq->add(r - n, c, J.values[k]);
    }
}
}  // namespace

LinearMatrices linear_matrices(Equations& eq, const Eigen::VectorXd& v, const Eigen::VectorXd& a,
                               const Eigen::VectorXd& lam, double t, double differences_step) {
    LinearMatrices out;
    out.n = eq.n_coordinates();
    out.nc = eq.n_constraints();
    eq.set_static_load_factor(1.0);
    eq.set(Eigen::VectorXd::Zero(out.n), v, a, lam, t);
    std::vector<Triplets> J;
    eq.tangents({{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}}, J);
    split(J[0], out.n, out.K, &out.Cq);
    split(J[1], out.n, out.C, nullptr);
    split(J[2], out.n, out.M, nullptr);
    if (differences_step > 0.0) out.differences = residual_differences(eq, v, a, lam, t, differences_step);
    return out;
}

Eigen::MatrixXd residual_differences(Equations& eq, const Eigen::VectorXd& v, const Eigen::VectorXd& a,
                                     const Eigen::VectorXd& lam, double t, double h) {
    const int n = eq.n_coordinates(), nc = eq.n_constraints();
    eq.set_static_load_factor(1.0);
    Eigen::MatrixXd D(n + nc, n);
    Eigen::VectorXd z = Eigen::VectorXd::Zero(n), rp, rm;
    for (int j = 0; j < n; ++j) {
        z[j] = h;
        eq.set(z, v, a, lam, t);
        eq.evaluate(1.0, 0.0, 0.0, rp, nullptr);
        z[j] = -h;
        eq.set(z, v, a, lam, t);
        eq.evaluate(1.0, 0.0, 0.0, rm, nullptr);
        z[j] = 0.0;
        D.col(j) = (rp - rm) / (2.0 * h);
    }
    eq.set(z, v, a, lam, t);
    return D;
}

}  // namespace pipeflex
