#include "pipeflex/assembly/model.hpp"
#include "pipeflex/core/format.hpp"
#include "pipeflex/elements/ancf_beam2d.hpp"  // AncfFrame (point masses at ANCF nodes)
#include "pipeflex/solvers/transient.hpp"      // TimeTable (the loads' time functions)

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

namespace pipeflex {
namespace {

double norm(const Vec3<double>& a) { return std::sqrt(dot(a, a)); }

Vec3<double> node_vec(const Eigen::VectorXd& x, int node, int off) {
    return {{x[6 * node + off], x[6 * node + off + 1], x[6 * node + off + 2]}};
}

// Generalised force of a nodal load (to be subtracted) on the node's 6 coordinates,
// templated so that the follower terms are differentiated by Dual numbers.
template <class S>
void load_force(const NodalLoad& l, const Mat3<double>& frame, const Vec3<S>& phi, S* f) {
    const std::array<double, 3> zero{};
    if (l.moment.c == zero && l.follower_force.c == zero && l.follower_moment.c == zero) {  // dead force: no rotation
        for (int i = 0; i < 3; ++i) {
            f[i] = S(l.force[i]);
            f[3 + i] = S(0.0);
        }
        return;
    }
    const Mat3<S> R = rotation_exp(phi) * promote<S>(frame);
    const Mat3<S> T = rotation_jacobian(phi);
    const Vec3<S> F = promote<S>(l.force) + R * promote<S>(l.follower_force);
    const Vec3<S> M = promote<S>(l.moment) + R * promote<S>(l.follower_moment);
    const Vec3<S> m = tmul(T, M);
    for (int i = 0; i < 3; ++i) {
        f[i] = F[i];
        f[3 + i] = m[i];
    }
}

// Nodal mass residual m (x_ddot - g) and rotary d/dt(J w) mapped by T^T.
template <class S>
void mass_residual(const NodalMass& nm, const Mat3<double>& frame, const LoadState& load,
                   const S* q, const S* v, const double* a, S* r) {
    const Vec3<S> phi = {{q[3], q[4], q[5]}}, phid = {{v[3], v[4], v[5]}};
    for (int i = 0; i < 3; ++i) r[i] = S(nm.mass * (a[i] - load.gravity[i] * load.gravity_factor));
    const NodeMotion<S> nd = node_motion(phi, phid, promote<S>(Vec3<double>{{a[3], a[4], a[5]}}));
    const Mat3<S> R = nd.R * promote<S>(frame);
    const Mat3<S>& T = nd.T;
    const Vec3<S>&w = nd.w, &al = nd.al;
    const Vec3<S> wb = tmul(R, w), ab = tmul(R, al);
    Vec3<S> jw, ja;
    for (int i = 0; i < 3; ++i) {
        jw[i] = nm.inertia[i] * wb[i];
        ja[i] = nm.inertia[i] * ab[i];
    }
    const Vec3<S> m = tmul(T, R * ja + cross(w, R * jw));
    for (int i = 0; i < 3; ++i) r[3 + i] = m[i];
}

// Destinations of the tangent entries, which the assembler emits in a fixed order (the
// same for every state, load and weights): triplets, the (row, col) list of the pattern,
// or the value slots of the cached CSC pattern.
struct TripletSink {
    Triplets* t;
    void add(int r, int c, double v) { t->add(r, c, v); }
};

struct PatternSink {
    std::vector<int> rows, cols;
    void add(int r, int c, double) {
        rows.push_back(r);
        cols.push_back(c);
    }
};

struct SlotSink {
    const int* slot;
    double* values;
    std::size_t k = 0;
    void add(int, int, double v) { values[slot[k++]] += v; }
};

// Scatter a full 6-per-node block pair (rows of node a, cols of node b) into the reduced
// tangent: T_a^T B T_b.
template <class Sink>
void scatter_block(const Model& m, int na, int nb, const double* blk, int ld, Sink* J) {
    const Eigen::MatrixXd& Ta = m.bases[na];
    const Eigen::MatrixXd& Tb = m.bases[nb];
    if (Ta.cols() == 0 || Tb.cols() == 0) return;
    if (m.is_selection[na] && m.is_selection[nb]) {
        const auto& sa = m.selected[na];
        const auto& sb = m.selected[nb];
        for (std::size_t i = 0; i < sa.size(); ++i)
            for (std::size_t j = 0; j < sb.size(); ++j)
                J->add(m.first_dof[na] + static_cast<int>(i), m.first_dof[nb] + static_cast<int>(j),
                       blk[ld * sa[i] + sb[j]]);
        return;
    }
    Eigen::Matrix<double, 6, 6> B;
    for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j) B(i, j) = blk[ld * i + j];
    const Eigen::MatrixXd R = Ta.transpose() * B * Tb;
    for (int i = 0; i < R.rows(); ++i)
        for (int j = 0; j < R.cols(); ++j) J->add(m.first_dof[na] + i, m.first_dof[nb] + j, R(i, j));
}

inline void scatter_vector(const Model& m, int n, const double* f, Eigen::VectorXd* r) {
    if (!m.reduced_slot.empty()) {  // every basis selects: a table lookup per slot
        const int* rs = m.reduced_slot.data() + 6 * n;
        for (int i = 0; i < 6; ++i)
            if (rs[i] >= 0) (*r)[rs[i]] += f[i];
        return;
    }
    if (m.is_selection[n]) {
        const auto& s = m.selected[n];
        for (std::size_t j = 0; j < s.size(); ++j) (*r)[m.first_dof[n] + static_cast<int>(j)] += f[s[j]];
        return;
    }
    const Eigen::MatrixXd& T = m.bases[n];
    for (int j = 0; j < T.cols(); ++j) {
        double s = 0.0;
        for (int i = 0; i < 6; ++i) s += T(i, j) * f[i];
        (*r)[m.first_dof[n] + j] += s;
    }
}

// Scatter an element's tangent ((6 n)^2 row-major for its n nodes), node block by block
// (two-node elements, the common case, with the loop bounds known).
template <int N, class Sink>
void scatter_nodes(const Model& m, const int* nodes, int n, const double* Je, Sink* J) {
    if (N > 0) n = N;
    const int ld = 6 * n;
    for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b) scatter_block(m, nodes[a], nodes[b], Je + 6 * ld * a + 6 * b, ld, J);
}

template <class Sink>
void scatter_element(const Model& m, const std::vector<int>& nodes, const double* Je, Sink* J) {
    const int n = static_cast<int>(nodes.size());
    if (n == 2)
        scatter_nodes<2>(m, nodes.data(), n, Je, J);
    else
        scatter_nodes<0>(m, nodes.data(), n, Je, J);
}

void scatter_residual(const Model& m, const std::vector<int>& nodes, const double* re, Eigen::VectorXd* residual) {
    if (residual == nullptr) return;
    if (nodes.size() == 2) {  // the common case: unrolled
        scatter_vector(m, nodes[0], re, residual);
        scatter_vector(m, nodes[1], re + 6, residual);
        return;
    }
    for (std::size_t a = 0; a < nodes.size(); ++a) scatter_vector(m, nodes[a], re + 6 * a, residual);
}

}  // namespace

void Model::finalize() {
    const int n = n_nodes();
    kinds.resize(n, NodeKind::frame);
    slopes.resize(n, Vec3<double>{{1.0, 0.0, 0.0}});
    if (bases.empty()) bases.assign(n, Eigen::MatrixXd::Identity(6, 6));
    if (static_cast<int>(bases.size()) != n)
        throw std::invalid_argument("the model has " + std::to_string(n) + " nodes but " +
                                    std::to_string(bases.size()) + " bases (set_bases: one 6 x k basis per node)");
    pattern_cache.reset();
    first_dof.assign(n, 0);
    int k = 0;
    for (int i = 0; i < n; ++i) {
        if (bases[i].rows() != 6) throw std::invalid_argument("basis of node " + std::to_string(i) + " must have 6 rows");
        first_dof[i] = k;
        k += static_cast<int>(bases[i].cols());
    }
    n_dofs = k;
    // Bases that only select slots (each column a unit vector): the scatter then copies
    // entries instead of multiplying T_a^T B T_b.
    selected.assign(n, {});
    is_selection.assign(n, false);
    for (int i = 0; i < n; ++i) {
        std::vector<int> slots;
        for (int j = 0; j < bases[i].cols(); ++j) {
            int slot = -1, nonzero = 0;
            for (int r = 0; r < 6; ++r)
                if (bases[i](r, j) != 0.0) {
                    ++nonzero;
                    slot = bases[i](r, j) == 1.0 ? r : -1;
                }
            if (nonzero != 1 || slot < 0) {
                slots.clear();
                break;
            }
            slots.push_back(slot);
        }
        if (static_cast<int>(slots.size()) == bases[i].cols()) selected[i] = std::move(slots);
        is_selection[i] = static_cast<int>(selected[i].size()) == bases[i].cols();
    }
    full_slot.clear();
    reduced_slot.clear();
    if (std::all_of(is_selection.begin(), is_selection.end(), [](bool s) { return s; })) {
        reduced_slot.assign(6 * n, -1);
        for (int i = 0; i < n; ++i)
            for (int s : selected[i]) {
                reduced_slot[6 * i + s] = static_cast<int>(full_slot.size());
                full_slot.push_back(6 * i + s);
            }
    }
    auto check_node = [n](int i, const char* what) {
        if (i < 0 || i >= n)
            throw std::invalid_argument(std::string(what) + " refers to node " + std::to_string(i) +
                                        ", but the model has nodes 0.." + std::to_string(n - 1));
    };
    // The elements: the generic checks, then each type's own (and its stress-free state).
    stress_offset.assign(elements.size(), 0);
    n_stresses = 0;
    uses_node_motions = false;
    max_element_nodes = 0;
    for (std::size_t k = 0; k < elements.size(); ++k) {
        Element& e = elements[k];
        for (int i : e.nodes()) {
            check_node(i, e.name());
            if (!e.accepts(kinds[i]))
                throw std::invalid_argument(std::string(e.name()) + " at node " + std::to_string(i) + ", " +
                                            (kinds[i] == NodeKind::ancf ? "an ANCF node" : "a frame node") +
                                            ", which it cannot connect");
        }
        e.finalize(*this);
        stress_offset[k] = n_stresses;
        n_stresses += e.n_stresses();
        uses_node_motions = uses_node_motions || e.uses_node_motions();
        max_element_nodes = std::max(max_element_nodes, e.n_nodes());
    }
    element_loads.clear();
    for (std::size_t d = 0; d < distributed_loads.size(); ++d) {
        const DistributedLoad& dl = distributed_loads[d];
        if (dl.element < 0 || dl.element >= static_cast<int>(elements.size()))
            throw std::invalid_argument("distributed load " + std::to_string(d) + " refers to element " +
                                        std::to_string(dl.element) + ", but the model has elements 0.." +
                                        std::to_string(static_cast<int>(elements.size()) - 1));
        const Element& e = elements[dl.element];
        if (!(e.line_mass() > 0.0))
            throw std::invalid_argument("distributed load " + std::to_string(d) + " on element " +
                                        std::to_string(dl.element) + " (" + e.name() +
                                        "): it carries distributed loads through its gravity term, which needs "
                                        "a mass per length > 0");
        for (int i = 0; i < 3; ++i)
            if (!std::isfinite(dl.force_per_length[i]))
                throw std::invalid_argument("distributed load " + std::to_string(d) +
                                            ": force_per_length must be finite [N/m]");
        element_loads.resize(elements.size());
        element_loads[dl.element].push_back(static_cast<int>(d));
    }
    for (const auto& l : loads) {
        check_node(l.node, "nodal load");
        if (kinds[l.node] == NodeKind::ancf &&
            (norm(l.moment) != 0.0 || norm(l.follower_force) != 0.0 || norm(l.follower_moment) != 0.0))
            throw std::invalid_argument("ANCF node " + std::to_string(l.node) +
                                        " takes dead forces only (no moments, no follower loads)");
    }
    for (const auto& m : masses) {
        check_node(m.node, "nodal mass");
        if (kinds[m.node] == NodeKind::ancf && norm(m.inertia) != 0.0)
            throw std::invalid_argument("a point mass at ANCF node " + std::to_string(m.node) +
                                        " cannot carry rotary inertia");
    }
    hub.co_rotating = false;
    for (int i : hub.nodes) check_node(i, "hub drive");
    for (int i : hub.nodes) hub.co_rotating = hub.co_rotating || kinds[i] == NodeKind::ancf;
    for (int i : hub.nodes) {
        if (hub.co_rotating && kinds[i] != NodeKind::ancf)
            throw std::invalid_argument("hub nodes must be all ANCF nodes or all frame nodes");
        if (!hub.co_rotating && bases[i].cols() != 0)
            throw std::invalid_argument("hub-driven node " + std::to_string(i) + " must be clamped (no free coordinates)");
    }
    if (hub.co_rotating) {
        for (const auto& e : elements)
            if (!e->in_co_rotating_frame())
                throw std::invalid_argument("a hub carrying ANCF beams turns a co-rotating frame: " +
                                            std::string(e->name()) + "s cannot join it");
        if (std::abs(hub.axis[2]) != 1.0) throw std::invalid_argument("the hub of ANCF beams must turn about z");
    }
    if (!hub.nodes.empty() && std::abs(norm(hub.axis) - 1.0) > 1e-12)
        throw std::invalid_argument("hub axis must be a unit vector");
}

void HubDrive::angle(double t, double* th, double* thd, double* thdd) const {
    const double T = spin_up_time;
    if (T > 0.0 && t < T) {
        // seed 002, eq. 13
        const double k = 2.0 * M_PI / T;
        *th = omega / T * (0.5 * t * t + (std::cos(k * t) - 1.0) / (k * k));
        *thd = omega / T * (t - std::sin(k * t) / k);
        *thdd = omega / T * (1.0 - std::cos(k * t));
    } else {
        *th = omega * (t - 0.5 * T);
        *thd = omega;
        *thdd = 0.0;
    }
}

void apply_hub_frame(const Model& model, LoadState& load, double t) {
    if (!model.hub.co_rotating) return;
    double th, thd, thdd;
    model.hub.angle(t, &th, &thd, &thdd);
    const double sgn = model.hub.axis[2];
    load.frame_rate = sgn * thd;
    load.frame_acceleration = sgn * thdd;
    load.frame_center = {model.hub.center[0], model.hub.center[1]};
}

void apply_hub(const Model& model, State& state, double t) {
    if (model.hub.nodes.empty() || model.hub.co_rotating) return;
    check_state(model, state);
    double th, thd, thdd;
    model.hub.angle(t, &th, &thd, &thdd);
    const Vec3<double>& ax = model.hub.axis;
    const Mat3<double> R = rotation_exp(Vec3<double>{{th * ax[0], th * ax[1], th * ax[2]}});
    auto set3 = [](Eigen::VectorXd& x, int at, const Vec3<double>& v) {
        for (int k = 0; k < 3; ++k) x[at + k] = v[k];
    };
    // velocity and acceleration of a vector u turning with the hub
    auto moving = [&](const Vec3<double>& u, Vec3<double>* vel, Vec3<double>* acc) {
        const Vec3<double> au = cross(ax, u);
        *vel = thd * au;
        *acc = thdd * au + thd * thd * cross(ax, au);
    };
    for (int n : model.hub.nodes) {
        Vec3<double> X, x, vel, acc;
        for (int k = 0; k < 3; ++k) X[k] = model.positions[n][k] - model.hub.center[k];
        const Vec3<double> u = R * X;
        for (int k = 0; k < 3; ++k) x[k] = model.hub.center[k] + u[k];
        moving(u, &vel, &acc);
        set3(state.q, 6 * n, x);
        set3(state.v, 6 * n, vel);
        set3(state.a, 6 * n, acc);
        if (model.kinds[n] == NodeKind::ancf) {
            const Vec3<double> s = R * model.slopes[n];
            moving(s, &vel, &acc);
            set3(state.q, 6 * n + 3, s);
            set3(state.v, 6 * n + 3, vel);
            set3(state.a, 6 * n + 3, acc);
        } else {
            // phi = 0 in the turned frame: phi_dot = omega, phi_ddot = omega_dot
            state.frames[n] = R;
            set3(state.q, 6 * n + 3, Vec3<double>{});
            set3(state.v, 6 * n + 3, thd * ax);
            set3(state.a, 6 * n + 3, thdd * ax);
        }
    }
}

State::State(const Model& m)
    : q(Eigen::VectorXd::Zero(6 * m.n_nodes())),
      v(Eigen::VectorXd::Zero(6 * m.n_nodes())),
      a(Eigen::VectorXd::Zero(6 * m.n_nodes())),
      frames(m.n_nodes()),
      kinds(m.kinds) {
    kinds.resize(m.n_nodes(), NodeKind::frame);
    for (int i = 0; i < m.n_nodes(); ++i) {
        for (int k = 0; k < 3; ++k) {
            q[6 * i + k] = m.positions[i][k];
            frames[i](k, k) = 1.0;
            if (kinds[i] == NodeKind::ancf) q[6 * i + 3 + k] = m.slopes[i][k];
        }
    }
}

void State::check_sizes() const {
    const auto n = static_cast<Eigen::Index>(frames.size());
    for (const auto& [name, x] : {std::pair<const char*, const Eigen::VectorXd*>{"q", &q}, {"v", &v}, {"a", &a}})
        if (x->size() != 6 * n)
            throw std::invalid_argument("state." + std::string(name) + " must have 6 entries per node (" +
                                        std::to_string(6 * n) + " for " + std::to_string(n) + " nodes), got " +
                                        std::to_string(x->size()));
    if (kinds.size() != frames.size()) throw std::invalid_argument("state: node kinds and frames differ in number");
}

void check_state(const Model& model, const State& state) {
    const int n = model.n_nodes();
    // (an element added since finalize: the kernels' buffers are sized by finalize)
    if (static_cast<int>(model.first_dof.size()) != n || static_cast<int>(model.bases.size()) != n ||
        model.stress_offset.size() != model.elements.size())
        throw std::invalid_argument("the model is not finalized (call finalize() after its last node)");
    if (static_cast<int>(state.frames.size()) != n)
        throw std::invalid_argument("the state has " + std::to_string(state.frames.size()) + " nodes, the model " +
                                    std::to_string(n) + ": a state of another model (use this model's initial_state())");
    state.check_sizes();
    for (int i = 0; i < n; ++i)
        if (state.kinds[i] != model.kinds[i])
            throw std::invalid_argument("node " + std::to_string(i) + " is an " +
                                        (model.kinds[i] == NodeKind::ancf ? "ANCF" : "frame") +
                                        " node of the model but not of the state: a state of another model");
}

double State::max_rotation() const {
    double big = 0.0;
    for (int i = 0; i < static_cast<int>(frames.size()); ++i)
        if (kinds[i] == NodeKind::frame) big = std::max(big, norm(node_vec(q, i, 3)));
    return big;
}

Mat3<double> planar_triad(const Vec3<double>& slope) {
    Vec3<double> e1 = (1.0 / norm(slope)) * slope;
    Vec3<double> e3{{0.0, 0.0, 1.0}};
    const Vec3<double> e2 = cross(e3, e1);
    e3 = cross(e1, e2);
    Mat3<double> R;
    for (int k = 0; k < 3; ++k) {
        R(k, 0) = e1[k];
        R(k, 1) = e2[k];
        R(k, 2) = e3[k];
    }
    return R;
}

Mat3<double> State::rotation(int node) const {
    if (node < 0 || node >= static_cast<int>(frames.size()))
        throw std::invalid_argument("node must be in [0, " + std::to_string(frames.size()) + "), got " +
                                    std::to_string(node));
    if (kinds[node] == NodeKind::ancf) return planar_triad(node_vec(q, node, 3));
    return rotation_exp(node_vec(q, node, 3)) * frames[node];
}

int State::rebase(double max_angle) { return rebase_frames(*this, max_angle, nullptr); }

int rebase_frames(State& s, double max_angle, const NodeMotion<double>* motions) {
    s.check_sizes();
    int count = 0;
    for (int i = 0; i < static_cast<int>(s.frames.size()); ++i) {
        const Vec3<double> phi = node_vec(s.q, i, 3);
        if (s.kinds[i] != NodeKind::frame || std::sqrt(dot(phi, phi)) <= max_angle) continue;
        // The angular velocity and acceleration are kept; their coordinates change.
        const NodeMotion<double> m =
            motions != nullptr ? motions[i] : node_motion(phi, node_vec(s.v, i, 3), node_vec(s.a, i, 3));
        s.frames[i] = m.R * s.frames[i];
        for (int k = 0; k < 3; ++k) {  // at phi = 0: T = I and the convective part vanishes
            s.q[6 * i + 3 + k] = 0.0;
            s.v[6 * i + 3 + k] = m.w[k];
            s.a[6 * i + 3 + k] = m.al[k];
        }
        ++count;
    }
    return count;
}

void node_motions(const Model& model, const State& state, std::vector<NodeMotion<double>>& motions) {
    motions.resize(model.n_nodes());
    for (int i = 0; i < model.n_nodes(); ++i)
        if (model.kinds[i] == NodeKind::frame)
            motions[i] = node_motion(node_vec(state.q, i, 3), node_vec(state.v, i, 3), node_vec(state.a, i, 3));
}

namespace {

// A load function's force F and moment M at time t, position x and velocity v; an ANCF
// node (no rotation coordinates) takes no moment.
void call_function(const Model& model, const NodalLoad& l, double t, const double* x, const double* v, double* F,
                   double* M) {
    l.function(t, x, v, F, M);
    if (model.kinds[l.node] == NodeKind::ancf && (M[0] != 0.0 || M[1] != 0.0 || M[2] != 0.0))
        throw std::invalid_argument(l.label + " returned a moment at t = " + fmt(t) +
                                    " s: an ANCF node takes forces only");
}

// The force and moment of a load function at the state (x, v of the node) and time t, as
// the generalised force on the node's 6 coordinates (load_force of the dead load).
void function_force(const Model& model, const NodalLoad& l, const State& state, double t, const double* x,
                    const double* v, double* g) {
    double F[3] = {}, M[3] = {};
    call_function(model, l, t, x, v, F, M);
    const int n = l.node;
    NodalLoad dead;
    for (int i = 0; i < 3; ++i) {
        dead.force[i] = F[i];
        dead.moment[i] = M[i];
    }
    load_force(dead, state.frames[n], node_vec(state.q, n, 3), g);
}

// A load function's residual and tangent blocks (the 6 x 6 block of the node, emitted
// whatever the weights, as the constant loads'). Its tangent: central differences of the
// function in the node's position and velocity, steps h = cbrt(eps) max(1, abs(x_i))
// (SI: metres, m/s), error O(h^2) and exact up to rounding for a linear function (a
// spring, a dashpot), so that Newton keeps its convergence rate on a stiff user load
// instead of the linear rate of a zero tangent; 12 calls per tangent. A moment's
// dependence on the rotation (T(phi)^T M) by Dual numbers, as the dead loads'.
template <class Sink>
void function_load(const Model& model, const NodalLoad& l, const State& state, double t, double lf,
                   const TangentWeights* w, Sink* sinks, int nw, Eigen::VectorXd* residual) {
    const int n = l.node;
    bool stiff = false;  // a weight set needs dR/dx or dR/dv
    for (int k = 0; k < nw; ++k) stiff = stiff || w[k].wK != 0.0 || w[k].wC != 0.0;
    double x[3], v[3];
    for (int i = 0; i < 3; ++i) {
        x[i] = state.q[6 * n + i];
        v[i] = state.v[6 * n + i];
    }
    double blk[36] = {};
    if (residual != nullptr || stiff) {
        double F[3] = {}, M[3] = {};
        call_function(model, l, t, x, v, F, M);
        NodalLoad dead;
        for (int i = 0; i < 3; ++i) {
            dead.force[i] = F[i];
            dead.moment[i] = M[i];
        }
        using D = Dual<double, 3>;
        Vec3<D> phi;
        for (int i = 0; i < 3; ++i) phi[i] = D(state.q[6 * n + 3 + i], i);
        D f[6];
        if (model.kinds[n] == NodeKind::ancf)  // slots 3-5 are the slope: dead force only
            for (int i = 0; i < 6; ++i) f[i] = D(i < 3 ? F[i] : 0.0);
        else
            load_force(dead, state.frames[n], phi, f);
        if (residual != nullptr) {
            double rv[6];
            for (int i = 0; i < 6; ++i) rv[i] = -lf * f[i].v;
            scatter_vector(model, n, rv, residual);
        }
        if (stiff) {
            double dx[18], dv[18];  // d g_i / d x_j and d g_i / d v_j (row-major 6 x 3)
            const double c = std::cbrt(std::numeric_limits<double>::epsilon());
            for (int pass = 0; pass < 2; ++pass) {
                double* y = pass == 0 ? x : v;
                double* d = pass == 0 ? dx : dv;
                for (int j = 0; j < 3; ++j) {
                    const double y0 = y[j], h = c * std::max(1.0, std::abs(y0));
                    double gp[6], gm[6];
                    y[j] = y0 + h;
                    function_force(model, l, state, t, x, v, gp);
                    y[j] = y0 - h;
                    function_force(model, l, state, t, x, v, gm);
                    y[j] = y0;
                    for (int i = 0; i < 6; ++i) d[3 * i + j] = (gp[i] - gm[i]) / (2.0 * h);
                }
            }
            for (int k = 0; k < nw; ++k) {
                for (int i = 0; i < 36; ++i) blk[i] = 0.0;
                for (int i = 0; i < 6; ++i)
                    for (int j = 0; j < 3; ++j) {
                        blk[6 * i + j] = -lf * (w[k].wK * dx[3 * i + j] + w[k].wC * dv[3 * i + j]);
                        if (model.kinds[n] == NodeKind::frame) blk[6 * i + 3 + j] = -lf * w[k].wK * f[i].d[j];
                    }
                scatter_block(model, n, n, blk, 6, &sinks[k]);
            }
            return;
        }
    }
    for (int k = 0; k < nw; ++k) scatter_block(model, n, n, blk, 6, &sinks[k]);  // zeros: the pattern's entries
}

// The load state of element k with its distributed loads (times the load factor and their
// time functions at load.time) in its gravity, g + q / line_mass, gravity_factor 1 (the
// kernel's consistent gravity term carries them); with_gravity false: the loads alone
// (no gravity, no flow: the generalised forces of the loads, external_forces).
LoadState distributed_gravity(const Model& model, std::size_t k, const LoadState& load, double load_factor,
                              bool with_gravity) {
    LoadState lk = with_gravity ? load : LoadState{};
    lk.gravity_factor = 1.0;
    for (int i = 0; i < 3; ++i) lk.gravity[i] = with_gravity ? load.gravity[i] * load.gravity_factor : 0.0;
    const double mu = model.elements[k].line_mass();
    for (int d : model.element_loads[k]) {
        const DistributedLoad& dl = model.distributed_loads[d];
        const double f = load_factor * (dl.time_function ? dl.time_function->at(load.time) : 1.0);
        for (int i = 0; i < 3; ++i) lk.gravity[i] += f * dl.force_per_length[i] / mu;
    }
    return lk;
}

// The assembler: the residual (if not null) and the tangents for the nw weight sets
// w[i] into sinks[i] (nw = 0: residual only), all in one pass over the elements (an
// element's data still in cache for every set); the residual comes with the first set.
// Entries are emitted whatever the weights (zeros included), so that the order is
// the pattern's.
template <class Sink>
void assemble_into(const Model& model, const State& state, const LoadState& load, double load_factor,
                   const TangentWeights* w, Sink* sinks, int nw, Eigen::VectorXd* residual,
                   const double* geometric_stresses = nullptr) {
    check_state(model, state);
    if (residual != nullptr) residual->setZero(model.n_dofs);
    // Caller-owned buffers of the element kernels, reused (no allocation per call): the
    // residual (6 per node of an element) and one tangent per weight set.
    const int nd = 6 * model.max_element_nodes;
    thread_local std::vector<double> re, Jmany, wflat;
    thread_local std::vector<double*> Jptr;
    re.resize(nd);
    Jmany.resize(static_cast<std::size_t>(nw) * nd * nd);
    wflat.resize(3 * nw);
    Jptr.resize(nw);
    for (int i = 0; i < nw; ++i) {
        wflat[3 * i] = w[i].wK;
        wflat[3 * i + 1] = w[i].wC;
        wflat[3 * i + 2] = w[i].wM;
        Jptr[i] = Jmany.data() + static_cast<std::size_t>(nd) * nd * i;
    }
    // The residual alone (every Newton iteration of the integrators): each node's rotation
    // kinematics once, shared by the node's elements.
    thread_local std::vector<NodeMotion<double>> motions;
    const bool with_motions = nw == 0 && model.uses_node_motions;
    if (with_motions) node_motions(model, state, motions);
    // plain pointers in the loop: each use of a thread_local costs a call (its TLS wrapper)
    const ElementInputs in{state, load, with_motions ? motions.data() : nullptr};
    ElementOutputs out;
    out.nw = nw;
    out.weights = wflat.data();
    out.r = residual != nullptr ? re.data() : nullptr;
    out.J = Jptr.data();
    for (std::size_t k = 0; k < model.elements.size(); ++k) {
        const Element& el = model.elements[k];
        out.geometric_stresses = geometric_stresses != nullptr ? geometric_stresses + model.stress_offset[k] : nullptr;
        if (!model.element_loads.empty() && !model.element_loads[k].empty())
            el.kernel(ElementInputs{state, distributed_gravity(model, k, load, load_factor, true), in.motions}, out);
        else
            el.kernel(in, out);
        for (int i = 0; i < nw; ++i) scatter_element(model, el.nodes(), out.J[i], &sinks[i]);
        scatter_residual(model, el.nodes(), out.r, residual);
    }
    AncfFrame frame;  // the co-rotating frame of the point masses at ANCF nodes
    frame.rate = load.frame_rate;
    frame.acceleration = load.frame_acceleration;
    frame.center[0] = load.frame_center[0];
    frame.center[1] = load.frame_center[1];
    for (const auto& nm : model.masses) {
        const int n = nm.node;
        if (model.kinds[n] == NodeKind::ancf) {
            // inertia in the (possibly) turning frame: a + 2 w S v + (w^2 S^2 + w_dot S)(x - c)
            const double wf = frame.rate, wd = frame.acceleration;
            if (residual != nullptr) {
                double rv[6] = {};
                const double rx = state.q[6 * n] - frame.center[0], ry = state.q[6 * n + 1] - frame.center[1];
                const double f[2] = {-2.0 * wf * state.v[6 * n + 1] - wf * wf * rx - wd * ry,
                                     2.0 * wf * state.v[6 * n] - wf * wf * ry + wd * rx};
                for (int i = 0; i < 3; ++i)
                    rv[i] = nm.mass * (state.a[6 * n + i] + (i < 2 ? f[i] : 0.0) - load.gravity[i] * load.gravity_factor);
                scatter_vector(model, n, rv, residual);
            }
            for (int k = 0; k < nw; ++k) {
                double blk[36] = {};
                for (int i = 0; i < 3; ++i) blk[6 * i + i] = w[k].wM * nm.mass - w[k].wK * nm.mass * wf * wf * (i < 2);
                blk[0 * 6 + 1] = nm.mass * (-w[k].wK * wd - w[k].wC * 2.0 * wf);
                blk[1 * 6 + 0] = nm.mass * (w[k].wK * wd + w[k].wC * 2.0 * wf);
                scatter_block(model, n, n, blk, 6, &sinks[k]);
            }
            continue;
        }
        using D = Dual<double, 6>;
        for (int k = 0; k < std::max(nw, 1); ++k) {
            const double wK = nw > 0 ? w[k].wK : 0.0, wC = nw > 0 ? w[k].wC : 0.0, wM = nw > 0 ? w[k].wM : 0.0;
            D qd[6], vd[6], rd[6];
            for (int i = 0; i < 6; ++i) {
                qd[i] = D(state.q[6 * n + i]);
                qd[i].d[i] = wK;
                vd[i] = D(state.v[6 * n + i]);
                vd[i].d[i] = wC;
            }
            mass_residual(nm, state.frames[n], load, qd, vd, state.a.data() + 6 * n, rd);
            double rv[6], blk[36];
            for (int i = 0; i < 6; ++i) {
                rv[i] = rd[i].v;
                for (int j = 0; j < 6; ++j) blk[6 * i + j] = rd[i].d[j];
            }
            if (k == 0 && residual != nullptr) scatter_vector(model, n, rv, residual);
            if (nw == 0) break;
            if (wM != 0.0) {
                // Mass matrix: m I and T^T R J R^T T.
                const Mat3<double> R = state.rotation(n);
                const Mat3<double> T = rotation_jacobian(node_vec(state.q, n, 3));
                const Mat3<double> RT = transpose(R) * T;
                Mat3<double> Jb{};
                for (int i = 0; i < 3; ++i) Jb(i, i) = nm.inertia[i];
                const Mat3<double> Mr = transpose(RT) * (Jb * RT);
                for (int i = 0; i < 3; ++i) {
                    blk[6 * i + i] += wM * nm.mass;
                    for (int j = 0; j < 3; ++j) blk[6 * (3 + i) + 3 + j] += wM * Mr(i, j);
                }
            }
            scatter_block(model, n, n, blk, 6, &sinks[k]);
        }
    }
    if (load_factor == 0.0 && nw == 0) return;
    for (const auto& lo : model.loads) {
        const int n = lo.node;
        const double lf = load_factor * (lo.time_function ? lo.time_function->at(load.time) : 1.0);
        if (lo.function) {
            function_load(model, lo, state, load.time, lf, w, sinks, nw, residual);
            continue;
        }
        const NodalLoad& l = lo;
        if (nw == 0) {  // the residual alone: no derivative in the rotation
            if (residual == nullptr) break;
            double f[6];
            load_force(l, state.frames[n], node_vec(state.q, n, 3), f);
            double rv[6];
            for (int i = 0; i < 6; ++i) rv[i] = -lf * f[i];
            scatter_vector(model, n, rv, residual);
            continue;
        }
        using D = Dual<double, 3>;
        Vec3<D> phi;
        for (int i = 0; i < 3; ++i) phi[i] = D(state.q[6 * n + 3 + i], i);
        D f[6];
        load_force(l, state.frames[n], phi, f);
        if (residual != nullptr) {
            double rv[6];
            for (int i = 0; i < 6; ++i) rv[i] = -lf * f[i].v;
            scatter_vector(model, n, rv, residual);
        }
        for (int k = 0; k < nw; ++k) {
            double blk[36] = {};
            for (int i = 0; i < 6; ++i)
                for (int j = 0; j < 3; ++j) blk[6 * i + 3 + j] = -lf * w[k].wK * f[i].d[j];
            scatter_block(model, n, n, blk, 6, &sinks[k]);
        }
    }
}

// CSC structure of the emitted (row, col) list: a counting sort by column, rows sorted
// and merged within each column (a few dozen entries), each entry's slot recorded.
std::shared_ptr<const TangentPattern> build_pattern(const Model& model) {
    const State state(model);
    const TangentWeights mass_only{0.0, 0.0, 1.0};  // the cheapest kernels; the order is the same
    PatternSink sink;
    assemble_into(model, state, LoadState{}, 1.0, &mass_only, &sink, 1, nullptr);
    auto p = std::make_shared<TangentPattern>();
    const int n = model.n_dofs;
    const std::size_t m = sink.rows.size();
    p->n = n;
    std::vector<int> start(n + 1, 0), order(m);
    for (int c : sink.cols) ++start[c + 1];
    for (int c = 0; c < n; ++c) start[c + 1] += start[c];
    {
        std::vector<int> next(start.begin(), start.end() - 1);
        for (std::size_t k = 0; k < m; ++k) order[next[sink.cols[k]]++] = static_cast<int>(k);
    }
    p->slot.assign(m, 0);
    p->col_ptr.assign(n + 1, 0);
    p->row_index.reserve(m / 2);
    for (int c = 0; c < n; ++c) {
        auto* b = order.data() + start[c];
        auto* e = order.data() + start[c + 1];
        std::sort(b, e, [&](int x, int y) { return sink.rows[x] < sink.rows[y]; });
        for (auto* it = b; it != e; ++it) {
            if (it == b || sink.rows[*it] != sink.rows[*(it - 1)]) p->row_index.push_back(sink.rows[*it]);
            p->slot[*it] = static_cast<int>(p->row_index.size()) - 1;
        }
        p->col_ptr[c + 1] = static_cast<int>(p->row_index.size());
    }
    p->row_index.shrink_to_fit();
    return p;
}

}  // namespace

void assemble(const Model& model, const State& state, const LoadState& load, double load_factor,
              double wK, double wC, double wM, Eigen::VectorXd* residual, Triplets* J,
              const double* geometric_stresses) {
    if (J != nullptr) J->clear();
    const TangentWeights w{wK, wC, wM};
    TripletSink sink{J};
    assemble_into(model, state, load, load_factor, &w, &sink, J != nullptr ? 1 : 0, residual, geometric_stresses);
}

void predicted_stresses(const Model& model, const State& state, const Eigen::VectorXd& dq,
                        std::vector<double>& sigma) {
    check_state(model, state);
    if (dq.size() != state.q.size())
        throw std::invalid_argument("predicted_stresses: dq must have " + std::to_string(state.q.size()) +
                                    " entries, got " + std::to_string(dq.size()));
    sigma.resize(model.n_stresses);
    for (std::size_t k = 0; k < model.elements.size(); ++k)
        if (model.elements[k].n_stresses() > 0)
            model.elements[k].predicted_stresses(state, dq, sigma.data() + model.stress_offset[k]);
}

std::shared_ptr<const TangentPattern> tangent_pattern(const Model& model) {
    if (static_cast<int>(model.first_dof.size()) != model.n_nodes())
        throw std::invalid_argument("the model is not finalized (call finalize() after its last node)");
    auto p = std::atomic_load(&model.pattern_cache);
    if (p == nullptr) {
        p = build_pattern(model);
        std::atomic_store(&model.pattern_cache, p);
    }
    return p;
}

void assemble_csc(const Model& model, const State& state, const LoadState& load, double load_factor,
                  const std::vector<TangentWeights>& w, Eigen::VectorXd* residual, double* const* values,
                  const double* geometric_stresses, const int* slot) {
    check_state(model, state);
    const auto pattern = tangent_pattern(model);
    std::vector<SlotSink> sinks;
    sinks.reserve(w.size());
    for (std::size_t i = 0; i < w.size(); ++i) {
        if (slot == nullptr) std::fill(values[i], values[i] + pattern->nnz(), 0.0);
        sinks.push_back(SlotSink{slot != nullptr ? slot : pattern->slot.data(), values[i]});
    }
    assemble_into(model, state, load, load_factor, w.data(), sinks.data(), static_cast<int>(w.size()), residual,
                  geometric_stresses);
    for (const auto& s : sinks)
        if (s.k != pattern->slot.size())
            throw std::logic_error("assemble_csc: the assembler emitted " + std::to_string(s.k) +
                                   " tangent entries, its pattern has " + std::to_string(pattern->slot.size()));
}

void assemble_geometric(const Model& model, const State& state, const Eigen::VectorXd& dq, Triplets* G) {
    check_state(model, state);
    for (const auto& e : model.elements)
        if (const char* why = e->prestress_unavailable()) throw std::invalid_argument(why);
    G->clear();
    TripletSink sink{G};
    const int nd = 6 * model.max_element_nodes;
    std::vector<double> Ge(static_cast<std::size_t>(nd) * nd);
    for (const auto& e : model.elements) {
        e->prestress_stiffness(state, dq, Ge.data());
        scatter_element(model, e->nodes(), Ge.data(), &sink);
    }
}

namespace {
// A nodal load's generalised force fl (6) at t, its time function's factor included.
void nodal_load_at(const Model& model, const NodalLoad& l, const State& state, double t, double* fl) {
    if (l.function) {
        double x[3], v[3];
        for (int i = 0; i < 3; ++i) {
            x[i] = state.q[6 * l.node + i];
            v[i] = state.v[6 * l.node + i];
        }
        function_force(model, l, state, t, x, v, fl);
    } else {
        load_force<double>(l, state.frames[l.node], node_vec(state.q, l.node, 3), fl);
    }
    const double s = l.time_function ? l.time_function->at(t) : 1.0;
    for (int i = 0; i < 6; ++i) fl[i] *= s;
}
}  // namespace

double load_power(const Model& model, const State& state, double t) {
    // v . f at every step of a transient: the nodal loads' forces without the vector
    if (!model.element_loads.empty()) return state.v.dot(external_forces(model, state, t));
    double P = 0.0;
    for (const auto& l : model.loads) {
        double fl[6];
        nodal_load_at(model, l, state, t, fl);
        for (int i = 0; i < 6; ++i) P += fl[i] * state.v[6 * l.node + i];
    }
    return P;
}

Eigen::VectorXd external_forces(const Model& model, const State& state, double t) {
    check_state(model, state);
    Eigen::VectorXd f = Eigen::VectorXd::Zero(6 * model.n_nodes());
    for (const auto& l : model.loads) {
        double fl[6];
        nodal_load_at(model, l, state, t, fl);
        for (int i = 0; i < 6; ++i) f[6 * l.node + i] += fl[i];
    }
    if (model.element_loads.empty()) return f;
    // distributed loads: the kernel's residual with them as its only gravity, at rest
    // (no inertia, damping or flow), less the same without them (the elastic part)
    State rest = state;
    rest.v.setZero();
    rest.a.setZero();
    LoadState none;
    none.time = t;
    std::vector<double> r1(6 * model.max_element_nodes), r0(r1.size());
    ElementOutputs out;
    for (std::size_t k = 0; k < model.elements.size(); ++k) {
        if (model.element_loads[k].empty()) continue;
        const Element& el = model.elements[k];
        out.r = r1.data();
        el.kernel(ElementInputs{rest, distributed_gravity(model, k, none, 1.0, false), nullptr}, out);
        out.r = r0.data();
        el.kernel(ElementInputs{rest, none, nullptr}, out);
        const std::vector<int>& nodes = el.nodes();
        for (std::size_t a = 0; a < nodes.size(); ++a)
            for (int i = 0; i < 6; ++i) f[6 * nodes[a] + i] -= r1[6 * a + i] - r0[6 * a + i];
    }
    return f;
}

void add_increment(const Model& model, Eigen::Ref<Eigen::VectorXd> full, const Eigen::VectorXd& dz) {
    if (full.size() != 6 * model.n_nodes())
        throw std::invalid_argument("the coordinates must have 6 entries per node (" +
                                    std::to_string(6 * model.n_nodes()) + "), got " + std::to_string(full.size()));
    if (dz.size() != model.n_dofs)
        throw std::invalid_argument("the increment must have n_dofs = " + std::to_string(model.n_dofs) +
                                    " entries, got " + std::to_string(dz.size()));
    if (!model.full_slot.empty()) {  // every iteration of the integrators: one pass, no small products
        for (int k = 0; k < model.n_dofs; ++k) full[model.full_slot[k]] += dz[k];
        return;
    }
    for (int n = 0; n < model.n_nodes(); ++n) {
        const Eigen::MatrixXd& T = model.bases[n];
        if (T.cols() == 0) continue;
        full.segment<6>(6 * n).noalias() += T * dz.segment(model.first_dof[n], T.cols());
    }
}

void set_state_coordinates(const Model& model, const Eigen::VectorXd& base, const Eigen::VectorXd& z,
                           const Eigen::VectorXd& vz, const Eigen::VectorXd& az, State& state) {
    state.q = base;
    state.v.setZero();
    state.a.setZero();
    const int n = model.n_dofs, full = 6 * model.n_nodes();
    const bool sized = z.size() == n && vz.size() == n && az.size() == n && state.q.size() == full &&
                       state.v.size() == full && state.a.size() == full;
    if (model.full_slot.empty() || !sized) {  // general bases, or add_increment's messages
        add_increment(model, state.q, z);
        add_increment(model, state.v, vz);
        add_increment(model, state.a, az);
        return;
    }
    // every Newton iteration: the three vectors in one pass over the slots
    double *q = state.q.data(), *v = state.v.data(), *a = state.a.data();
    for (int k = 0; k < n; ++k) {
        const int s = model.full_slot[k];
        q[s] += z[k];
        v[s] += vz[k];
        a[s] += az[k];
    }
}

Eigen::VectorXd reduce(const Model& model, const Eigen::VectorXd& full) {
    Eigen::VectorXd r;
    reduce(model, full, r);
    return r;
}

void reduce(const Model& model, const Eigen::VectorXd& full, Eigen::VectorXd& out) {
    if (full.size() != 6 * model.n_nodes())
        throw std::invalid_argument("the vector to reduce must have 6 entries per node (" +
                                    std::to_string(6 * model.n_nodes()) + "), got " + std::to_string(full.size()));
    if (!model.full_slot.empty()) {  // every basis selects (re-basing, every step): a gather
        out.resize(model.n_dofs);
        for (int k = 0; k < model.n_dofs; ++k) out[k] = 0.0 + full[model.full_slot[k]];  // as the sum: -0 -> 0
        return;
    }
    out.setZero(model.n_dofs);
    for (int n = 0; n < model.n_nodes(); ++n) scatter_vector(model, n, full.data() + 6 * n, &out);
}

double fluid_power(const Model& model, const State& state, const LoadState& load, const NodeMotion<double>* motions) {
    double P = 0.0;
    for (const auto& e : model.elements) e->add_fluid_power(state, load, motions, &P);
    return P;
}

bool model_damped(const Model& model) {
    for (const auto& e : model.elements)
        if (e->damped()) return true;
    return false;
}

double damping_power(const Model& model, const State& state) {
    double P = 0.0;
    for (const auto& e : model.elements)
        if (e->damped()) e->add_damping_power(state, &P);
    return P;
}

void energies(const Model& model, const State& state, double* kinetic, double* elastic) {
    check_state(model, state);
    double T = 0.0, U = 0.0;
    for (const auto& e : model.elements) {
        double t, u;
        e->energies(state, &t, &u);
        T += t;
        U += u;
    }
    for (const auto& nm : model.masses) {
        const int n = nm.node;
        if (model.kinds[n] == NodeKind::ancf) {
            const Vec3<double> xd = node_vec(state.v, n, 0);
            T += 0.5 * nm.mass * dot(xd, xd);
            continue;
        }
        const Vec3<double> xd = node_vec(state.v, n, 0);
        const Vec3<double> w = rotation_jacobian(node_vec(state.q, n, 3)) * node_vec(state.v, n, 3);
        const Vec3<double> wb = tmul(state.rotation(n), w);
        T += 0.5 * nm.mass * dot(xd, xd);
        for (int i = 0; i < 3; ++i) T += 0.5 * nm.inertia[i] * wb[i] * wb[i];
    }
    *kinetic = T;
    *elastic = U;
}

}  // namespace pipeflex
