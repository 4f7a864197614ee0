#include "pipeflex/core/interrupt.hpp"
#include "pipeflex/solvers/equations.hpp"
#include "pipeflex/solvers/sparse_lu.hpp"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

namespace pipeflex {

int negative_eigenvalues(const Triplets& J, int n) {
    std::vector<Eigen::Triplet<double>> entries;
    entries.reserve(J.values.size());
    for (size_t k = 0; k < J.values.size(); ++k)
        if (J.rows[k] < n && J.cols[k] < n) entries.emplace_back(J.rows[k], J.cols[k], J.values[k]);
    Eigen::SparseMatrix<double> A(n, n);
    A.setFromTriplets(entries.begin(), entries.end());
    // a non-symmetric tangent (the flow's follower forces) has complex eigenvalues in
    // general, and its symmetric part's inertia says nothing about them
    const Eigen::SparseMatrix<double> At = A.transpose();
    if ((A - At).norm() > 1e-10 * A.norm()) return -1;
    // a symmetric (AMD) permutation and L D L^T: a congruence, so D has the inertia of A
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower> ldlt(A);
    if (ldlt.info() != Eigen::Success) return -1;
    const Eigen::VectorXd d = ldlt.vectorD();
    if (!d.allFinite() || (d.array() == 0.0).any()) return -1;
    return static_cast<int>((d.array() < 0.0).count());
}

FrameGram::FrameGram(const Triplets& J, int n, int nc, const Eigen::VectorXd& w) : C(nc, n) {
    std::vector<Eigen::Triplet<double>> cs;
    for (std::size_t k = 0; k < J.values.size(); ++k)
        if (J.rows[k] >= n && J.cols[k] < n && w[J.cols[k]] != 0.0)
            cs.emplace_back(J.rows[k] - n, J.cols[k], J.values[k]);
    C.setFromTriplets(cs.begin(), cs.end());
    CW = C * w.asDiagonal();
    G = CW * Eigen::SparseMatrix<double>(C.transpose());
    n_shifted = static_cast<int>((w.array() != 0.0).count());
    w_ = w;
}

void FrameGram::factorize() {
    if (factorized_) return;
    factorized_ = true;
    const int nc = static_cast<int>(G.rows());
    if (nc == 0) return;
    double delta = 0.0;
    for (int a = 0; a < nc; ++a) delta = std::max(delta, G.coeff(a, a));
    Eigen::SparseMatrix<double> A = G;
    Eigen::SparseMatrix<double> I(nc, nc);
    I.setIdentity();
    A += (delta > 0.0 ? 1e-12 * delta : 1.0) * I;
    ldlt_.compute(A);
}

int FrameGram::free_motions() {
    factorize();
    if (G.rows() == 0) return n_shifted;
    if (ldlt_.info() != Eigen::Success) return n_shifted;  // not positive: count none as locked
    const Eigen::VectorXd d = ldlt_.vectorD();
    const double top = d.cwiseAbs().maxCoeff();
    const int rank = static_cast<int>((d.array() > 1e-10 * top).count());
    return std::max(0, n_shifted - rank);
}

Eigen::VectorXd FrameGram::free_force(const Eigen::VectorXd& f) {
    factorize();
    Eigen::VectorXd g = (w_.array() != 0.0).select(f, 0.0);
    if (G.rows() == 0 || ldlt_.info() != Eigen::Success) return g;
    // the regularised solve, refined twice against G itself (the regularisation would leave
    // 1e-12 of the reactions in the projection; G's null space is C^T's, so its component of
    // mu does not matter)
    const Eigen::VectorXd b = CW * g;
    Eigen::VectorXd mu = ldlt_.solve(b);
    for (int k = 0; k < 2; ++k) mu += ldlt_.solve(b - G * mu);
    g -= C.transpose() * mu;
    return g;
}

namespace {

// The bordered matrix [K, rt; c^T, d] ((m + 1) x (m + 1), rt and c stored whole so that
// the pattern does not depend on the state) from K's triplets (m x m; with constraints
// the scaled KKT matrix, and rt, c with its constraint rows).
void bordered(const Triplets& K, int m, const Eigen::VectorXd& rt, const Eigen::VectorXd& c, double d, Triplets& A) {
    A = K;
    for (int i = 0; i < m; ++i) {
        A.add(i, m, rt[i]);
        A.add(m, i, c[i]);
    }
    A.add(m, m, d);
}

// A mechanism's regularisation (StaticNewtonOptions::shift) from the frames' Gram matrix
// (FrameGram with w = shift s): the penalty
//     1/2 sum_i w_i (x_i - (C^T nu)_i)^2 + 1/2 delta |nu|^2
// over the shifted coordinates S, with nc more unknowns nu that minimise it: it is
// 1/2 |x_S|^2_W projected off the range of C^T, so it acts on the motions of S that the
// constraints leave free (a hinge's rotation), and not on those they lock, however soft:
// those move the other coordinates too (a body's frame turned against its elastic modes at
// a clamp), and the penalty would slow their Newton. H its Hessian ((n + 2 nc) square: x,
// the multipliers' rows (none), nu); delta (1e-8 of G's largest diagonal) keeps nu
// determined where C's rows are dependent.
Eigen::SparseMatrix<double> mechanism_penalty(const FrameGram& gram, const Eigen::VectorXd& w, double s) {
    const int n = static_cast<int>(w.size()), nc = static_cast<int>(gram.G.rows());
    std::vector<Eigen::Triplet<double>> h;
    double delta = 0.0;
    for (int a = 0; a < nc; ++a) delta = std::max(delta, gram.G.coeff(a, a));
    delta = delta > 0.0 ? 1e-8 * delta : s;
    const int nu = n + nc;
    for (int i = 0; i < n; ++i)
        if (w[i] != 0.0) h.emplace_back(i, i, w[i]);
    for (int j = 0; j < gram.CW.outerSize(); ++j)
        for (Eigen::SparseMatrix<double>::InnerIterator e(gram.CW, j); e; ++e) {
            h.emplace_back(e.col(), nu + e.row(), -e.value());
            h.emplace_back(nu + e.row(), e.col(), -e.value());
        }
    for (int j = 0; j < gram.G.outerSize(); ++j)
        for (Eigen::SparseMatrix<double>::InnerIterator e(gram.G, j); e; ++e)
            h.emplace_back(nu + e.row(), nu + e.col(), e.value());
    for (int a = 0; a < nc; ++a) h.emplace_back(nu + a, nu + a, delta);
    Eigen::SparseMatrix<double> H(nu + nc, nu + nc);
    H.setFromTriplets(h.begin(), h.end());
    return H;
}

// The free motions from a Gram matrix at the state whose residual is r, multipliers lam.
FreeMotions free_motions_of(FrameGram& gram, const Eigen::VectorXd& r, const Eigen::VectorXd& lam) {
    FreeMotions f;
    f.count = gram.free_motions();
    f.force = gram.free_force(r);
    if (lam.size() > 0) f.reaction = (gram.C.transpose() * lam).lpNorm<Eigen::Infinity>();
    return f;
}

// A mechanism's correction: the penalised solve y0 = A^-1 rhs and three more solves with the
// same LU, y_j = A^-1 K y_(j-1) (A = K + H), combined as sum c_j y_j. In a direction of
// stiffness k that the penalty w acts on, A^-1 K is mu = k / (k + w) and the step is
// phi(mu) of Newton's, the error contracting by 1 - phi(mu) per iteration.
//  - kSafeFilter: y3, phi = mu^4: a free motion much softer than the penalty keeps its value
//    to fourth order (loaded or not, as a truncated pseudo-inverse keeps it), one much
//    stiffer converges at the rate 4 w / k; but one of stiffness near w (a chain's sag on
//    spherical joints, stiff through its tension only) crawls (k = 3.3 w: 0.65).
//  - kFastFilter: 4 y2 - 3 y3, phi = 4 mu^3 - 3 mu^4 (a Hermite step: phi(1) = 1,
//    phi'(1) = 0): rate 6 (w / k)^2, 0.24 at k = 3.3 w; a soft free motion keeps its value
//    to third order. Used once the residual on the free motions has fallen below
//    kFastFilterBelow of the force level, and only while the frames have moved less than
//    kFastFilterNear model sizes in this solve (the corrections' sum on S, rotations
//    counted as lengths): a loaded free motion whose stiffness grows as it moves (a
//    pendulum swinging down from the horizontal) would otherwise be walked to a far
//    equilibrium, where a driven mechanism must be refused (a stiff enough free motion
//    converges near: the chain's sag moved its frames by 1e-4 model sizes).
// Both sum to 1, so the correction satisfies the linearised constraints (H's constraint rows
// are zero).
constexpr int kShiftFilterSolves = 4;
constexpr double kSafeFilter[kShiftFilterSolves] = {0.0, 0.0, 0.0, 1.0};
constexpr double kFastFilter[kShiftFilterSolves] = {0.0, 0.0, 4.0, -3.0};
constexpr double kFastFilterBelow = 1e-3;
constexpr double kFastFilterNear = 1e-3;

}  // namespace

FreeMotions free_motions(Equations& eq, double t, const Eigen::VectorXd& lam, const Eigen::VectorXd& w) {
    const int n = eq.n_coordinates(), nc = eq.n_constraints();
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
    Eigen::VectorXd r;
    Triplets J;
    eq.set(zero, zero, zero, lam, t);
    eq.evaluate(1.0, 0.0, 0.0, r, &J);
    FrameGram gram(J, n, nc, w);
    return free_motions_of(gram, r.head(n), lam);
}

StaticNewtonResult static_newton(Equations& eq, double t, Eigen::VectorXd& lam, const StaticNewtonOptions& opt) {
    const int n = eq.n_coordinates(), nc = eq.n_constraints();
    const double L = eq.length_scale(), tol = opt.tol;
    StaticBorder* border = opt.border;
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
    Eigen::VectorXd r, rhs(n + nc), x, y, v = zero, a = zero, rt, rp, c, b;
    // a mechanism's penalty (mechanism_penalty) brings nc more unknowns
    const bool shifted = opt.shift.size() > 0 && border == nullptr;
    const int m = shifted ? n + 2 * nc : n + nc;
    Triplets J, Jb;
    const int dense_below = opt.dense_below < 0 ? kDenseLuBelow : opt.dense_below;
    FixedPatternLU lu(dense_below), lub(dense_below);
    StaticNewtonResult out;
    // the first tangent is the state's own; no prediction outlives the solve (the
    // equations may serve an integrator next)
    struct Forget {
        Equations& eq;
        ~Forget() { eq.predict_stresses(nullptr); }
    } forget{eq};
    eq.predict_stresses(nullptr);
    const bool by_force = opt.force_scale > 0.0;
    double fscale = opt.force_scale;
    // the residual at the state set (its base configuration); false if not finite
    const auto residual_here = [&](Triplets* tangent) {
        eq.set(zero, zero, zero, lam, t);
        eq.evaluate(1.0, 0.0, 0.0, r, tangent);
        out.residual = r.head(n).norm();
        // a norm that overflows is not finite either: inf <= tol * inf must not pass for convergence
        out.nonfinite = !r.allFinite() || !std::isfinite(out.residual);
        return !out.nonfinite;
    };
    const auto constraints_held = [&]() { return nc == 0 || r.tail(nc).lpNorm<Eigen::Infinity>() <= 1e-6 * L; };
    const auto satisfied = [&]() {
        if (border != nullptr) return constraints_held() && std::abs(border->constraint(nullptr, nullptr)) <= tol;
        return constraints_held();
    };
    if (by_force) {  // a warm start: converged already at the model's own force level
        if (!residual_here(nullptr)) return out;
        if (out.residual <= tol * fscale && satisfied()) {
            out.converged = true;
            return out;
        }
    }
    // converged after the correction x was applied: the residual reported is the end state's
    const auto converged_applied = [&]() {
        out.converged = true;
        if (opt.inertia && nc == 0) {
            if (residual_here(&J)) out.negative_end = negative_eigenvalues(J, n);
        } else if (shifted) {  // the free motions at the end state (its Gram matrix)
            if (residual_here(&J)) {
                FrameGram gram(J, n, nc, opt.shift);
                out.free = free_motions_of(gram, r.head(n), lam);
            }
        } else if (opt.apply_converged_correction || border != nullptr) {
            residual_here(nullptr);
        }
        return out;
    };
    double last = std::numeric_limits<double>::infinity();
    bool fast = false;  // a mechanism's correction: kFastFilter rather than kSafeFilter
    Eigen::VectorXd moved = zero;  // the sum of the corrections
    for (int it = 1; it <= opt.max_iterations; ++it) {
        poll_interrupt();
        out.iterations = it;
        if (!residual_here(&J)) return out;
        const double rnorm = out.residual;
        fscale = std::max(fscale, rnorm);
        if (it == 1 && opt.inertia && nc == 0) out.negative_start = negative_eigenvalues(J, n);
        if (border != nullptr) {  // Newton on the bordered system: x = (dz, dlambda / s, dtau)
            const double tau = border->parameter(), h = border->difference_step();
            border->set_parameter(tau + h);
            eq.evaluate(1.0, 0.0, 0.0, rp, nullptr);
            border->set_parameter(tau - h);
            eq.evaluate(1.0, 0.0, 0.0, rt, nullptr);
            border->set_parameter(tau);
            rt = (rp - rt) / (2.0 * h);
            double d = 0.0;
            const double g = border->constraint(&c, &d);
            double s = 1.0;
            if (nc > 0) {  // the constraint rows and columns scaled as the plain path's (dc/dtau too)
                s = scale_constraints(J, n, 1.0);
                s = s > 0.0 ? s : 1.0;
                scale_constraints(J, n, s);
                rt.tail(nc) *= s;
                c.conservativeResizeLike(Eigen::VectorXd::Zero(n + nc));
            }
            double dtau = std::numeric_limits<double>::quiet_NaN();
            if (nc == 0 && !border->bordered_only() && lu.factorize(n, J.rows, J.cols, J.values)) {
                const Eigen::VectorXd mr = -r, mrt = -rt;
                lu.solve(mr, x);
                lu.solve(mrt, b);
                const double den = c.dot(b) + d;
                if (den != 0.0 && std::isfinite(den)) {
                    dtau = -(g + c.dot(x)) / den;
                    x += dtau * b;
                }
            }
            // K singular (or singular by construction), or constraints: the whole bordered
            // matrix, regular at a simple limit point
            if (!std::isfinite(dtau)) {
                const int m = n + nc;
                bordered(J, m, rt, c, d, Jb);
                Eigen::VectorXd rb(m + 1), xb;
                rb.head(n) = -r.head(n);
                rb.segment(n, nc) = -s * r.tail(nc);
                rb[m] = -g;
                if (!lub.factorize(m + 1, Jb.rows, Jb.cols, Jb.values)) {
                    out.singular = true;
                    return out;
                }
                lub.solve(rb, xb);
                x = xb.head(n);
                dtau = xb[m];
                if (nc > 0) lam += s * xb.segment(n, nc);
            }
            if (!x.allFinite() || !std::isfinite(dtau)) {
                out.singular = true;
                return out;
            }
            out.correction = x.lpNorm<Eigen::Infinity>();
            eq.predict_stresses(&x);
            eq.set(x, zero, zero, lam, t);
            eq.rebase(v, a);
            border->accumulate(x, dtau);
            const double size = std::max(out.correction / L, std::abs(dtau) / std::max(1.0, std::abs(border->parameter())));
            // a small correction converges only with the constraints held, as without a border
            if ((size <= tol && constraints_held()) || (rnorm <= 1e-3 * tol * std::max(fscale, 1e-300) && satisfied()))
                return converged_applied();
            if (size >= 0.5 * last && size <= 1e3 * tol && satisfied())  // stalled at round-off
                return converged_applied();
            last = size;
            continue;
        }
        // constraint rows and columns scaled by the stiffness block's size (as the integrator's)
        double s = scale_constraints(J, n, 1.0);
        s = s > 0.0 ? s : 1.0;
        Eigen::SparseMatrix<double> H;
        std::unique_ptr<FrameGram> gram;
        if (shifted) {
            gram = std::make_unique<FrameGram>(J, n, nc, s * opt.shift);
            H = mechanism_penalty(*gram, s * opt.shift, s);
        }
        scale_constraints(J, n, s);
        for (int j = 0; j < H.outerSize(); ++j)
            for (Eigen::SparseMatrix<double>::InnerIterator e(H, j); e; ++e) J.add(e.row(), e.col(), e.value());
        if (!lu.factorize(m, J.rows, J.cols, J.values)) {
            out.singular = true;
            return out;
        }
        rhs = Eigen::VectorXd::Zero(m);
        rhs.head(n) = -r.head(n);
        rhs.segment(n, nc) = -s * r.tail(nc);
        lu.solve(rhs, x);
        if (shifted) {  // the filtered correction (kSafeFilter, kFastFilter)
            // once fast, fast for the rest of the solve (the force on the free motions falls
            // with the error there; one Gram factorisation fewer per iteration)
            fast = fast || gram->free_force(r.head(n)).norm() <= kFastFilterBelow * fscale;
            const bool near =
                (opt.shift.array() != 0.0).select(moved, 0.0).lpNorm<Eigen::Infinity>() <= kFastFilterNear * L;
            const double* c = fast && near ? kFastFilter : kSafeFilter;
            y = c[0] * x;
            for (int k = 1; k < kShiftFilterSolves; ++k) {
                rhs = H * x;
                lu.solve(rhs, b);
                x -= b;
                y += c[k] * x;
            }
            x = y;
        }
        if (!x.allFinite()) {
            out.singular = true;
            return out;
        }
        const double size = x.head(n).lpNorm<Eigen::Infinity>();
        const bool held = satisfied();
        out.correction = size;
        lam += s * x.segment(n, nc);
        const bool small = held && size <= tol * L;
        const bool balanced = by_force && held && (rnorm <= 1e-3 * tol * fscale || rnorm == 0.0);
        // converged: unless asked, the correction (round-off here) is not applied, so that an
        // exact state, such as a straight pipe under flow, keeps its exact symmetry
        if ((small || balanced) && !opt.apply_converged_correction) {
            out.converged = true;
            if (shifted) out.free = free_motions_of(*gram, r.head(n), lam);  // the state is r's
            return out;
        }
        if (!small && !balanced && opt.divergence > 0.0 && it >= opt.divergence_from && size > opt.divergence * L) {
            out.diverged = true;  // a correction beyond the model: a (nearly) singular tangent
            return out;
        }
        if (shifted) moved += x.head(n);
        eq.predict_stresses(&x);
        eq.set(x.head(n), zero, zero, lam, t);
        eq.rebase(v, a);
        if (small || balanced) return converged_applied();
        if (held && size >= 0.5 * last && size <= 1e3 * tol * L)  // stalled at round-off
            return converged_applied();
        last = size;
    }
    return out;
}

}  // namespace pipeflex
