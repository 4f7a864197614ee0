// Time integration of  R(q, q_dot, q_ddot, t) = 0  (reduced coordinates).
//
// Two integrators, each written once on the Equations of any system:
//  * IDA (SUNDIALS, variable-order BDF; ida.hpp), on the stabilised index-2 form with
//    constraints;
//  * generalised-alpha (Arnold & Bruls 2007, Chung-Hulbert parameters from rho_inf),
//    Newton on the accelerations with the iteration matrix M + gamma' C + beta' K.
// Rotations are integrated in the rotation-vector chart of the nodes' reference frames
// and re-based (generalised-alpha: every step; IDA: when |phi| exceeds rebase_angle,
// followed by a re-initialisation). Velocities are carried as spatial angular
// velocities across a re-basing.
#pragma once

#include "pipeflex/assembly/model.hpp"
#include "pipeflex/errors.hpp"

#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace pipeflex {

// Function of time: a piecewise-linear table (constant beyond its ends), optionally an
// envelope modulating a sine carrier: f(t) = table(t) sin(omega t + phase) if omega != 0.
struct TimeTable {
    std::vector<double> t, value;
    double omega = 0.0;  // carrier angular frequency [rad/s] (0: no carrier)
    double phase = 0.0;  // carrier phase [rad]
    double mean = 0.0;   // constant added to the carried envelope (a pulsating flow's mean)
    double at(double time) const;
    double rate(double time) const;  // derivative
    static TimeTable constant(double value) {
        TimeTable f;
        f.t = {0.0};
        f.value = {value};
        return f;
    }
};

struct TransientOptions {
    double rtol = 1e-6;         // IDA relative tolerance
    double atol = 1e-8;         // IDA absolute tolerance [m, rad, m/s, rad/s]
    int max_order = 5;          // IDA: largest BDF order (2 is A-stable)
    double step = 1e-3;         // generalised-alpha step h [s] (error_rate > 0: the first step)
    double error_rate = 0.0;    // generalised-alpha: local error per unit time [m/s] (0: fixed step)
    double motion_rate = 0.0;   // generalised-alpha: its rise per metre of motion beyond the model [1/s]
                                // (AlphaOptions::motion_rate)
    bool error_per_step = false;  // generalised-alpha: the control per step (AlphaOptions::error_per_step)
    // generalised-alpha's error control, element models: the length [m] a node's rotation (or
    // ANCF slope) error counts at; 0: the node's longest element (ElementEquations::error_scales)
    double rotation_error_length = 0.0;
    std::vector<double> steps;  // generalised-alpha: the steps [s] to take in order (AlphaOptions::steps)
    double min_step = 1e-12;    // generalised-alpha: smallest step before giving up [s]
    double rho_inf = 0.9;       // generalised-alpha spectral radius at infinity
    double newton_tol = 1e-10;  // generalised-alpha: position correction / length_scale
    int max_newton = 12;
    long max_steps = 10000000;
    double rebase_angle = 1.0;  // IDA: re-base a node when |phi| exceeds this [rad]
    double length_scale = 1.0;  // [m] model size, for convergence tests
    bool work = true;           // integrate the work of fluid forces and loads every step
    double divergence_limit = 1e3;  // a node farther than this many length scales from its
                                    // reference position counts as divergence
};

struct TransientOutput {
    std::vector<double> t;
    std::vector<double> x, R, xd, w;  // per output: 3N positions, 9N rotations (row-major),
                                      // 3N velocities, 3N spatial angular velocities
    // energies and works [J]; dissipated: the energy the damping forces took out since the start
    std::vector<double> kinetic, elastic, gravity_potential, fluid_work, load_work, dissipated;
    long steps = 0, newton_iterations = 0, jacobians = 0, rebases = 0, failed_steps = 0,
         convergence_failures = 0;
};

using ProgressFn = std::function<void(double)>;

// The time functions scale the model's mass flow (mdot(t) = mass_flow(t)) and its
// nodal loads (f_ext(t) = load_factor(t) f_ext).
struct TimeFunctions {
    TimeTable mass_flow, load_factor;
};



// The tangent-linear map of a generalised-alpha flow map, kept step by step: K and C at
// every converged step and the step's exact iteration matrix M + gamma' C + beta' K,
// factorised (at the start M alone, for the initial acceleration consistent with z0, v0).
// apply() maps directions (dz0, dv0) to d(z, v)_end without integrating again: one pass
// of products and triangular solves per call, so a matrix-free (Krylov) shooting pays
// one flow map per Newton iteration and a pass per direction, and the monodromy matrix
// (the identity's 2n columns) is formed only when asked.
class FlowMapTangent {
   public:
    struct Impl;
    explicit FlowMapTangent(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}
    // (2n x p) directions [dz0; dv0] -> (2n x p) [dz; dv] at the end
    Eigen::MatrixXd apply(const Eigen::MatrixXd& directions) const;
    int dimension() const;       // 2n
    std::size_t bytes() const;   // memory held [bytes]

   private:
    std::shared_ptr<const Impl> impl_;
};

// A flow map's outcome (flow_map in system.hpp).
struct FlowMapOutput {
    std::vector<double> z;   // displacement after each step, (n_steps + 1) x n, row-major
    Eigen::VectorXd v, a;    // velocity and acceleration at the end
    Eigen::VectorXd a0;      // consistent initial acceleration
    std::shared_ptr<FlowMapTangent> tangent;  // with sensitivity only
    long steps = 0, newton_iterations = 0, jacobians = 0;
};


// Gravitational potential energy [J] of pipes and point masses: -sum m g . x.
double gravity_potential(const Model& model, const State& state, const LoadState& load);

}  // namespace pipeflex
