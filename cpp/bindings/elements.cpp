#include "convert.hpp"
#include "pipeflex/assembly/model.hpp"
#include "pipeflex/core/rotation.hpp"
#include "pipeflex/elements/ancf_beam2d.hpp"
#include "pipeflex/elements/pipe_beam3d.hpp"

#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>

namespace py = pybind11;
using namespace pipeflex;
using namespace pipeflex::bindings;

namespace {

using Vec12 = Eigen::Matrix<double, 12, 1>;
using Mat12 = Eigen::Matrix<double, 12, 12, Eigen::RowMajor>;

NodeFrames frames(const RowMat3& p, const RowMat3& q) { return {to_mat3(p), to_mat3(q)}; }

}  // namespace

void bind_elements(py::module_& m) {
    py::class_<PipeElementData>(m, "PipeElementData")
        .def(py::init<>())
        .def_readwrite("l0", &PipeElementData::l0)
        .def_readwrite("EA", &PipeElementData::EA)
        .def_readwrite("GJ", &PipeElementData::GJ)
        .def_readwrite("EIy", &PipeElementData::EIy)
        .def_readwrite("EIz", &PipeElementData::EIz)
        .def_readwrite("Phi_y", &PipeElementData::Phi_y)
        .def_readwrite("Phi_z", &PipeElementData::Phi_z)
        .def_readwrite("strain0", &PipeElementData::strain0)
        .def_property(
            "offset_p", [](const PipeElementData& d) { return from_mat3<RowMat3>(d.offset_p); },
            [](PipeElementData& d, const RowMat3& a) { d.offset_p = to_mat3(a); })
        .def_property(
            "offset_q", [](const PipeElementData& d) { return from_mat3<RowMat3>(d.offset_q); },
            [](PipeElementData& d, const RowMat3& a) { d.offset_q = to_mat3(a); })
        .def_readwrite("pipe_mass", &PipeElementData::pipe_mass)
        .def_readwrite("fluid_mass", &PipeElementData::fluid_mass)
        .def_readwrite("kv", &PipeElementData::kv)
        .def_readwrite("rotary_inertia", &PipeElementData::rotary_inertia)
        .def_readwrite("flow_factor", &PipeElementData::flow_factor)
        .def_readwrite("end_terms_p", &PipeElementData::end_terms_p)
        .def_readwrite("end_terms_q", &PipeElementData::end_terms_q)
        .def_readwrite("eta_axial", &PipeElementData::eta_axial)
        .def_readwrite("eta_torsion", &PipeElementData::eta_torsion)
        .def_readwrite("eta_bending", &PipeElementData::eta_bending)
        .def_readwrite("c_ext", &PipeElementData::c_ext)
        .def_readwrite("k_found", &PipeElementData::k_found);

    py::class_<LoadState>(m, "LoadState")
        .def(py::init<>())
        .def_readwrite("mass_flow", &LoadState::mass_flow)
        .def_readwrite("mass_flow_rate", &LoadState::mass_flow_rate)
        .def_readwrite("gravity", &LoadState::gravity)
        .def_readwrite("gravity_factor", &LoadState::gravity_factor)
        .def_readwrite("frame_rate", &LoadState::frame_rate)
        .def_readwrite("frame_acceleration", &LoadState::frame_acceleration)
        .def_readwrite("frame_center", &LoadState::frame_center);

    m.def(
        "pipe_tangent",
        [](const PipeElementData& d, const RowMat3& fp, const RowMat3& fq, const LoadState& load,
           const Vec12& q, const Vec12& v, const Vec12& a, double wK, double wC, double wM,
           std::optional<Eigen::Matrix<double, 6, 1>> sigma_geometric) {
            Vec12 r;
            Mat12 J;
            if (sigma_geometric) {
                const double w[3] = {wK, wC, wM};
                double* Jp = J.data();
                pipe_tangents(d, frames(fp, fq), load, q.data(), v.data(), a.data(), 1, w, r.data(), &Jp,
                              sigma_geometric->data());
            } else {
                pipe_tangent(d, frames(fp, fq), load, q.data(), v.data(), a.data(), wK, wC, wM, r.data(), J.data());
            }
            return py::make_tuple(r, J);
        },
        py::arg("data"), py::arg("frame_p"), py::arg("frame_q"), py::arg("load"), py::arg("q"),
        py::arg("v"), py::arg("a"), py::arg("wK"), py::arg("wC"), py::arg("wM"),
        py::arg("sigma_geometric") = py::none(),
        "Element residual r (12) and weighted tangent wK dr/dq + wC dr/dv + wM M (12x12); with "
        "sigma_geometric (6) the geometric part of dr/dq takes those stresses (the mixed Newton).");
    m.def(
        "pipe_predicted_stresses",
        [](const PipeElementData& d, const RowMat3& fp, const RowMat3& fq, const Vec12& q, const Vec12& dq) {
            Eigen::Matrix<double, 6, 1> s;
            pipe_predicted_stresses(d, frames(fp, fq), q.data(), dq.data(), s.data());
            return s;
        },
        py::arg("data"), py::arg("frame_p"), py::arg("frame_q"), py::arg("q"), py::arg("dq"),
        "Generalised stresses (6) of the strains linearised at q, extrapolated along dq (12).");
    m.def(
        "pipe_tangent_ad",
        [](const PipeElementData& d, const RowMat3& fp, const RowMat3& fq, const LoadState& load,
           const Vec12& q, const Vec12& v, const Vec12& a, double wK, double wC, double wM) {
            Vec12 r;
            Mat12 J;
            pipe_tangent_ad(d, frames(fp, fq), load, q.data(), v.data(), a.data(), wK, wC, wM, r.data(), J.data());
            return py::make_tuple(r, J);
        },
        py::arg("data"), py::arg("frame_p"), py::arg("frame_q"), py::arg("load"), py::arg("q"),
        py::arg("v"), py::arg("a"), py::arg("wK"), py::arg("wC"), py::arg("wM"),
        "pipe_tangent by forward AD of the residual (the tests' reference).");
    m.def(
        "pipe_fluid_forces",
        [](const PipeElementData& d, const RowMat3& fp, const RowMat3& fq, const LoadState& load,
           const Vec12& q, const Vec12& v) {
            Vec12 f;
            pipe_fluid_forces(d, frames(fp, fq), load, q.data(), v.data(), f.data());
            return f;
        },
        py::arg("data"), py::arg("frame_p"), py::arg("frame_q"), py::arg("load"), py::arg("q"),
        py::arg("v"), "Flow-dependent part of the element residual (12): r(flow) - r(no flow).");
    m.def(
        "pipe_fluid_power",
        [](const PipeElementData& d, const RowMat3& fp, const RowMat3& fq, const LoadState& load,
           const Vec12& q, const Vec12& v) { return pipe_fluid_power(d, frames(fp, fq), load, q.data(), v.data()); },
        py::arg("data"), py::arg("frame_p"), py::arg("frame_q"), py::arg("load"), py::arg("q"), py::arg("v"),
        "Power [W] the fluid forces deliver to the element, -v . pipe_fluid_forces (the transients' fluid work).");
    m.def(
        "_bench_pipe_kernels",
        [](const PipeElementData& d, const RowMat3& fp, const RowMat3& fq, const LoadState& load,
           const Vec12& q, const Vec12& v, const Vec12& a, int repeats) {
            // Timed in C++: one Python call costs about as much as the residual itself.
            const NodeFrames f = frames(fp, fq);
            double r[12], J[144];
            double sink = 0.0;
            auto time = [&](auto&& kernel) {
                const auto t0 = std::chrono::steady_clock::now();
                for (int k = 0; k < repeats; ++k) {
                    kernel();
                    sink += r[0] + J[13];
                }
                const std::chrono::duration<double> dt = std::chrono::steady_clock::now() - t0;
                return dt.count() / repeats;
            };
            py::dict out;
            out["residual"] = time([&] { pipe_tangent(d, f, load, q.data(), v.data(), a.data(), 0, 0, 0, r, nullptr); });
            out["tangent"] = time([&] { pipe_tangent(d, f, load, q.data(), v.data(), a.data(), 1, 0.5, 0.25, r, J); });
            out["tangent_ad"] = time([&] { pipe_tangent_ad(d, f, load, q.data(), v.data(), a.data(), 1, 0.5, 0.25, r, J); });
            out["mass_matrix"] = time([&] { pipe_mass_matrix(d, f, q.data(), J); });
            out["fluid_forces"] = time([&] { pipe_fluid_forces(d, f, load, q.data(), v.data(), r); });
            out["_sink"] = sink;
            return out;
        },
        py::arg("data"), py::arg("frame_p"), py::arg("frame_q"), py::arg("load"), py::arg("q"),
        py::arg("v"), py::arg("a"), py::arg("repeats"),
        "Seconds per call of the element kernels (residual, tangent, tangent_ad, mass_matrix, "
        "fluid_forces), timed over `repeats` calls each in C++ (benchmarks/bench_kernels.py).");
    m.def(
        "pipe_mass_matrix",
        [](const PipeElementData& d, const RowMat3& fp, const RowMat3& fq, const Vec12& q) {
            Mat12 M;
            pipe_mass_matrix(d, frames(fp, fq), q.data(), M.data());
            return M;
        },
        py::arg("data"), py::arg("frame_p"), py::arg("frame_q"), py::arg("q"));
    m.def(
        "pipe_strains",
        [](const PipeElementData& d, const RowMat3& fp, const RowMat3& fq, const Vec12& q) {
            Eigen::Matrix<double, 6, 1> e;
            pipe_strains(d, frames(fp, fq), q.data(), e.data());
            return e;
        },
        py::arg("data"), py::arg("frame_p"), py::arg("frame_q"), py::arg("q"));
    py::class_<AncfElementData>(m, "AncfElementData")
        .def(py::init<>())
        .def_readwrite("l", &AncfElementData::l)
        .def_readwrite("EA", &AncfElementData::EA)
        .def_readwrite("EI", &AncfElementData::EI)
        .def_readwrite("mass", &AncfElementData::mass)
        .def_readwrite("tip_mass", &AncfElementData::tip_mass)
        .def_readwrite("eta_axial", &AncfElementData::eta_axial)
        .def_readwrite("eta_bending", &AncfElementData::eta_bending)
        .def_readwrite("c_ext", &AncfElementData::c_ext)
        .def_readwrite("k_found", &AncfElementData::k_found)
        .def_property(
            "elastic", [](const AncfElementData& d) { return d.elastic == AncfElastic::model_a ? "A" : "0"; },
            [](AncfElementData& d, const std::string& m) {
                if (m != "A" && m != "0") throw std::invalid_argument("elastic model must be 'A' or '0', got '" + m + "'");
                d.elastic = m == "A" ? AncfElastic::model_a : AncfElastic::model_0;
            });
    using Vec8 = Eigen::Matrix<double, 8, 1>;
    using Mat8 = Eigen::Matrix<double, 8, 8, Eigen::RowMajor>;
    m.def(
        "ancf_tangent",
        [](const AncfElementData& d, const Vec8& e, const Vec8& v, const Vec8& a, const Eigen::Vector2d& g,
           const Eigen::Vector4d& frame, double wK, double wC, double wM) {
            Vec8 r;
            Mat8 J;
            AncfFrame f;
            f.rate = frame[0];
            f.acceleration = frame[1];
            f.center[0] = frame[2];
            f.center[1] = frame[3];
            ancf_tangent(d, e.data(), v.data(), a.data(), g.data(), &f, wK, wC, wM, r.data(), J.data());
            return py::make_tuple(r, J);
        },
        py::arg("data"), py::arg("e"), py::arg("v"), py::arg("a"), py::arg("gravity"), py::arg("frame"), py::arg("wK"),
        py::arg("wC"), py::arg("wM"),
        "Planar ANCF element (seed 002): residual (8) and weighted tangent (8x8); frame = (rate [rad/s], "
        "acceleration [rad/s^2], centre x, y [m]) of a co-rotating frame (zeros: inertial).");
    m.def(
        "ancf_geometric_stiffness",
        [](const AncfElementData& d, const Vec8& e, const Vec8& de) {
            Mat8 G;
            ancf_geometric_stiffness(d, e.data(), de.data(), G.data());
            return G;
        },
        py::arg("data"), py::arg("e"), py::arg("de"), "Model A prestress stiffness of the strains linearised along de.");
    m.def(
        "ancf_energies",
        [](const AncfElementData& d, const Vec8& e, const Vec8& v) {
            double t, u;
            ancf_energies(d, e.data(), v.data(), &t, &u);
            return py::make_tuple(t, u);
        },
        py::arg("data"), py::arg("e"), py::arg("v"), "Kinetic and elastic energy [J].");
    m.def(
        "ancf_model_a_matrix",
        [](const AncfElementData& d, int which) {
            if (which < 0 || which > 4) throw std::invalid_argument("which must be 0 (K_A) .. 4 (M)");
            Mat8 out;
            ancf_model_a_matrix(d, which, out.data());
            return out;
        },
        py::arg("data"), py::arg("which"), "K_A, K_M, K_B, K_t or M (which = 0..4) of seed 002's appendix.");
    m.def(
        "planar_triad", [](const Eigen::Vector3d& slope) { return from_mat3<RowMat3>(planar_triad(to_vec3(slope))); },
        py::arg("slope"), "Triad (columns e1, e2, e3) of a planar ANCF node: e1 along the slope, e3 = z.");
    m.def(
        "rotation_exp",
        [](const Eigen::Vector3d& phi) { return from_mat3<RowMat3>(rotation_exp(to_vec3(phi))); },
        py::arg("phi"), "exp(skew(phi)) for a rotation vector phi [rad].");
    m.def(
        "rotation_jacobian",
        [](const Eigen::Vector3d& phi) { return from_mat3<RowMat3>(rotation_jacobian(to_vec3(phi))); },
        py::arg("phi"), "Left Jacobian T(phi): omega = T(phi) phi_dot.");
    m.def(
        "convective_angular_acceleration",
        [](const Eigen::Vector3d& phi, const Eigen::Vector3d& phid) {
            const Vec3<double> w = convective_angular_acceleration(to_vec3(phi), to_vec3(phid));
            return Eigen::Vector3d(w[0], w[1], w[2]);
        },
        py::arg("phi"), py::arg("phi_dot"),
        "d/dt[T(phi)] phi_dot [rad/s^2]: omega_dot = T(phi) phi_ddot + this, for a rotation vector phi [rad] "
        "and its rate phi_dot [rad/s].");
}
