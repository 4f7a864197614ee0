// Bindings of the multibody system core (seed 004): states cross as numpy arrays.
#include "outputs.hpp"
#include "pipeflex/assembly/axial_spring.hpp"
#include "pipeflex/assembly/bushing.hpp"
#include "pipeflex/assembly/ground_spring.hpp"
#include "pipeflex/core/small_matrix_eigen.hpp"
#include "pipeflex/multibody/multibody.hpp"
#include "pipeflex/multibody/multibody_equations.hpp"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>

namespace py = pybind11;
using namespace pipeflex;

MbState pipeflex::to_state(const MultibodySystemCore& sys, const Arr& r, const Arr& R, const VecX& eta, const VecX& v,
                 const VecX& a, const VecX& lam, double t) {
    const int nb = sys.n_bodies();
    if (r.size() != 3 * nb || R.size() != 9 * nb)
        throw std::invalid_argument("r must be (n_bodies, 3) and R (n_bodies, 3, 3)");
    const int n = sys.n_coordinates(), nc = sys.n_constraints();
    if (eta.size() != n || v.size() != n || a.size() != n || lam.size() != nc)
        throw std::invalid_argument("state: eta, v and a must have " + std::to_string(n) +
                                    " entries (n_coordinates) and lam " + std::to_string(nc) + " (n_constraints)");
    MbState s;
    auto rr = r.unchecked();
    auto RR = R.unchecked();
    const double* pr = rr.data(0);
    const double* pR = RR.data(0);
    for (int j = 0; j < nb; ++j) {
        s.r.emplace_back(pr[3 * j], pr[3 * j + 1], pr[3 * j + 2]);
        Mat3d M;
        for (int i = 0; i < 3; ++i)
            for (int k = 0; k < 3; ++k) M(i, k) = pR[9 * j + 3 * i + k];
        s.R.push_back(M);
    }
    s.eta = eta;
    s.v = v;
    s.a = a;
    s.lam = lam;
    s.t = t;
    return s;
}

py::tuple pipeflex::from_state(const MbState& s) {
    const size_t nb = s.r.size();
    Arr r({nb, size_t(3)}), R({nb, size_t(3), size_t(3)});
    auto rr = r.mutable_unchecked<2>();
    auto RR = R.mutable_unchecked<3>();
    for (size_t j = 0; j < nb; ++j)
        for (int i = 0; i < 3; ++i) {
            rr(j, i) = s.r[j][i];
            for (int k = 0; k < 3; ++k) RR(j, i, k) = s.R[j](i, k);
        }
    return py::make_tuple(r, R, s.eta, s.v, s.a, s.lam, s.t);
}

// FreeMotions as a dict: the force per body (n_bodies, 6), its moments divided by the
// length scale (arcs of the model's size: in N throughout).
py::dict pipeflex::free_dict(const MultibodySystemCore& sys, const FreeMotions& f) {
    const double L = sys.length_scale();
    py::array_t<double> force({sys.n_bodies(), 6});
    auto F = force.mutable_unchecked<2>();
    for (int j = 0; j < sys.n_bodies(); ++j)
        for (int i = 0; i < 6; ++i) F(j, i) = f.force[sys.offset(j) + i] / (i < 3 ? 1.0 : L);
    py::dict d;
    d["count"] = f.count;
    d["force"] = force;
    d["reaction"] = f.reaction;
    return d;
}

void bind_multibody(py::module_& m) {
    py::class_<MultibodySystemCore>(m, "MultibodySystemCore")
        .def(py::init<>())
        .def(
            "add_body",
            [](MultibodySystemCore& sys, const FfrfBodyData& d, const MatX& basis, const std::vector<double>& s,
               double fluid_mass, double flow_factor, std::optional<py::dict> foundation, const Vec3d& r_ref,
               const Mat3d& R_ref, double mass_per_length,
               const std::vector<std::pair<Vec3d, TimeTable>>& distributed, double rate_force_zero) {
                MbBody b;
                b.rate_force_zero = rate_force_zero;
                b.data = d;
                b.basis = basis;
                b.s = s;
                b.fluid_mass = fluid_mass;
                b.flow_factor = flow_factor;
                if (foundation) {
                    const py::dict& f = *foundation;
                    b.foundation.kL = f["kL"].cast<double>();
                    b.foundation.X = f["X"].cast<Vec3d>();
                    b.foundation.X0 = f["X0"].cast<Vec3d>();
                    b.foundation.W0 = f["W0"].cast<Mat3d>();
                    b.foundation.XPhi = f["XPhi"].cast<MatX>();
                    b.foundation.K = f["K"].cast<MatX>();
                    b.foundation.x = f["x"].cast<VecX>();
                    b.foundation.C = f["C"].cast<MatX>();
                    if (!(b.foundation.kL > 0.0)) throw std::invalid_argument("add_body: foundation kL must be > 0");
                }
                b.r_ref = r_ref;
                b.R_ref = R_ref;
                b.mass_per_length = mass_per_length;
                b.distributed = distributed;
                return sys.add_body(std::move(b));
            },
            py::arg("data"), py::arg("basis"), py::arg("s"), py::arg("fluid_mass"), py::arg("flow_factor"),
            py::arg("foundation") = py::none(), py::arg("r_ref") = Vec3d::Zero(),
            py::arg("R_ref") = Mat3d::Identity(), py::arg("mass_per_length") = 0.0,
            py::arg("distributed") = std::vector<std::pair<Vec3d, TimeTable>>{}, py::arg("rate_force_zero") = 0.0,
            "A body: its constants, basis Phi, node coordinates s [m], mu_f [kg/m], flow factor; optionally a "
            "Winkler foundation (a dict of FfrfFoundation's constants: kL, X, X0, W0, XPhi, K, x, C) about the "
            "reference placement r_ref [m], R_ref, distributed loads (q (3) [N/m] global, TimeTable s(t)): "
            "s(t) q per length on a body of mass_per_length [kg/m], and s0 [m] where the fluid acceleration's "
            "axial force vanishes (rate_force_zero).")
        .def(
            "add_joint",
            [](MultibodySystemCore& sys, int kind, int body_a, int node_a, int body_b, int node_b, const Vec3d& p_ground,
               const Mat3d& A_ground, const Mat3d& C0, const Vec3d& axis_b, const Vec3d& perp0, const Vec3d& perp1,
               const Vec3d& direction, const Vec3d& p0, std::optional<TimeTable> torque, double junction) {
                if (kind < 0 || kind > 3) throw std::invalid_argument("joint kind must be 0..3");
                MbJoint j;
                j.kind = static_cast<JointKind>(kind);
                j.body_a = body_a;
                j.node_a = node_a;
                j.body_b = body_b;
                j.node_b = node_b;
                j.p_ground = p_ground;
                j.A_ground = A_ground;
                j.C0 = C0;
                j.axis_b = axis_b;
                j.perp_a = {perp0, perp1};
                j.direction = direction;
                j.p0 = p0;
                if (torque) {
                    if (j.kind != JointKind::hinge) throw std::invalid_argument("only hinges take a driving torque");
                    j.actuated = true;
                    j.torque = *torque;
                }
                if (junction != 0.0) {
                    if (j.kind != JointKind::rigid || body_b < 0)
                        throw std::invalid_argument("a flow junction is a rigid joint between two bodies");
                    j.junction = true;
                    j.upstream = junction > 0.0 ? 1.0 : -1.0;
                }
                sys.add_joint(j);
            },
            py::arg("kind"), py::arg("body_a"), py::arg("node_a"), py::arg("body_b"), py::arg("node_b"),
            py::arg("p_ground"), py::arg("A_ground"), py::arg("C0"), py::arg("axis_b"), py::arg("perp0"),
            py::arg("perp1"), py::arg("direction"), py::arg("p0"), py::arg("torque") = py::none(),
            py::arg("junction") = 0.0)
        .def(
            "add_load",
            [](MultibodySystemCore& sys, int body, int node, const std::vector<TimeTable>& f,
               const std::vector<TimeTable>& mo) {
                if (f.size() != 3 || mo.size() != 3) throw std::invalid_argument("force and moment need 3 components");
                MbLoad l;
                l.body = body;
                l.node = node;
                for (int i = 0; i < 3; ++i) {
                    l.force[i] = f[i];
                    l.moment[i] = mo[i];
                }
                sys.add_load(l);
            },
            py::arg("body"), py::arg("node"), py::arg("force"), py::arg("moment"))
        .def(
            "add_spring",
            [](MultibodySystemCore& sys, int body_a, int node_a, const Vec3d& p0_a, const Mat3d& A0_a, int body_b,
               int node_b, const Vec3d& p0_b, const Mat3d& A0_b, double k, double c) {
                auto e = std::make_unique<AxialSpring>(0, 1, k, c);
                sys.add_spring(std::move(e), {MbSpringNode{body_a, node_a, p0_a, A0_a},
                                              MbSpringNode{body_b, node_b, p0_b, A0_b}});
                return sys.n_springs() - 1;
            },
            py::arg("body_a"), py::arg("node_a"), py::arg("p0_a"), py::arg("A0_a"), py::arg("body_b"),
            py::arg("node_b"), py::arg("p0_b"), py::arg("A0_b"), py::arg("k"), py::arg("c") = 0.0,
            "An axial spring-damper (k [N/m], c [N s/m]) between two body nodes, unstressed at the distance of "
            "their reference positions p0_a, p0_b [m] (A0: reference orientations). Its index among the springs.")
        .def(
            "add_ground_spring",
            [](MultibodySystemCore& sys, int body, int node, const Vec3d& p0, const Mat3d& A0, const Vec3d& k,
               const Vec3d& c, const std::optional<Vec3d>& anchor, const Vec3d& k_phi, const Vec3d& c_phi) {
                auto e = std::make_unique<GroundSpring>(0, to_vec3(k), to_vec3(c), anchor.has_value(),
                                                        anchor ? to_vec3(*anchor) : Vec3<double>{}, to_vec3(k_phi),
                                                        to_vec3(c_phi));
                sys.add_spring(std::move(e), {MbSpringNode{body, node, p0, A0}});
                return sys.n_springs() - 1;
            },
            py::arg("body"), py::arg("node"), py::arg("p0"), py::arg("A0"), py::arg("k"), py::arg("c"),
            py::arg("anchor") = py::none(), py::arg("k_phi") = Vec3d::Zero(), py::arg("c_phi") = Vec3d::Zero(),
            "A spring-damper from a body node to the ground (the element model's ground spring): k (3) [N/m], "
            "c (3) [N s/m] along the global axes, unstressed at anchor [m] (None: p0, the node's reference "
            "position); k_phi (3) [N m/rad], c_phi (3) [N m s/rad] on its rotation from the reference "
            "orientation A0. Its index among the springs.")
        .def(
            "add_bushing",
            [](MultibodySystemCore& sys, int body_a, int node_a, const Vec3d& p0_a, const Mat3d& A0_a, int body_b,
               int node_b, const Vec3d& p0_b, const Mat3d& A0_b, const Vec3d& k, const Vec3d& c, const Vec3d& k_phi,
               const Vec3d& c_phi) {
                auto e = std::make_unique<Bushing>(0, 1, to_vec3(k), to_vec3(c), to_vec3(k_phi), to_vec3(c_phi));
                sys.add_spring(std::move(e), {MbSpringNode{body_a, node_a, p0_a, A0_a},
                                              MbSpringNode{body_b, node_b, p0_b, A0_b}});
                return sys.n_springs() - 1;
            },
            py::arg("body_a"), py::arg("node_a"), py::arg("p0_a"), py::arg("A0_a"), py::arg("body_b"),
            py::arg("node_b"), py::arg("p0_b"), py::arg("A0_b"), py::arg("k"), py::arg("c"),
            py::arg("k_phi") = Vec3d::Zero(), py::arg("c_phi") = Vec3d::Zero(),
            "A bushing (the element model's) between two body nodes: k (3) [N/m], c (3) [N s/m] along the global "
            "axes on the nodes' relative displacement from p0_b - p0_a [m], k_phi (3) [N m/rad], c_phi (3) "
            "[N m s/rad] on their relative rotation from the reference orientations A0_a, A0_b. Its index among "
            "the springs.")
        .def(
            "spring_energy",
            [](const MultibodySystemCore& sys, const Arr& r, const Arr& R, const VecX& eta, const VecX& v) {
                const MbState s = to_state(sys, r, R, eta, v, VecX::Zero(v.size()), VecX::Zero(sys.n_constraints()),
                                           0.0);
                return py::make_tuple(sys.spring_energy(s), sys.spring_damping_power(s));
            },
            py::arg("r"), py::arg("R"), py::arg("eta"), py::arg("v"),
            "(U [J], P [W]): the springs' elastic energy and the power their dashpots dissipate at the state.")
        .def("set_gravity", &MultibodySystemCore::set_gravity, py::arg("gravity"), "Gravity (3) [m/s^2].")
        .def("finalize", &MultibodySystemCore::finalize)
        .def("set_length_scale", &MultibodySystemCore::set_length_scale, py::arg("length"),
             "Set the model's size [m] for the Newton tests (at least the longest body).")
        .def_property_readonly("length_scale", &MultibodySystemCore::length_scale,
                               "The model's size [m] used by the Newton tests.")
        .def_property_readonly("n_coordinates", &MultibodySystemCore::n_coordinates)
        .def_property_readonly("n_constraints", &MultibodySystemCore::n_constraints)
        .def(
            "node",
            [](const MultibodySystemCore& sys, const Arr& r, const Arr& R, const VecX& eta, int body, int nd) {
                if (body < 0 || body >= sys.n_bodies())
                    throw std::invalid_argument("body must be in [0, " + std::to_string(sys.n_bodies()) + "), got " +
                                                std::to_string(body));
                if (nd < 0 || nd >= sys.n_nodes(body))
                    throw std::invalid_argument("node must be in [0, " + std::to_string(sys.n_nodes(body)) +
                                                ") on body " + std::to_string(body) + ", got " + std::to_string(nd));
                const VecX z = VecX::Zero(sys.n_coordinates());
                const MbState s = to_state(sys, r, R, eta, z, z, VecX::Zero(sys.n_constraints()), 0.0);
                Vec3d p;
                Mat3d A;
                MatX Jp, Ja;
                sys.node(s, body, nd, p, A, &Jp, &Ja);
                return py::make_tuple(p, A, Jp, Ja);
            },
            py::arg("r"), py::arg("R"), py::arg("eta"), py::arg("body"), py::arg("node"))
        .def(
            "evaluate",
            [](const MultibodySystemCore& sys, const Arr& r, const Arr& R, const VecX& eta, const VecX& v,
               const VecX& a, const VecX& lam, double t, double mdot, double mdot_rate, double load_factor,
               double gravity_factor, double wK, double wC, double wM, bool tangent, bool jacobian) {
                const MbState s = to_state(sys, r, R, eta, v, a, lam, t);
                MbEvaluation ev;
                sys.evaluate(s, mdot, mdot_rate, load_factor, gravity_factor, wK, wC, wM, tangent, ev);
                return py::make_tuple(ev.F, ev.c,
                                      jacobian ? py::object(py::cast(sys.constraint_jacobian(ev))) : py::none(),
                                      tangent ? py::object(py::cast(sys.dense_tangent(ev))) : py::none());
            },
            py::arg("r"), py::arg("R"), py::arg("eta"), py::arg("v"), py::arg("a"), py::arg("lam"), py::arg("t"),
            py::arg("mass_flow"), py::arg("mass_flow_rate"), py::arg("load_factor"), py::arg("gravity_factor"),
            py::arg("wK"), py::arg("wC"), py::arg("wM"), py::arg("tangent"), py::arg("jacobian") = true)
        .def(
            "constraints",
            [](const MultibodySystemCore& sys, const Arr& r, const Arr& R, const VecX& eta, double t) {
                const VecX zero = VecX::Zero(eta.size());
                const MbState s = to_state(sys, r, R, eta, zero, zero, VecX::Zero(sys.n_constraints()), t);
                MbEvaluation ev;
                sys.evaluate(s, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, false, ev);
                return py::make_tuple(ev.c, sys.sparse_constraint_jacobian(ev));
            },
            "(c, C_q): the constraint equations [m, rad] and their Jacobian, sparse (CSC).",
            py::arg("r"), py::arg("R"), py::arg("eta"), py::arg("t"))
        .def(
            "free_motions",
            [](const MultibodySystemCore& sys, const Arr& r, const Arr& R, const VecX& eta, const VecX& lam, double t,
               double mass_flow) {
                const MbState s = to_state(sys, r, R, eta, VecX::Zero(eta.size()), VecX::Zero(eta.size()), lam, t);
                FreeMotions f;
                {
                    py::gil_scoped_release release;
                    f = multibody_free_motions(sys, s, mass_flow);
                }
                return free_dict(sys, f);
            },
            "The frames' free motions at the state (at rest, the full loads; the core's FrameGram): 'count' the "
            "rigid motions the joints leave free, 'force' (n_bodies, 6) the residual's generalised force on them "
            "(projected off the range of the frames' constraint rows; moments divided by the length scale, so in "
            "N), 'reaction' the largest joint reaction on a frame coordinate [N, N m].",
            py::arg("r"), py::arg("R"), py::arg("eta"), py::arg("lam"), py::arg("t"), py::arg("mass_flow"));
}
