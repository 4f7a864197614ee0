// The generalised-alpha flow map of any system and its tangent-linear map.
#include "pipeflex/core/format.hpp"
#include "pipeflex/core/interrupt.hpp"
#include "pipeflex/core/rotation_eigen.hpp"
#include "pipeflex/solvers/element_equations.hpp"
#include "pipeflex/solvers/sparse_lu.hpp"
#include "pipeflex/solvers/system.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace pipeflex {

// The linearisation of one step of the flow map (or of its start): K, C and C_q at the
// converged state, dense below kDenseLuBelow unknowns (where the products with the
// directions are dense anyway), and the step's KKT iteration matrix [S, s C_q^T; s C_q, 0]
// factorised by the integrators' FixedPatternLU. The constraint rows of a step's
// right-hand side are -s q_weight C_q X (the step's end on the constraints: C_q dz' = 0
// with dz' = X + beta' da'; at the start the linearised C_q(q) a0 = 0 of
// initial_acceleration: C_q da0 = -d(C_q a0)/dz dz0, TangentStep::G).
//
// Floating frames (Run::frame_rotations) are re-based every step. Their sensitivities are
// spatial rotation increments dtheta (exp(dtheta~) R), what the equations' left-trivialised
// tangent takes; at a step's end R' = exp(dz'~) R with dz' its chart increment, so
//     dtheta' = T(dz') d(dz') + exp(dz'~) dtheta     (T: the left Jacobian, dexp),
// and the step's matrix has the K and C_q columns of each frame's rotation times T(dz')
// (TangentStep::frames: T and exp per frame). The start maps dz0 -> T(z0) dz0, the end
// dtheta -> T(z)^-1 dtheta (z = log(R R_start^T), the start chart).
struct TangentStep {
    Eigen::MatrixXd Kd, Cd, Qd;
    Eigen::SparseMatrix<double> Ks, Cs, Qs;
    // the start with constraints: d(C_q a0)/dz (initial_acceleration's rows C_q a0 = 0)
    Eigen::SparseMatrix<double> G;
    double q_weight = 0.0, s = 1.0;
    std::shared_ptr<FixedPatternLU> lu;
    std::vector<Eigen::Matrix3d> frames;  // per frame: T(dz'), exp(dz'~) (empty: none)
};

struct FlowMapTangent::Impl {
    int n = 0, nc = 0;
    AlphaMethod m{0.9};
    double h = 0.0;
    bool dense = true;
    std::vector<TangentStep> steps;  // [0]: the start (M, for the initial acceleration)
    std::vector<int> rotations;      // the frames' first rotation coordinates
    std::vector<Eigen::Matrix3d> start_map, end_map;  // per frame: T(z0), T(z_end)^-1
};

int FlowMapTangent::dimension() const { return 2 * impl_->n; }

std::size_t FlowMapTangent::bytes() const {
    std::size_t b = 0;
    for (const auto& s : impl_->steps) {
        b += sizeof(double) * static_cast<std::size_t>(s.Kd.size() + s.Cd.size() + s.Qd.size() + 9 * s.frames.size());
        b += (sizeof(double) + sizeof(int)) * static_cast<std::size_t>(s.G.nonZeros());
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
        if (s.G.nonZeros()) rhs.bottomRows(nc) -= s.s * (s.G * X);
        s.lu->solve(rhs, x);
        out = x.topRows(n);
    };
    const std::size_t nf = T.rotations.size();
    for (std::size_t f = 0; f < nf; ++f) {
        const int c = T.rotations[f];
        Sz.middleRows(c, 3) = T.start_map[f] * Sz.middleRows(c, 3);
    }
    // [M, C_q^T; C_q, 0] [da0; dlam0] = [-(K dz0 + C dv0); -G dz0]
    solve(T.steps.front(), Sz, Sv, Sa);
    Spa = Sa;
    const AlphaMethod& m = T.m;
    const double h = T.h, hh = h * h;
    const double zpa = hh * (0.5 - m.beta) + hh * m.beta * m.c3, za = hh * m.beta * m.c2;
    const double vpa = h * (1.0 - m.gamma) + h * m.gamma * m.c3, va = h * m.gamma * m.c2;
    Eigen::MatrixXd inc;
    for (std::size_t k = 1; k < T.steps.size(); ++k) {
        poll_interrupt();
        const TangentStep& st = T.steps[k];
        Pz = Sz + h * Sv + zpa * Spa + za * Sa;
        for (std::size_t f = 0; f < nf; ++f) {  // dtheta' = T (chart increment) + exp dtheta
            const int c = T.rotations[f];
            inc = h * Sv.middleRows(c, 3) + zpa * Spa.middleRows(c, 3) + za * Sa.middleRows(c, 3);
            Pz.middleRows(c, 3).noalias() = st.frames[2 * f] * inc;
            Pz.middleRows(c, 3).noalias() += st.frames[2 * f + 1] * Sz.middleRows(c, 3);
        }
        Pv = Sv + vpa * Spa + va * Sa;
        solve(st, Pz, Pv, San);
        Spa = m.c1 * San + m.c2 * Sa + m.c3 * Spa;
        Sz = Pz + m.bp(h) * San;
        for (std::size_t f = 0; f < nf; ++f) {
            const int c = T.rotations[f];
            Sz.middleRows(c, 3).noalias() += m.bp(h) * ((st.frames[2 * f] - Eigen::Matrix3d::Identity()) *
                                                         San.middleRows(c, 3));
        }
        Sv = Pv + m.gp(h) * San;
        Sa.swap(San);
    }
    for (std::size_t f = 0; f < nf; ++f) {
        const int c = T.rotations[f];
        Sz.middleRows(c, 3) = T.end_map[f] * Sz.middleRows(c, 3);
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

// The rotation vector of Q (|angle| <= pi).
Eigen::Vector3d rotation_log(const Eigen::Matrix3d& Q) {
    const Eigen::AngleAxisd aa(Eigen::Quaterniond(Q).normalized());
    return aa.angle() * aa.axis();
}

}  // namespace

FlowMapOutput flow_map(System& sys, double mdot, const Eigen::VectorXd& z0, const Eigen::VectorXd& v0, double duration,
                       int n_steps, bool sensitivity, const TransientOptions& options,
                       const TimeTable& load_factor) {
    const int n = sys.n_coordinates(), nc = sys.n_constraints();
    if (z0.size() != n || v0.size() != n)
        throw std::invalid_argument("flow map: z0 and v0 must have " + std::to_string(n) + " entries (the system's "
                                    "coordinates), got " + std::to_string(z0.size()) + " and " +
                                    std::to_string(v0.size()));
    if (!(duration > 0.0) || !std::isfinite(duration) || n_steps < 1)
        throw std::invalid_argument("flow map: duration must be positive and finite and n_steps at least 1");
    Drive drive;  // constant flow; loads at their full value unless a load factor is given
    drive.mass_flow = TimeTable::constant(mdot);
    drive.load_factor = load_factor;
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

    // Floating frames: re-based onto the start z0 and after every step, as integrate does
    // (their rates are spatial, so only a chart at the step's start is exact); the end and
    // the trajectory are mapped back to the start chart: per frame the rotation's log
    // relative to the start frame (Q = exp(z0~), then exp(dz'~) Q per step), the other
    // re-based coordinates summed.
    const std::vector<int> rotations = run->frame_rotations;
    const int fb = run->frames_begin, fe = run->frames_end;
    const bool frames = fe > fb;
    std::vector<Eigen::Matrix3d> Q;
    Eigen::VectorXd zc;  // z in the start chart
    if (frames) {
        for (int c : rotations) Q.push_back(rotation_exp(Eigen::Vector3d(z0.segment<3>(c))));
        zc = z0;
        eq.set(z, v, Eigen::VectorXd::Zero(n), lam, 0.0);
        run->rebase_frames();
        z.segment(fb, fe - fb).setZero();
    }
    const Eigen::VectorXd& zout = frames ? zc : z;
    initial_acceleration(eq, z, v, 0.0, a, lam);
    Eigen::VectorXd pa = a;
    out.a0 = a;
    Eigen::VectorXd an(n), pan(n), zn(n), vn(n), a_prev = a;
    out.z.reserve(static_cast<std::size_t>(n) * (n_steps + 1));
    out.z.insert(out.z.end(), zout.data(), zout.data() + n);

    // The tangent-linear map: each step's linearisation at its converged state, kept for
    // FlowMapTangent::apply.
    std::shared_ptr<FlowMapTangent::Impl> tangent;
    std::shared_ptr<FixedPatternLU> analysed;  // sparse: the KKT matrix's analysed pattern
    std::vector<Triplets> J;
    std::vector<Eigen::Matrix3d> step_frames;  // the step's T(dz'), exp(dz'~) per frame
    std::vector<int> frame_of(frames ? n : 0, -1);
    for (std::size_t f = 0; f < rotations.size(); ++f)
        for (int i = 0; i < 3; ++i) frame_of[rotations[f] + i] = static_cast<int>(f);
    // K, C, C_q and the KKT iteration matrix with weights (wK, wC, 1) at the state set
    auto linearize = [&](double t, double wK, double wC, double q_weight) {
        eq.tangents({{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {wK, wC, 1.0}}, J);
        TangentStep s;
        s.q_weight = q_weight;
        if (frames) {
            // the frames' rotation columns of K (weight wK) and of C_q times T(dz') - I
            // added to the KKT matrix: the same triplet pattern every step (zeros at the start)
            const Triplets& K = J[0];
            Triplets& A = J[2];
            const std::size_t nk = K.values.size();
            for (std::size_t k = 0; k < nk; ++k) {
                const int i = K.rows[k], j = K.cols[k];
                if (j >= n || frame_of[j] < 0) continue;
                const int f = frame_of[j], c = rotations[f];
                const double w = (i < n ? wK : 1.0) * K.values[k];
                for (int l = 0; l < 3; ++l) {
                    const double d = step_frames.empty() ? 0.0 : step_frames[2 * f](j - c, l) - (j - c == l ? 1.0 : 0.0);
                    A.add(i, c + l, w * d);
                }
            }
            s.frames = step_frames;
        }
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
        tangent->rotations = rotations;
        for (int c : rotations) tangent->start_map.push_back(rotation_jacobian(Eigen::Vector3d(z0.segment<3>(c))));
        eq.set(z, v, a, lam, 0.0);
        linearize(0.0, 0.0, 0.0, 0.0);  // [M, C_q^T; C_q, 0] [da0; dlam0] = [-(K dz0 + C dv0); -G dz0]
        if (nc) {
            // G = d(C_q a0)/dz by central differences of the constraint rows' tangent in the
            // coordinates they involve (a second derivative of the constraints, which the
            // equations do not give; its error ~ eps^2 of C_q's curvature)
            std::vector<char> involved(n, 0);
            for (std::size_t k = 0; k < J[0].values.size(); ++k)
                if (J[0].rows[k] >= n && J[0].cols[k] < n) involved[J[0].cols[k]] = 1;
            const double eps = 1e-5 * std::max(1.0, eq.length_scale());
            std::vector<Eigen::Triplet<double>> g;
            Eigen::VectorXd r, zp, cp(nc), cm(nc);
            Triplets Jp;
            for (int j = 0; j < n; ++j) {
                if (!involved[j]) continue;
                for (int sign = 1; sign >= -1; sign -= 2) {
                    zp = z;
                    zp[j] += sign * eps;
                    eq.set(zp, v, a, lam, 0.0);
                    eq.evaluate(1.0, 0.0, 0.0, r, &Jp);
                    Eigen::VectorXd& c = sign > 0 ? cp : cm;
                    c.setZero();
                    for (std::size_t k = 0; k < Jp.values.size(); ++k)
                        if (Jp.rows[k] >= n && Jp.cols[k] < n) c[Jp.rows[k] - n] += Jp.values[k] * a[Jp.cols[k]];
                }
                for (int i = 0; i < nc; ++i) {
                    const double d = (cp[i] - cm[i]) / (2.0 * eps);
                    if (d != 0.0) g.emplace_back(i, j, d);
                }
            }
            TangentStep& s0 = tangent->steps.front();
            s0.G.resize(nc, n);
            s0.G.setFromTriplets(g.begin(), g.end());
            eq.set(z, v, a, lam, 0.0);
        }
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
        if (frames) {
            step_frames.clear();
            for (std::size_t f = 0; f < rotations.size(); ++f) {
                const Eigen::Vector3d dphi = zn.segment<3>(rotations[f]);
                step_frames.push_back(rotation_jacobian(dphi));
                step_frames.push_back(rotation_exp(dphi));
                Q[f] = step_frames.back() * Q[f];
            }
            zc.head(fb) = zn.head(fb);
            zc.segment(fb, fe - fb) += zn.segment(fb, fe - fb);
            zc.tail(n - fe) = zn.tail(n - fe);
            for (std::size_t f = 0; f < rotations.size(); ++f) zc.segment<3>(rotations[f]) = rotation_log(Q[f]);
        }
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
        if (frames) {
            run->rebase_frames();
            z.segment(fb, fe - fb).setZero();
            // the next step starts at z = 0 in the frames' coordinates: Newton's kept
            // matrix is of the old chart, which only its contraction sees
        }
        out.z.insert(out.z.end(), zout.data(), zout.data() + n);
    }
    out.v = v;
    out.a = a;
    out.steps = n_steps;
    out.newton_iterations = stats.newton_iterations;
    out.jacobians += stats.jacobians;
    if (sensitivity) {
        for (std::size_t f = 0; f < rotations.size(); ++f)
            tangent->end_map.push_back(rotation_jacobian(Eigen::Vector3d(zc.segment<3>(rotations[f]))).inverse());
        out.tangent = std::make_shared<FlowMapTangent>(tangent);
    }
    return out;
}

}  // namespace pipeflex
