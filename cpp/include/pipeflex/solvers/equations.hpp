// The equations interface every formulation gives the solvers, and the one
// generalised-alpha integrator built on it.
//
// A system (element model, floating-frame bodies with joints) is
//     R(q, v, a, t) + C_q(q)^T lambda = 0,    c(q, t) = 0,
// with q on a configuration manifold (node frames, body frames). The solvers see q only
// through a chart around a base configuration q0: q = q0 (+) z, z in R^n; the system
// says what (+) is (a sum for positions and modal amplitudes, exp(z~) R0 for frames) and
// what v and a mean (chart rates for element nodes, spatial angular velocities for
// bodies). Re-basing (q0 <- q, z <- 0) keeps z small; the system maps v and a into the
// new chart.
//
// The tangent is one routine with weights chosen by the analysis (static: wK = 1;
// generalised-alpha: wK = 1, wC = dv/dz, wM = da/dz; linearisation: one weight at a
// time): the triplets of
//     [ wK dR/dz + wC dR/dv + wM dR/da + wK d(C_q^T lambda)/dz    s C_q^T ]
//     [ s C_q                                                      0      ]
// ((n + nc) x (n + nc)), the constraint rows and columns scaled by s (chosen by the
// solver: the size of the top-left block, so that pivoting sees comparable entries).
#pragma once

#include "pipeflex/assembly/model.hpp"
#include "pipeflex/solvers/tangent_csc.hpp"

#include <Eigen/Core>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace pipeflex {

// Told of every accepted step by the integrators, right after Equations::accept (the
// state set to the step's end): the run's sensors (sensors.hpp). It may throw to end the run.
class StepObserver {
   public:
    virtual ~StepObserver() = default;
    virtual void step(double t) = 0;
};

class Equations {
   public:
    virtual ~Equations() = default;
    StepObserver* observer = nullptr;  // none: no sensors
    virtual int n_coordinates() const = 0;            // n
    virtual int n_constraints() const { return 0; }   // nc
    virtual double length_scale() const = 0;          // [m] model size, for tolerances
    // The state q0 (+) z, v, a (n each), multipliers lambda (nc) at time t [s].
    virtual void set(const Eigen::VectorXd& z, const Eigen::VectorXd& v, const Eigen::VectorXd& a,
                     const Eigen::VectorXd& lambda, double t) = 0;
    // At the state set: the residual [R + C_q^T lambda; c] (n + nc) and, if tangent is not
    // null, the weighted tangent above with s = 1 (the solvers scale). The pattern of the
    // triplets must not depend on the state (a fixed-pattern LU is kept across calls).
    virtual void evaluate(double wK, double wC, double wM, Eigen::VectorXd& residual, Triplets* tangent) = 0;
    // The tangents of several weights at the state set, each as evaluate's triplets: the
    // flow map's linearisation takes K, C and its step's iteration matrix at every step
    // (an element model assembles them in one pass).
    virtual void tangents(const std::vector<TangentWeights>& weights, std::vector<Triplets>& J) {
        J.resize(weights.size());
        Eigen::VectorXd r;
        for (std::size_t k = 0; k < weights.size(); ++k)
            evaluate(weights[k].wK, weights[k].wC, weights[k].wM, r, &J[k]);
    }
    // The same tangents' first n columns in compressed columns on the pattern kept in out
    // (TangentCsc: built at the first call, values only while the entries' sources stay
    // the same): the linearisation's K, C, M and C_q. By default from tangents()' triplets;
    // a system assembled on a fixed pattern (an element model) writes straight into it.
    virtual void tangents_csc(const std::vector<TangentWeights>& weights, TangentCsc& out) {
        std::vector<Triplets> J;
        tangents(weights, J);
        out.assemble(n_coordinates(), n_constraints(), static_cast<int>(weights.size()), nullptr, {}, J);
    }
    // The state set becomes the base (z = 0); v and a are mapped into the new chart.
    // Returns the number of frames re-based.
    virtual int rebase(Eigen::VectorXd& v, Eigen::VectorXd& a) = 0;
    // Called with the state set to an accepted step's end: throws ConvergenceError if the
    // motion left the model's domain (diverged, not finite); bookkeeping (work).
    virtual void accept(double t, double h) { (void)t; (void)h; }
    // When modified Newton re-evaluates its iteration matrix: after a correction that
    // shrank by less than slow_rate (that of the one before), within a step after
    // long_step + 1 iterations with an older matrix, and at the next step after a step
    // that needed more than long_step iterations (after that step's first correction if
    // the integrator calls its prediction rough). The floating-frame bodies keep theirs
    // longer: their Newton contracts well on an old matrix, and even with the joints'
    // tangent analytic the default policy took seed 004's curved pipe 1.8x the time and
    // left the FFRF chain 3-4x the Newton error.
    struct RefreshPolicy {
        double slow_rate = 0.25;
        int long_step = 3;
    };
    virtual RefreshPolicy refresh_policy() const { return {}; }
    // Whether generalised-alpha may predict a step by other than extrapolating the
    // acceleration (GeneralizedAlpha::Prediction) when that would have been closer on the
    // last step. Off by default: on the floating-frame bodies (Newton tolerance 1e-9) the
    // damped predictors bias what Newton leaves, and a spinning body's energy drifted 6x
    // more over 4000 steps.
    virtual bool adaptive_prediction() const { return false; }
    // Statics: scale the applied loads and gravity by f (any real: the arc-length border
    // differences it beyond the loads' range).
    virtual void set_static_load_factor(double f) { (void)f; }
    // Statics: the mass flow mdot [kg/s] of the loads that depend on it (any real, as f).
    virtual void set_static_mass_flow(double mdot) { (void)mdot; }
    // Statics: the Newton correction dz (its first n entries; reduced coordinates) about to
    // be added to the state set. A system may extrapolate its stresses along it and take
    // them for the next tangent's geometric part (the mixed Newton: pipe_predicted_stresses);
    // nullptr: forget any (a new solve starts from the state's own stresses).
    virtual void predict_stresses(const Eigen::VectorXd* dz) { (void)dz; }
    // Mass flow at t [kg/s], for error reports.
    virtual double mass_flow(double t) const { (void)t; return 0.0; }
    // Why a singular mass matrix or iteration matrix is singular, in the system's terms.
    virtual std::string singular_mass_hint() const { return "coordinates without inertia"; }
    // [m per unit] How far a unit error of each coordinate moves the model (n entries,
    // > 0), for the integrator's error control: 1 for displacements (the default, every
    // coordinate), the model size for rotations and slopes (an angle error e moves a
    // point at that distance by e times it).
    virtual void error_scales(Eigen::VectorXd& s) const { s = Eigen::VectorXd::Ones(n_coordinates()); }
    // [m] The size of the motion at the state set: the largest displacement of a node (a
    // body's frame origin) from its reference position, for the integrator's error control
    // (AlphaOptions::motion_rate); 0 (the default): not measured, the tolerance stays at the
    // model size. Called once per accepted step: a pass over the nodes, no residual.
    virtual double motion_size() const { return 0.0; }

    // The kinematics IDA (ida.hpp) integrates, z' = N(z) v, at the state set. The defaults
    // are an element model's: its rates are chart rates (N = I).
    // zd = N(z) w: the chart's rate of the rates w (n); a floating frame's rotation
    // coordinates: T(z)^-1 w (T the left Jacobian of exp; w spatial).
    virtual void chart_rates(const Eigen::VectorXd& w, Eigen::VectorXd& zd) const { zd = w; }
    // w = N(z)^-1 dz: a chart increment as an increment of the rates' kind (spatial for a
    // frame: T(z) dz), the one the tangent's columns are taken in.
    virtual void rate_increments(const Eigen::VectorXd& dz, Eigen::VectorXd& w) const { w = dz; }
    // c_t (nc) at the state set: the constraints' rate at fixed q (driven joints; zero
    // unless a joint moves with time), so that the velocity constraint is C_q v + c_t = 0.
    virtual void constraint_rate(Eigen::VectorXd& ct) const { ct = Eigen::VectorXd::Zero(n_constraints()); }
    // [rad] The largest rotation of the state set's frames from the chart's base (what
    // rebase() resets): IDA re-bases and restarts once it exceeds the run's rebase_angle.
    virtual double chart_rotation() const { return 0.0; }
    // rebase() re-bases the frames turned beyond angle [rad] (all of them by default).
    virtual void set_rebase_angle(double angle) { (void)angle; }
};

// Scales the constraint rows and columns of an (n + nc) tangent's triplets by s (so that
// pivoting sees entries comparable to the top-left block's); returns the largest magnitude
// of that block.
double scale_constraints(Triplets& J, int n, double s);

struct AlphaOptions {
    double step = 1e-3;         // h [s]: the step (error_rate > 0: the first step)
    double min_step = 1e-12;    // smallest step before giving up [s]
    double rho_inf = 0.9;       // spectral radius at infinite frequency, in [0, 1]
    double newton_tol = 1e-10;  // position error left by Newton / length_scale
    int max_newton = 12;
    long max_steps = 10000000;  // steps, failed (halved) ones included
    // [m/s] > 0: the step h is controlled by the local error estimate (GeneralizedAlpha):
    // each coordinate's estimated error of a step, in metres (Equations::error_scales), at
    // most error_rate h, so that the errors of a run of duration T add up to at most
    // error_rate T (error per unit step: the global error proportional to the tolerance);
    // 0: the fixed step `step`.
    double error_rate = 0.0;
    // [1/s] >= 0, with error_rate: a motion larger than the model (Equations::motion_size
    // D > length_scale L, at the step's start) raises the rate to error_rate + motion_rate
    // (D - L) (simulate: rtol / (ERROR_ACCUMULATION T), so that the tolerance is rtol D +
    // atol: relative to the motion once it outgrows the model); 0: error_rate alone.
    double motion_rate = 0.0;
    // with error_rate: the control per step instead of per unit step. A step's error is held
    // at error_rate h_mean (h_mean the mean of the steps taken so far) instead of error_rate
    // h: the same sum error_rate T over the run, spread with the step h ~ C^(-1/3) (C the
    // local error's coefficient) instead of C^(-1/2), which minimises the steps for a given
    // sum of local errors (error per step).
    bool error_per_step = false;
    // [s] non-empty: the steps to take, in order, in place of step and error_rate: a mesh
    // recorded by an error-controlled run (GeneralizedAlpha::steps_taken), e.g. each step
    // halved for Richardson extrapolation over the mesh. Each output time must fall on a
    // step's end (to round-off); a failed Newton iteration throws (no halving).
    std::vector<double> steps;
};

// Chung-Hulbert parameters from rho_inf and the update formulas of one step
//   pa' = c1 a' + c2 a + c3 pa,  z' = z + h v + h^2 ((1/2 - beta) pa + beta pa'),
//   v' = v + h ((1 - gamma) pa + gamma pa').
struct AlphaMethod {
    double am, af, gamma, beta, c1, c2, c3;
    explicit AlphaMethod(double rho)
        : am((2.0 * rho - 1.0) / (rho + 1.0)), af(rho / (rho + 1.0)), gamma(0.5 + af - am),
          beta(0.25 * (gamma + 0.5) * (gamma + 0.5)), c1((1.0 - af) / (1.0 - am)), c2(af / (1.0 - am)),
          c3(-am / (1.0 - am)) {}
    double bp(double h) const { return h * h * beta * c1; }  // d z' / d a'
    double gp(double h) const { return h * gamma * c1; }     // d v' / d a'
};

struct AlphaStats {
    // failed_steps: steps halved after Newton failed; rejected_steps: steps redone
    // because the local error estimate exceeded error_rate
    long steps = 0, newton_iterations = 0, jacobians = 0, rebases = 0, failed_steps = 0, rejected_steps = 0;
    // [m] the accepted steps' local error estimates summed (a bound of the global error
    // where errors add up; 0 with a fixed step) and the largest single one, per step
    double error_sum = 0.0, error_max = 0.0;
    double smallest_step = 0.0, largest_step = 0.0;  // [s] accepted steps
};

// Newton on one step's end state: the position corrections dz from
//     [S, s C_q^T; s C_q, 0] [dz; dlambda / s] = -[R + C_q^T lambda; s c],
//     S = K + (gp/bp) C + (1/bp) M,
// factorised sparsely on a fixed pattern and kept (modified Newton) across iterations
// and steps while the corrections contract fast. Shared by the integrator and the flow
// map of periodic orbits.
class AlphaNewton {
   public:
    AlphaNewton(Equations& eq, const AlphaMethod& m, const AlphaOptions& opt);
    ~AlphaNewton();
    AlphaNewton(const AlphaNewton&) = delete;
    AlphaNewton& operator=(const AlphaNewton&) = delete;

    struct Failure {
        bool singular = false;
        int iterations = 0;
        double residual = 0.0;
    };

    // From the step's start (z, v, a, pa at t; z in the current chart) and a predicted
    // an (lam: the multipliers' guess), solves for the end state an, pan, zn, vn, lam at
    // t + h. False if Newton did not converge (why in failure).
    bool solve(double t, double h, const Eigen::VectorXd& z, const Eigen::VectorXd& v, const Eigen::VectorXd& a,
               const Eigen::VectorXd& pa, Eigen::VectorXd& an, Eigen::VectorXd& pan, Eigen::VectorXd& zn,
               Eigen::VectorXd& vn, Eigen::VectorXd& lam, AlphaStats& stats, Failure& failure);
    void invalidate();
    // Whether the next steps' predicted states are rough (far from the solution in stiff
    // directions: spurious strains of stiff modes). A matrix taken at such a state
    // contracts poorly once the first correction has removed them, so a refresh due at
    // a step's start is taken after its first correction, made with the kept matrix.
    void set_rough_prediction(bool rough);
    // The Newton tolerance of the next steps (position error / length_scale), in place of
    // the options' newton_tol (the error-controlled step ties it to its tolerance).
    void set_tolerance(double newton_tol);
    // Judge a step long (its next step's matrix re-evaluated) only past `extra` more
    // iterations than the system's RefreshPolicy::long_step.
    void lengthen_long_step(int extra);
    // Solves the last step's iteration matrix for the right side (b; 0) (zero constraint
    // rows) and returns the coordinates' part in b: the error filter of the step control.
    // False if no factorisation is at hand.
    bool filter(Eigen::VectorXd& b);

   private:
    struct Impl;
    Impl* impl_;
};

// Throws the ConvergenceError (SingularMatrixError if singular) of a failed Newton
// solve at time t [s] with step h [s], naming both.
[[noreturn]] void throw_newton_failure(const Equations& eq, double t, double h, const AlphaNewton::Failure& f);

// Consistent acceleration and multipliers at the state set (z, v, a = 0, lambda = 0):
// [M, C_q^T; C_q, 0] [a; lambda] = [-R(q, v, 0); 0]. Throws std::invalid_argument
// (singular mass) if the system's mass matrix is singular on the constraints' null space.
void initial_acceleration(Equations& eq, const Eigen::VectorXd& z, const Eigen::VectorXd& v, double t,
                          Eigen::VectorXd& a, Eigen::VectorXd& lam);

// Static equilibrium R(q, 0, 0) + C_q^T lambda = 0, c(q) = 0 at time t by Newton's method
// on the scaled KKT matrix [K, s C_q^T; s C_q, 0] (sparse LU): from the state's base
// configuration and the multipliers lam (updated). Converged when the correction is
// below tol model sizes and the constraints below 1e-6 model sizes (or stalls at
// round-off within 1e3 tol), or (force_scale > 0) when the residual is below
// 1e-3 tol times the force level. The configuration is re-based after every iteration.
// The one Newton of the static analyses: multibody systems, coupled systems and element
// models (static_equilibrium's load stepping calls it once per load step).
// An optional border of static_newton's system (arc-length continuation): one more
// unknown, a path parameter tau that sets the equations' loads, with its column dR/dtau
// (central differences of step difference_step: exact for a residual at most quadratic
// in tau), and one more equation g = 0 on the increment accumulated from the step's start
// and tau, with its gradient (c, d).
class StaticBorder {
   public:
    virtual ~StaticBorder() = default;
    virtual double parameter() const = 0;
    virtual void set_parameter(double tau) = 0;  // the equations' loads at tau
    virtual double difference_step() const { return 0.5; }
    // g at the increment accumulated so far and, if c is not null, its gradient c (n), d
    virtual double constraint(Eigen::VectorXd* c, double* d) const = 0;
    // a Newton correction: the increment accumulates dz, tau moves by dtau
    virtual void accumulate(const Eigen::VectorXd& dz, double dtau) = 0;
    // Solve the whole bordered matrix, not by block elimination: the tangent is singular
    // by construction (a zero mode that the border equation fixes), where an LU of it may
    // or may not fail on round-off.
    virtual bool bordered_only() const { return false; }
};

// The spherical arc-length constraint of one continuation step as static_newton's border
// (pipeflex.analysis.arclength): the path parameter tau sets the equations' static mass flow
// mdot = m0 + m1 tau [kg/s] and load factor l0 + l1 tau; g = (|W dq|^2 + psi2 dtau^2 - ds^2)
// / ds^2 on the increment (dq, dtau) from the step's start (w2: the squared weights W^2, n).
struct ArcPath {
    double m0 = 0.0, m1 = 0.0, l0 = 0.0, l1 = 1.0;
};
struct ArcBorder final : StaticBorder {
    Equations& eq;
    ArcPath path;
    Eigen::VectorXd w2, dq;
    double psi2, ds, tau, dtau;
    ArcBorder(Equations& e, const ArcPath& p, Eigen::VectorXd w2_, Eigen::VectorXd dq_, double psi2_, double ds_,
              double tau_, double dtau_)
        : eq(e), path(p), w2(std::move(w2_)), dq(std::move(dq_)), psi2(psi2_), ds(ds_), tau(tau_), dtau(dtau_) {
        set_parameter(tau);
    }
    double parameter() const override { return tau; }
    void set_parameter(double t) override {
        eq.set_static_mass_flow(path.m0 + path.m1 * t);
        eq.set_static_load_factor(path.l0 + path.l1 * t);
    }
    double constraint(Eigen::VectorXd* c, double* d) const override {
        const double ds2 = ds * ds;
        if (c != nullptr) {
            *c = (2.0 / ds2) * w2.cwiseProduct(dq);
            *d = 2.0 * psi2 * dtau / ds2;
        }
        return (w2.cwiseProduct(dq).dot(dq) + psi2 * dtau * dtau - ds2) / ds2;
    }
    void accumulate(const Eigen::VectorXd& dz, double dt) override {
        dq += dz;
        dtau += dt;
        tau += dt;
        set_parameter(tau);
    }
};

struct StaticNewtonOptions {
    double tol = 1e-10;      // correction / length_scale
    int max_iterations = 25;
    // [N] > 0: the model's force level F. A start with |R| <= tol F is converged (a warm
    // start: no iteration); an iteration whose residual is below 1e-3 tol max(F, the
    // largest |R| seen) converges (the correction applied) even if the correction is not
    // small: a stiff model's corrections stall above tol at round-off of the residual.
    double force_scale = 0.0;
    // Apply the converged correction (element models: the result is the Newton iterate
    // after it, and its residual is evaluated there). Off for the multibody systems: an
    // exact state, such as a straight pipe under flow, keeps its exact symmetry.
    bool apply_converged_correction = false;
    // A correction longer than this many model sizes is divergence (a nearly singular
    // tangent); <= 0: none (element models: a large first correction onto a far branch of
    // the path is the load stepping's to judge).
    double divergence = 10.0;
    // ...applied from this iteration on (element models: 2; the first correction from the
    // start may be long, a later one that long is Newton diverging, and failing at once
    // lets the load stepping halve the step without 25 wasted iterations)
    int divergence_from = 1;
    // Count the negative eigenvalues of a symmetric tangent (the negative pivots of its
    // LDL^T, Sylvester's law of inertia) at the start and at the converged end (one more
    // tangent and factorisation), for the load stepping's acceptance test: along a
    // regular equilibrium path the count is constant; a step that changes it crossed a
    // critical point. Systems without constraints only; a non-symmetric tangent (flow
    // forces) is not counted.
    bool inertia = false;
    // A border: Newton on [K, dR/dtau; c^T, d] by block elimination (two solves with K's
    // LU), the whole bordered matrix where K is singular (it is regular at a simple limit
    // point) or the border says so (bordered_only). With constraints always the whole
    // bordered KKT matrix [K, s C_q^T, dR/dtau; s C_q, 0, s dc/dtau; c^T, 0, d] (scaled as
    // without a border), and the constraints must hold too.
    // Converged when the correction is below tol model sizes and that of tau below
    // tol max(1, |tau|) (or, with |g| <= tol, that relative correction stalls at round-off
    // within 1e3 tol), or the residual below 1e-3 tol times the force level and |g| <= tol
    // (a warm start: |R| <= tol F and |g| <= tol).
    StaticBorder* border = nullptr;
    // Below this many unknowns the tangent is factorised densely (FixedPatternLU); < 0:
    // kDenseLuBelow, the integrators' crossover.
    int dense_below = -1;
    // A mechanism (joints that leave a rigid motion free: a free hinge, a spherical joint)
    // has a singular KKT matrix. Empty, or n weights (nonzero on the coordinates S whose
    // free motions make the mechanism: the bodies' frames): the stiffness is penalised by
    // shift_i s (s the stiffness block's largest magnitude) on the motions of S that the
    // constraints leave free, which makes the KKT matrix regular, and the correction is
    // filtered by three more solves with the same LU, so that a free motion much softer than
    // the penalty (loaded or not) keeps its value, as a truncated pseudo-inverse keeps it,
    // and one much stiffer converges at the rate 4 penalty / its stiffness, 6 (penalty / its
    // stiffness)^2 once the residual on the free motions has fallen below 1e-3 of the force
    // level, near the start (static_newton.cpp: kSafeFilter, kFastFilter). The residual is
    // not penalised, so neither is the equilibrium; a loaded free motion keeps its residual
    // (the caller judges it). Not with a border.
    Eigen::VectorXd shift;
};
// The constraint Gram matrix of a set S of coordinates (a mechanism's: the bodies' frames),
// the one concept behind the mechanism test, static_newton's penalty on the free motions
// (StaticNewtonOptions::shift) and the free-motion force: C (nc x n) the constraint rows'
// S columns of the KKT triplets J (rows >= n, unscaled), W = diag(w) (w nonzero on S),
// CW = C W, G = C W C^T (banded for a chain: sparse, linear in the bodies).
struct FrameGram {
    FrameGram(const Triplets& J, int n, int nc, const Eigen::VectorXd& w);
    // The motions of S that C leaves free: |S| - rank C, the pivots of G's L D L^T (G
    // regularised by 1e-12 of its largest diagonal, so dependent rows, a body clamped at
    // both ends, give pivots of that size) below 1e-10 of the largest counted as zero.
    int free_motions();
    // f (n) on S projected off range(C^T) in W's metric, f - C^T G^-1 C W f (zero off S):
    // the part of a force on S that no constraint reaction balances (C W of it is zero).
    // (With the penalty's W, uniform on S, the metric of the frames' coordinates: whether a
    // force is balanced does not depend on it, only the size of the part that is not.)
    Eigen::VectorXd free_force(const Eigen::VectorXd& f);
    Eigen::SparseMatrix<double> C, CW, G;
    int n_shifted = 0;  // |S|

   private:
    void factorize();
    Eigen::VectorXd w_;
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower> ldlt_;
    bool factorized_ = false;
};

// The free motions of S (w's nonzero entries) at the equations' state at rest under their
// loads (load factor as set), with the multipliers lam: FrameGram's count, the residual's
// free-motion force (n, zero off S) and the largest constraint reaction on S, max |C^T lam|.
struct FreeMotions {
    int count = -1;  // -1: not evaluated
    Eigen::VectorXd force;
    double reaction = 0.0;
};
FreeMotions free_motions(Equations& eq, double t, const Eigen::VectorXd& lam, const Eigen::VectorXd& w);

struct StaticNewtonResult {
    bool converged = false, singular = false;
    bool diverged = false;   // a correction longer than options.divergence model sizes
    bool nonfinite = false;  // the residual is not finite (the state left the model's domain)
    int iterations = 0;
    double residual = 0.0;    // |R + C_q^T lambda| at the end [N]
    double correction = 0.0;  // last |dz| [m, rad]
    // with options.inertia: the negative eigenvalues of the tangent at the start and at the
    // converged end (-1: not counted: no iteration, or a zero pivot)
    int negative_start = -1, negative_end = -1;
    // with options.shift, converged: the free motions at the end state (FreeMotions), so
    // that the caller judges whether the loads drive one
    FreeMotions free;
};
StaticNewtonResult static_newton(Equations& eq, double t, Eigen::VectorXd& lam, const StaticNewtonOptions& opt);
// The number of negative eigenvalues of a symmetric n x n matrix given by triplets
// (repeats summed), from a sparse LDL^T; -1 if a pivot is zero (singular) or the matrix
// is not symmetric (to 1e-10 of its norm).
int negative_eigenvalues(const Triplets& J, int n);
inline StaticNewtonResult static_newton(Equations& eq, double t, Eigen::VectorXd& lam, double tol,
                                        int max_iterations) {
    StaticNewtonOptions opt;
    opt.tol = tol;
    opt.max_iterations = max_iterations;
    return static_newton(eq, t, lam, opt);
}

// The Lie-group generalised-alpha integrator (Arnold & Bruls 2007) of any system: equal
// steps within each interval between output times, halved after a failed Newton
// iteration and doubled back after (or error-controlled steps, or the steps given:
// AlphaOptions); the frames re-based after every step.
class GeneralizedAlpha {
   public:
    // Starts at time t0 from the state's rates v (n) with consistent a and lambda.
    GeneralizedAlpha(Equations& eq, const AlphaOptions& opt, double t0, const Eigen::VectorXd& v0);
    ~GeneralizedAlpha();
    GeneralizedAlpha(const GeneralizedAlpha&) = delete;
    GeneralizedAlpha& operator=(const GeneralizedAlpha&) = delete;

    // Steps to time t_out (> time()); afterwards the system is set to the state there.
    void advance_to(double t_out);
    double time() const { return t_; }
    const Eigen::VectorXd& velocity() const { return v_; }
    const Eigen::VectorXd& acceleration() const { return a_; }
    const Eigen::VectorXd& multipliers() const { return lam_; }
    const AlphaStats& stats() const { return stats_; }
    // [s] the accepted steps in order (error-controlled runs only: error_rate > 0)
    const std::vector<double>& steps_taken() const { return taken_; }

   private:
    Equations& eq_;
    AlphaOptions opt_;
    AlphaMethod method_;
    AlphaNewton newton_;
    AlphaStats stats_;
    // The predictor of the next step's acceleration an: whichever would have been
    // closest to the last step's converged one (another than the extrapolated only if
    // clearly closer) if the system allows (Equations::adaptive_prediction), else the
    // extrapolated one.
    enum class Prediction {
        extrapolated,  // linear in time from the last two steps: O(h^2) on smooth motion
        constant,      // an = a
        zero,          // an = 0 (Arnold & Bruls' predictor)
        zero_pseudo,   // the step's pseudo-acceleration pan = 0: z' = z + h v + h^2 (1/2 - beta) pa;
                       // the closest where stiff modes ring (a fine mesh started off balance)
    };
    Prediction prediction_ = Prediction::extrapolated;
    bool adaptive_prediction_;
    double t_ = 0.0, h_ = 0.0, h_prev_ = 0.0, t_start_ = 0.0;
    // [s] the step of the last Newton failure (error control), relaxed after each accepted step
    double newton_cap_ = std::numeric_limits<double>::infinity();
    std::vector<double> taken_;
    std::size_t replayed_ = 0;  // steps of opt_.steps taken
    Eigen::VectorXd v_, a_, pa_, lam_, an_, pan_, zn_, vn_, a_prev_, zero_, offset_, lam_start_, pa_rescaled_;
    Eigen::VectorXd error_weights_;  // s_i / error_rate: a coordinate's error in [s]
    // The local error of the step just converged (step hs, ending at tn) in tolerances
    // error_rate hs (<= 1: accepted, per unit step); filtered through the iteration matrix (two residual
    // evaluations) on a retry whose estimate did not fall with the step, and after a step
    // accepted so until the unfiltered estimate meets the tolerance again.
    double local_error(double hs, double tn);
    Eigen::VectorXd filtered_, residual_, residual_shifted_;  // local_error's work vectors
    double raw_error_ = 0.0;                          // the last step's unfiltered estimate
    double rejected_step_ = 0.0, rejected_error_ = 0.0;  // the last rejected try (0: none since)
    bool ringing_ = false;  // the last accepted step passed by its filtered estimate alone
    // The tolerance's factor from the motion's size at the step's start: (error_rate +
    // motion_rate (D - L)) / error_rate, exactly 1 while D <= L (a motion within the model)
    double motion_factor_ = 1.0;
    void measure_motion();
};

}  // namespace pipeflex
