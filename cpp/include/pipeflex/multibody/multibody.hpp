// Systems of floating-frame bodies joined by Lagrange-multiplier joints (seed 004).
//
// Coordinates, body after body: q_j = [r_j; pi_j; eta_j] (pi a global rotation increment,
// R <- exp(pi~) R), velocities v_j = [r_dot; omega; eta_dot] (global), accelerations a = v_dot.
// Equations
//     F(q, v, a, t) + C_q^T lambda = 0,   c(q) = 0,
// with F the body kernels' residual (ffrf_body.hpp) minus the nodal loads. The joints
// act between body nodes: position p = r + R (x + Phi_u eta), orientation
// A = R exp((Phi_theta eta)~); variations dp = dr - (p - r)~ dpi + R Phi_u deta and
// d alpha = dpi + R T(theta) Phi_theta deta (T the left Jacobian of exp).
//
// Time integration: Lie-group generalised-alpha (Arnold & Bruls 2007; Bruls, Cardona &
// Arnold 2012) on the index-3 form, constraint rows scaled by the iteration matrix's size.
#pragma once

#include "pipeflex/assembly/element.hpp"
#include "pipeflex/elements/ffrf_body.hpp"
#include "pipeflex/solvers/transient.hpp"
#include <Eigen/SparseCore>

#include <array>
#include <map>
#include <memory>
#include <utility>
#include <vector>

namespace pipeflex {

struct MbBody {
    FfrfBodyData data;
    MatX basis;                 // Phi (6 n_nodes x m)
    std::vector<double> s;      // node coordinates along the body axis [m]
    double fluid_mass = 0.0;    // mu_f [kg/m]
    double flow_factor = 1.0;   // sdot = flow_factor mdot / mu_f
    // Winkler foundation (kL = 0: none), holding the centre line at its place in the
    // assembly: the frame's reference position r_ref [m] and rotation R_ref
    FfrfFoundation foundation;
    Vec3d r_ref = Vec3d::Zero();
    Mat3d R_ref = Mat3d::Identity();
    // distributed loads s(t) q [N/m] (global, per length, times the load factor): the
    // weight term's consistent load with g -> s q / mass_per_length (mu_p + mu_f [kg/m])
    double mass_per_length = 0.0;
    std::vector<std::pair<Vec3d, TimeTable>> distributed;
    double rate_force_zero = 0.0;  // s0 [m] of FfrfBodyMotion (the flow path's, set by the builder)
};

enum class JointKind { rigid = 0, hinge = 1, spherical = 2, roller = 3 };

struct MbJoint {
    JointKind kind = JointKind::rigid;
    int body_a = 0, node_a = 0;
    int body_b = -1, node_b = 0;  // body_b < 0: the ground
    Vec3d p_ground = Vec3d::Zero();
    Mat3d A_ground = Mat3d::Identity();
    Mat3d C0 = Mat3d::Identity();           // rigid: reference A_a^T A_b
    Vec3d axis_b = Vec3d::UnitZ();          // hinge: axis in node b's frame
    std::array<Vec3d, 2> perp_a{};          // hinge: two normals to the axis in node a's frame
    Vec3d direction = Vec3d::UnitZ();       // roller: constrained global direction
    Vec3d p0 = Vec3d::Zero();               // roller: reference position
    bool actuated = false;                  // hinge: driving torque about the axis,
    TimeTable torque;                       //   +T on body a, -T on body b [N m]
    // rigid joint where the flow passes from one body to the other: the fluid's
    // momentum flux turning there pushes the pipe with P_up t_up - P_down t_down
    // (t along the flow, P = mu_f sdot^2); upstream = +1 if body a is upstream, else -1
    bool junction = false;
    double upstream = 1.0;
    int rows() const;
};

// The constraint equations c (j.rows()) of joint j between node a (position pa [m],
// orientation Aa, variation maps Jpa, Jaa: 3 x n_a) and node b (the same; Jpb = Jab =
// nullptr for the ground), and their Jacobians Ja (rows x n_a), Jb (rows x n_b).
// The nodes may be body nodes or element nodes: only their kinematics enter.
void joint_rows(const MbJoint& j, const Vec3d& pa, const Mat3d& Aa, const MatX& Jpa, const MatX& Jaa,
                const Vec3d& pb, const Mat3d& Ab, const MatX* Jpb, const MatX* Jab, Eigen::Ref<VecX> c,
                Eigen::Ref<MatX> Ja, Eigen::Ref<MatX> Jb);

// Forces and moments [N, N m] on a joint's two nodes (global), in the residual's sense:
// they add Jpa^T f[0] + Jaa^T m[0] + Jpb^T f[1] + Jab^T m[1] to it; and their derivatives
// in the nodes' spatial rotation variations (A_i <- exp(skew(d alpha_i)) A_i):
// df[i][k] = d f[i] / d alpha_k, dm[i][k] = d m[i] / d alpha_k. They depend on the nodes'
// orientations only, so these derivatives and the nodes' own (node maps turning at fixed
// forces) make the geometric stiffness.
struct JointNodeForces {
    Vec3d f[2], m[2];
    Mat3d df[2][2], dm[2][2];
    void clear();
};

// Adds joint j's reactions C_q^T lam (lam: its j.rows() multipliers) as the forces on its
// nodes of orientations Aa, Ab (Ab unused for the ground): the same rows as joint_rows.
void joint_reactions(const MbJoint& j, const Mat3d& Aa, const Mat3d& Ab, bool ground,
                     const Eigen::Ref<const VecX>& lam, JointNodeForces& F);

// K += w (Jp_i^T df[i][k] + Ja_i^T dm[i][k]) Ja_k: node i's generalised forces' change
// with node k's orientation (Jp_i, Ja_i: 3 x n_i, Ja_k: 3 x n_k node maps; K n_i x n_k).
void add_turning_stiffness(const JointNodeForces& F, int i, int k, const MatX& Jpi, const MatX& Jai,
                           const MatX& Jak, double w, Eigen::Ref<MatX> K);

struct MbLoad {
    int body = 0, node = 0;
    std::array<TimeTable, 3> force, moment;  // [N], [N m], global
};

// A massless spring-damper of the element interface (AxialSpring, GroundSpring) on body
// nodes: element node i is the body node nodes[i]. The kernel runs on a frame node that
// stands for the body node, x = p, phi = 0 (frame A A0^T: its rotation from the reference
// orientation A0), x_dot = p_dot, phi_dot = omega (the node's spatial angular velocity);
// its forces reach the body through the node maps, Q = Jp^T f + Ja^T m, and its tangents
// through the chain rule (the maps' own change, node_stiffness and the velocity's change
// with the configuration at fixed v, and the second order of the stand-in's chart).
struct MbSpringNode {
    int body = 0, node = 0;
    Vec3d p0 = Vec3d::Zero();      // reference position [m] (the spring's length, anchor)
    Mat3d A0 = Mat3d::Identity();  // reference orientation (the rotational spring's zero)
};

struct Model;

struct MbSpring {
    std::shared_ptr<const Element> element;  // finalized on model
    std::shared_ptr<const Model> model;      // its nodes at the reference positions
    std::vector<MbSpringNode> nodes;
};

struct MbState {
    std::vector<Vec3d> r;
    std::vector<Mat3d> R;
    VecX eta, v, a, lam;  // eta: elastic entries used (frame entries 0)
    double t = 0.0;
};

// Scratch of one joint's evaluation (node maps, its Jacobian blocks, applied forces).
struct MbJointWork {
    MatX Jpa, Jaa, Jpb, Jab, Ja, Jb;
    VecX fa, fb;
};

struct MbEvaluation {
    VecX F;   // body residuals - loads + C_q^T lambda
    VecX c;   // constraint equations
    // wK dF/dq + wC dF/dv + wM dF/da, dF/dq including the joint reactions and loads, by
    // blocks between bodies: S[k] couples the pair tangent_pairs()[k] (a body with itself,
    // or two bodies a joint joins); the rest of S is zero.
    std::vector<MatX> S;
    // scratch, kept between evaluations so that a time loop does not allocate
    std::vector<FfrfBodyWork> work;
    std::vector<FfrfBodyMotion> motion;
    std::vector<MbJointWork> joint_work;
};

class MultibodySystemCore {
   public:
    int add_body(MbBody body);
    void add_joint(const MbJoint& j);
    void add_load(const MbLoad& l);
    // A spring-damper element on body nodes (one per element node, checked; the element
    // must accept frame nodes): finalized on the nodes' reference positions.
    void add_spring(std::unique_ptr<Element> element, const std::vector<MbSpringNode>& nodes);
    int n_springs() const { return static_cast<int>(springs_.size()); }
    // Elastic energy [J] of the springs and the power [W] their dashpots dissipate.
    double spring_energy(const MbState& s) const;
    double spring_damping_power(const MbState& s) const;
    // Spring k's element and the state of its stand-in nodes at s (sensors.cpp).
    const Element& spring_element(int k) const { return *springs_.at(static_cast<std::size_t>(k)).element; }
    State spring_nodes_state(const MbState& s, int k) const;
    const MbBody& body(int j) const { return bodies_.at(static_cast<std::size_t>(j)); }
    const Vec3d& gravity() const { return gravity_; }
    void set_gravity(const Vec3d& g) { gravity_ = g; }
    void finalize();

    int n_coordinates() const { return n_; }
    int n_constraints() const { return nc_; }
    int offset(int j) const { return offsets_[j]; }        // first coordinate of body j (j = n_bodies: n)
    int constraint_row(int k) const { return rows_[k]; }  // first row of joint k (k = n_joints: nc)
    const std::vector<MbJoint>& joints() const { return joints_; }
    int n_bodies() const { return static_cast<int>(bodies_.size()); }
    int n_nodes(int body) const { return static_cast<int>(bodies_.at(body).s.size()); }
    // The model's size [m], the scale of the Newton tests (converged increments, the
    // divergence limit): at least the longest body; build() sets the extent of the
    // assembly configuration (a chain of many short bodies is as large as the chain).
    double length_scale() const { return length_scale_; }
    void set_length_scale(double L);

    // Throws std::invalid_argument unless the state's sizes fit the system (n_bodies
    // frames, n_coordinates eta, v, a, n_constraints lam) and its numbers are finite.
    void check_state(const MbState& s) const;
    // Node position, orientation and 3 x n_j variation maps (indices checked).
    void node(const MbState& s, int body, int node, Vec3d& p, Mat3d& A, MatX* Jp, MatX* Ja) const;
    void increment(MbState& s, const VecX& dq) const;  // dq: n_coordinates entries (checked)
    // K += w d(Jp^T f + Ja^T m)/dq of a node at fixed global force f and moment m (K: the
    // body's coordinates square): the node maps' change with the frame's rotation (spatial
    // increments, as increment()) and the modal coordinates.
    void node_stiffness(const MbState& s, int body, int node, const Vec3d& f, const Vec3d& m, double w,
                        Eigen::Ref<MatX> K) const;
    // W = d(G v)/dq (6 x n_j) of a node at fixed velocities v: the change of its velocity
    // [p_dot; omega_node] = G v (G = [Jp; Ja]) with the configuration (spatial frame
    // increments, as increment()).
    void node_velocity_derivative(const MbState& s, int body, int node, MatX& W) const;
    // Full evaluation; the tangent only if with_tangent (wK also adds the joint
    // reactions' geometric stiffness at the state's multipliers).
    void evaluate(const MbState& s, double mdot, double mdot_rate, double load_factor, double gravity_factor,
                  double wK, double wC, double wM, bool with_tangent, MbEvaluation& out) const;
    // The pairs of bodies (a, b) whose tangent block S(a, b) can be nonzero, and the index
    // of a pair's block (-1 if none); set by finalize().
    const std::vector<std::pair<int, int>>& tangent_pairs() const { return pairs_; }
    int tangent_block(int a, int b) const;
    // S (n_coordinates square, dense) of an evaluation's blocks.
    MatX dense_tangent(const MbEvaluation& ev) const;
    // C_q (n_constraints x n_coordinates, dense) of the joints' blocks of an evaluation.
    MatX constraint_jacobian(const MbEvaluation& ev) const;
    // The same, sparse (n_constraints x N): a joint's rows touch its two bodies only.
    Eigen::SparseMatrix<double> sparse_constraint_jacobian(const MbEvaluation& ev) const;
    // max |C_q v| [m/s, rad/s] from an evaluation's joint blocks.
    double velocity_drift(const MbState& s, const MbEvaluation& ev) const;

   private:
    void joint_equations(const MbState& s, const MbJoint& j, Eigen::Ref<VecX> c, Eigen::Ref<MatX> Ja,
                         Eigen::Ref<MatX> Jb, MbJointWork& w) const;
    // Applied generalised forces of a joint on bodies a and b (w.fa, w.fb; fb empty for the
    // ground): a hinge's driving torque (times load_factor) and the flow junction force.
    // False if none.
    bool joint_forces(const MbState& s, const MbJoint& j, double mdot, double load_factor, MbJointWork& w) const;
    // The same forces on the joint's nodes (orientations Aa, Ab), added to F with the
    // residual's sign (-), and their derivatives.
    void joint_loads(const MbState& s, const MbJoint& j, double mdot, double load_factor, const Mat3d& Aa,
                     const Mat3d& Ab, JointNodeForces& F) const;
    double junction_pressure(int body, double mdot) const;  // P = mu_f sdot^2 [N]
    // The springs' generalised forces into F and (with_tangent) their wK dF/dq + wC dF/dv
    // into S.
    void spring_forces(const MbState& s, double wK, double wC, bool with_tangent, MbEvaluation& out) const;
    // w d(C_q^T lambda - Q_loads)/dq at fixed lambda, analytic: the joints' reactions and
    // applied forces (turning with their nodes) and the nodal loads (dead, global).
    void geometric_stiffness(const MbState& s, double mdot, double load_factor, std::vector<MatX>& S, double w) const;

    std::vector<MbBody> bodies_;
    std::vector<MbJoint> joints_;
    std::vector<MbLoad> loads_;
    std::vector<MbSpring> springs_;
    std::vector<int> offsets_{0}, rows_{0};
    std::vector<std::pair<int, int>> pairs_;
    std::map<std::pair<int, int>, int> pair_index_;
    Vec3d gravity_ = Vec3d::Zero();
    int n_ = 0, nc_ = 0;
    double length_scale_ = 1.0;
};

}  // namespace pipeflex
