#include "pipeflex/solvers/equations.hpp"

#include "pipeflex/core/format.hpp"
#include "pipeflex/core/interrupt.hpp"
#include "pipeflex/errors.hpp"
#include "pipeflex/solvers/sparse_lu.hpp"

#include <Eigen/QR>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace pipeflex {

namespace {

// Largest constrained system whose singular start is solved densely (minimum norm).
constexpr int kDenseMinimumNormLimit = 4000;
// How much closer (on the last step) a predictor must be than the extrapolation to replace it.
constexpr double kPredictorMargin = 4.0;
// Step size control (error_rate > 0): the error of a step in tolerances (error_rate h) is
// O(h^2), so the step that meets it is h (1 / err)^(1/2), taken with a safety factor. A
// new step costs a new iteration matrix (modified Newton keeps one per step size), so the
// step grows only when it can grow by kGrowMin at least, and by kGrowMax at most; a
// rejected step shrinks by kShrinkMax at most.
constexpr double kSafety = 0.8, kGrowMin = 1.5, kGrowMax = 2.0, kShrinkMax = 0.2;
// Newton's share of a controlled step's error tolerance: the position error it leaves
// (at most newton_tol) is at most this fraction of the step's error_rate h, so that Newton
// neither over-solves nor adds noise to the accelerations the error estimate differences
// (noise ~ |beta - 1/6| / beta of it, 0.57 at rho_inf 0.6). On the peer's scene at rtol
// 1e-4 (rho_inf 0.6, the error per step): 1.31 Newton iterations per step at 0.3 (2191
// steps, 8.4e-5 m), 1.19 at 1 (2113, 9.1e-5 m; 0.93 of the instructions), at 3 and 10 the
// estimate's noise adds steps (2272, 2278); per unit step it was 1.6 at 0.1, 1.2 at 0.3 and 1.
// With the error per step the step's budget is error_rate h_mean; Newton is held to the
// step's own h, the stricter where steps are short (h_mean instead: no change measured).
constexpr double kNewtonShare = 1.0;
// ... with constraints (index 3): the constraints' violation Newton leaves (up to its
// tolerance) is corrected entirely by the next step, as violation / (beta h^2) in its
// acceleration, which the error estimate counts at |beta - 1/6| / beta share h_last / h
// (0.46-0.57): a retry after a rejection, at a step cut below about half the share of the
// last one, is rejected again by the last step's Newton error alone, and the step
// collapses (the FFRF cantilever of 8 bodies at rtol 1e-3, rho_inf 0.8, the estimate
// filtered as in local_error: at 0.3 its step fell to 1e-12 s at 0.66 s; at 0.03 3341
// steps, none below 5e-5 s). A tenth of the share keeps a retry at kShrinkMax of the
// last step below 0.09 of its tolerance.
constexpr double kConstrainedNewtonShare = 0.03;
// With the error per step, a correction more than this factor larger than the last (from
// the third on) ends the step as a Newton failure (halved): iterations that wander do not
// converge, they may land within the tolerance by chance. The rigid sprinkler at rtol 3e-2
// (steps of 16 ms, Newton's cap 1e-6 binding) accepted such steps after 8-11 corrections
// that rose and fell by 40x, up to 540 tolerances off (its tip 0.13 m off; 6.4e-4 m with
// this rule and kNewtonMemory); the peer's scene never meets it (bit for bit).
constexpr double kWanderingRate = 2.0;
// After a Newton failure (error control) the next steps stay below 0.9 of the failed step,
// a cap relaxed by this factor per accepted step: growing straight back to the step Newton
// failed at cycles grow - fail - halve (seed 000's fluttering 8-element cantilever at rtol
// 3e-3 with the wandering rule alone: 1160 failures, 3.3x the time; with this memory 60
// failures, the time unchanged; 1.02 instead: 306 failures, +30 %).
constexpr double kNewtonMemory = 1.005;
// A given step (AlphaOptions::steps) within this fraction of the time left to the output
// time ends there: the sum of a recorded mesh's steps meets its output times to round-off.
constexpr double kMeshRoundOff = 1e-6;

}  // namespace

double scale_constraints(Triplets& J, int n, double s) {
    double size = 0.0;
    for (std::size_t k = 0; k < J.values.size(); ++k) {
        const bool cr = J.rows[k] >= n, cc = J.cols[k] >= n;
        if (cr != cc)
            J.values[k] *= s;
        else if (!cr)
            size = std::max(size, std::abs(J.values[k]));
    }
    return size;
}

// ----------------------------------------------------------------- Newton -------------

struct AlphaNewton::Impl {
    Impl(Equations& e, const AlphaMethod& m, const AlphaOptions& o)
        : eq(e), method(m), opt(o), n(e.n_coordinates()), nc(e.n_constraints()), lu(kDenseLuBelow, true), r(n + nc),
          x(n + nc), dz(n), policy(e.refresh_policy()), tol(o.newton_tol) {}

    // rate / (1 - rate) of the modified Newton iteration; pessimistic until measured
    static constexpr double kUnknownContraction = 20.0, kMinContraction = 0.1;
    static constexpr int kShortLife = 1;  // steps (see solve)
    Equations& eq;
    const AlphaMethod& method;
    const AlphaOptions& opt;
    int n, nc;
    FixedPatternLU lu;
    bool fresh = false;  // is lu the iteration matrix for the current step size?
    bool stale = false;  // refresh at the next step (this one was long)
    bool rough = false;  // see set_rough_prediction
    double lu_step = -1.0, contraction = kUnknownContraction, scale = 1.0;
    Triplets J;
    Eigen::VectorXd r, x, dz;
    Equations::RefreshPolicy policy;
    double tol;  // newton_tol in force
    // the contraction was measured in the step whose matrix this is (see solve)
    bool rate_of_fresh_matrix = false;
    int age = 0;        // steps completed with the matrix
    int last_life = 0;  // ... with the one before it
};

AlphaNewton::AlphaNewton(Equations& eq, const AlphaMethod& m, const AlphaOptions& opt)
    : impl_(new Impl(eq, m, opt)) {}
AlphaNewton::~AlphaNewton() { delete impl_; }
void AlphaNewton::invalidate() { impl_->fresh = false; }
void AlphaNewton::set_rough_prediction(bool rough) { impl_->rough = rough; }
void AlphaNewton::set_tolerance(double newton_tol) { impl_->tol = newton_tol; }
void AlphaNewton::lengthen_long_step(int extra) { impl_->policy.long_step += extra; }

bool AlphaNewton::filter(Eigen::VectorXd& b) {
    Impl& s = *impl_;
    if (!(s.lu_step > 0.0) || b.size() != s.n) return false;
    s.r.head(s.n) = b;
    s.r.tail(s.nc).setZero();
    s.lu.solve(s.r, s.x);
    if (s.x.size() != s.n + s.nc || !s.x.allFinite()) return false;
    b = s.x.head(s.n);
    return true;
}

bool AlphaNewton::solve(double t, double h, const Eigen::VectorXd& z, const Eigen::VectorXd& v,
                        const Eigen::VectorXd& a, const Eigen::VectorXd& pa, Eigen::VectorXd& an,
                        Eigen::VectorXd& pan, Eigen::VectorXd& zn, Eigen::VectorXd& vn, Eigen::VectorXd& lam,
                        AlphaStats& stats, Failure& failure) {
    Impl& s = *impl_;
    const AlphaMethod& m = s.method;
    const int n = s.n, nc = s.nc;
    const double tn = t + h, bp = m.bp(h), gp = m.gp(h), L = s.eq.length_scale();
    pan = m.c1 * an + m.c2 * a + m.c3 * pa;
    zn = z + h * v + h * h * ((0.5 - m.beta) * pa + m.beta * pan);
    vn = v + h * ((1.0 - m.gamma) * pa + m.gamma * pan);
    double prev = 0.0;
    if (std::abs(s.lu_step - h) > 1e-10 * h) s.fresh = false;  // same step up to round-off
    // With the error per step (the run alone: Newton's tolerance is the step's share of
    // the error, up to 1e-6 L) a matrix's contraction measured in its own step (at the
    // state it was evaluated at) does not carry to the next: there it is unknown until
    // measured (elsewhere Newton's tolerance is 1e-10 or 0.01 rtol: the leftover is
    // negligible). On the rigid sprinkler, turning a few hundredths of a radian per step
    // about a free hinge with stiff bending and axial modes, a matrix one step old barely
    // contracts in the free rotation, and steps accepted after one correction by the
    // carried rate left up to 9 times Newton's tolerance there, which the free rotation
    // keeps (its tip at rtol 1e-4: 1.9e-3 m; 2.1e-4 m so). On the peer's scene at rtol
    // 1e-4 no cost (2509 iterations, 2581 with the rate carried).
    if (s.rate_of_fresh_matrix && s.opt.error_per_step) {
        s.contraction = std::max(s.contraction, Impl::kUnknownContraction);
        s.rate_of_fresh_matrix = false;
    }
    // the refresh due after a long step: at the predicted state, or after the first
    // correction if the prediction is rough
    const bool defer = s.stale && s.fresh && s.rough;
    if (s.stale && !defer) s.fresh = false;
    s.stale = false;
    int refreshed_at = 0;  // the iteration that evaluated a matrix in this step (0: none)
    int it = 0;
    for (it = 1; it <= s.opt.max_newton; ++it) {
        s.eq.set(zn, vn, an, lam, tn);
        if (it > s.policy.long_step + 1 && refreshed_at == 0) s.fresh = false;  // a long step with an old matrix
        if (defer && it == 2 && refreshed_at == 0) s.fresh = false;
        if (!s.fresh) {
            s.eq.evaluate(1.0, gp / bp, 1.0 / bp, s.r, &s.J);
            if (nc > 0) {
                const double size = scale_constraints(s.J, n, s.scale);
                // the scale is the block's size, fixed while the factors are kept
                if (size > 0.0 && std::abs(size - s.scale) > 0.5 * s.scale) {
                    scale_constraints(s.J, n, size / s.scale);
                    s.scale = size;
                }
            }
            ++stats.jacobians;
            if (!s.lu.factorize(n + nc, s.J.rows, s.J.cols, s.J.values)) {
                failure = {true, it - 1, s.r.norm()};
                return false;
            }
            s.fresh = true;
            refreshed_at = it;
            s.last_life = s.age;
            s.age = 0;
            s.lu_step = h;
            s.contraction = Impl::kUnknownContraction;
        } else {
            s.eq.evaluate(0.0, 0.0, 0.0, s.r, nullptr);
        }
        const double rnorm = s.r.norm();
        failure = {false, it - 1, rnorm};
        if (!std::isfinite(rnorm)) break;
        s.r = -s.r;
        if (nc > 0) s.r.tail(nc) *= s.scale;
        s.lu.solve(s.r, s.x);
        s.dz = s.x.head(n);
        if (!s.dz.allFinite()) break;
        zn += s.dz;
        vn += (gp / bp) * s.dz;
        an += (1.0 / bp) * s.dz;
        pan += (m.c1 / bp) * s.dz;
        if (nc > 0) lam += s.scale * s.x.tail(nc);
        ++stats.newton_iterations;
        // Converged when the position error left after this correction, estimated from
        // the contraction rate as rate / (1 - rate) |correction| (the test of SUNDIALS'
        // IDA), is below newton_tol model sizes. The rate is measured within the step,
        // else carried over from earlier steps with this matrix (not from the matrix's own
        // step, see above; counting every carried rate as 10 at least cost the peer's scene
        // 46 % more iterations at rtol 1e-4).
        const double corr = s.dz.lpNorm<Eigen::Infinity>();
        if (it > 1) {
            const double rate = prev > 0.0 ? corr / prev : 0.0;
            if (s.opt.error_per_step && it > 2 && rate > kWanderingRate) break;  // wandering
            // Slow contraction: refresh. Not on the rate of the first correction with a
            // matrix evaluated in this iteration: that correction is about the error the old
            // matrix left, so the rate is the old matrix's (the new one is exact there; on
            // the peer's scene at rtol 1e-4, 23 of 100 matrices were evaluated again at the
            // next step so). Unless the old matrix lasted a single step: then matrices do not
            // last, and the next is best evaluated at the next step's prediction (the rigid
            // sprinkler, whose free rotation a matrix one step old does not follow: at rtol
            // 1e-4 12 rtol L off with the new matrix kept, 2 so).
            if (rate > s.policy.slow_rate && (refreshed_at != it || s.last_life <= Impl::kShortLife)) s.fresh = false;
            // floored: one fast contraction must not license large corrections later
            s.contraction = rate < 0.9 ? std::max(rate / (1.0 - rate), Impl::kMinContraction) : 1e3;
            s.rate_of_fresh_matrix = refreshed_at > 0;
            // stalled at round-off near the tolerance with a matrix of this step: accept
            if (rate >= 0.5 && refreshed_at > 0 && corr <= 10.0 * s.tol * L) {
                ++s.age;
                return true;
            }
        }
        if (s.contraction * corr <= s.tol * L) {
            // long: with the error per step, the iterations with the step's own matrix if it
            // has one (a matrix evaluated at the third iteration is not stale after the
            // fourth: the peer's scene at rtol 1e-4 in 69 matrices instead of 83); elsewhere
            // every iteration of the step (a shooting Newton's free periodic orbits, fixed
            // steps at newton_tol 1e-10, stalled at a defect of 8.6e-11 with the new
            // matrices kept)
            const int with_matrix = s.opt.error_per_step && refreshed_at > 0 ? it - refreshed_at + 1 : it;
            s.stale = with_matrix > s.policy.long_step;
            ++s.age;
            return true;
        }
        if (corr > L) break;  // diverging
        prev = corr;
    }
    failure.iterations = std::min(it, s.opt.max_newton);
    s.fresh = false;
    return false;
}

// ------------------------------------------------------- initial acceleration ----------

void initial_acceleration(Equations& eq, const Eigen::VectorXd& z, const Eigen::VectorXd& v, double t,
                          Eigen::VectorXd& a, Eigen::VectorXd& lam) {
    const int n = eq.n_coordinates(), nc = eq.n_constraints();
    a = Eigen::VectorXd::Zero(n);
    lam = Eigen::VectorXd::Zero(nc);
    eq.set(z, v, a, lam, t);
    Eigen::VectorXd r;
    Triplets trip;
    eq.evaluate(0.0, 0.0, 1.0, r, &trip);
    const std::string singular = "the mass matrix is singular: " + eq.singular_mass_hint();
    if (nc == 0) {
        // symmetric positive definite: LDLT of 0.5 (M + M^T), whose pivots show a singular M
        std::vector<Eigen::Triplet<double>> sym;
        sym.reserve(2 * trip.values.size());
        for (std::size_t k = 0; k < trip.values.size(); ++k) {
            sym.emplace_back(trip.rows[k], trip.cols[k], 0.5 * trip.values[k]);
            sym.emplace_back(trip.cols[k], trip.rows[k], 0.5 * trip.values[k]);
        }
        Eigen::SparseMatrix<double> M(n, n);
        M.setFromTriplets(sym.begin(), sym.end());
        Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(M);
        const bool factored = ldlt.info() == Eigen::Success;
        const Eigen::VectorXd d = factored ? Eigen::VectorXd(ldlt.vectorD()) : Eigen::VectorXd::Zero(n);
        if (!factored || n == 0 || d.minCoeff() <= 1e-12 * d.cwiseAbs().maxCoeff())
            throw std::invalid_argument(singular);
        a = ldlt.solve(-r);
        return;
    }
    const double size = scale_constraints(trip, n, 1.0), s = size > 0.0 ? size : 1.0;
    scale_constraints(trip, n, s);
    FixedPatternLU lu(kDenseLuBelow);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n + nc), x;
    rhs.head(n) = -r.head(n);
    if (lu.factorize(n + nc, trip.rows, trip.cols, trip.values)) lu.solve(rhs, x);
    if (x.size() != n + nc || !x.allFinite()) {
        // Coordinates that are massless but stiff (torsion of a body without rotary
        // inertia) leave the matrix singular; the index-3 iteration matrix is regular
        // there (stiffness), so start from the minimum-norm acceleration.
        if (n + nc > kDenseMinimumNormLimit)
            throw std::invalid_argument(singular + ", or the constraints are redundant (a motion locked twice)");
        Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n + nc, n + nc);
        for (std::size_t k = 0; k < trip.values.size(); ++k) A(trip.rows[k], trip.cols[k]) += trip.values[k];
        x = A.completeOrthogonalDecomposition().solve(rhs);
    }
    a = x.head(n);
    lam = s * x.tail(nc);
}

// ------------------------------------------------------- the integrator ----------------

namespace {

AlphaOptions checked(const AlphaOptions& o) {
    if (!std::isfinite(o.step) || !(o.step > 0.0)) throw std::invalid_argument("step must be > 0 and finite");
    if (!(o.rho_inf >= 0.0 && o.rho_inf <= 1.0)) throw std::invalid_argument("rho_inf must be in [0, 1]");
    if (!(o.newton_tol > 0.0)) throw std::invalid_argument("newton_tol must be > 0");
    if (!(o.error_rate >= 0.0) || !std::isfinite(o.error_rate))
        throw std::invalid_argument("error_rate must be >= 0 and finite (0: a fixed step)");
    if (!(o.motion_rate >= 0.0) || !std::isfinite(o.motion_rate))
        throw std::invalid_argument("motion_rate must be >= 0 and finite");
    if (o.max_newton < 1) throw std::invalid_argument("max_newton must be >= 1");
    for (const double h : o.steps)
        if (!std::isfinite(h) || !(h > 0.0)) throw std::invalid_argument("steps must be > 0 and finite");
    return o;
}

std::string failure_message(double t, double h, const AlphaNewton::Failure& f, const Equations& eq) {
    if (f.singular)
        return "generalised-alpha failed at t = " + fmt(t) + " s: singular iteration matrix with step " + fmt(h) +
               " s (residual " + fmt(f.residual) + " after " + std::to_string(f.iterations) +
               " iterations): a mechanism, " + eq.singular_mass_hint();
    return "generalised-alpha failed at t = " + fmt(t) + " s: Newton did not converge with step " + fmt(h) +
           " s (residual " + fmt(f.residual) + " after " + std::to_string(f.iterations) +
           " iterations); the motion may diverge";
}

}  // namespace

[[noreturn]] void throw_newton_failure(const Equations& eq, double t, double h, const AlphaNewton::Failure& f) {
    ConvergenceError::Where where;
    where.time = t;
    where.mass_flow = eq.mass_flow(t);
    where.iteration = f.iterations;
    where.residual = f.residual;
    if (f.singular) throw SingularMatrixError(failure_message(t, h, f, eq), where);
    throw ConvergenceError(failure_message(t, h, f, eq), where);
}

GeneralizedAlpha::GeneralizedAlpha(Equations& eq, const AlphaOptions& opt, double t0, const Eigen::VectorXd& v0)
    : eq_(eq), opt_(checked(opt)), method_(opt_.rho_inf), newton_(eq, method_, opt_),
      adaptive_prediction_(eq.adaptive_prediction()), t_(t0), h_(opt_.step), t_start_(t0) {
    const int n = eq.n_coordinates();
    if (n == 0)
        throw std::invalid_argument("the model has no free coordinates (every node is fixed): there is no "
                                    "motion to integrate");
    if (v0.size() != n) throw std::invalid_argument("generalised-alpha: v0 must have n_coordinates entries");
    zero_ = Eigen::VectorXd::Zero(n);
    v_ = v0;
    initial_acceleration(eq, zero_, v_, t0, a_, lam_);
    pa_ = a_;
    a_prev_ = a_;
    // A given mesh (the extrapolation's refined runs) is solved to a tolerance of 10 rtol / n
    // per step: a fourth iteration there is the tolerance's, not a stale matrix's (at rtol
    // 1e-6 on the peer's scene 426 of its 799 matrices followed a step of 4 or more: 681 now)
    if (!opt_.steps.empty()) newton_.lengthen_long_step(1);
    if (opt_.error_rate > 0.0) {
        eq.error_scales(error_weights_);
        if (error_weights_.size() != n || !(error_weights_.minCoeff() > 0.0))
            throw std::logic_error("error_scales: n positive entries expected");
        error_weights_ /= opt_.error_rate;
    }
    an_.resize(n);
    pan_.resize(n);
    zn_.resize(n);
    vn_.resize(n);
    eq.set(zero_, v_, a_, lam_, t0);
    measure_motion();
}

GeneralizedAlpha::~GeneralizedAlpha() = default;

void GeneralizedAlpha::measure_motion() {
    // Only once the motion outgrows the model: within it the tolerance (and every step)
    // is the absolute one's, bit for bit. The motion at the step's start stands for the
    // step's (a growing motion is judged a step late, on the strict side).
    if (!(opt_.error_rate > 0.0 && opt_.motion_rate > 0.0)) return;
    const double D = eq_.motion_size(), L = eq_.length_scale();
    motion_factor_ = D > L && std::isfinite(D) ? 1.0 + opt_.motion_rate * (D - L) / opt_.error_rate : 1.0;
}

void GeneralizedAlpha::advance_to(double t_out) {
    // Equal steps within each output interval (a short last step would disturb the
    // method's history); halved after a failed Newton iteration, restored after.
    while (t_ < t_out - 1e-14 * std::max(1.0, std::abs(t_))) {
        poll_interrupt();
        const double left = t_out - t_;
        const bool replay = !opt_.steps.empty();
        // error control: the controlled step until the output time is near (then the rest
        // in one or two equal steps), so that the iteration matrix is kept. With constraints
        // the controlled step divided equally over the rest of the output interval: every
        // changed step is a new matrix (the joints' rows factorised too, Newton held to
        // kConstrainedNewtonShare), and one or two shorter steps before each output changed it
        // twice per output (seed 004's cantilever of 8 bodies, 401 outputs in 2 s, rtol
        // 3e-3: 781 matrices in 1958 steps, 0.74 s; so 334 in 2502, 0.53 s, the tip 0.11 mm
        // off a fine step's instead of 0.62). Element models refresh most steps' matrices
        // anyway, and there the same took seed 000's fluttering cantilever of Fig. 4 twice
        // the time and seed 002's spin-up at rtol 1e-4 twice the steps.
        const double whole = eq_.n_constraints() > 0 ? 0.0 : 2.0;
        double hs = opt_.error_rate > 0.0 && whole > 0.0 && left > whole * h_ ? h_ : left / std::ceil(left / h_ - 1e-9);
        if (replay) {
            if (replayed_ == opt_.steps.size())
                throw std::invalid_argument("generalised-alpha: the steps given end at t = " + fmt(t_) +
                                            " s, before the output time " + fmt(t_out) + " s");
            hs = opt_.steps[replayed_];
            // the output time, up to the round-off of the steps' sums (far below a step; a
            // mesh of a million tiny steps accumulates some eps |t| per step in t)
            const double roundoff = kMeshRoundOff * hs + 4.0 * std::numeric_limits<double>::epsilon() *
                                                             std::abs(t_out) * static_cast<double>(replayed_ + 1);
            if (std::abs(hs - left) <= roundoff)
                hs = left;
            else if (hs > left)
                throw std::invalid_argument("generalised-alpha: the steps given pass the output time " + fmt(t_out) +
                                            " s (step " + fmt(hs) + " s from t = " + fmt(t_) +
                                            " s): each output time must end a step");
        }
        const double tn = t_ + hs;
        // Predictor (see Prediction): on smooth motion the extrapolated acceleration
        // (error O(h^2) instead of O(h): one correction usually converges); where stiff
        // modes ring, the acceleration history is rough and extrapolating it throws the
        // predicted state far off (a fine mesh: 7x the first correction of pan = 0).
        // Without a last step (start, after a failed one): the constant acceleration.
        const double ratio = h_prev_ > 0.0 ? hs / h_prev_ : 0.0;
        if (h_prev_ > 0.0 && prediction_ == Prediction::zero)
            an_.setZero();
        else if (h_prev_ > 0.0 && prediction_ == Prediction::zero_pseudo)
            an_ = -(method_.c2 * a_ + method_.c3 * pa_) / method_.c1;
        else
            an_ = a_ + ratio * (a_ - a_prev_);
        // halved steps count too: max_steps bounds the work, not only the progress
        if (stats_.steps + stats_.failed_steps + stats_.rejected_steps >= opt_.max_steps)
            throw std::invalid_argument("generalised-alpha: max_steps = " + std::to_string(opt_.max_steps) +
                                        " steps (failed ones included) reached at t = " + fmt(t_) + " s (step " +
                                        fmt(hs) + " s) before t_end; raise max_steps, or the motion may be diverging");
        lam_start_ = lam_;
        if (opt_.error_rate > 0.0) {
            const double share = eq_.n_constraints() > 0 ? kConstrainedNewtonShare : kNewtonShare;
            newton_.set_tolerance(
                std::min(opt_.newton_tol, share * opt_.error_rate * motion_factor_ * hs / eq_.length_scale()));
        }
        AlphaNewton::Failure failure;
        // A changed step (error control): the pseudo-acceleration lags the acceleration by
        // (alpha_m - alpha_f) h a' (second order: pa = a(t + (alpha_m - alpha_f) h)), so its
        // offset is rescaled to the new step; kept, every change of step would leave an
        // error in the velocity that the estimate does not see (the rigid sprinkler at rtol
        // 1e-2, its step cut from 5 to 0.3 ms and grown back: 0.15 m off, 1.6e-3 m rescaled).
        // (Kept on a cut, with the error per step, the peer's cantilever released without
        // flow met rtol 3e-3 over 2 s, 4.4e-4 m against 1.8e-2 m rescaled, but over 0.5 s at
        // rtol 1e-3 it diverged: 1.18 m.)
        const bool rescale = opt_.error_rate > 0.0 && !taken_.empty() && hs != taken_.back();
        if (rescale) pa_rescaled_ = a_ + (hs / taken_.back()) * (pa_ - a_);  // a member: no allocation per step
        const Eigen::VectorXd& pa = rescale ? pa_rescaled_ : pa_;
        if (!newton_.solve(t_, hs, zero_, v_, a_, pa, an_, pan_, zn_, vn_, lam_, stats_, failure)) {
            if (replay) throw_newton_failure(eq_, t_, hs, failure);  // a given mesh is not changed
            ++stats_.failed_steps;
            lam_ = lam_start_;
            h_prev_ = 0.0;  // retry from the constant predictor: extrapolation may have misled
            newton_cap_ = hs;
            h_ = 0.5 * hs;
            if (h_ < opt_.min_step) throw_newton_failure(eq_, t_, hs, failure);
            continue;
        }
        if (opt_.error_rate > 0.0) {
            // per step: the error against error_rate h_mean, so in tolerances (error_rate hs)
            // times hs / h_mean and of order 3 in the step (see AlphaOptions::error_per_step)
            const bool per_step = opt_.error_per_step;
            const double step_share = per_step && !taken_.empty() ? hs * taken_.size() / (t_ - t_start_) : 1.0;
            // (the estimate's filtering judges the error per unit step: a stiff mode's does not
            // fall with the step)
            const double err_unit = local_error(hs, tn), err = err_unit * step_share;
            const double factor = err > 0.0 ? kSafety / (per_step ? std::cbrt(err) : std::sqrt(err)) : kGrowMax;
            if (err > 1.0) {
                if (hs <= opt_.min_step) {
                    ConvergenceError::Where where;
                    where.time = t_;
                    where.mass_flow = eq_.mass_flow(t_);
                    throw ConvergenceError("generalised-alpha's error control failed at t = " + fmt(t_) +
                                               " s: the local error (" + fmt(err) +
                                               " tolerances) asks for a step below min_step = " +
                                               fmt(opt_.min_step) + " s: a tolerance below round-off, or a motion "
                                               "that is not smooth there (an impact, a diverging mode)",
                                           where);
                }
                ++stats_.rejected_steps;
                rejected_step_ = hs;
                rejected_error_ = raw_error_;
                lam_ = lam_start_;
                h_ = std::max(opt_.min_step, hs * std::clamp(factor, kShrinkMax, kSafety));
                continue;
            }
            rejected_step_ = 0.0;
            // the step from the control (not a short one that reached an output time); a
            // memory of the last few steps' errors (growth by the largest) held the spin-up's
            // step at a stiff mode's ringing (seed 002, rtol 1e-4: 6470 steps against 886)
            if (factor >= kGrowMin) h_ = std::max(h_, hs * std::min(factor, kGrowMax));
            if (h_ > 0.9 * newton_cap_) h_ = std::max(hs, 0.9 * newton_cap_);
            newton_cap_ *= kNewtonMemory;
            const double e_m = err_unit * opt_.error_rate * motion_factor_ * hs;
            stats_.error_sum += e_m;
            stats_.error_max = std::max(stats_.error_max, e_m);
        }
        if (adaptive_prediction_) {
            // the next step's predictor: the one closest to this step's converged
            // acceleration (the norm of Newton's corrections, up to the factor bp); another
            // replaces the extrapolation only if kPredictorMargin times closer, since at a
            // loose newton_tol the converged accelerations are noisy and the choice would
            // flip on smooth motion (the peer's scene at 1e-6: 50 % more matrices)
            const double err[4] = {
                (a_ + ratio * (a_ - a_prev_) - an_).lpNorm<Eigen::Infinity>(), (a_ - an_).lpNorm<Eigen::Infinity>(),
                an_.lpNorm<Eigen::Infinity>(),
                (method_.c2 * a_ + method_.c3 * pa_ + method_.c1 * an_).lpNorm<Eigen::Infinity>() / method_.c1};
            const int best = static_cast<int>(std::min_element(err + 1, err + 4) - err);
            prediction_ = kPredictorMargin * err[best] < err[0] ? static_cast<Prediction>(best) : Prediction::extrapolated;
            newton_.set_rough_prediction(prediction_ == Prediction::zero_pseudo);
        }
        eq_.set(zn_, vn_, an_, lam_, tn);
        eq_.accept(tn, hs);
        measure_motion();  // the state set is the step's end
        // accept: re-base the frames to the step's end, carrying the pseudo-acceleration's
        // offset from the true acceleration over
        offset_ = pan_ - an_;
        a_prev_ = a_;
        v_ = vn_;
        a_ = an_;
        stats_.rebases += eq_.rebase(v_, a_);
        pa_ = a_ + offset_;
        // the predictor extrapolates the re-based coordinates: at z = 0 those of
        // consecutive steps are all spatial angular accelerations, so comparable
        h_prev_ = hs;
        t_ = tn;
        ++stats_.steps;
        if (replay) ++replayed_;
        if (opt_.error_rate > 0.0) taken_.push_back(hs);
        stats_.smallest_step = stats_.steps == 1 ? hs : std::min(stats_.smallest_step, hs);
        stats_.largest_step = std::max(stats_.largest_step, hs);
        if (opt_.error_rate == 0.0 && h_ < opt_.step) h_ = std::min(opt_.step, 2.0 * h_);
        if (eq_.observer != nullptr) eq_.observer->step(t_);  // sensors: the state is still the step's end
    }
    eq_.set(zero_, v_, a_, lam_, t_);
}

double GeneralizedAlpha::local_error(double hs, double tn) {
    // The displacement's local error of a Newmark-type step, (beta - 1/6) h^3 z''' with
    // z''' ~ (a' - a) / h (Zienkiewicz & Xie 1991): the generalised-alpha update against
    // the third-order Taylor step through the same accelerations. The largest coordinate
    // in tolerances: a local motion (a tip) is not diluted by a large model.
    const double c = std::abs(method_.beta - 1.0 / 6.0) * hs;  // (.) hs^2 / (error_rate hs)
    // (in the motion's tolerances: / motion_factor_, 1 within the model)
    const double raw = c * (an_ - a_).cwiseProduct(error_weights_).lpNorm<Eigen::Infinity>() / motion_factor_;
    raw_error_ = raw;
    // On a resolved motion the estimate falls as hs^2 with the step; on a retry after a
    // rejection where it fell less than in proportion to hs, it is not the motion's; nor
    // on the steps after one that the filtered estimate alone passed, while the unfiltered
    // one stays above 1 (the ringing persists: tried unfiltered, each step grown after a
    // filtered one was rejected and retried at about half the last, the FFRF cantilever
    // of 8 bodies at rtol 1e-3 down to 3e-10 s within 35 steps, and to 1e-9 s with
    // kConstrainedNewtonShare alone)
    const bool retry = rejected_step_ > hs && raw >= rejected_error_ * hs / rejected_step_;
    if (raw <= 1.0 || !(opt_.rho_inf < 1.0) || !(retry || ringing_)) {
        if (raw <= 1.0) ringing_ = false;
        return raw;
    }
    // A retry the estimate above would reject again: filtered (as RADAU5's estimate, Hairer &
    // Wanner IV.8), e = (M + gp C + bp K)^-1 M d, d the estimate above, solved with the
    // step's iteration matrix and zero constraint rows. A resolved mode passes unchanged
    // (factor 1 / (1 + bp w^2)); an unresolved stiff one, which rho_inf < 1 damps, counts
    // at its amplitude, not at h^2 w^2 times it: unfiltered, a rejection shrinks the step
    // towards 1/w, where the stiff mode's estimate grows (the stored acceleration is not
    // the mode's), and once resolved the undamped mode holds the step there (the rigid
    // sprinkler at rtol 1e-4: 897197 steps down to 4e-10 s; 1244 filtered). The estimate
    // lies on the constraints (G e = 0): the multipliers' index-3 ringing, which moves no
    // constrained position and grows as the step shrinks, does not count (FFRF bodies
    // failed at min_step). Elsewhere the unfiltered estimate (a mode the step passes over
    // is lost, not damped: a free vibration's steps must not grow past its period).
    // M d from the residual, linear in the accelerations: r(a' + d / bp) - r(a') = M d / bp.
    const int n = static_cast<int>(an_.size());
    const double bp = method_.bp(hs);
    filtered_ = (c * hs / bp) * (an_ - a_);
    filtered_ += an_;
    eq_.set(zn_, vn_, filtered_, lam_, tn);
    eq_.evaluate(0.0, 0.0, 0.0, residual_shifted_, nullptr);
    eq_.set(zn_, vn_, an_, lam_, tn);
    eq_.evaluate(0.0, 0.0, 0.0, residual_, nullptr);
    filtered_ = residual_shifted_.head(n) - residual_.head(n);
    if (!newton_.filter(filtered_)) return raw;
    const double err = filtered_.cwiseProduct(error_weights_).lpNorm<Eigen::Infinity>() / (hs * motion_factor_);
    if (err <= 1.0) ringing_ = true;
    return err;
}

}  // namespace pipeflex
