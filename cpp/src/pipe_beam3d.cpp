#include "pipeflex/elements/pipe_beam3d.hpp"

#include "pipeflex/elements/hermite.hpp"

#include <cmath>
#include <type_traits>

namespace pipeflex {
namespace {

template <class S> Vec3<S> vec(const S* p) { return {{p[0], p[1], p[2]}}; }

// fn(std::true_type) or fn(std::false_type) as flag: a run-time flag made a compile-time one.
template <class Fn> void with_flag(bool flag, Fn&& fn) {
    if (flag)
        fn(std::true_type{});
    else
        fn(std::false_type{});
}

template <class S> void add_to(S* dst, const Vec3<S>& x) {
    for (int i = 0; i < 3; ++i) dst[i] += x[i];
}

// R_ref R_offset. The offset is the identity on a straight run: then no product (the same
// values: the product's other terms are zeros).
inline Mat3<double> frame_offset(const Mat3<double>& frame, const Mat3<double>& offset) {
    static constexpr std::array<double, 9> identity{1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
    return offset.c == identity ? frame : frame * offset;
}

// End triad E = exp(phi) R_ref R_offset; its columns are e_x, e_y, e_z.
template <class S>
Mat3<S> end_triad(const Vec3<S>& phi, const Mat3<double>& frame, const Mat3<double>& offset) {
    return rotation_exp(phi) * promote<S>(frame_offset(frame, offset));
}

// Generalised strains eps (eqs. 1-2), from the barred strains eps_bar, their gradients with
// respect to the virtual displacements u = [dx^p, dtheta^p, dx^q, dtheta^q] (spatial
// virtual rotations) and the Jacobian d eps/d eps_bar (add_strain_work: eps's gradients
// are never formed). Both are kept by their nonzero parts (bar_grad_matrix and
// strain_jacobian give them whole): the gradients' 3-blocks el (stretch, at x^q; -el at
// x^p), tw (twist, at theta^p; -tw at theta^q) and, of the bending strain k = 2..5 at index
// k - 2, gx (at x^q; -gx at x^p) and gr (at theta of node k % 2); the Jacobian is I plus
// the rows j0 = J[0][2..5], j1 = J[1][2..5] and the entries +-c6 s56, +-c6 s34, +-c6 eb_1.
template <class S> struct Strains {
    std::array<S, 6> eps;
    std::array<S, 6> bar;
    Vec3<S> el, tw, gx[4], gr[4];
    std::array<S, 4> j0, j1;
    S a56, a34, a1;
};

template <class S>
Strains<S> strains(double l0, const Vec3<S>& xp, const Vec3<S>& xq, const Mat3<S>& Ep,
                   const Mat3<S>& Eq) {
    using std::sqrt;
    const Vec3<S> d = xq - xp;
    const S l = sqrt(dot(d, d));
    const Vec3<S> el = (S(1.0) / l) * d;
    const Vec3<S> eyp = Ep.col(1), ezp = Ep.col(2), eyq = Eq.col(1), ezq = Eq.col(2);

    Strains<S> out;
    auto& eb = out.bar;  // barred strains
    eb[0] = l - l0;
    out.el = el;
    eb[1] = 0.5 * l0 * (dot(ezp, eyq) - dot(eyp, ezq));
    const Vec3<S> c1 = cross(ezp, eyq) - cross(eyp, ezq);
    for (int i = 0; i < 3; ++i) out.tw[i] = 0.5 * l0 * c1[i];
    // eps_bar_k = s l0 e_l . e (e a triad vector of node k % 2: 0 for p, 1 for q)
    auto bend = [&](int k, double s, const Vec3<S>& e) {
        const S ele = dot(el, e);
        eb[k] = s * l0 * ele;
        out.gx[k - 2] = (S(s * l0) / l) * (e - ele * el);  // s l0 (I - el el^T) e / l
        out.gr[k - 2] = (s * l0) * cross(e, el);
    };
    bend(2, -1.0, ezp);
    bend(3, 1.0, ezq);
    bend(4, 1.0, eyp);
    bend(5, -1.0, eyq);

    // eps(eps_bar) of eq. 1 and the Jacobian de/deb.
    const double c30 = 1.0 / (30.0 * l0), c6 = 1.0 / (6.0 * l0), c1l = 1.0 / l0;
    auto& e = out.eps;
    e[0] = eb[0] + c30 * (2.0 * eb[2] * eb[2] + eb[2] * eb[3] + 2.0 * eb[3] * eb[3] +
                          2.0 * eb[4] * eb[4] + eb[4] * eb[5] + 2.0 * eb[5] * eb[5]);
    e[1] = eb[1] + c1l * (eb[3] * eb[4] - eb[2] * eb[5]);
    const S s56 = eb[4] + eb[5], s34 = eb[2] + eb[3];
    e[2] = eb[2] + c6 * eb[1] * s56;
    e[3] = eb[3] - c6 * eb[1] * s56;
    e[4] = eb[4] - c6 * eb[1] * s34;
    e[5] = eb[5] + c6 * eb[1] * s34;
    out.j0 = {c30 * (4.0 * eb[2] + eb[3]), c30 * (eb[2] + 4.0 * eb[3]), c30 * (4.0 * eb[4] + eb[5]),
              c30 * (eb[4] + 4.0 * eb[5])};
    out.j1 = {-c1l * eb[5], c1l * eb[4], c1l * eb[3], -c1l * eb[2]};
    out.a56 = c6 * s56;
    out.a34 = c6 * s34;
    out.a1 = c6 * eb[1];
    return out;
}

// The Jacobian d eps/d eps_bar whole (6 x 6).
template <class S> std::array<std::array<S, 6>, 6> strain_jacobian(const Strains<S>& st) {
    std::array<std::array<S, 6>, 6> J;
    for (auto& row : J) row.fill(S(0.0));
    for (int i = 0; i < 6; ++i) J[i][i] = S(1.0);
    for (int k = 0; k < 4; ++k) {
        J[0][2 + k] = st.j0[k];
        J[1][2 + k] = st.j1[k];
    }
    J[2][1] = st.a56;  J[2][4] = st.a1;  J[2][5] = st.a1;
    J[3][1] = -st.a56; J[3][4] = -st.a1; J[3][5] = -st.a1;
    J[4][1] = -st.a34; J[4][2] = -st.a1; J[4][3] = -st.a1;
    J[5][1] = st.a34;  J[5][2] = st.a1;  J[5][3] = st.a1;
    return J;
}

// The barred strains' gradients d eps_bar/du whole (6 x 12).
template <class S> std::array<std::array<S, 12>, 6> bar_grad_matrix(const Strains<S>& st) {
    std::array<std::array<S, 12>, 6> gb;
    for (auto& g : gb) g.fill(S(0.0));
    for (int i = 0; i < 3; ++i) {
        gb[0][i] = -st.el[i];
        gb[0][6 + i] = st.el[i];
        gb[1][3 + i] = st.tw[i];
        gb[1][9 + i] = -st.tw[i];
        for (int k = 2; k < 6; ++k) {
            gb[k][i] = -st.gx[k - 2][i];
            gb[k][6 + i] = st.gx[k - 2][i];
            gb[k][6 * (k % 2) + 3 + i] = st.gr[k - 2][i];
        }
    }
    return gb;
}

// (d eps/d eps_bar)^T s, the terms in the order of a dense product (the same values).
template <class S, class T> std::array<S, 6> strain_jacobian_t(const Strains<S>& st, const T* s) {
    std::array<S, 6> sb;
    sb[0] = S(s[0]);
    sb[1] = s[1] + s[2] * st.a56 - s[3] * st.a56 - s[4] * st.a34 + s[5] * st.a34;
    sb[2] = s[0] * st.j0[0] + s[1] * st.j1[0] + s[2] - s[4] * st.a1 + s[5] * st.a1;
    sb[3] = s[0] * st.j0[1] + s[1] * st.j1[1] + s[3] - s[4] * st.a1 + s[5] * st.a1;
    sb[4] = s[0] * st.j0[2] + s[1] * st.j1[2] + s[2] * st.a1 - s[3] * st.a1 + s[4];
    sb[5] = s[0] * st.j0[3] + s[1] * st.j1[3] + s[2] * st.a1 - s[3] * st.a1 + s[5];
    return sb;
}

// f += D^T s, D = d eps/du = (d eps/d eps_bar)(d eps_bar/du): as (d eps_bar/du)^T ((d eps/
// d eps_bar)^T s) on the nonzero blocks, strain by strain (the order of a dense product).
template <class S, class T> void add_strain_work(const Strains<S>& st, const T* s, S* f) {
    const std::array<S, 6> sb = strain_jacobian_t(st, s);
    for (int i = 0; i < 3; ++i) {
        f[i] -= sb[0] * st.el[i];
        f[6 + i] += sb[0] * st.el[i];
        f[3 + i] += sb[1] * st.tw[i];
        f[9 + i] -= sb[1] * st.tw[i];
    }
    for (int k = 2; k < 6; ++k) {
        S* fr = f + 6 * (k % 2) + 3;
        for (int i = 0; i < 3; ++i) {
            f[i] -= sb[k] * st.gx[k - 2][i];
            fr[i] += sb[k] * st.gr[k - 2][i];
            f[6 + i] += sb[k] * st.gx[k - 2][i];
        }
    }
}

// Generalised stresses sigma (eqs. 6-7) from the strain deviations de = eps - eps^0.
template <class S> std::array<S, 6> stresses(const PipeElementData& e, const std::array<S, 6>& de) {
    const double l3 = e.l0 * e.l0 * e.l0;
    const double ky = e.EIy / ((1.0 + e.Phi_z) * l3), kz = e.EIz / ((1.0 + e.Phi_y) * l3);
    std::array<S, 6> s;
    s[0] = (e.EA / e.l0) * de[0];
    s[1] = (e.GJ / l3) * de[1];
    s[2] = ky * ((4.0 + e.Phi_z) * de[2] + (-2.0 + e.Phi_z) * de[3]);
    s[3] = ky * ((-2.0 + e.Phi_z) * de[2] + (4.0 + e.Phi_z) * de[3]);
    s[4] = kz * ((4.0 + e.Phi_y) * de[4] + (-2.0 + e.Phi_y) * de[5]);
    s[5] = kz * ((-2.0 + e.Phi_y) * de[4] + (4.0 + e.Phi_y) * de[5]);
    return s;
}

// Kelvin-Voigt forces D^T sigma_d (added to f): the strain rates eps_dot = D u_dot of the
// virtual-space velocities u_dot = [xdot^p, w^p, xdot^q, w^q] (w the spatial angular
// velocities), sigma_d = C eta eps_dot with C of stresses() (one eta per strain group).
template <class S>
void add_kelvin_voigt(const PipeElementData& e, const Strains<S>& st, const S* ud, S* f) {
    // eps_bar_dot = (d eps_bar/du) u_dot on the nonzero blocks, in the order of a dense product
    auto acc = [](S& x, const Vec3<S>& g, const S* u, double sign) {
        for (int i = 0; i < 3; ++i) x += (sign * g[i]) * u[i];
    };
    std::array<S, 6> br;
    for (auto& x : br) x = S(0.0);
    acc(br[0], st.el, ud, -1.0);
    acc(br[0], st.el, ud + 6, 1.0);
    acc(br[1], st.tw, ud + 3, 1.0);
    acc(br[1], st.tw, ud + 9, -1.0);
    for (int k = 2; k < 6; ++k) {
        acc(br[k], st.gx[k - 2], ud, -1.0);
        if (k % 2 == 0) acc(br[k], st.gr[k - 2], ud + 3, 1.0);
        acc(br[k], st.gx[k - 2], ud + 6, 1.0);
        if (k % 2 == 1) acc(br[k], st.gr[k - 2], ud + 9, 1.0);
    }
    // eps_dot = (d eps/d eps_bar) eps_bar_dot
    std::array<S, 6> rate;
    rate[0] = br[0] + st.j0[0] * br[2] + st.j0[1] * br[3] + st.j0[2] * br[4] + st.j0[3] * br[5];
    rate[1] = br[1] + st.j1[0] * br[2] + st.j1[1] * br[3] + st.j1[2] * br[4] + st.j1[3] * br[5];
    rate[2] = st.a56 * br[1] + br[2] + st.a1 * br[4] + st.a1 * br[5];
    rate[3] = -(st.a56 * br[1]) + br[3] - st.a1 * br[4] - st.a1 * br[5];
    rate[4] = -(st.a34 * br[1]) - st.a1 * br[2] - st.a1 * br[3] + br[4];
    rate[5] = st.a34 * br[1] + st.a1 * br[2] + st.a1 * br[3] + br[5];
    std::array<S, 6> s = stresses(e, rate);
    s[0] *= e.eta_axial;
    s[1] *= e.eta_torsion;
    for (int i = 2; i < 6; ++i) s[i] *= e.eta_bending;
    add_strain_work(st, s.data(), f);
}

// N values side by side: stresses() of the rows of a 6 x N matrix, C times its N columns in
// one call (each value as in a call per column).
template <int N> struct Pack {
    std::array<double, N> v;
};
template <int N> Pack<N> operator*(double s, const Pack<N>& a) {
    Pack<N> r;
    for (int i = 0; i < N; ++i) r.v[i] = s * a.v[i];
    return r;
}
template <int N> Pack<N> operator+(const Pack<N>& a, const Pack<N>& b) {
    Pack<N> r;
    for (int i = 0; i < N; ++i) r.v[i] = a.v[i] + b.v[i];
    return r;
}

template <class S>
std::array<S, 6> strain_deviation(const PipeElementData& e, const std::array<S, 6>& eps) {
    std::array<S, 6> de;
    for (int i = 0; i < 6; ++i) de[i] = eps[i] - e.strain0[i];
    return de;
}

// The centre line's Hermite forces F_i (i = 0..3; eqs. 12-20, unsplit) of its inertia,
// gravity, external damping, foundation and flow on a = [x^p, l0 e^p_x, x^q, l0 e^q_x] and
// its rates ad, add.
template <class S>
inline void hermite_forces(const PipeElementData& e, const LoadState& load, const Vec3<S> (&a)[4], const Vec3<S> (&ad)[4],
                    const Vec3<S> (&add)[4], Vec3<S> (&F)[4]) {
    const double l0 = e.l0;
    const double mtot = e.pipe_mass + e.fluid_mass;
    const double mdot = e.flow_factor * load.mass_flow;
    const double mdd = e.flow_factor * load.mass_flow_rate;
    const double P = e.fluid_mass > 0.0 ? e.kv * mdot * mdot / e.fluid_mass : 0.0;
    Vec3<double> g;
    for (int i = 0; i < 3; ++i) g[i] = load.gravity[i] * load.gravity_factor * mtot * l0;
    // terms with a zero factor (no flow, a steady flow) skipped: adding zeros changes no value;
    // the rarely present ones as compile-time flags (no tests in the unrolled sums)
    const bool flow = mdot != 0.0, unsteady = mdd != 0.0, pressure = P != 0.0, viscous = e.c_ext != 0.0;
    const bool found = e.k_found != 0.0;
    auto sum = [&](auto with_viscous, auto with_found, auto with_unsteady) {
        // by component, over i innermost (vectorised); each F_i summed in the order over j, terms
        S Fc[3][4];
        for (int c = 0; c < 3; ++c)
            for (int i = 0; i < 4; ++i) Fc[c][i] = S(g[c] * -hermite::load[i]);
        auto term = [&](const double (&m)[4][4], int j, double scale, const Vec3<S>& x) {
            for (int c = 0; c < 3; ++c)
                for (int i = 0; i < 4; ++i) Fc[c][i] += x[c] * (scale * m[i][j]);
        };
        for (int j = 0; j < 4; ++j) {
            term(hermite::mass, j, mtot * l0, add[j]);
            if constexpr (decltype(with_viscous)::value) term(hermite::mass, j, e.c_ext * l0, ad[j]);
            if constexpr (decltype(with_found)::value)
                term(hermite::mass, j, e.k_found * l0, a[j] - promote<S>(e.found0[j]));
            if (flow) term(hermite::first, j, 2.0 * mdot, ad[j]);
            if constexpr (decltype(with_unsteady)::value) term(hermite::first, j, mdd, a[j]);
            if (pressure) term(hermite::second, j, P / l0, a[j]);
        }
        for (int i = 0; i < 4; ++i) F[i] = {{Fc[0][i], Fc[1][i], Fc[2][i]}};
    };
    with_flag(viscous, [&](auto v_) {
        with_flag(found, [&](auto f_) { with_flag(unsteady, [&](auto u_) { sum(v_, f_, u_); }); });
    });
}

}  // namespace

template <class S>
void pipe_residual(const PipeElementData& e, const NodeFrames& ref, const LoadState& load, const S* q, const S* v,
                   const double* acc, const NodeMotion<S>& np, const NodeMotion<S>& nq, S* r) {
    const double l0 = e.l0;
    const Vec3<S> xp = vec(q), xq = vec(q + 6);
    const Vec3<S> vxp = vec(v), vxq = vec(v + 6);
    // the end triads E = exp(phi) R_ref R_offset (end_triad)
    const Mat3<S> Ep = np.R * promote<S>(frame_offset(ref.p, e.offset_p)),
                  Eq = nq.R * promote<S>(frame_offset(ref.q, e.offset_q));
    const Mat3<S>&Tp = np.T, &Tq = nq.T;
    const Vec3<S>&wp = np.w, &wq = nq.w, &alp = np.al, &alq = nq.al;

    // f in virtual-displacement space [dx^p, dtheta^p, dx^q, dtheta^q].
    S f[12];
    for (auto& x : f) x = S(0.0);

    // Elastic forces D^T sigma.
    const Strains<S> st = strains(l0, xp, xq, Ep, Eq);
    const std::array<S, 6> sig = stresses(e, strain_deviation(e, st.eps));
    add_strain_work(st, sig.data(), f);
    if (e.kelvin_voigt()) {
        S ud[12];
        for (int i = 0; i < 3; ++i) {
            ud[i] = vxp[i];
            ud[3 + i] = wp[i];
            ud[6 + i] = vxq[i];
            ud[9 + i] = wq[i];
        }
        add_kelvin_voigt(e, st, ud, f);
    }

    // Centre-line inertia and fluid, on a = [x^p, l0 e^p_x, x^q, l0 e^q_x].
    const Vec3<S> exp_ = Ep.col(0), exq = Eq.col(0);
    const Vec3<S> a[4] = {xp, l0 * exp_, xq, l0 * exq};
    const Vec3<S> ad[4] = {vxp, l0 * cross(wp, exp_), vxq, l0 * cross(wq, exq)};
    const Vec3<S> add[4] = {promote<S>(vec(acc)), l0 * (cross(alp, exp_) + cross(wp, cross(wp, exp_))),
                            promote<S>(vec(acc + 6)), l0 * (cross(alq, exq) + cross(wq, cross(wq, exq)))};
    const double mdot = e.flow_factor * load.mass_flow;
    const double P = e.fluid_mass > 0.0 ? e.kv * mdot * mdot / e.fluid_mass : 0.0;
    Vec3<S> F[4];
    hermite_forces(e, load, a, ad, add, F);
    // Remove split-off end terms of eqs. 19-20 where asked (their sum is eqs. 21-22).
    if (!e.end_terms_p) F[0] += mdot * vxp + P * exp_;
    if (!e.end_terms_q) F[2] += -(mdot * vxq + P * exq);
    add_to(f, F[0]);
    add_to(f + 3, l0 * cross(exp_, F[1]));
    add_to(f + 6, F[2]);
    add_to(f + 9, l0 * cross(exq, F[3]));

    // Rotary inertia of the cross-sections, lumped at the nodes: d/dt(J w) spatially.
    auto rotary = [&](const Mat3<S>& E, const Vec3<S>& w, const Vec3<S>& al, S* dst) {
        Vec3<S> jw_b, ja_b;
        const Vec3<S> wb = tmul(E, w), ab = tmul(E, al);
        for (int i = 0; i < 3; ++i) {
            const double Ji = 0.5 * l0 * e.rotary_inertia[i];
            jw_b[i] = Ji * wb[i];
            ja_b[i] = Ji * ab[i];
        }
        add_to(dst, E * ja_b + cross(w, E * jw_b));
    };
    // only the polar inertia (the bending one neglected): E Jb E^T x = J_x e_x (e_x . x), the
    // values of rotary()'s full products (their other terms are zeros)
    auto polar = [&](const Vec3<S>& ex, const Vec3<S>& w, const Vec3<S>& al, S* dst) {
        const double Jx = 0.5 * l0 * e.rotary_inertia[0];
        add_to(dst, (Jx * dot(ex, al)) * ex + cross(w, (Jx * dot(ex, w)) * ex));
    };
    if (e.rotary_inertia[1] != 0.0 || e.rotary_inertia[2] != 0.0) {
        rotary(Ep, wp, alp, f + 3);
        rotary(Eq, wq, alq, f + 9);
    } else if (e.rotary_inertia[0] != 0.0) {
        polar(exp_, wp, alp, f + 3);
        polar(exq, wq, alq, f + 9);
    }

    // Map virtual rotations to rotation-vector coordinates: dtheta = T dphi.
    for (int i = 0; i < 3; ++i) {
        r[i] = f[i];
        r[6 + i] = f[6 + i];
    }
    const Vec3<S> mp = tmul(Tp, vec(f + 3)), mq = tmul(Tq, vec(f + 9));
    for (int i = 0; i < 3; ++i) {
        r[3 + i] = mp[i];
        r[9 + i] = mq[i];
    }
}

template <class S>
void pipe_residual(const PipeElementData& e, const NodeFrames& ref, const LoadState& load, const S* q, const S* v,
                   const double* acc, S* r) {
    const NodeMotion<S> np = node_motion(vec(q + 3), vec(v + 3), promote<S>(vec(acc + 3)));
    const NodeMotion<S> nq = node_motion(vec(q + 9), vec(v + 9), promote<S>(vec(acc + 9)));
    pipe_residual(e, ref, load, q, v, acc, np, nq, r);
}

template void pipe_residual<double>(const PipeElementData&, const NodeFrames&, const LoadState&,
                                    const double*, const double*, const double*, double*);
template void pipe_residual<double>(const PipeElementData&, const NodeFrames&, const LoadState&, const double*,
                                    const double*, const double*, const NodeMotion<double>&,
                                    const NodeMotion<double>&, double*);

namespace {

// Without a matrix, or with only the mass weight: the residual and wM M, no derivatives.
// True if that was all that was asked.
bool residual_or_mass_only(const PipeElementData& e, const NodeFrames& ref, const LoadState& load,
                           const double* q, const double* v, const double* acc, double wK, double wC,
                           double wM, double* r, double* J) {
    if (J != nullptr && (wK != 0.0 || wC != 0.0)) return false;
    if (r != nullptr) pipe_residual<double>(e, ref, load, q, v, acc, r);
    if (J == nullptr) return true;
    pipe_mass_matrix(e, ref, q, J);
    for (int k = 0; k < 144; ++k) J[k] *= wM;
    return true;
}

}  // namespace

void pipe_tangent_ad(const PipeElementData& e, const NodeFrames& ref, const LoadState& load,
                     const double* q, const double* v, const double* acc, double wK, double wC,
                     double wM, double* r, double* J) {
    if (residual_or_mass_only(e, ref, load, q, v, acc, wK, wC, wM, r, J)) return;
    using D = Dual<double, 12>;
    D qd[12], vd[12], rd[12];
    for (int i = 0; i < 12; ++i) {
        qd[i] = D(q[i]);
        qd[i].d[i] = wK;
        vd[i] = D(v[i]);
        vd[i].d[i] = wC;
    }
    pipe_residual<D>(e, ref, load, qd, vd, acc, rd);
    for (int i = 0; i < 12; ++i) {
        if (r != nullptr) r[i] = rd[i].v;
        for (int j = 0; j < 12; ++j) J[12 * i + j] = rd[i].d[j];
    }
    if (wM != 0.0) {
        double M[144];
        pipe_mass_matrix(e, ref, q, M);
        for (int k = 0; k < 144; ++k) J[k] += wM * M[k];
    }
}

namespace {

using V3 = Vec3<double>;
using M3 = Mat3<double>;

M3 operator+(const M3& a, const M3& b) {
    M3 r;
    for (int k = 0; k < 9; ++k) r.c[k] = a.c[k] + b.c[k];
    return r;
}
M3 operator-(const M3& a, const M3& b) {
    M3 r;
    for (int k = 0; k < 9; ++k) r.c[k] = a.c[k] - b.c[k];
    return r;
}
M3 operator*(double s, const M3& a) {
    M3 r;
    for (int k = 0; k < 9; ++k) r.c[k] = s * a.c[k];
    return r;
}
// y += s x
void axpy(M3& y, double s, const M3& x) {
    for (int k = 0; k < 9; ++k) y.c[k] += s * x.c[k];
}
void add_to(M3& y, const M3& x) {
    for (int k = 0; k < 9; ++k) y.c[k] += x.c[k];
}
void sub_from(M3& y, const M3& x) {
    for (int k = 0; k < 9; ++k) y.c[k] -= x.c[k];
}
void add_diag(M3& y, double s) {
    for (int i = 0; i < 3; ++i) y(i, i) += s;
}
// m skew(a) and skew(a) m without the zeros' products (the same values as the full products)
M3 mul_skew(const M3& m, const V3& a) {
    M3 r;
    for (int i = 0; i < 3; ++i) {
        r(i, 0) = m(i, 1) * a[2] - m(i, 2) * a[1];
        r(i, 1) = m(i, 2) * a[0] - m(i, 0) * a[2];
        r(i, 2) = m(i, 0) * a[1] - m(i, 1) * a[0];
    }
    return r;
}
M3 skew_mul(const V3& a, const M3& m) {
    M3 r;
    for (int j = 0; j < 3; ++j) {
        r(0, j) = a[1] * m(2, j) - a[2] * m(1, j);
        r(1, j) = a[2] * m(0, j) - a[0] * m(2, j);
        r(2, j) = a[0] * m(1, j) - a[1] * m(0, j);
    }
    return r;
}
M3 outer(const V3& a, const V3& b) {
    M3 r;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) r(i, j) = a[i] * b[j];
    return r;
}
// a^T b
M3 tmul(const M3& a, const M3& b) {
    M3 r;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) r(i, j) = a(0, i) * b(0, j) + a(1, i) * b(1, j) + a(2, i) * b(2, j);
    return r;
}

// A node's triad and the derivatives of its angular velocity w = T phid and angular
// acceleration al = T phidd + Td phid with respect to phi and phid.
struct NodeRotation {
    M3 E, T, dT[3];
    V3 e, w, al;   // e = E e_x
    M3 Bw, Ba, Cc; // dw/dphi, dal/dphi, dal/dphid
};

NodeRotation node_rotation(const V3& phi, const V3& phid, const V3& phidd, const M3& frame,
                           const M3& offset) {
    NodeRotation n;
    M3 Td, dTd[3];
    rotation_jacobian_derivatives(phi, phid, n.T, n.dT, Td, dTd);
    n.E = end_triad(phi, frame, offset);
    n.e = n.E.col(0);
    n.w = n.T * phid;
    n.al = n.T * phidd + Td * phid;
    for (int k = 0; k < 3; ++k) {
        const V3 bw = n.dT[k] * phid, ba = n.dT[k] * phidd + dTd[k] * phid;
        for (int i = 0; i < 3; ++i) {
            n.Bw(i, k) = bw[i];
            n.Ba(i, k) = ba[i];
        }
    }
    n.Cc = n.Bw + Td;
    return n;
}

// Column blocks of the derivatives of f (virtual-displacement space): with respect to x and
// the virtual rotation theta (through E) of each node, and to the node's xdot, w, xddot, al.
// Node n's block is base + 2 n.
enum Col { cX = 0, cTH = 1, cVX = 4, cW = 5, cAX = 8, cAL = 9, n_col = 12 };

// Elastic forces D^T sigma (added to f) and their derivatives: D^T C D plus the geometric
// part sum sigma_i d^2 eps_i, the latter as d^2 eps/d eps_bar^2 and the barred strains'
// second derivatives weighted by the barred stresses sigma_bar = (d eps/d eps_bar)^T sigma.
// With sig_geo (not null) the geometric part takes those stresses instead of the state's,
// and fg receives D^T (sig_geo - sigma) for the rotation map's own derivative (the mixed
// Newton: see pipe_tangents).
void elastic(const PipeElementData& e, const V3& xp, const V3& xq, const M3& Ep, const M3& Eq,
             const double* sig_geo, double* f, double* fg, M3 (*df)[n_col]) {
    const double l0 = e.l0;
    const Strains<double> st = strains(l0, xp, xq, Ep, Eq);
    std::array<double, 6> sig = stresses(e, strain_deviation(e, st.eps));
    add_strain_work(st, sig.data(), f);
    if (sig_geo != nullptr) {
        double ds[6];
        for (int i = 0; i < 6; ++i) ds[i] = sig_geo[i] - sig[i];
        add_strain_work(st, ds, fg);
        for (int i = 0; i < 6; ++i) sig[i] = sig_geo[i];
    }

    const auto Jb = strain_jacobian(st);
    const std::array<double, 6> sb = strain_jacobian_t(st, sig.data());  // barred stresses
    // H = J^T C J + sum_i sigma_i d^2 eps_i / d eps_bar^2 (C from the linear stresses()).
    std::array<Pack<6>, 6> Jrows;
    for (int n = 0; n < 6; ++n) Jrows[n].v = Jb[n];
    const std::array<Pack<6>, 6> CJ = stresses(e, Jrows);
    double H[6][6];
    for (int k = 0; k < 6; ++k) {  // row by row (vectorised), each sum in the order over i
        for (int m = 0; m < 6; ++m) H[k][m] = 0.0;
        for (int i = 0; i < 6; ++i)
            for (int m = 0; m < 6; ++m) H[k][m] += Jb[i][k] * CJ[i].v[m];
    }
    const double c30 = 1.0 / (30.0 * l0), c6 = 1.0 / (6.0 * l0), c1l = 1.0 / l0;
    H[2][2] += 4.0 * c30 * sig[0];
    H[3][3] += 4.0 * c30 * sig[0];
    H[4][4] += 4.0 * c30 * sig[0];
    H[5][5] += 4.0 * c30 * sig[0];
    auto sym = [&](int i, int j, double x) {
        H[i][j] += x;
        H[j][i] += x;
    };
    sym(2, 3, c30 * sig[0]);
    sym(4, 5, c30 * sig[0]);
    sym(3, 4, c1l * sig[1]);
    sym(2, 5, -c1l * sig[1]);
    sym(1, 4, c6 * (sig[2] - sig[3]));
    sym(1, 5, c6 * (sig[2] - sig[3]));
    sym(1, 2, c6 * (sig[5] - sig[4]));
    sym(1, 3, c6 * (sig[5] - sig[4]));

    // The barred strains' gradients at x^p are minus those at x^q, so D^T H D and the second
    // derivatives are formed on the blocks b = 0 x^q, 1 theta^p, 2 theta^q (K; g9 the 9
    // columns 6..8, 3..5, 9..11 of d eps_bar/du) and x^p's follow by sign. Row by row so
    // that the compiler vectorises; each sum in the order of the dense product.
    // rows padded to 10 (a zero column) for pairs of doubles
    double g9[6][10] = {}, Hg[6][10], K9[9][10];
    for (int i = 0; i < 3; ++i) {
        g9[0][i] = st.el[i];
        g9[1][3 + i] = st.tw[i];
        g9[1][6 + i] = -st.tw[i];
        for (int k = 2; k < 6; ++k) {
            g9[k][i] = st.gx[k - 2][i];
            g9[k][3 + 3 * (k % 2) + i] = st.gr[k - 2][i];
        }
    }
    for (int k = 0; k < 6; ++k) {
        for (int j = 0; j < 10; ++j) Hg[k][j] = 0.0;
        for (int m = 0; m < 6; ++m)
            for (int j = 0; j < 10; ++j) Hg[k][j] += H[k][m] * g9[m][j];
    }
    for (int i = 0; i < 9; ++i) {
        for (int j = 0; j < 10; ++j) K9[i][j] = 0.0;
        for (int k = 0; k < 6; ++k)
            for (int j = 0; j < 10; ++j) K9[i][j] += g9[k][i] * Hg[k][j];
    }
    M3 K[3][3];
    for (int b = 0; b < 3; ++b)
        for (int c = 0; c < 3; ++c)
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j) K[b][c](i, j) = K9[3 * b + i][3 * c + j];

    // Second derivatives of the barred strains.
    const V3 d = xq - xp;
    const double l = std::sqrt(dot(d, d));
    const V3 el = (1.0 / l) * d;
    M3 P = -1.0 * outer(el, el);  // I - el el^T
    add_diag(P, 1.0);
    axpy(K[0][0], sb[0] / l, P);

    const V3 eyp = Ep.col(1), ezp = Ep.col(2), eyq = Eq.col(1), ezq = Eq.col(2);
    const M3 Ap = mul_skew(skew(eyq), ezp) - mul_skew(skew(ezq), eyp);
    const M3 Aq = mul_skew(skew(eyp), ezq) - mul_skew(skew(ezp), eyq);
    const double s1 = 0.5 * l0 * sb[1];
    axpy(K[1][1], s1, Ap);
    axpy(K[1][2], s1, Aq);
    axpy(K[2][1], -s1, Ap);
    axpy(K[2][2], -s1, Aq);

    auto bend = [&](int k, double s, const V3& ev, int n) {
        const double c = sb[k] * s * l0;
        const double ele = dot(el, ev);
        const V3 h = ev - ele * el;
        M3 Gxx = outer(h, el) + outer(el, h);
        axpy(Gxx, ele, P);
        Gxx = (-c / (l * l)) * Gxx;
        const M3 Gxt = (-c / l) * mul_skew(P, ev);
        const M3 Grx = (c / l) * skew_mul(ev, P);
        const M3 Grt = c * mul_skew(skew(el), ev);
        add_to(K[0][0], Gxx);
        add_to(K[0][1 + n], Gxt);
        add_to(K[1 + n][0], Grx);
        add_to(K[1 + n][1 + n], Grt);
    };
    bend(2, -1.0, ezp, 0);
    bend(3, 1.0, ezq, 1);
    bend(4, 1.0, eyp, 0);
    bend(5, -1.0, eyq, 1);

    // to df's blocks 0 x^p, 1 theta^p, 2 x^q, 3 theta^q
    static constexpr int blk[3] = {2, 1, 3};
    for (int b = 0; b < 3; ++b)
        for (int c = 0; c < 3; ++c) {
            add_to(df[blk[b]][blk[c]], K[b][c]);
            if (b == 0) sub_from(df[0][blk[c]], K[b][c]);
            if (c == 0) sub_from(df[blk[b]][0], K[b][c]);
            if (b == 0 && c == 0) add_to(df[0][0], K[b][c]);
        }
}

// Kelvin-Voigt forces (added to f) and their derivatives (added to df). dR/du_dot =
// D^T C eta D from the strain gradient D; d/du at fixed rates by forward AD in the 12
// directions x and theta of both nodes: the variation E -> exp(skew(dtheta)) E of the
// triads is (I + skew(dtheta)) E to first order, so the columns are those of df.
void kelvin_voigt(const PipeElementData& e, const V3& xp, const V3& xq, const M3& Ep, const M3& Eq,
                  const V3 (&vel)[4], double* f, M3 (*df)[n_col]) {
    using D = Dual<double, 12>;
    const V3 xs[2] = {xp, xq};
    const M3 Es[2] = {Ep, Eq};
    Vec3<D> x[2];
    Mat3<D> E[2];
    for (int n = 0; n < 2; ++n) {
        Vec3<D> th;
        for (int i = 0; i < 3; ++i) {
            x[n][i] = D(xs[n][i], 6 * n + i);
            th[i] = D(0.0, 6 * n + 3 + i);
        }
        E[n] = promote<D>(Es[n]);
        const Mat3<D> dE = skew(th) * E[n];
        for (int k = 0; k < 9; ++k) E[n].c[k] += dE.c[k];
    }
    const Strains<D> st = strains(e.l0, x[0], x[1], E[0], E[1]);
    D ud[12], fd[12];
    for (int b = 0; b < 4; ++b)
        for (int i = 0; i < 3; ++i) {
            ud[3 * b + i] = D(vel[b][i]);
            fd[3 * b + i] = D(0.0);
        }
    add_kelvin_voigt(e, st, ud, fd);
    static constexpr int pos[4] = {cX, cTH, cX + 2, cTH + 2}, rate[4] = {cVX, cW, cVX + 2, cW + 2};
    for (int i = 0; i < 12; ++i) {
        f[i] += fd[i].v;
        for (int j = 0; j < 12; ++j) df[i / 3][pos[j / 3]](i % 3, j % 3) += fd[i].d[j];
    }
    // D = (d eps/d eps_bar)(d eps_bar/du) and C eta D, column by column
    std::array<Pack<12>, 6> Dm;
    const auto Jd = strain_jacobian(st);
    const auto gd = bar_grad_matrix(st);
    for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 12; ++j) {
            double h = 0.0;
            for (int k = 0; k < 6; ++k) h += Jd[i][k].v * gd[k][j].v;
            Dm[i].v[j] = h;
        }
    std::array<Pack<12>, 6> CD = stresses(e, Dm);
    CD[0] = e.eta_axial * CD[0];
    CD[1] = e.eta_torsion * CD[1];
    for (int i = 2; i < 6; ++i) CD[i] = e.eta_bending * CD[i];
    for (int a = 0; a < 12; ++a)
        for (int b = 0; b < 12; ++b) {
            double h = 0.0;
            for (int i = 0; i < 6; ++i) h += Dm[i].v[a] * CD[i].v[b];
            df[a / 3][rate[b / 3]](a % 3, b % 3) += h;
        }
}

}  // namespace

// By hand, 10x faster than AD: the virtual-space forces f depend on phi only through the
// triads E (a variation E -> exp(skew(dtheta)) E with dtheta = T dphi), w and al; so f is
// differentiated in 3x3 blocks with respect to x, theta, xdot, w, xddot and al, and chained
// with T, dw/dphi, dal/dphi and dal/dphid; the rotation rows add d(T^T m)/dphi.
void pipe_tangent(const PipeElementData& e, const NodeFrames& ref, const LoadState& load,
                  const double* q, const double* v, const double* acc, double wK, double wC,
                  double wM, double* r, double* J) {
    if (residual_or_mass_only(e, ref, load, q, v, acc, wK, wC, wM, r, J)) return;
    const double w[3] = {wK, wC, wM};
    pipe_tangents(e, ref, load, q, v, acc, 1, w, r, &J);
}

void pipe_tangents(const PipeElementData& e, const NodeFrames& ref, const LoadState& load,
                   const double* q, const double* v, const double* acc, int nw, const double* weights,
                   double* r, double* const* Js, const double* sigma_geometric) {
    const double l0 = e.l0;
    const V3 xp = vec(q), xq = vec(q + 6), vxp = vec(v), vxq = vec(v + 6);
    const NodeRotation nd[2] = {node_rotation(vec(q + 3), vec(v + 3), vec(acc + 3), ref.p, e.offset_p),
                                node_rotation(vec(q + 9), vec(v + 9), vec(acc + 9), ref.q, e.offset_q)};

    // f in virtual-displacement space (as in pipe_residual) and df its derivatives.
    double f[12] = {}, fg[12] = {};
    M3 df[4][n_col] = {};
    elastic(e, xp, xq, nd[0].E, nd[1].E, sigma_geometric, f, fg, df);
    if (e.kelvin_voigt()) {
        const V3 vel[4] = {vxp, nd[0].w, vxq, nd[1].w};
        kelvin_voigt(e, xp, xq, nd[0].E, nd[1].E, vel, f, df);
    }

    // Centre-line inertia and fluid on a = [x^p, l0 e^p_x, x^q, l0 e^q_x]: the Hermite
    // forces F_i and their derivatives dF (then mapped like f: l0 e x F at the slopes).
    const V3 ex[2] = {nd[0].e, nd[1].e}, w[2] = {nd[0].w, nd[1].w}, al[2] = {nd[0].al, nd[1].al};
    const V3 a[4] = {xp, l0 * ex[0], xq, l0 * ex[1]};
    const V3 ad[4] = {vxp, l0 * cross(w[0], ex[0]), vxq, l0 * cross(w[1], ex[1])};
    const V3 add[4] = {vec(acc), l0 * (cross(al[0], ex[0]) + cross(w[0], cross(w[0], ex[0]))),
                       vec(acc + 6), l0 * (cross(al[1], ex[1]) + cross(w[1], cross(w[1], ex[1])))};
    const double mtot = e.pipe_mass + e.fluid_mass;
    const double mdot = e.flow_factor * load.mass_flow;
    const double mdd = e.flow_factor * load.mass_flow_rate;
    const double P = e.fluid_mass > 0.0 ? e.kv * mdot * mdot / e.fluid_mass : 0.0;
    V3 F[4];
    hermite_forces(e, load, a, ad, add, F);
    const bool viscous = e.c_ext != 0.0, found = e.k_found != 0.0;
    if (!e.end_terms_p) F[0] += mdot * vxp + P * ex[0];
    if (!e.end_terms_q) F[2] += -(mdot * vxq + P * ex[1]);
    add_to(f, F[0]);
    add_to(f + 3, l0 * cross(ex[0], F[1]));
    add_to(f + 6, F[2]);
    add_to(f + 9, l0 * cross(ex[1], F[3]));
    // dF_i/d(column of node n), added to df at once: as is at the positions (rows 0, 2), times
    // l0 skew(e_x) at the slopes (rows 1, 3); diagonal blocks as their diagonals.
    const V3 lex[2] = {l0 * ex[0], l0 * ex[1]};  // skew(lex) = l0 skew(e_x)
    for (int n = 0; n < 2; ++n) {
        // d a_j, d ad_j, d add_j of the slope j = 2n+1 with respect to theta, w and al.
        const M3 Se = skew(ex[n]), Sw = skew(w[n]), SwSe = mul_skew(Sw, ex[n]);
        const M3 Xk = -l0 * Se, Xg = -l0 * SwSe, Xm = -l0 * mul_skew(skew(al[n]) + mul_skew(Sw, w[n]), ex[n]);
        const M3 Ym = -l0 * (skew(cross(w[n], ex[n])) + SwSe);
        for (int i = 0; i < 4; ++i) {
            double ck[2], cv[2], cm[2];
            for (int s = 0; s < 2; ++s) {
                const int j = 2 * n + s;
                cm[s] = mtot * l0 * hermite::mass[i][j];
                const double cg = 2.0 * mdot * hermite::first[i][j];
                // the foundation enters like the terms on a_j (its reference a0 is constant)
                ck[s] = found ? mdd * hermite::first[i][j] + P / l0 * hermite::second[i][j] +
                                    e.k_found * l0 * hermite::mass[i][j]
                              : mdd * hermite::first[i][j] + P / l0 * hermite::second[i][j];
                // the viscous force enters like the Coriolis one (both on ad_j)
                cv[s] = viscous ? cg + e.c_ext * l0 * hermite::mass[i][j] : cg;
            }
            M3 th = ck[1] * Xk;
            axpy(th, cv[1], Xg);
            axpy(th, cm[1], Xm);
            M3 wv = cv[1] * Xk;
            axpy(wv, cm[1], Ym);
            const M3 am = cm[1] * Xk;
            double dv = cv[0];
            // the split-off end terms removed where asked (F above)
            if (i == 0 && n == 0 && !e.end_terms_p) {
                dv += mdot;
                axpy(th, -P, skew(ex[0]));
            }
            if (i == 2 && n == 1 && !e.end_terms_q) {
                dv += -mdot;
                axpy(th, P, skew(ex[1]));
            }
            M3* row = df[i];
            if (i % 2 == 0) {
                add_diag(row[cX + 2 * n], ck[0]);
                add_diag(row[cVX + 2 * n], dv);
                add_diag(row[cAX + 2 * n], cm[0]);
                add_to(row[cTH + 2 * n], th);
                add_to(row[cW + 2 * n], wv);
                add_to(row[cAL + 2 * n], am);
            } else {
                const V3& L = lex[i / 2];
                const M3 SL = skew(L);
                axpy(row[cX + 2 * n], ck[0], SL);
                axpy(row[cVX + 2 * n], dv, SL);
                axpy(row[cAX + 2 * n], cm[0], SL);
                add_to(row[cTH + 2 * n], skew_mul(L, th));
                add_to(row[cW + 2 * n], skew_mul(L, wv));
                add_to(row[cAL + 2 * n], skew_mul(L, am));
            }
        }
    }
    for (int n = 0; n < 2; ++n) axpy(df[2 * n + 1][cTH + 2 * n], 1.0, mul_skew(skew(F[2 * n + 1]), lex[n]));

    // Rotary inertia: m = Js al + w x (Js w) with Js = E Jb E^T, d(Js x)/dtheta = Js [x] - [Js x].
    if (e.rotary_inertia[0] != 0.0 || e.rotary_inertia[1] != 0.0 || e.rotary_inertia[2] != 0.0) {
        for (int n = 0; n < 2; ++n) {
            const M3& E = nd[n].E;
            V3 jw_b, ja_b;
            const V3 wb = tmul(E, w[n]), ab = tmul(E, al[n]);
            M3 EJ;
            for (int i = 0; i < 3; ++i) {
                const double Ji = 0.5 * l0 * e.rotary_inertia[i];
                jw_b[i] = Ji * wb[i];
                ja_b[i] = Ji * ab[i];
                for (int k = 0; k < 3; ++k) EJ(k, i) = E(k, i) * Ji;
            }
            const V3 Jw = E * jw_b, Ja = E * ja_b;
            add_to(f + 6 * n + 3, Ja + cross(w[n], Jw));
            const M3 Js = EJ * transpose(E), SJw = skew(Jw);
            const int t = 2 * n + 1;
            axpy(df[t][cTH + 2 * n], 1.0, mul_skew(Js, al[n]) - skew(Ja) + skew_mul(w[n], mul_skew(Js, w[n]) - SJw));
            axpy(df[t][cW + 2 * n], 1.0, skew_mul(w[n], Js) - SJw);
            axpy(df[t][cAL + 2 * n], 1.0, Js);
        }
    }

    if (r != nullptr) {
        for (int i = 0; i < 3; ++i) {
            r[i] = f[i];
            r[6 + i] = f[6 + i];
        }
        const V3 mp = tmul(nd[0].T, vec(f + 3)), mq = tmul(nd[1].T, vec(f + 9));
        for (int i = 0; i < 3; ++i) {
            r[3 + i] = mp[i];
            r[9 + i] = mq[i];
        }
    }

    // J = wK dr/dq + wC dr/dqdot + wM dr/dqddot: a rotation column maps through
    // theta = T phi, w(phi, phid), al(phi, phid, phidd); a rotation row through T^T, whose
    // own derivative adds d(T^T m)/dphi.
    for (int set = 0; set < nw; ++set) {
        const double wK = weights[3 * set], wC = weights[3 * set + 1], wM = weights[3 * set + 2];
        double* J = Js[set];
        M3 Sth[2], Sw[2], Sal[2];
        for (int n = 0; n < 2; ++n) {
            Sth[n] = wK * nd[n].T;
            Sw[n] = wK * nd[n].Bw + wC * nd[n].T;
            Sal[n] = wK * nd[n].Ba + wC * nd[n].Cc + wM * nd[n].T;
        }
        for (int rb = 0; rb < 4; ++rb)
            for (int n = 0; n < 2; ++n) {
                M3 bx = wK * df[rb][cX + 2 * n];
                axpy(bx, wC, df[rb][cVX + 2 * n]);
                axpy(bx, wM, df[rb][cAX + 2 * n]);
                M3 bp = df[rb][cTH + 2 * n] * Sth[n] + df[rb][cW + 2 * n] * Sw[n] + df[rb][cAL + 2 * n] * Sal[n];
                if (rb % 2 == 1) {
                    const M3& T = nd[rb / 2].T;
                    bx = tmul(T, bx);
                    bp = tmul(T, bp);
                    if (rb / 2 == n && wK != 0.0) {
                        const V3 m = vec(f + 3 * rb) + vec(fg + 3 * rb);
                        for (int k = 0; k < 3; ++k) {
                            const V3 col = tmul(nd[n].dT[k], m);
                            for (int i = 0; i < 3; ++i) bp(i, k) += wK * col[i];
                        }
                    }
                }
                for (int i = 0; i < 3; ++i)
                    for (int j = 0; j < 3; ++j) {
                        J[12 * (3 * rb + i) + 6 * n + j] = bx(i, j);
                        J[12 * (3 * rb + i) + 6 * n + 3 + j] = bp(i, j);
                    }
            }
    }
}

void pipe_fluid_forces(const PipeElementData& e, const NodeFrames& ref, const LoadState& load,
                       const double* q, const double* v, double* f) {
    const double l0 = e.l0;
    const V3 php = vec(q + 3), phq = vec(q + 9);
    const V3 exp_ = end_triad(php, ref.p, e.offset_p).col(0);
    const V3 exq = end_triad(phq, ref.q, e.offset_q).col(0);
    const M3 Tp = rotation_jacobian(php), Tq = rotation_jacobian(phq);
    const V3 wp = Tp * vec(v + 3), wq = Tq * vec(v + 9);
    const V3 a[4] = {vec(q), l0 * exp_, vec(q + 6), l0 * exq};
    const V3 ad[4] = {vec(v), l0 * cross(wp, exp_), vec(v + 6), l0 * cross(wq, exq)};
    const double mdot = e.flow_factor * load.mass_flow;
    const double mdd = e.flow_factor * load.mass_flow_rate;
    const double P = e.fluid_mass > 0.0 ? e.kv * mdot * mdot / e.fluid_mass : 0.0;
    V3 F[4];
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
            F[i] += (2.0 * mdot * hermite::first[i][j]) * ad[j];
            F[i] += (mdd * hermite::first[i][j]) * a[j];
            F[i] += (P / l0 * hermite::second[i][j]) * a[j];
        }
    if (!e.end_terms_p) F[0] += mdot * vec(v) + P * exp_;
    if (!e.end_terms_q) F[2] += -(mdot * vec(v + 6) + P * exq);
    const V3 mp = tmul(Tp, l0 * cross(exp_, F[1])), mq = tmul(Tq, l0 * cross(exq, F[3]));
    for (int i = 0; i < 3; ++i) {
        f[i] = F[0][i];
        f[3 + i] = mp[i];
        f[6 + i] = F[2][i];
        f[9 + i] = mq[i];
    }
}

double pipe_fluid_power(const PipeElementData& e, const NodeFrames& ref, const LoadState& load, const double* q,
                        const double* v, const NodeMotion<double>& np, const NodeMotion<double>& nq) {
    // -(u_dot . f) of pipe_fluid_forces, u_dot = [xdot^p, w^p, xdot^q, w^q], summed in the
    // centre-line rates ad as -sum_i F_i . ad_i (the moments' power is F_1 . l0 (w^p x e^p)).
    // The Coriolis part 2 mdot sum_ij H_ij ad_i . ad_j takes only the symmetric part of
    // H = hermite::first, diag(-1, 0, 1, 0) / 2: mdot (|xdot^q|^2 - |xdot^p|^2).
    const double l0 = e.l0;
    // the end axes e_x: the first columns of pipe_residual's end triads R R_ref R_offset
    const V3 exp_ = np.R * (ref.p * e.offset_p.col(0)), exq = nq.R * (ref.q * e.offset_q.col(0));
    const V3 &wp = np.w, &wq = nq.w;
    const V3 vp = vec(v), vq = vec(v + 6);
    const double mdot = e.flow_factor * load.mass_flow;
    const double mdd = e.flow_factor * load.mass_flow_rate;
    const double P = e.fluid_mass > 0.0 ? e.kv * mdot * mdot / e.fluid_mass : 0.0;
    double power = mdot * (dot(vq, vq) - dot(vp, vp));
    if (mdd != 0.0 || P != 0.0) {
        const V3 a[4] = {vec(q), l0 * exp_, vec(q + 6), l0 * exq};
        const V3 ad[4] = {vp, l0 * cross(wp, exp_), vq, l0 * cross(wq, exq)};
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j)
                power += (mdd * hermite::first[i][j] + P / l0 * hermite::second[i][j]) * dot(ad[i], a[j]);
    }
    if (!e.end_terms_p) power += mdot * dot(vp, vp) + P * dot(exp_, vp);
    if (!e.end_terms_q) power -= mdot * dot(vq, vq) + P * dot(exq, vq);
    return -power;
}

double pipe_fluid_power(const PipeElementData& e, const NodeFrames& ref, const LoadState& load, const double* q,
                        const double* v) {
    const V3 zero{};  // the power takes no angular acceleration
    return pipe_fluid_power(e, ref, load, q, v, node_motion(vec(q + 3), vec(v + 3), zero),
                            node_motion(vec(q + 9), vec(v + 9), zero));
}

double pipe_damping_power(const PipeElementData& e, const NodeFrames& ref, const double* q, const double* v) {
    const bool viscous = e.c_ext != 0.0;
    if (!e.kelvin_voigt() && !viscous) return 0.0;
    const double l0 = e.l0;
    const V3 php = vec(q + 3), phq = vec(q + 9);
    const M3 Ep = end_triad(php, ref.p, e.offset_p), Eq = end_triad(phq, ref.q, e.offset_q);
    const V3 wp = rotation_jacobian(php) * vec(v + 3), wq = rotation_jacobian(phq) * vec(v + 9);
    // the residual's forces are in virtual-displacement space [dx^p, dtheta^p, dx^q,
    // dtheta^q] (pipe_residual): their power is u_dot . f with u_dot = [xdot^p, w^p, xdot^q, w^q]
    double P = 0.0;
    if (e.kelvin_voigt()) {
        double ud[12], f[12] = {};
        for (int i = 0; i < 3; ++i) {
            ud[i] = v[i];
            ud[3 + i] = wp[i];
            ud[6 + i] = v[6 + i];
            ud[9 + i] = wq[i];
        }
        add_kelvin_voigt(e, strains(l0, vec(q), vec(q + 6), Ep, Eq), ud, f);
        for (int i = 0; i < 12; ++i) P += ud[i] * f[i];
    }
    if (viscous) {  // c_ext l0 ad^T M ad on the centre-line rates ad of pipe_residual
        const V3 ad[4] = {vec(v), l0 * cross(wp, Ep.col(0)), vec(v + 6), l0 * cross(wq, Eq.col(0))};
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j) P += e.c_ext * l0 * hermite::mass[i][j] * dot(ad[i], ad[j]);
    }
    return P;
}

void pipe_mass_matrix(const PipeElementData& e, const NodeFrames& ref, const double* q, double* M) {
    const double l0 = e.l0;
    const Mat3<double> Ep = end_triad(vec(q + 3), ref.p, e.offset_p);
    const Mat3<double> Eq = end_triad(vec(q + 9), ref.q, e.offset_q);
    const Mat3<double> Tp = rotation_jacobian(vec(q + 3)), Tq = rotation_jacobian(vec(q + 9));
    // da_i = A_i dq_(block of i): I for positions, -l0 skew(e_x) T for rotations.
    Mat3<double> A[4];
    Mat3<double> I{};
    for (int i = 0; i < 3; ++i) I(i, i) = 1.0;
    A[0] = I;
    A[2] = I;
    A[1] = skew(Ep.col(0)) * Tp;
    A[3] = skew(Eq.col(0)) * Tq;
    for (int k = 0; k < 9; ++k) {
        A[1].c[k] *= -l0;
        A[3].c[k] *= -l0;
    }
    const double mtot = (e.pipe_mass + e.fluid_mass) * l0;
    for (int k = 0; k < 144; ++k) M[k] = 0.0;
    for (int a = 0; a < 4; ++a)
        for (int b = 0; b < 4; ++b) {
            const Mat3<double> blk = transpose(A[a]) * A[b];
            const double c = mtot * hermite::mass[a][b];
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j) M[12 * (3 * a + i) + 3 * b + j] += c * blk(i, j);
        }
    auto rotary = [&](const Mat3<double>& E, const Mat3<double>& T, int off) {
        Mat3<double> Jb{};
        for (int i = 0; i < 3; ++i) Jb(i, i) = 0.5 * l0 * e.rotary_inertia[i];
        const Mat3<double> ET = transpose(E) * T;
        const Mat3<double> blk = transpose(ET) * (Jb * ET);
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) M[12 * (off + i) + off + j] += blk(i, j);
    };
    rotary(Ep, Tp, 3);
    rotary(Eq, Tq, 9);
}

void pipe_predicted_stresses(const PipeElementData& e, const NodeFrames& ref, const double* q, const double* dq,
                             double* sigma) {
    using D = Dual<double, 1>;
    D qd[12];
    for (int i = 0; i < 12; ++i) {
        qd[i] = D(q[i]);
        qd[i].d[0] = dq[i];
    }
    const Mat3<D> Ep = end_triad(vec(qd + 3), ref.p, e.offset_p);
    const Mat3<D> Eq = end_triad(vec(qd + 9), ref.q, e.offset_q);
    const auto de = strain_deviation(e, strains(e.l0, vec(qd), vec(qd + 6), Ep, Eq).eps);
    std::array<double, 6> lin;
    for (int i = 0; i < 6; ++i) lin[i] = de[i].v + de[i].d[0];
    const auto s = stresses(e, lin);
    for (int i = 0; i < 6; ++i) sigma[i] = s[i];
}

void pipe_strains(const PipeElementData& e, const NodeFrames& ref, const double* q, double* strain) {
    const Mat3<double> Ep = end_triad(vec(q + 3), ref.p, e.offset_p);
    const Mat3<double> Eq = end_triad(vec(q + 9), ref.q, e.offset_q);
    const auto de = strain_deviation(e, strains(e.l0, vec(q), vec(q + 6), Ep, Eq).eps);
    for (int i = 0; i < 6; ++i) strain[i] = de[i];
}

void pipe_energies(const PipeElementData& e, const NodeFrames& ref, const double* q,
                   const double* v, double* kinetic, double* elastic) {
    const double l0 = e.l0;
    const Mat3<double> Ep = end_triad(vec(q + 3), ref.p, e.offset_p);
    const Mat3<double> Eq = end_triad(vec(q + 9), ref.q, e.offset_q);
    const auto de = strain_deviation(e, strains(l0, vec(q), vec(q + 6), Ep, Eq).eps);
    const auto sig = stresses(e, de);
    double U = 0.0;
    for (int i = 0; i < 6; ++i) U += 0.5 * sig[i] * de[i];
    if (e.k_found != 0.0) {  // 1/2 k_found l0 (a - a0)^T (int N^T N dxi) (a - a0)
        const Vec3<double> a[4] = {vec(q), l0 * Ep.col(0), vec(q + 6), l0 * Eq.col(0)};
        Vec3<double> u[4];
        for (int i = 0; i < 4; ++i) u[i] = a[i] - e.found0[i];
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j) U += 0.5 * e.k_found * l0 * hermite::mass[i][j] * dot(u[i], u[j]);
    }
    *elastic = U;
    double M[144];
    pipe_mass_matrix(e, ref, q, M);
    double T = 0.0;
    for (int i = 0; i < 12; ++i)
        for (int j = 0; j < 12; ++j) T += 0.5 * v[i] * M[12 * i + j] * v[j];
    *kinetic = T;
}

}  // namespace pipeflex
