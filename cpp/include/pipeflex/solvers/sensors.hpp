// Sensors: quantities recorded at every accepted step of a transient run (not only at the
// output times), and crossing (event) sensors that locate the times a sensor passes a
// level inside the step and may end the run.
//
// The integrators call the equations' StepObserver after each accepted step, with the
// state set to the step's end (Equations::observer); the SensorRecorder evaluates its
// sensors there through the run (Run::sense) into growing buffers. A crossing is located
// on the cubic Hermite interpolant of its sensor component between the two step ends,
// with the component's rate where the state gives it (a position's velocity, a
// velocity's acceleration, an angle's angular velocity) and otherwise the rates of the
// parabola through the last three steps' values (the secant on the first step).
#pragma once

#include "pipeflex/solvers/equations.hpp"

#include <array>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace pipeflex {

class Run;
class ElementEquations;
class MultibodySystemCore;
class Element;
struct MbState;
struct State;
struct LoadState;

enum class SensorKind : int {
    node_position = 0,      // x (3) [m]
    node_velocity = 1,      // v (3) [m/s]
    node_acceleration = 2,  // a (3) [m/s^2]
    node_rotation = 3,      // rotation vector log(R) (3) [rad] from the reference orientation
    node_angle = 4,         // axis . log(R) [rad], unwrapped (1)
    energy = 5,             // kinetic, elastic, gravity potential, their sum (4) [J]
    strain = 6,             // pipe element at s: axial strain, twist and curvatures (4) [-, 1/m]
    section_force = 7,      // pipe element at s: N [N], T, M_y, M_z [N m] (4)
    axial_spring = 8,       // tension (1) [N] of the element (an axial spring)
    ground_spring = 9,      // the force on its node (3) [N] of the element (a ground spring)
    joint_force = 10,       // a joint's multipliers (rows) [N, N m]: index its first constraint row
    bushing = 11,           // the force on its node b (3) [N] of the element (a bushing)
    custom = 12,            // a user's function of the state (rows values): SensorSpec::custom
};

// Which part of a system a sensor reads: an element model's nodes, elements and springs;
// the bodies' nodes, springs and joints; a coupled system's couplings (their multipliers).
enum class SensorPart : int { elements = 0, bodies = 1, couplings = 2 };

// What a custom sensor sees: the parts' states as set (nullptr: the system has no such part).
struct SensorState {
    const State* elements = nullptr;
    const MbState* bodies = nullptr;
    const Eigen::VectorXd* coupling_multipliers = nullptr;
};
// A custom sensor's function: its values (SensorSpec::rows) at time t [s] and the state.
using CustomSensor = std::function<void(double t, const SensorState& state, double* value)>;

struct SensorSpec {
    SensorKind kind = SensorKind::node_position;
    int index = 0;                    // node, or element (its index in the model's registry)
    double s = 0.0;                   // local coordinate along the element in [0, 1]
    std::array<double, 3> axis{};     // node_angle: the unit axis
    int rows = 0;                     // joint_force: the joint's constraint rows; custom: its values
    SensorPart part = SensorPart::elements;
    int body = 0;                     // part bodies, node sensors: the node's body (index: its node)
    std::array<double, 9> frame{};    // a body node's rotation: its reference orientation A0 (row-major)
    std::shared_ptr<const CustomSensor> custom;  // custom: the function
    int width() const;
};

struct CrossingSpec {
    int sensor = 0;      // the sensor (index in the recorder's list)
    int component = 0;   // of its values
    double level = 0.0;  // [the sensor's unit]
    int direction = 0;   // +1 up, -1 down, 0 both
    bool terminal = false;
};

// Thrown by the recorder when a terminal crossing is found: the integrators' callers end
// the run at that step (the state set to its end).
struct TerminalEvent {
    double time;  // the crossing's time [s]
};

// The sensors of one run and what they recorded.
class SensorLog {
   public:
    std::vector<SensorSpec> sensors;
    std::vector<CrossingSpec> crossings;
    // recorded: the start and every accepted step's end
    std::vector<double> t;
    std::vector<std::vector<double>> values;          // per sensor: width values per time
    std::vector<std::vector<double>> crossing_times;  // per crossing [s]
    std::vector<std::vector<int>> crossing_signs;     // per crossing: +1 up, -1 down
    bool stopped = false;                             // a terminal crossing ended the run
    double stop_time = 0.0;                           // its time [s]
    // Empties the records (a new run), keeping the specifications; checks them.
    void reset();
    bool empty() const { return sensors.empty(); }
};

// Evaluates the log's sensors at each accepted step through the run, and its crossings.
class SensorRecorder final : public StepObserver {
   public:
    SensorRecorder(Run& run, SensorLog& log);
    // At the state set to time t (the start or an accepted step's end). Throws
    // TerminalEvent after recording, if a terminal crossing lies in the step.
    void step(double t) override;

   private:
    Run& run_;
    SensorLog& log_;
    std::vector<std::vector<double>> rate_, last_rate_;  // per sensor: the rates (NaN: none)
    std::vector<double> buf_, rate_buf_;
};

// An element model's sensor at the equations' state set, time t [s]: value (width) and,
// where the state gives it, rate (width; left NaN otherwise). std::invalid_argument for a
// node or element out of range or of the wrong type.
void sense_element(const ElementEquations& eq, const SensorSpec& s, double t, double* value, double* rate);
// A sensor of floating-frame bodies at their state st, time t [s] (as sense_element): a
// body node's kinematics (position, velocity, acceleration, rotation from its reference
// orientation frame), the bodies' energies, a body spring's force, a joint's multipliers.
void sense_bodies(const MultibodySystemCore& sys, const MbState& st, const SensorSpec& s, double t, double* value,
                  double* rate);
// A spring element's force at the state st (s.kind: axial_spring, its tension [N], or
// ground_spring, the force on its node [N]); std::invalid_argument if el is not one.
void sense_spring(const Element& el, const State& st, const LoadState& load, const SensorSpec& s, double* value);
// A custom sensor (s.custom) at the state: value (s.rows); false if s is not custom.
bool sense_custom(const SensorSpec& s, double t, const SensorState& state, double* value);

}  // namespace pipeflex
