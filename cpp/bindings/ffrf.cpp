// Bindings of the floating-frame body kernels (seed 004).
#include "pipeflex/elements/ffrf_body.hpp"

#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>

namespace py = pybind11;
using namespace pipeflex;

void bind_ffrf(py::module_& m) {
    m.def(
        "beam_integrals",
        [](double l) {
            BeamIntegrals b;
            beam_integrals(l, b);
            py::dict r;
            r["NN"] = MatX(b.NN);
            r["NdN"] = MatX(b.NdN);
            r["NddN"] = MatX(b.NddN);
            r["NSN"] = std::vector<MatX>(b.NSN.begin(), b.NSN.end());
            r["NSdN"] = std::vector<MatX>(b.NSdN.begin(), b.NSdN.end());
            r["N"] = MatX(b.N);
            return r;
        },
        py::arg("l"));
    m.def(
        "beam_stiffness",
        [](double l, double EA, double GJ, double EIy, double EIz) {
            Mat12d k;
            beam_stiffness(l, EA, GJ, EIy, EIz, k);
            return MatX(k);
        },
        py::arg("l"), py::arg("EA"), py::arg("GJ"), py::arg("EIy"), py::arg("EIz"));

    m.def(
        "beam_slope_integrals",
        [](double l) {
            Mat12d g0, g1;
            beam_slope_integrals(l, g0, g1);
            return std::make_pair(MatX(g0), MatX(g1));
        },
        py::arg("l"),
        "(G0, G1): int (N_y'^T N_y' + N_z'^T N_z') ds [1/m] and the same weighted by s [-] (s from the element's "
        "start) over one element of length l [m].");

    py::class_<FfrfBodyData>(m, "FfrfBodyData")
        .def(py::init([](MatX M, MatX K, VecX eta0, std::vector<MatX> A, std::vector<MatX> Bk, std::vector<MatX> GPhi,
                         std::vector<VecX> Gx, MatX CPhi, MatX HPhi, VecX Cx, VecX Hx, MatX Ng,
                         std::optional<MatX> D, double mu_f, MatX Ubar, MatX Us, MatX Ue, MatX dUs, MatX dUe,
                         MatX Gs0, MatX Gs1, MatX Ua) {
                 if (A.size() != 3 || Bk.size() != 3 || GPhi.size() != 3 || Gx.size() != 3)
                     throw std::invalid_argument("A, Bk, GPhi, Gx need 3 entries (k = x, y, z)");
                 FfrfBodyData d;
                 d.M = std::move(M);
                 d.K = std::move(K);
                 d.eta0 = std::move(eta0);
                 for (int k = 0; k < 3; ++k) {
                     d.A[k] = A[k];
                     d.Bk[k] = Bk[k];
                     d.GPhi[k] = GPhi[k];
                     d.Gx[k] = Gx[k];
                 }
                 d.CPhi = std::move(CPhi);
                 d.HPhi = std::move(HPhi);
                 d.Cx = std::move(Cx);
                 d.Hx = std::move(Hx);
                 d.Ng = std::move(Ng);
                 if (D) d.D = std::move(*D);
                 d.mu_f = mu_f;
                 d.Ubar = std::move(Ubar);
                 d.Us = std::move(Us);
                 d.Ue = std::move(Ue);
                 d.dUs = std::move(dUs);
                 d.dUe = std::move(dUe);
                 d.Gs0 = std::move(Gs0);
                 d.Gs1 = std::move(Gs1);
                 d.Ua = std::move(Ua);
                 check_ffrf_body(d);
                 return d;
             }),
             py::arg("M"), py::arg("K"), py::arg("eta0"), py::arg("A"), py::arg("Bk"), py::arg("GPhi"),
             py::arg("Gx"), py::arg("CPhi"), py::arg("HPhi"), py::arg("Cx"), py::arg("Hx"), py::arg("Ng"),
             py::arg("D") = py::none(), py::arg("mu_f") = 0.0, py::arg("Ubar") = MatX(0, 0), py::arg("Us") = MatX(0, 0),
             py::arg("Ue") = MatX(0, 0), py::arg("dUs") = MatX(0, 0), py::arg("dUe") = MatX(0, 0),
             py::arg("Gs0") = MatX(0, 0), py::arg("Gs1") = MatX(0, 0), py::arg("Ua") = MatX(0, 0),
             "A body's reduced constants (ffrf_body.hpp); D (m x m) the elastic coordinates' damping (None: undamped); mu_f [kg/m], Ubar = int N Phi mu_f ds [kg], Us, Ue "
             "(Phi's translation rows at the start and end node) and dUs, dUe (du/ds there per eta), 3 x m, give "
             "the fluid forces' moment on the deformed lever arm (all empty: left out); Gs0, Gs1 (m x m, "
             "Phi^T int lateral slopes^T slopes ds Phi and the same weighted by s) the geometric stiffness of the fluid "
             "acceleration's axial force, Ua (3 x m, int N Phi mu_f ds) its load's moment on the deformed lever arm (all "
             "three empty: left out).")
        .def_property_readonly("n", [](const FfrfBodyData& d) { return d.M.rows(); })
        .def_readonly("M", &FfrfBodyData::M)
        .def_readonly("K", &FfrfBodyData::K)
        .def_readonly("eta0", &FfrfBodyData::eta0)
        .def_readonly("Ng", &FfrfBodyData::Ng)
        .def_readonly("D", &FfrfBodyData::D)
        .def_readonly("Gs0", &FfrfBodyData::Gs0)
        .def_readonly("Gs1", &FfrfBodyData::Gs1)
        .def(
            "forces",
            [](const FfrfBodyData& d, const Mat3d& R, const Vec3d& omega, const VecX& a, const VecX& eta,
               const VecX& eta_dot, double sdot, double sddot, const Vec3d& gravity, double wK, double wC, double wM,
               bool tangent, double rate_force_zero) {
                const FfrfBodyMotion s{R, omega, a, eta, eta_dot, sdot, sddot, gravity, rate_force_zero};
                const Eigen::Index n = d.M.rows();
                VecX r(n);
                MatX t(tangent ? n : 0, tangent ? n : 0);
                FfrfBodyWork work;
                ffrf_body_forces(d, s, wK, wC, wM, work, r, t, tangent);
                return std::make_pair(r, tangent ? std::optional<MatX>(t) : std::nullopt);
            },
            py::arg("R"), py::arg("omega"), py::arg("a"), py::arg("eta"), py::arg("eta_dot"), py::arg("sdot"),
            py::arg("sddot"), py::arg("gravity"), py::arg("wK") = 1.0, py::arg("wC") = 0.0, py::arg("wM") = 0.0,
            py::arg("tangent") = true, py::arg("rate_force_zero") = 0.0);
}
