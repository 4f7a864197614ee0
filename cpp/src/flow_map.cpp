// The generalised-alpha flow map of any system and its tangent-linear map.
#include "pipeflex/core/format.hpp"
#include "pipeflex/core/interrupt.hpp"
#include "pipeflex/solvers/element_equations.hpp"
#include "pipeflex/solvers/sparse_lu.hpp"
#include "pipeflex/solvers/system.hpp"

#include <algorithm>
#include <cmath>

namespace pipeflex {

// The linearisation of one step of the flow map (or of its start): K, C and C_q at the
// converged state, dense below kDenseLuBelow unknowns (where the products with the
// directions are dense anyway), and the step's KKT iteration matrix [S, s C_q^T; s C_q, 0]
// factorised by the integrators' FixedPatternLU. The constraint rows of a step's
// right-hand side are -s q_weight C_q X (the step's end on the constraints: C_q dz' = 0
// with dz' = X + beta' da'; at the start C_q da0 = 0, as initial_acceleration).
struct TangentStep {
    Eigen::MatrixXd Kd, Cd, Qd;
    Eigen::SparseMatrix<double> Ks, Cs, Qs;
    double q_weight = 0.0, s = 1.0;
    std::shared_ptr<FixedPatternLU> lu;
};

struct FlowMapTangent::Impl {
    int n = 0, nc = 0;
    AlphaMethod m{0.9};
    double h = 0.0;
    bool dense = true;
    std::vector<TangentStep> steps;  // [0]: the start (M, for the initial acceleration)
};

int FlowMapTangent::dimension() const { return 2 * impl_->n; }

std::size_t FlowMapTangent::bytes() const {
    std::size_t b = 0;
    for (const auto& s : impl_->steps) {
        b += sizeof(double) * static_cast<std::size_t>(s.Kd.size() + s.Cd.size() + s.Qd.size());
        b += (sizeof(double) + sizeof(int)) *
             static_cast<std::size_t>(s.Ks.nonZeros() + s.Cs.nonZeros() + s.Qs.nonZeros());
        if (s.lu) b += s.lu->bytes();
    }
    return b;
}

Eigen::MatrixXd FlowMapTangent::apply(const Eigen::MatrixXd& directions) const {
    const Impl& T = *impl_;
    const int n = T.n, nc = T.nc;
    if (directions.rows() != 2 * n)
        throw std::invalid_argument("flow map tangent: directions must have " + std::to_string(2 * n) +
                                    " rows (dz0 then dv0), got " + std::to_string(directions.rows()));
    const Eigen::Index p = directions.cols();
    // Sensitivities of (z, v, a, pa) to the directions: n x p each.
    Eigen::MatrixXd Sz = directions.topRows(n), Sv = directions.bottomRows(n);
    Eigen::MatrixXd Sa(n, p), Spa(n, p), Pz(n, p), Pv(n, p), San(n, p), rhs(n + nc, p), x(n + nc, p);
    // out = the first n rows of J^-1 [-(K X + C Y); -s q_weight C_q X] for the step's J
    auto solve = [&](const TangentStep& s, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, Eigen::MatrixXd& out) {
        if (T.dense) {
            rhs.topRows(n).noalias() = -s.Kd * X;
            rhs.topRows(n).noalias() -= s.Cd * Y;
            if (nc) rhs.bottomRows(nc).noalias() = (-s.s * s.q_weight) * (s.Qd * X);
        } else {
            rhs.topRows(n) = -(s.Ks * X + s.Cs * Y);
            if (nc) rhs.bottomRows(nc) = (-s.s * s.q_weight) * (s.Qs * X);
        }
        s.lu->solve(rhs, x);
        out = x.topRows(n);
    };
    solve(T.steps.front(), Sz, Sv, Sa);  // [M, C_q^T; C_q, 0] [da0; dlam0] = [-(K dz0 + C dv0); 0]
    Spa = Sa;
    const AlphaMethod& m = T.m;
    const double h = T.h, hh = h * h;
    const double zpa = hh * (0.5 - m.beta) + hh * m.beta * m.c3, za = hh * m.beta * m.c2;
    const double vpa = h * (1.0 - m.gamma) + h * m.gamma * m.c3, va = h * m.gamma * m.c2;
    for (std::size_t k = 1; k < T.steps.size(); ++k) {
        poll_interrupt();
        Pz = Sz + h * Sv + zpa * Spa + za * Sa;
        Pv = Sv + vpa * Spa + va * Sa;
        solve(T.steps[k], Pz, Pv, San);
        Spa = m.c1 * San + m.c2 * Sa + m.c3 * Spa;
        Sz = Pz + m.bp(h) * San;
        Sv = Pv + m.gp(h) * San;
        Sa.swap(San);
    }
    Eigen::MatrixXd out(2 * n, p);
    out << Sz, Sv;
    return out;
}

namespace {

// The (rows x cols) block at (r0, c0) of triplets (repeats summed), dense.
Eigen::MatrixXd dense_block(const Triplets& J, int r0, int rows, int c0, int cols) {
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(rows, cols);
    for (std::size_t k = 0; k < J.values.size(); ++k) {
        const int i = J.rows[k] - r0, j = J.cols[k] - c0;
        if (i >= 0 && i < rows && j >= 0 && j < cols) A(i, j) += J.values[k];
    }
    return A;
}

// The (rows x cols) block at (r0, c0) of triplets (repeats summed), sparse.
Eigen::SparseMatrix<double> block(const Triplets& J, int r0, int rows, int c0, int cols) {
    std::vector<Eigen::Triplet<double>> t;
    t.reserve(J.values.size());
    for (std::size_t k = 0; k < J.values.size(); ++k) {
        const int i = J.rows[k] - r0, j = J.cols[k] - c0;
        if (i >= 0 && i < rows && j >= 0 && j < cols) t.emplace_back(i, j, J.values[k]);
    }
    Eigen::SparseMatrix<double> A(rows, cols);
    A.setFromTriplets(t.begin(), t.end());
    return A;
}

}  // namespace

FlowMapOutput flow_map(System& sys, double mdot, const Eigen::VectorXd& z0, const Eigen::VectorXd& v0, double duration,
                       int n_steps, bool sensitivity, const TransientOptions& options) {
    const int n = sys.n_coordinates(), nc = sys.n_constraints();
    if (z0.size() != n || v0.size() != n)
        throw std::invalid_argument("flow map: z0 and v0 must have " + std::to_string(n) + " entries (the system's "
                                    "coordinates), got " + std::to_string(z0.size()) + " and " +
                                    std::to_string(v0.size()));
    if (!(duration > 0.0) || !std::isfinite(duration) || n_steps < 1)
        throw std::invalid_argument("flow map: duration must be positive and finite and n_steps at least 1");
    Drive drive;  // autonomous: constant flow, loads at their full value
    drive.mass_flow = TimeTable::constant(mdot);
    drive.options = options;
    drive.options.work = false;
    const std::unique_ptr<Run> run = sys.start(drive, System::Mode::fixed_chart);
    Equations& eq = run->equations();
    const AlphaOptions aopt = alpha_options(drive.options);
    const AlphaMethod m(aopt.rho_inf);
    const double h = duration / n_steps;

    FlowMapOutput out;
    Eigen::VectorXd z = z0, v = v0;
    Eigen::VectorXd a, lam = run->lam;
    initial_acceleration(eq, z, v, 0.0, a, lam);
    Eigen::VectorXd pa = a;
    out.a0 = a;
    Eigen::VectorXd an(n), pan(n), zn(n), vn(n), a_prev = a;
    out.z.reserve(static_cast<std::size_t>(n) * (n_steps + 1));
    out.z.insert(out.z.end(), z.data(), z.data() + n);

    // The tangent-linear map: each step's linearisation at its converged state, kept for
    // FlowMapTangent::apply.
    std::shared_ptr<FlowMapTangent::Impl> tangent;
    std::shared_ptr<FixedPatternLU> analysed;  // sparse: the KKT matrix's analysed pattern
    std::vector<Triplets> J;
    // K, C, C_q and the KKT iteration matrix with weights (wK, wC, 1) at the state set
    auto linearize = [&](double t, double wK, double wC, double q_weight) {
        eq.tangents({{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {wK, wC, 1.0}}, J);
        TangentStep s;
        s.q_weight = q_weight;
        if (nc) {  // pivoting sees comparable entries
            const double size = scale_constraints(J[2], n, 1.0);
            s.s = size > 0.0 ? size : 1.0;
            scale_constraints(J[2], n, s.s);
        }
        bool ok;
        if (tangent->dense) {
            s.Kd = dense_block(J[0], 0, n, 0, n);
            s.Cd = dense_block(J[1], 0, n, 0, n);
            if (nc) s.Qd = dense_block(J[0], n, nc, 0, n);
            s.lu = std::make_shared<FixedPatternLU>(kDenseLuBelow);
            ok = s.lu->factorize_dense(dense_block(J[2], 0, n + nc, 0, n + nc));
        } else {
            s.Ks = block(J[0], 0, n, 0, n);
            s.Cs = block(J[1], 0, n, 0, n);
            if (nc) s.Qs = block(J[0], n, nc, 0, n);
            // each step's factorisation is kept: a copy of the LU analysed on the KKT
            // pattern (banded for a chain of elements) takes the step's values
            if (!analysed) {
                analysed = std::make_shared<FixedPatternLU>(kDenseLuBelow);
                analysed->analyze(n + nc, J[2].rows, J[2].cols);
            }
            s.lu = std::make_shared<FixedPatternLU>(*analysed);
            ok = s.lu->factorize(n + nc, J[2].rows, J[2].cols, J[2].values);
            s.lu->keep_factors_only();
        }
        if (!ok) throw SingularMatrixError("flow map: singular tangent at t = " + fmt(t) + " s", ConvergenceError::Where{});
        ++out.jacobians;
        tangent->steps.push_back(std::move(s));
    };
    if (sensitivity) {
        tangent = std::make_shared<FlowMapTangent::Impl>();
        tangent->n = n;
        tangent->nc = nc;
        tangent->m = m;
        tangent->h = h;
        tangent->dense = n + nc < kDenseLuBelow;
        tangent->steps.reserve(static_cast<std::size_t>(n_steps) + 1);
        eq.set(z, v, a, lam, 0.0);
        linearize(0.0, 0.0, 0.0, 0.0);  // [M, C_q^T; C_q, 0] [da0; dlam0] = [-(K dz0 + C dv0); 0]
    }

    AlphaNewton newton(eq, m, aopt);
    AlphaStats stats;
    double t = 0.0;
    for (int k = 0; k < n_steps; ++k) {
        poll_interrupt();
        // the extrapolated predictor, or the constant one if Newton fails from it (stiff
        // modes make the acceleration history rough); the converged step is the same
        an = k > 0 ? Eigen::VectorXd(2.0 * a - a_prev) : a;
        AlphaNewton::Failure failure;
        Eigen::VectorXd lam_start = lam;
        bool ok = newton.solve(t, h, z, v, a, pa, an, pan, zn, vn, lam, stats, failure);
        if (!ok && k > 0) {
            an = a;
            lam = lam_start;
            ok = newton.solve(t, h, z, v, a, pa, an, pan, zn, vn, lam, stats, failure);
        }
        if (!ok) throw_newton_failure(eq, t, h, failure);
        const double tn = t + h;
        if (sensitivity) {
            // the exact iteration matrix at the converged state
            eq.set(zn, vn, an, lam, tn);
            linearize(tn, m.bp(h), m.gp(h), 1.0 / m.bp(h));
        }
        a_prev = a;
        z = zn;
        v = vn;
        a = an;
        pa = pan;
        t = tn;
        eq.set(z, v, a, lam, t);
        eq.accept(t, h);  // throws if the motion left the model's domain
        out.z.insert(out.z.end(), z.data(), z.data() + n);
    }
    out.v = v;
    out.a = a;
    out.steps = n_steps;
    out.newton_iterations = stats.newton_iterations;
    out.jacobians += stats.jacobians;
    if (sensitivity) out.tangent = std::make_shared<FlowMapTangent>(tangent);
    return out;
}

}  // namespace pipeflex
