// One system object of any formulation (an element model, floating-frame bodies, both
// coupled) with the state it works on: what every analysis takes. The analyses below are
// written once, on System and Equations; a formulation only builds its System.
//
// An analysis starts a Run on the system (the formulation's equations at the system's
// state, driven by a mass flow and a load factor in time, for dynamics or statics), solves
// on the run's Equations, records the run's state at output times and finishes the run,
// which leaves the end state in the system.
#pragma once

#include "pipeflex/multibody/multibody.hpp"
#include "pipeflex/solvers/equations.hpp"
#include "pipeflex/solvers/linear_matrices.hpp"
#include "pipeflex/solvers/rotating_systems.hpp"
#include "pipeflex/solvers/sensors.hpp"
#include "pipeflex/solvers/transient.hpp"

#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace pipeflex {

// A run's outputs by name: per output time, a block of values of a fixed shape per name
// (a node's position: shape (n_nodes, 3)), and the integrator's counters.
struct Record {
    struct Series {
        std::vector<long> shape;  // of one output time's block
        std::vector<double> data;
    };
    std::vector<double> t;
    std::vector<std::pair<std::string, Series>> series;
    // the integrator's work: steps, newton_iterations, jacobians, rebases, failed_steps
    // (IDA's error-test failures), convergence_failures (steps redone after Newton failed)
    std::vector<std::pair<std::string, long>> counters;
    // the step control's figures (error-controlled generalised-alpha): error_sum and
    // error_max [m] (AlphaStats), smallest_step and largest_step [s]; none with a fixed step
    std::vector<std::pair<std::string, double>> estimates;
    std::vector<double> steps;  // [s] the accepted steps of an error-controlled run, in order
    // The series `name`, added with `shape` the first time.
    Series& operator()(const std::string& name, const std::vector<long>& shape);
};

// What drives a run: the mass flow [kg/s] and the load factor (loads and gravity) as
// functions of time, and the options (one vocabulary for every formulation).
struct Drive {
    TimeTable mass_flow = TimeTable::constant(0.0);
    TimeTable load_factor = TimeTable::constant(1.0);
    TransientOptions options;
    SensorLog* sensors = nullptr;  // transient runs: recorded at every accepted step (sensors.hpp)
};

// The equations of one analysis at the system's state. For statics the mass flow is its
// value at t = 0 and the loads are scaled by Equations::set_static_load_factor.
class Run {
   public:
    virtual ~Run() = default;
    virtual Equations& equations() = 0;
    // After the integrator has set the start up (consistent accelerations): bookkeeping.
    virtual void begin(double t) { (void)t; }
    // The state the equations are set to, at output time t.
    virtual void record(double t, Record& out) = 0;
    // A sensor at the equations' state set, time t [s]: value (s.width()) and, where the
    // state gives it, its rate (left NaN otherwise); std::invalid_argument where the
    // system has no such quantity.
    virtual void sense(const SensorSpec& s, double t, double* value, double* rate) {
        (void)t, (void)value, (void)rate;
        throw std::invalid_argument("sensor of kind " + std::to_string(static_cast<int>(s.kind)) +
                                    " is not available on this system");
    }
    // The equations' state (as set) back into the system; statics: at rest, with the
    // multipliers lam.
    virtual void finish() = 0;
    // The start: time [s], rates (chart of z = 0) and multipliers of the system's state.
    double t0 = 0.0;
    Eigen::VectorXd v, a, lam;
    // Floating frames (the flow map re-bases them every step, as dynamics does): the
    // coordinates [frames_begin, frames_end) are the bodies' (frames and modal amplitudes),
    // re-based together; frame_rotations: the first of each frame's three rotation
    // coordinates (R = exp(z~) R0; their rates are spatial angular velocities, which
    // re-basing keeps). None: the fixed chart is exact (element nodes' rates are chart rates).
    std::vector<int> frame_rotations;
    int frames_begin = 0, frames_end = 0;
    // The frames' coordinates of the state set become their base (z = 0 there).
    virtual void rebase_frames() {}
};

class System {
   public:
    // dynamics: the chart re-based onto the state's frames at the start (z = 0 there);
    // fixed_chart: dynamics in the chart of the state as it is (z relative to it: the flow
    // map's); statics: as Run says.
    enum class Mode { dynamics, fixed_chart, statics };
    virtual ~System() = default;
    virtual std::unique_ptr<Run> start(const Drive& drive, Mode mode) = 0;
    // The formulation's part of the static Newton's options (each override says why).
    // mechanism: the joints leave a rigid motion free (penalised; bodies only).
    virtual void static_policy(StaticNewtonOptions& opt, bool mechanism) const {
        (void)opt;
        if (mechanism) throw std::invalid_argument("mechanism: only systems of bodies have free frame motions");
    }
    // [m] the model's size (Newton's tests)
    virtual double length_scale() const = 0;
    virtual int n_coordinates() const = 0;
    virtual int n_constraints() const { return 0; }
    // Per coordinate (n): 1 if it is a length [m] (positions, a body's elastic amplitudes),
    // else 0 (rotations [rad], ANCF slopes [-]): the arc-length metric's weights.
    virtual Eigen::VectorXd length_coordinates() const = 0;
    // Values recorded per output time (Run::record), to bound a run's output memory.
    virtual double record_size() const = 0;
    // The system in rigid rotation about its hinge at the mass flow mdot [kg/s] (the
    // formulation's rigid-rotation equations), from its state; pin (n): the hinge angle's
    // row, lam: the state's multipliers. RotatingSystem::finish leaves the end state here.
    virtual std::unique_ptr<RotatingSystem> rotating(const RotationHinge& hinge, double mdot, Eigen::VectorXd& pin,
                                                     Eigen::VectorXd& lam) = 0;
    // The parts' own state: the bodies' (nullptr without bodies), the couplings'
    // multipliers (nullptr without couplings).
    virtual MbState* body_state() { return nullptr; }
    virtual const State* element_state() const { return nullptr; }  // the element model's (nullptr without)
    virtual const MultibodySystemCore* bodies() const { return nullptr; }
    virtual Eigen::VectorXd* coupling_multipliers() { return nullptr; }
    // The linearisation's tangent pattern, kept across linearize() calls on this system
    // (TangentCsc; one analysis at a time on a system, as for its state).
    TangentCsc& tangent_csc() { return tangent_csc_; }

   private:
    TangentCsc tangent_csc_;
};

// The element model (the model, the state updated in place by every analysis, the load
// state: gravity, hub frame; its mass flow is the drive's).
std::unique_ptr<System> element_system(const Model& model, State& state, const LoadState& load);
// An element model's part of the static Newton's options (its system's static_policy,
// and the arc-length corrector's): the converged correction is applied (the result is the
// Newton iterate after it, its residual evaluated there), and divergence is judged from the
// second correction on (the first from the start may land on a far branch of the path,
// which the load stepping judges).
void element_static_policy(StaticNewtonOptions& opt);

// [m] An element model's size for Newton's tests: the largest extent of its reference
// node positions along x, y or z, at least kMinLengthScale (a model of coincident nodes).
constexpr double kMinLengthScale = 1e-3;
double model_length_scale(const Model& model);
// An element run's outputs (TransientOutput: x, R, xd, omega, energies, work) appended to
// the record's series (not its times); the counters too if `counters`.
void append_element_outputs(const TransientOutput& o, long n_nodes, Record& out, bool counters = false);
class ElementEquations;
// The element equations' state as set, at output time t, appended to the record.
void record_element(const ElementEquations& eq, double t, Record& out);
// Bodies and joints, the state owned (body_state() reads it).
std::unique_ptr<System> body_system(const MultibodySystemCore& bodies, const MbState& state);
// A body state's outputs appended to the record's series: r (n_bodies, 3), R (n_bodies,
// 3, 3), eta, v, a, lam and drift (max |C_q v|, at the mass flow at t; ev: scratch), each
// name after the prefix.
void append_body_outputs(const MultibodySystemCore& bodies, const MbState& s, const TimeTable& mass_flow, double t,
                         MbEvaluation& ev, Record& out, const std::string& prefix = "");

// length_coordinates of an element model's reduced coordinates (1 where a coordinate's
// basis column moves only node positions) and of bodies' coordinates (frame origins and
// elastic amplitudes).
Eigen::VectorXd element_length_coordinates(const Model& model);
Eigen::VectorXd body_length_coordinates(const MultibodySystemCore& bodies);

// Static equilibrium under the constant mass flow mdot [kg/s] with the loads and gravity
// times load_factor, by the one static_newton from the system's state (updated); the
// formulation adds its policy (System::static_policy).
StaticNewtonResult static_equilibrium(System& sys, double mdot, double load_factor, StaticNewtonOptions opt,
                                      const TransientOptions& options, bool mechanism = false);

// One arc-length step's Newton corrector (static_newton with ArcBorder) on the system: from
// its state (the step's start) moved by the predictor dq (n; predict false: the state is
// the predictor's already, dq the increment from the step's start), with tau the predicted path
// parameter and dtau its increment; tau, dq and dtau updated (the increment accumulated from
// the step's start), the end state left in the system; the formulation's static_policy.
StaticNewtonResult static_arc_newton(System& sys, const ArcPath& path, const Eigen::VectorXd& w2, double psi2,
                                     double ds, double& tau, Eigen::VectorXd& dq, double& dtau,
                                     StaticNewtonOptions opt, const TransientOptions& options, bool predict = true);
// The unit tangent (v (n), s) of the equilibrium path R(q, tau) = 0 (and the constraints) at
// the system's state at tau, in the metric |W v|^2 + psi2 s^2 (w2 = W^2), oriented along the
// previous tangent (pq (n), pt): from the bordered matrix [K, dR/dtau; W^2 pq, psi2 pt]
// (dR/dtau by central differences of step 1/2, exact for a residual quadratic in tau; with
// constraints the KKT matrix, scaled as static_newton's). False if it is singular.
bool static_arc_tangent(System& sys, const ArcPath& path, double tau, const Eigen::VectorXd& w2, double psi2,
                        const Eigen::VectorXd& pq, double pt, Eigen::VectorXd& v, double& s,
                        const TransientOptions& options);

// The linearised equations (linear_matrices) about the system's state (its rates and
// multipliers) under the constant mass flow mdot [kg/s].
// mdot_rate [kg/s^2]: the flow's rate at the state (the fluid's acceleration terms of an
// element model; floating-frame bodies have none).
LinearMatrices linearize(System& sys, double mdot, const TransientOptions& options, double differences_step = 0.0,
                         double mdot_rate = 0.0);

// Generalised-alpha from the system's state (time times.front(), its rates, consistent
// accelerations and multipliers) through the output times; the end state stays in the
// system.
Record integrate(System& sys, const Drive& drive, const std::vector<double>& times, const ProgressFn& progress);

// Steady rotation of the system about its hinge at the mass flow mdot [kg/s] (one
// static_newton with omega as its border: rotating_systems.hpp) from its state (updated:
// the last iterate with the rotation's rates), omega from omega_guess (NaN: the rigid
// balance of the starting shape).
SteadyRotationOutcome steady_rotation(System& sys, const RotationHinge& hinge, double mdot, double omega_guess,
                                      const SteadyRotationOptions& opt);

// The generalised-alpha flow map of the system, autonomous (constant mass flow mdot [kg/s],
// loads at their full value), over `duration` [s] in n_steps equal steps in the chart of
// the system's state: from z0 [m, rad, ...] and v0 (n each) to z, v at the end. Element
// nodes stay in the fixed chart (no re-basing, so their rotations must stay well below pi
// from it); floating frames (Run::frame_rotations) are re-based every step, as integrate
// does, and their z at every step is in the start chart (the rotation's log relative to
// the state's frame, below pi; v spatial as v0). With sensitivity also its tangent-
// linear map d(z, v)_end / d(z0, v0) (FlowMapTangent; the initial acceleration and
// multipliers consistent with z0, v0), with the exact iteration matrix of every step:
// applied to the identity it is the monodromy matrix of a periodic orbit, whose
// eigenvalues are its Floquet multipliers. The frames' sensitivities are transported
// through each step's chart change (flow_map.cpp). With constraints each step's linearisation is
// its KKT system, so a direction that violates them is mapped onto them by the first step
// (a zero multiplier per constrained direction). load_factor: the nodal loads' factor
// lambda(t), t from 0 at z0 (default 1: autonomous); a Sine of period `duration` makes it
// the stroboscopic map of a forced system (analysis/forced.py).
FlowMapOutput flow_map(System& sys, double mdot, const Eigen::VectorXd& z0, const Eigen::VectorXd& v0, double duration,
                       int n_steps, bool sensitivity, const TransientOptions& options,
                       const TimeTable& load_factor = TimeTable::constant(1.0));

}  // namespace pipeflex
