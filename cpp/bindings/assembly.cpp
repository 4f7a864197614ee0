#include "convert.hpp"
#include "pipeflex/assembly/ancf_element.hpp"
#include "pipeflex/assembly/axial_spring.hpp"
#include "pipeflex/assembly/bushing.hpp"
#include "pipeflex/assembly/ground_spring.hpp"
#include "pipeflex/assembly/model.hpp"
#include "pipeflex/assembly/pipe_element.hpp"
#include "pipeflex/core/format.hpp"
#include "pipeflex/core/user_function_error.hpp"
#include "pipeflex/solvers/system.hpp"
#include "pipeflex/solvers/transient.hpp"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <optional>
#include <tuple>

namespace py = pybind11;
using namespace pipeflex;
using namespace pipeflex::bindings;

namespace {

// Index checks at the boundary: the core trusts its indices. Any change of a finalized
// model's structure un-finalizes it, so that its states are refused until finalize()
// numbers the coordinates again.
int node_index(const Model& md, int i, const char* what) {
    if (i < 0 || i >= md.n_nodes())
        throw std::invalid_argument(std::string(what) + " must be a node index in [0, " + std::to_string(md.n_nodes()) +
                                    "), got " + std::to_string(i));
    return i;
}

// A Python callable fn(t, position, velocity) -> (force, moment) as a core LoadFunction.
// The integrators release the GIL: each call takes it. The callable is held through a
// shared_ptr whose deleter takes the GIL, so that the core may copy and drop models on
// any thread. Python errors become C++ exceptions that hold no Python object (IDA keeps
// them across SUNDIALS, user_function_error.hpp): fn's own as RuntimeError with its type
// and message, a bad return as ValueError.
LoadFunction python_load(py::object fn, const std::string& label) {
    std::shared_ptr<py::object> held(new py::object(std::move(fn)), [](py::object* p) {
        py::gil_scoped_acquire gil;
        delete p;
    });
    return [held, label](double t, const double* x, const double* v, double* f, double* m) {
        py::gil_scoped_acquire gil;
        py::object out;
        try {
            out = (*held)(t, py::array_t<double>(3, x), py::array_t<double>(3, v));
        } catch (py::error_already_set& e) {
            const std::string type = py::str(e.type().attr("__name__"));
            throw UserFunctionError(label + " raised at t = " + fmt(t) + " s: " + type + ": " +
                                    std::string(py::str(e.value())));
        }
        const auto bad = [&](const std::string& why) {
            return UserFunctionValueError(label + " at t = " + fmt(t) + " s: " + why);
        };
        if (!py::isinstance<py::tuple>(out) && !py::isinstance<py::list>(out))
            throw bad("must return a pair (force (3) [N], moment (3) [N m]), got " +
                      std::string(py::str(py::type::of(out).attr("__name__"))));
        const py::sequence seq = out;
        if (seq.size() != 2)
            throw bad("must return a pair (force (3) [N], moment (3) [N m]), got " + std::to_string(seq.size()) +
                      " items");
        for (int k = 0; k < 2; ++k) {
            const char* what = k == 0 ? "force" : "moment";
            py::array_t<double> a;
            try {
                a = py::array_t<double, py::array::forcecast>::ensure(seq[k]);
            } catch (py::error_already_set&) {
                a = py::array_t<double>();
            }
            if (!a || a.ndim() != 1 || a.shape(0) != 3) throw bad(std::string(what) + " must have 3 components");
            double* dst = k == 0 ? f : m;
            for (int i = 0; i < 3; ++i) {
                dst[i] = a.at(i);
                if (!std::isfinite(dst[i]))
                    throw bad(std::string(what) + "[" + std::to_string(i) + "] is not finite (" + fmt(dst[i]) + ")");
            }
        }
    };
}

void changed(Model& md) {
    md.first_dof.clear();
    md.n_dofs = 0;
}

int frame_index(const State& s, int i) {
    if (i < 0 || i >= static_cast<int>(s.frames.size()))
        throw std::invalid_argument("node must be in [0, " + std::to_string(s.frames.size()) + "), got " +
                                    std::to_string(i));
    return i;
}

// Setter of q, v or a: a vector of 6 entries per node of the state, else refused.
void set_coordinates(State& s, Eigen::VectorXd& dst, const Eigen::VectorXd& x, const char* name) {
    const auto n = static_cast<Eigen::Index>(s.frames.size());
    if (x.size() != 6 * n)
        throw std::invalid_argument(std::string("State.") + name + " must have 6 entries per node (" +
                                    std::to_string(6 * n) + " for " + std::to_string(n) + " nodes), got " +
                                    std::to_string(x.size()));
    dst = x;
}

using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;
using Ints = py::array_t<int, py::array::c_style | py::array::forcecast>;
using Bools = py::array_t<bool, py::array::c_style | py::array::forcecast>;

// The entries of one argument of a bulk call: n rows of `width` values each.
template <class A> auto rows(const A& a, py::ssize_t n, py::ssize_t width, const char* name) {
    if (a.size() != n * width)
        throw std::invalid_argument(std::string(name) + " must have " + std::to_string(width) + " entries for each of the " +
                                    std::to_string(n) + " rows, got " + std::to_string(a.size()));
    return a.data();
}

py::tuple triplets_to_numpy(const Triplets& t) {
    return py::make_tuple(py::array_t<int>(t.rows.size(), t.rows.data()),
                          py::array_t<int>(t.cols.size(), t.cols.data()),
                          py::array_t<double>(t.values.size(), t.values.data()));
}

}  // namespace

void bind_assembly(py::module_& m) {
    py::class_<Model>(m, "Model")
        .def(py::init<>())
        .def("add_node",
             [](Model& md, const Eigen::Vector3d& x) {
                 changed(md);
                 md.positions.push_back(to_vec3(x));
                 return md.n_nodes() - 1;
             },
             py::arg("position"), "A frame node at position (3) [m]; its index.")
        .def("add_nodes",
             [](Model& md, const Doubles& x) {
                 if (x.ndim() != 2 || x.shape(1) != 3)
                     throw std::invalid_argument("positions must be an (n, 3) array");
                 const double* v = x.data();
                 changed(md);
                 for (py::ssize_t i = 0; i < x.shape(0); ++i)
                     md.positions.push_back({{v[3 * i], v[3 * i + 1], v[3 * i + 2]}});
             },
             py::arg("positions"), "Frame nodes at the rows of positions (n, 3) [m], in order.")
        .def("add_pipe",
             [](Model& md, int p, int q, const PipeElementData& d) {
                 changed(md);
                 md.elements.add(std::make_unique<PipeElement>(node_index(md, p, "p"), node_index(md, q, "q"), d));
                 return md.elements.count<PipeElement>() - 1;
             },
             py::arg("p"), py::arg("q"), py::arg("data"), "A pipe element from node p to node q; its index.")
        .def("add_pipes",
             // The fields of PipeElementData as one array per field (a row per element): a
             // model's elements cross in one call instead of one object each.
             [](Model& md, const Ints& p, const Ints& q, const Doubles& l0, const Doubles& EA, const Doubles& GJ,
                const Doubles& EIy, const Doubles& EIz, const Doubles& Phi_y, const Doubles& Phi_z,
                const Doubles& offset_p, const Doubles& offset_q, const Doubles& pipe_mass,
                const Doubles& fluid_mass, const Doubles& kv, const Doubles& rotary_inertia,
                const Doubles& flow_factor, const Bools& end_terms_p, const Bools& end_terms_q,
                const std::optional<Doubles>& eta, const std::optional<Doubles>& c_ext,
                const std::optional<Doubles>& k_found) {
                 const py::ssize_t n = p.size();
                 const int* pp = rows(p, n, 1, "p");
                 const int* qq = rows(q, n, 1, "q");
                 const double* s[] = {rows(l0, n, 1, "l0"), rows(EA, n, 1, "EA"), rows(GJ, n, 1, "GJ"),
                                      rows(EIy, n, 1, "EIy"), rows(EIz, n, 1, "EIz"), rows(Phi_y, n, 1, "Phi_y"),
                                      rows(Phi_z, n, 1, "Phi_z"), rows(pipe_mass, n, 1, "pipe_mass"),
                                      rows(fluid_mass, n, 1, "fluid_mass"), rows(kv, n, 1, "kv"),
                                      rows(flow_factor, n, 1, "flow_factor")};
                 const double* op = rows(offset_p, n, 9, "offset_p");
                 const double* oq = rows(offset_q, n, 9, "offset_q");
                 const double* ri = rows(rotary_inertia, n, 3, "rotary_inertia");
                 const bool* ep = rows(end_terms_p, n, 1, "end_terms_p");
                 const bool* eq = rows(end_terms_q, n, 1, "end_terms_q");
                 const double* et = eta ? rows(*eta, n, 3, "eta") : nullptr;
                 const double* ce = c_ext ? rows(*c_ext, n, 1, "c_ext") : nullptr;
                 const double* kf = k_found ? rows(*k_found, n, 1, "k_found") : nullptr;
                 for (py::ssize_t k = 0; k < n; ++k) {  // all indices checked before the model changes
                     node_index(md, pp[k], "p");
                     node_index(md, qq[k], "q");
                 }
                 changed(md);
                 md.elements.reserve(md.elements.size() + static_cast<std::size_t>(n));
                 for (py::ssize_t k = 0; k < n; ++k) {
                     PipeElementData d;
                     d.l0 = s[0][k];
                     d.EA = s[1][k];
                     d.GJ = s[2][k];
                     d.EIy = s[3][k];
                     d.EIz = s[4][k];
                     d.Phi_y = s[5][k];
                     d.Phi_z = s[6][k];
                     std::copy(op + 9 * k, op + 9 * k + 9, d.offset_p.c.begin());  // row-major, as Mat3
                     std::copy(oq + 9 * k, oq + 9 * k + 9, d.offset_q.c.begin());
                     d.pipe_mass = s[7][k];
                     d.fluid_mass = s[8][k];
                     d.kv = s[9][k];
                     std::copy(ri + 3 * k, ri + 3 * k + 3, d.rotary_inertia.begin());
                     d.flow_factor = s[10][k];
                     d.end_terms_p = ep[k];
                     d.end_terms_q = eq[k];
                     if (et != nullptr) {
                         d.eta_axial = et[3 * k];
                         d.eta_torsion = et[3 * k + 1];
                         d.eta_bending = et[3 * k + 2];
                     }
                     if (ce != nullptr) d.c_ext = ce[k];
                     if (kf != nullptr) d.k_found = kf[k];
                     md.elements.add(std::make_unique<PipeElement>(pp[k], qq[k], d));
                 }
             },
             py::arg("p"), py::arg("q"), py::kw_only(), py::arg("l0"), py::arg("EA"), py::arg("GJ"), py::arg("EIy"),
             py::arg("EIz"), py::arg("Phi_y"), py::arg("Phi_z"), py::arg("offset_p"), py::arg("offset_q"),
             py::arg("pipe_mass"), py::arg("fluid_mass"), py::arg("kv"), py::arg("rotary_inertia"),
             py::arg("flow_factor"), py::arg("end_terms_p"), py::arg("end_terms_q"), py::arg("eta") = py::none(),
             py::arg("c_ext") = py::none(), py::arg("k_found") = py::none(),
             "Pipe elements from nodes p to q (arrays of n indices), the fields of PipeElementData "
             "one array each: n values, offset_p/offset_q (n, 3, 3), rotary_inertia (n, 3); eta (n, 3): "
             "eta_axial, eta_torsion, eta_bending [s] (None: undamped), c_ext (n) [N s/m^2] (None: 0), "
             "k_found (n) [N/m^2] elastic foundation per length (None: 0).")
        .def("add_load",
             [](Model& md, int node, const Eigen::Vector3d& f, const Eigen::Vector3d& mo,
                const Eigen::Vector3d& ff, const Eigen::Vector3d& fm, std::optional<TimeTable> time_function) {
                 changed(md);
                 NodalLoad l{node_index(md, node, "node"), to_vec3(f), to_vec3(mo), to_vec3(ff), to_vec3(fm)};
                 if (time_function) l.time_function = std::make_shared<const TimeTable>(*time_function);
                 md.loads.push_back(std::move(l));
             },
             py::arg("node"), py::arg("force"), py::arg("moment"), py::arg("follower_force"), py::arg("follower_moment"),
             py::arg("time_function") = py::none(),
             "Dead force [N] and moment [N m], and follower force and moment in the node frame, at node; "
             "time_function (None: 1) scales it (besides the load factor).")
        .def("add_distributed_load",
             [](Model& md, int element, const Eigen::Vector3d& q, std::optional<TimeTable> time_function) {
                 if (element < 0 || element >= static_cast<int>(md.elements.size()))
                     throw std::invalid_argument("element must be in [0, " + std::to_string(md.elements.size()) +
                                                 "), got " + std::to_string(element));
                 changed(md);
                 DistributedLoad l{element, to_vec3(q), nullptr};
                 if (time_function) l.time_function = std::make_shared<const TimeTable>(*time_function);
                 md.distributed_loads.push_back(std::move(l));
             },
             py::arg("element"), py::arg("force_per_length"), py::arg("time_function") = py::none(),
             "A distributed dead load q (3) [N/m] in global axes on element (its index in the registry), per "
             "unit of its reference length, consistent like its gravity; time_function (None: 1) scales it "
             "(besides the load factor).")
        .def("add_load_function",
             [](Model& md, int node, py::function fn, const std::string& label) {
                 changed(md);
                 NodalLoad l;
                 l.node = node_index(md, node, "node");
                 l.label = label;
                 l.function = python_load(std::move(fn), label);
                 md.loads.push_back(std::move(l));
             },
             py::arg("node"), py::arg("fn"), py::arg("label"),
             "A load fn(t [s], position (3) [m], velocity (3) [m/s]) -> (force (3) [N], moment (3) [N m]) in "
             "global axes at node, scaled by the load factor; label names it in error messages.")
        .def("add_mass",
             [](Model& md, int node, double mass, const Eigen::Vector3d& inertia) {
                 changed(md);
                 md.masses.push_back({node_index(md, node, "node"), mass, to_vec3(inertia)});
             },
             py::arg("node"), py::arg("mass"), py::arg("inertia"),
             "Concentrated mass [kg] and rotary inertia (3) [kg m^2] in the node frame at node.")
        .def("add_ancf_node",
             [](Model& md, const Eigen::Vector3d& x, const Eigen::Vector3d& slope) {
                 changed(md);
                 md.positions.push_back(to_vec3(x));
                 md.kinds.resize(md.positions.size() - 1, NodeKind::frame);
                 md.kinds.push_back(NodeKind::ancf);
                 md.slopes.resize(md.positions.size() - 1, Vec3<double>{{1.0, 0.0, 0.0}});
                 md.slopes.push_back(to_vec3(slope));
                 return md.n_nodes() - 1;
             },
             py::arg("position"), py::arg("slope"), "A planar ANCF node at position (3) [m] with slope (3); its index.")
        .def("add_ancf",
             [](Model& md, int p, int q, const AncfElementData& d) {
                 changed(md);
                 md.elements.add(std::make_unique<AncfElement>(node_index(md, p, "p"), node_index(md, q, "q"), d));
                 return md.elements.count<AncfElement>() - 1;
             },
             py::arg("p"), py::arg("q"), py::arg("data"), "An ANCF element from node p to node q; its index.")
        .def("add_spring",
             [](Model& md, int a, int b, double k, double c) {
                 auto e = std::make_unique<AxialSpring>(node_index(md, a, "node_a"), node_index(md, b, "node_b"), k, c);
                 changed(md);
                 md.elements.add(std::move(e));
                 return md.elements.count<AxialSpring>() - 1;
             },
             py::arg("node_a"), py::arg("node_b"), py::arg("k"), py::arg("c") = 0.0,
             "A linear axial spring of stiffness k [N/m] between the positions of node_a and node_b, "
             "unstressed at their reference distance, with a dashpot c [N s/m] in parallel; its index among "
             "the springs.")
        .def("add_ground_spring",
             [](Model& md, int node, const Eigen::Vector3d& k, const Eigen::Vector3d& c,
                const std::optional<Eigen::Vector3d>& anchor, const Eigen::Vector3d& k_phi,
                const Eigen::Vector3d& c_phi) {
                 auto e = std::make_unique<GroundSpring>(node_index(md, node, "node"), to_vec3(k), to_vec3(c),
                                                         anchor.has_value(),
                                                         anchor ? to_vec3(*anchor) : Vec3<double>{}, to_vec3(k_phi),
                                                         to_vec3(c_phi));
                 changed(md);
                 md.elements.add(std::move(e));
                 return md.elements.count<GroundSpring>() - 1;
             },
             py::arg("node"), py::arg("k"), py::arg("c"), py::arg("anchor") = py::none(),
             py::arg("k_phi") = Eigen::Vector3d::Zero(), py::arg("c_phi") = Eigen::Vector3d::Zero(),
             "A linear spring-damper from node to the ground: stiffness k (3) [N/m] and damping c (3) [N s/m] "
             "along the global axes, unstressed at anchor (3) [m] (None: the node's reference position); at a "
             "frame node also k_phi (3) [N m/rad] on the rotation vector from the reference orientation and "
             "c_phi (3) [N m s/rad] on the angular velocity, about the global axes. Its index among the ground "
             "springs.")
        .def("add_bushing",
             [](Model& md, int a, int b, const Eigen::Vector3d& k, const Eigen::Vector3d& c,
                const Eigen::Vector3d& k_phi, const Eigen::Vector3d& c_phi) {
                 auto e = std::make_unique<Bushing>(node_index(md, a, "node_a"), node_index(md, b, "node_b"),
                                                    to_vec3(k), to_vec3(c), to_vec3(k_phi), to_vec3(c_phi));
                 changed(md);
                 md.elements.add(std::move(e));
                 return md.elements.count<Bushing>() - 1;
             },
             py::arg("node_a"), py::arg("node_b"), py::arg("k"), py::arg("c"),
             py::arg("k_phi") = Eigen::Vector3d::Zero(), py::arg("c_phi") = Eigen::Vector3d::Zero(),
             "A linear spring-damper (bushing) between node_a and node_b (they may coincide): force K (x_b - x_a "
             "- d0) + C (v_b - v_a) on a, its opposite on b (k (3) [N/m], c (3) [N s/m] along the global axes, d0 "
             "the reference offset); between frame nodes also k_phi (3) [N m/rad] on the rotation vector of "
             "R_b R_a^T and c_phi (3) [N m s/rad] on w_b - w_a, about the global axes. Its index among the "
             "bushings.")
        .def("set_hub",
             [](Model& md, const std::vector<int>& nodes, const Eigen::Vector3d& axis, const Eigen::Vector3d& center,
                double omega, double spin_up_time) {
                 changed(md);
                 for (int i : nodes) node_index(md, i, "hub node");
                 md.hub.nodes = nodes;
                 md.hub.axis = to_vec3(axis);
                 md.hub.center = to_vec3(center);
                 md.hub.omega = omega;
                 md.hub.spin_up_time = spin_up_time;
             },
             py::arg("nodes"), py::arg("axis"), py::arg("center"), py::arg("omega"), py::arg("spin_up_time"))
        .def("hub_angle",
             [](const Model& md, double t) {
                 double a, b, c;
                 md.hub.angle(t, &a, &b, &c);
                 return py::make_tuple(a, b, c);
             },
             py::arg("t"), "The hub's angle [rad], rate [rad/s] and acceleration [rad/s^2] at time t [s].")
        .def("ancf_nodes",
             [](const Model& md, int i) {
                 const AncfElement* e = i >= 0 ? md.elements.nth<AncfElement>(i) : nullptr;
                 if (e == nullptr)
                     throw std::invalid_argument("ANCF element index must be in [0, " +
                                                 std::to_string(md.elements.count<AncfElement>()) + "), got " +
                                                 std::to_string(i));
                 return py::make_tuple(e->p(), e->q());
             },
             py::arg("element"), "The nodes (p, q) of ANCF element number element.")
        .def("set_bases",
             [](Model& md, const std::vector<Eigen::MatrixXd>& b) {
                 changed(md);
                 md.bases = b;
             },
             py::arg("bases"), "Each node's basis of its reduced coordinates (6 x n_i).")
        .def("set_shared_bases",
             [](Model& md, const std::vector<Eigen::MatrixXd>& distinct, const Ints& index) {
                 const int* k = index.data();
                 for (py::ssize_t i = 0; i < index.size(); ++i)
                     if (k[i] < 0 || k[i] >= static_cast<int>(distinct.size()))
                         throw std::invalid_argument("index must be in [0, " + std::to_string(distinct.size()) +
                                                     ") (one of the distinct bases), got " + std::to_string(k[i]));
                 changed(md);
                 md.bases.clear();
                 md.bases.reserve(static_cast<std::size_t>(index.size()));
                 for (py::ssize_t i = 0; i < index.size(); ++i) md.bases.push_back(distinct[k[i]]);
             },
             py::arg("distinct"), py::arg("index"),
             "The bases of set_bases given once each: node i gets distinct[index[i]] (most nodes share one).")
        .def("finalize", &Model::finalize, "Numbers the reduced coordinates; checks consistency.")
        .def_property_readonly("n_nodes", &Model::n_nodes)
        .def_readonly("n_dofs", &Model::n_dofs)
        .def_property_readonly("length_scale", &model_length_scale,
                               "The model's size [m] for Newton's tests: the largest extent of its reference node "
                               "positions along x, y or z, at least 1 mm.")
        .def_readonly("first_dof", &Model::first_dof)
        .def("pipe", [](const Model& md, int i) {
            const PipeElement* e = i >= 0 ? md.elements.nth<PipeElement>(i) : nullptr;
            if (e == nullptr)
                throw std::invalid_argument("pipe element index must be in [0, " +
                                            std::to_string(md.elements.count<PipeElement>()) + "), got " +
                                            std::to_string(i));
            return e->data;
        },
        py::arg("element"), "The data of pipe element number element (a copy).");

    py::class_<State>(m, "State")
        .def(py::init<const Model&>(), py::arg("model"), "The reference state of a finalized model.")
        .def_property(
            "q", [](State& s) -> Eigen::Ref<Eigen::VectorXd> { return s.q; },
            [](State& s, const Eigen::VectorXd& x) { set_coordinates(s, s.q, x, "q"); }, py::return_value_policy::reference_internal)
        .def_property(
            "v", [](State& s) -> Eigen::Ref<Eigen::VectorXd> { return s.v; },
            [](State& s, const Eigen::VectorXd& x) { set_coordinates(s, s.v, x, "v"); }, py::return_value_policy::reference_internal)
        .def_property(
            "a", [](State& s) -> Eigen::Ref<Eigen::VectorXd> { return s.a; },
            [](State& s, const Eigen::VectorXd& x) { set_coordinates(s, s.a, x, "a"); }, py::return_value_policy::reference_internal)
        .def("frame", [](const State& s, int i) { return from_mat3<RowMat3>(s.frames[frame_index(s, i)]); },
             py::arg("node"), "The reference rotation (3, 3) of node.")
        .def("set_frame", [](State& s, int i, const RowMat3& R) { s.frames[frame_index(s, i)] = to_mat3(R); },
             py::arg("node"), py::arg("R"), "Sets the reference rotation (3, 3) of node.")
        .def_property(
            "frames",
            [](const State& s) {
                const auto n = static_cast<py::ssize_t>(s.frames.size());
                py::array_t<double> out({n, py::ssize_t{3}, py::ssize_t{3}});
                auto o = out.mutable_unchecked<3>();
                for (py::ssize_t i = 0; i < n; ++i)
                    for (int r = 0; r < 3; ++r)
                        for (int c = 0; c < 3; ++c) o(i, r, c) = s.frames[i](r, c);
                return out;
            },
            [](State& s, const py::array_t<double, py::array::c_style | py::array::forcecast>& a) {
                const auto n = static_cast<py::ssize_t>(s.frames.size());
                if (a.ndim() != 3 || a.shape(0) != n || a.shape(1) != 3 || a.shape(2) != 3)
                    throw std::invalid_argument("frames must have shape (" + std::to_string(n) + ", 3, 3)");
                auto x = a.unchecked<3>();
                for (py::ssize_t i = 0; i < n; ++i)
                    for (int r = 0; r < 3; ++r)
                        for (int c = 0; c < 3; ++c) s.frames[i](r, c) = x(i, r, c);
            },
            "Every node's reference rotation, (n_nodes, 3, 3), copied (one call where frame(i) is one per node).")
        .def("rotation", [](const State& s, int i) { return from_mat3<RowMat3>(s.rotation(frame_index(s, i))); },
             py::arg("node"), "The rotation (3, 3) of node: exp(phi) R_ref (ANCF node: e1 along the slope, e3 = z).")
        .def("rebase", &State::rebase, py::arg("max_angle"))
        .def("copy", [](const State& s) { return State(s); });

    m.def(
        "assemble",
        [](const Model& md, const State& s, const LoadState& load, double lf, double wK, double wC,
           double wM, bool matrix) {
            Eigen::VectorXd r;
            Triplets t;
            {
                py::gil_scoped_release release;
                assemble(md, s, load, lf, wK, wC, wM, &r, matrix ? &t : nullptr);
            }
            if (!matrix) return py::make_tuple(r, py::none());
            return py::make_tuple(r, triplets_to_numpy(t));
        },
        py::arg("model"), py::arg("state"), py::arg("load"), py::arg("load_factor"), py::arg("wK"),
        py::arg("wC"), py::arg("wM"), py::arg("matrix") = true,
        "Reduced residual and weighted tangent triplets (rows, cols, values): the route of the C++ "
        "integrators, kept as the reference of assemble_csc's tests.");
    m.def(
        "assemble_csc",
        [](const Model& md, const State& s, const LoadState& load, double lf,
           const std::vector<std::tuple<double, double, double>>& weights, bool residual) {
            check_state(md, s);
            const auto pattern = tangent_pattern(md);
            const auto nnz = static_cast<py::ssize_t>(pattern->nnz());
            std::vector<TangentWeights> w;
            std::vector<py::array_t<double>> data;
            std::vector<double*> values;
            for (const auto& [wK, wC, wM] : weights) {
                w.push_back({wK, wC, wM});
                data.emplace_back(nnz);
                values.push_back(data.back().mutable_data());
            }
            Eigen::VectorXd r;
            {
                py::gil_scoped_release release;
                assemble_csc(md, s, load, lf, w, residual ? &r : nullptr, values.data());
            }
            py::list out;
            for (auto& d : data) out.append(d);
            const py::array_t<int> indices(nnz, pattern->row_index.data());
            const py::array_t<int> indptr(static_cast<py::ssize_t>(pattern->col_ptr.size()), pattern->col_ptr.data());
            return py::make_tuple(residual ? py::cast(r) : py::none(), out, indices, indptr);
        },
        py::arg("model"), py::arg("state"), py::arg("load"), py::arg("load_factor"), py::arg("weights"),
        py::arg("residual") = true,
        "Reduced residual (or None) and, in one pass over the elements, the values of the tangent "
        "wK K + wC C + wM M for each (wK, wC, wM) of weights on the model's cached CSC pattern: "
        "(r, [data per weight set], indices, indptr), with fresh copies of the pattern arrays.");
    m.def(
        "assemble_geometric",
        [](const Model& md, const State& s, const Eigen::VectorXd& dq) {
            if (dq.size() != 6 * md.n_nodes()) throw std::invalid_argument("dq must have 6 entries per node");
            Triplets t;
            assemble_geometric(md, s, dq, &t);
            return triplets_to_numpy(t);
        },
        py::arg("model"), py::arg("state"), py::arg("dq"),
        "Prestress stiffness triplets of the first-order strains of the full displacement dq.");
    m.def("external_forces", &external_forces, py::arg("model"), py::arg("state"), py::arg("t") = 0.0,
          "The nodal loads at the state and time t [s], 6 per node [N, N m] (load factor 1).");
    m.def(
        "add_increment",
        [](const Model& md, State& s, const Eigen::VectorXd& dz, const std::string& which) {
            if (which != "q" && which != "v" && which != "a")
                throw std::invalid_argument("add_increment: which must be \"q\", \"v\" or \"a\", got \"" + which + "\"");
            Eigen::VectorXd& x = which == "q" ? s.q : which == "v" ? s.v : s.a;
            add_increment(md, x, dz);
        },
        py::arg("model"), py::arg("state"), py::arg("dz"), py::arg("which"),
        "Adds the reduced increment dz to the state's coordinates which (\"q\", \"v\" or \"a\"), in place.");
    m.def("reduce", py::overload_cast<const Model&, const Eigen::VectorXd&>(&reduce), py::arg("model"), py::arg("full"),
          "T^T full: a vector of 6 entries per node on the reduced coordinates.");
}
