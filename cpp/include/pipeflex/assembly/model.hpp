// Model (immutable after construction), State (mutable) and the assembler.
//
// Every node carries 6 coordinates: a frame node [x (3) m, phi (3) rad], an ANCF node
// [r (3) m, r' (3) -] (position and slope; planar elements use the x, y components and
// the builder fixes z, z'). Supports are linear
// constraints on them, eliminated through a per-node basis T_n (6 x k_n): the free
// (reduced) coordinates z give dq_n = T_n dz_n. The assembler evaluates
//     R(z) = T^T [ sum_e r_e(q, q_dot, q_ddot) - lambda f_ext(q) ]
// and the weighted tangent J = wK dR/dq + wC dR/dq_dot + wM dR/dq_ddot (reduced), one
// routine for static (1, 0, 0), linearisation (one weight at a time) and time stepping.
#pragma once

#include "pipeflex/assembly/element.hpp"
#include "pipeflex/elements/pipe_beam3d.hpp"

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace pipeflex {

// Prescribed rotation of the hub about the axis a through the centre c by the angle
// theta(t): eq. 13 of seed 002 (spin-up to Omega over spin_up_time T, then constant
// Omega), or theta = Omega t when T = 0.
//  * Frame nodes (pipe elements) are driven in inertial coordinates: the hub nodes must
//    be clamped; a node at X (reference) is carried to c + R(theta)(X - c) and its frame
//    turns with R(theta).
//  * ANCF hub nodes: the model is integrated in the co-rotating hub frame (co_rotating),
//    where the clamp is fixed and the elements feel the frame's fictitious forces; the
//    clamp fixes the slope's direction, not its length (the root strain stays free).
//    The axis must be z and all elements ANCF.
struct HubDrive {
    std::vector<int> nodes;
    Vec3<double> axis{{0.0, 0.0, 1.0}};  // unit axis a
    Vec3<double> center{};              // c [m]
    double omega = 0.0;                 // Omega [rad/s] final angular velocity
    double spin_up_time = 0.0;          // T [s]
    bool co_rotating = false;           // set by Model::finalize (ANCF hub nodes)
    // theta [rad], theta_dot [rad/s], theta_ddot [rad/s^2] at time t [s].
    void angle(double t, double* th, double* thd, double* thdd) const;
};

struct TimeTable;  // solvers/transient.hpp

// A load given by a function (the bindings' Python callables): at time t [s], the node's
// position x (3) [m] and velocity v (3) [m/s] (its first 3 coordinates and their rates),
// writes the force f (3) [N] and moment m (3) [N m] in global axes; it throws on failure
// (the message names the load and t).
using LoadFunction = std::function<void(double t, const double* x, const double* v, double* f, double* m)>;

// Nodal load: dead force/moment in global axes, follower force/moment in the node frame,
// or (function set) the function's force and moment. Each is scaled by the load factor
// and, if set, by its own time function at the load state's time (LoadState::time).
struct NodalLoad {
    int node = 0;
    Vec3<double> force{}, moment{};                  // [N], [N m] dead
    Vec3<double> follower_force{}, follower_moment{};  // [N], [N m] in the node frame
    std::shared_ptr<const TimeTable> time_function;  // null: 1
    LoadFunction function;                           // empty: the constant load above
    std::string label;                               // the function's name in error messages
};

// Concentrated mass at a node: mass [kg] and rotary inertia [kg m^2] in the node frame.
struct NodalMass {
    int node = 0;
    double mass = 0.0;
    Vec3<double> inertia{};
};

// A distributed dead load on an element: q [N/m] per unit of its reference length, in
// global axes, times its time function (null: 1) and the load factor. Consistent like
// the element's gravity, which carries it (Element::line_mass).
struct DistributedLoad {
    int element = 0;
    Vec3<double> force_per_length{};
    std::shared_ptr<const TimeTable> time_function;
};

struct TangentPattern;

struct Model {
    std::vector<Vec3<double>> positions;  // reference node positions [m]
    // Every element (pipe_element.hpp, ancf_element.hpp, ...: the Element interface), in
    // the order added; the assembler sums their contributions in this order.
    ElementList elements;
    std::vector<NodeKind> kinds;          // per node (default frame)
    std::vector<Vec3<double>> slopes;     // reference slope r' of ANCF nodes
    HubDrive hub;
    std::vector<NodalLoad> loads;
    std::vector<NodalMass> masses;
    std::vector<DistributedLoad> distributed_loads;
    // Set by finalize: per element, its distributed loads (indices; empty if none at all)
    std::vector<std::vector<int>> element_loads;
    std::vector<Eigen::MatrixXd> bases;  // T_n (6 x k_n) per node
    std::vector<int> first_dof;          // first reduced coordinate of each node
    // per node: whether T_n only selects slots, and the slot of each reduced coordinate
    std::vector<bool> is_selection;
    std::vector<std::vector<int>> selected;
    // When every basis is a selection (the common case): the slot in the 6-per-node vector
    // of each reduced coordinate (n_dofs entries; empty otherwise)
    std::vector<int> full_slot;
    std::vector<int> reduced_slot;  // the inverse, 6 per node (-1: a fixed slot)
    int n_dofs = 0;
    // Set by finalize from the elements: the first of each element's stresses of the
    // mixed Newton (Element::n_stresses) and their total; whether an element takes the
    // nodes' rotation kinematics (Element::uses_node_motions); the most nodes of one.
    std::vector<int> stress_offset;
    int n_stresses = 0;
    bool uses_node_motions = false;
    int max_element_nodes = 0;
    // The CSC pattern of the tangent, built by tangent_pattern() at its first use and
    // dropped by finalize(): every change of the structure ends with finalize().
    mutable std::shared_ptr<const TangentPattern> pattern_cache;

    int n_nodes() const { return static_cast<int>(positions.size()); }
    void finalize();  // numbers the reduced coordinates; checks consistency
};

// Triad of a planar (ANCF) node: e1 along the slope dr/dx, e3 = z, e2 = e3 x e1.
Mat3<double> planar_triad(const Vec3<double>& slope);

struct State {
    Eigen::VectorXd q, v, a;              // 6 per node: positions, rotation vectors
    std::vector<Mat3<double>> frames;     // reference rotation of each node

    explicit State(const Model& m);
    // Re-base the rotation of every node whose |phi| exceeds max_angle [rad] (rebase_frames).
    int rebase(double max_angle);
    // Nodal rotation matrix R = exp(phi) R_ref (ANCF node: e1 along the slope, e3 = z).
    Mat3<double> rotation(int node) const;
    // Largest |phi| over the frame nodes [rad].
    double max_rotation() const;
    // Throws std::invalid_argument unless q, v, a have 6 entries per frame (what the
    // setters of the bindings guarantee; checked again at every entry point).
    void check_sizes() const;
    std::vector<NodeKind> kinds;
};

// Throws std::invalid_argument unless the state fits the model: as many nodes, the
// same node kinds (a state of another model is refused before any buffer is read).
// Every entry point that takes a Model and a State calls it.
void check_state(const Model& model, const State& state);

struct Triplets {
    std::vector<int> rows, cols;
    std::vector<double> values;
    void clear() { rows.clear(); cols.clear(); values.clear(); }
    void add(int r, int c, double v) {
        rows.push_back(r);
        cols.push_back(c);
        values.push_back(v);
    }
};

// Reduced residual (size n_dofs) and, if J is not null, the weighted tangent.
// geometric_stresses (model.n_stresses, each element's at its stress_offset; may be null):
// the stresses of the elements' geometric stiffness (the pipe's: pipe_tangents'
// sigma_geometric).
void assemble(const Model& model, const State& state, const LoadState& load, double load_factor,
              double wK, double wC, double wM, Eigen::VectorXd* residual, Triplets* J,
              const double* geometric_stresses = nullptr);

// The elements' stresses of the mixed Newton extrapolated from the state along the
// full-coordinate increment dq (model.n_stresses, as geometric_stresses above; the pipe's:
// pipe_predicted_stresses).
void predicted_stresses(const Model& model, const State& state, const Eigen::VectorXd& dq,
                        std::vector<double>& sigma);

// Sparsity of the reduced tangent wK K + wC C + wM M for any weights (the assembler
// emits the same entries in the same order whatever the weights, state and loads):
// compressed columns (col_ptr, n + 1; row_index, rows ascending in each column, no
// repeats) and the value slot of each emitted entry, in emission order.
struct TangentPattern {
    int n = 0;
    std::vector<int> col_ptr, row_index;
    std::vector<int> slot;
    std::size_t nnz() const { return row_index.size(); }
};

// The model's tangent pattern, computed at the first call after finalize() and shared
// by later calls (safe from several threads: a race computes it twice).
std::shared_ptr<const TangentPattern> tangent_pattern(const Model& model);

// Reduced residual (if not null) and, in one pass over the elements, the tangent for
// each weight set w[i] written to values[i] (pattern->nnz() entries each, overwritten)
// on pattern = tangent_pattern(model): K, C and M at once without triplets.
// geometric_stresses: as assemble's. slot (pattern->slot.size() entries; null:
// pattern->slot): the value slot of each emitted entry in a larger pattern that holds the
// model's (TangentCsc: a coupled system's), the values then added to, not overwritten.
void assemble_csc(const Model& model, const State& state, const LoadState& load, double load_factor,
                  const std::vector<TangentWeights>& w, Eigen::VectorXd* residual, double* const* values,
                  const double* geometric_stresses = nullptr, const int* slot = nullptr);

// Geometric stiffness (reduced triplets) of the prestress that the full-coordinate
// displacement dq produces to first order about the state: ANCF Model A elements only
// (Element::prestress_stiffness; the others throw their prestress_unavailable()).
void assemble_geometric(const Model& model, const State& state, const Eigen::VectorXd& dq, Triplets* G);

// Set position, velocity and acceleration of the hub nodes to the drive's motion at t
// (inertial mode), or the frame rates of the load (co-rotating mode).
void apply_hub(const Model& model, State& state, double t);
void apply_hub_frame(const Model& model, LoadState& load, double t);

// Full (6 per node) generalised force of the external nodal loads at load factor 1 and
// time t [s] (the loads' time functions and load functions at t).
Eigen::VectorXd external_forces(const Model& model, const State& state, double t = 0.0);
// Their power v . external_forces [W] (state.v in the nodes' coordinates, as the forces).
double load_power(const Model& model, const State& state, double t);

// Add the reduced increment dz to the coordinates (q <- q + T dz); dz has n_dofs
// entries, full 6 per node (both checked).
void add_increment(const Model& model, Eigen::Ref<Eigen::VectorXd> full, const Eigen::VectorXd& dz);
// The state at reduced coordinates z around base (6 per node), rates vz and accelerations
// az: q = base + T z, v = T vz, a = T az (add_increment's, in one pass; sizes checked).
void set_state_coordinates(const Model& model, const Eigen::VectorXd& base, const Eigen::VectorXd& z,
                           const Eigen::VectorXd& vz, const Eigen::VectorXd& az, State& state);
Eigen::VectorXd reduce(const Model& model, const Eigen::VectorXd& full);  // T^T f (full: 6 per node, checked)
// The same into out (resized to n_dofs: no allocation once it has that size).
void reduce(const Model& model, const Eigen::VectorXd& full, Eigen::VectorXd& out);

// node_motion of every frame node at the state into motions (resized to n_nodes; the
// entries of ANCF nodes are left as they are).
void node_motions(const Model& model, const State& state, std::vector<NodeMotion<double>>& motions);
// Re-base the rotation of every frame node whose |phi| exceeds max_angle [rad]: R_ref <- R,
// phi <- 0, the angular velocity and acceleration kept (State::rebase). motions: the
// nodes' node_motion at the state (node_motions), or null (evaluated here).
int rebase_frames(State& state, double max_angle, const NodeMotion<double>* motions);

// Power of the fluid forces on the structure [W]: -v . f_fluid summed over the elements
// (the flow-dependent part of the pipe elements' residuals).
// motions: the nodes' node_motion at the state (node_motions), or null.
double fluid_power(const Model& model, const State& state, const LoadState& load,
                   const NodeMotion<double>* motions = nullptr);

// Whether an element has damping forces (Element::damped), and the power v . f_d [W]
// (>= 0) those forces take out of the motion, summed over the elements.
bool model_damped(const Model& model);
double damping_power(const Model& model, const State& state);

// Energies [J]: kinetic, elastic; potential of gravity is separate.
void energies(const Model& model, const State& state, double* kinetic, double* elastic);

}  // namespace pipeflex
