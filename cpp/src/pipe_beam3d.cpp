#include "pipeflex/elements/pipe_beam3d.hpp"

#include "pipeflex/elements/hermite.hpp"

namespace pipeflex {
namespace {

template <class S> Vec3<S> vec(const S* p) { return {{p[0], p[1], p[2]}}; }

template <class S> void add_to(S* dst, const Vec3<S>& x) {
    for (int i = 0; i < 3; ++i) dst[i] += x[i];
}

// End triad E = exp(phi) R_ref R_offset; its columns are e_x, e_y, e_z.
template <class S>
Mat3<S> end_triad(const Vec3<S>& phi, const Mat3<double>& frame, const Mat3<double>& offset) {
    return rotation_exp(phi) * promote<S>(frame * offset);
}

// Generalised strains eps (eqs. 1-2) and their gradients with respect to the virtual
// displacements u = [dx^p, dtheta^p, dx^q, dtheta^q] (spatial virtual rotations).
template <class S> struct Strains {
    std::array<S, 6> eps;
    std::array<std::array<S, 12>, 6> grad;
};

template <class S>
Strains<S> strains(double l0, const Vec3<S>& xp, const Vec3<S>& xq, const Mat3<S>& Ep,
                   const Mat3<S>& Eq) {
    using std::sqrt;
    const Vec3<S> d = xq - xp;
    const S l = sqrt(dot(d, d));
    const Vec3<S> el = (S(1.0) / l) * d;
    const Vec3<S> eyp = Ep.col(1), ezp = Ep.col(2), eyq = Eq.col(1), ezq = Eq.col(2);

    std::array<S, 6> eb;                          // barred strains
    std::array<std::array<S, 12>, 6> gb{};        // their gradients
    for (auto& g : gb) g.fill(S(0.0));
    eb[0] = l - l0;
    for (int i = 0; i < 3; ++i) {
        gb[0][i] = -el[i];
        gb[0][6 + i] = el[i];
    }
    eb[1] = 0.5 * l0 * (dot(ezp, eyq) - dot(eyp, ezq));
    const Vec3<S> c1 = cross(ezp, eyq) - cross(eyp, ezq);
    for (int i = 0; i < 3; ++i) {
        gb[1][3 + i] = 0.5 * l0 * c1[i];
        gb[1][9 + i] = -0.5 * l0 * c1[i];
    }
    // eps_bar_k = s l0 e_l . e (e a triad vector of node n = 0 for p, 1 for q)
    auto bend = [&](int k, double s, const Vec3<S>& e, int n) {
        const S ele = dot(el, e);
        eb[k] = s * l0 * ele;
        const Vec3<S> gx = (S(s * l0) / l) * (e - ele * el);  // s l0 (I - el el^T) e / l
        const Vec3<S> gr = (s * l0) * cross(e, el);
        for (int i = 0; i < 3; ++i) {
            gb[k][i] = -gx[i];
            gb[k][6 + i] = gx[i];
            gb[k][6 * n + 3 + i] = gr[i];
        }
    };
    bend(2, -1.0, ezp, 0);
    bend(3, 1.0, ezq, 1);
    bend(4, 1.0, eyp, 0);
    bend(5, -1.0, eyq, 1);

    // eps(eps_bar) of eq. 1 and the Jacobian de/deb.
    const double c30 = 1.0 / (30.0 * l0), c6 = 1.0 / (6.0 * l0), c1l = 1.0 / l0;
    Strains<S> out;
    auto& e = out.eps;
    e[0] = eb[0] + c30 * (2.0 * eb[2] * eb[2] + eb[2] * eb[3] + 2.0 * eb[3] * eb[3] +
                          2.0 * eb[4] * eb[4] + eb[4] * eb[5] + 2.0 * eb[5] * eb[5]);
    e[1] = eb[1] + c1l * (eb[3] * eb[4] - eb[2] * eb[5]);
    const S s56 = eb[4] + eb[5], s34 = eb[2] + eb[3];
    e[2] = eb[2] + c6 * eb[1] * s56;
    e[3] = eb[3] - c6 * eb[1] * s56;
    e[4] = eb[4] - c6 * eb[1] * s34;
    e[5] = eb[5] + c6 * eb[1] * s34;
    S J[6][6];
    for (auto& row : J)
        for (auto& x : row) x = S(0.0);
    for (int i = 0; i < 6; ++i) J[i][i] = S(1.0);
    J[0][2] = c30 * (4.0 * eb[2] + eb[3]);
    J[0][3] = c30 * (eb[2] + 4.0 * eb[3]);
    J[0][4] = c30 * (4.0 * eb[4] + eb[5]);
    J[0][5] = c30 * (eb[4] + 4.0 * eb[5]);
    J[1][2] = -c1l * eb[5];
    J[1][3] = c1l * eb[4];
    J[1][4] = c1l * eb[3];
    J[1][5] = -c1l * eb[2];
    J[2][1] = c6 * s56;  J[2][4] = c6 * eb[1];  J[2][5] = c6 * eb[1];
    J[3][1] = -c6 * s56; J[3][4] = -c6 * eb[1]; J[3][5] = -c6 * eb[1];
    J[4][1] = -c6 * s34; J[4][2] = -c6 * eb[1]; J[4][3] = -c6 * eb[1];
    J[5][1] = c6 * s34;  J[5][2] = c6 * eb[1];  J[5][3] = c6 * eb[1];
    for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 12; ++j) {
            S g = S(0.0);
            for (int k = 0; k < 6; ++k) g += J[i][k] * gb[k][j];
            out.grad[i][j] = g;
        }
    return out;
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

template <class S>
std::array<S, 6> strain_deviation(const PipeElementData& e, const std::array<S, 6>& eps) {
    std::array<S, 6> de;
    for (int i = 0; i < 6; ++i) de[i] = eps[i] - e.strain0[i];
    return de;
}

}  // namespace

template <class S>
void pipe_residual(const PipeElementData& e, const NodeFrames& ref, const LoadState& load,
                   const S* q, const S* v, const double* acc, S* r) {
    const double l0 = e.l0;
    const Vec3<S> xp = vec(q), php = vec(q + 3), xq = vec(q + 6), phq = vec(q + 9);
    const Vec3<S> vxp = vec(v), vphp = vec(v + 3), vxq = vec(v + 6), vphq = vec(v + 9);
    const Mat3<S> Ep = end_triad(php, ref.p, e.offset_p), Eq = end_triad(phq, ref.q, e.offset_q);
    const Mat3<S> Tp = rotation_jacobian(php), Tq = rotation_jacobian(phq);
    const Vec3<S> wp = Tp * vphp, wq = Tq * vphq;
    // The convective angular acceleration is quadratic in phi_dot: at rest its value and
    // first derivatives vanish, so the nested derivative is skipped there.
    auto convective = [](const Vec3<S>& phi, const Vec3<S>& phid) {
        if (value_of(phid[0]) == 0.0 && value_of(phid[1]) == 0.0 && value_of(phid[2]) == 0.0)
            return Vec3<S>{{S(0.0), S(0.0), S(0.0)}};
        return convective_angular_acceleration(phi, phid);
    };
    const Vec3<S> alp = Tp * promote<S>(vec(acc + 3)) + convective(php, vphp);
    const Vec3<S> alq = Tq * promote<S>(vec(acc + 9)) + convective(phq, vphq);

    // f in virtual-displacement space [dx^p, dtheta^p, dx^q, dtheta^q].
    S f[12];
    for (auto& x : f) x = S(0.0);

    // Elastic forces D^T sigma.
    const Strains<S> st = strains(l0, xp, xq, Ep, Eq);
    const std::array<S, 6> sig = stresses(e, strain_deviation(e, st.eps));
    for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 12; ++j) f[j] += sig[i] * st.grad[i][j];

    // Centre-line inertia and fluid, on a = [x^p, l0 e^p_x, x^q, l0 e^q_x].
    const Vec3<S> exp_ = Ep.col(0), exq = Eq.col(0);
    const Vec3<S> a[4] = {xp, l0 * exp_, xq, l0 * exq};
    const Vec3<S> ad[4] = {vxp, l0 * cross(wp, exp_), vxq, l0 * cross(wq, exq)};
    const Vec3<S> add[4] = {promote<S>(vec(acc)), l0 * (cross(alp, exp_) + cross(wp, cross(wp, exp_))),
                            promote<S>(vec(acc + 6)), l0 * (cross(alq, exq) + cross(wq, cross(wq, exq)))};
    const double mtot = e.pipe_mass + e.fluid_mass;
    const double mdot = e.flow_factor * load.mass_flow;
    const double mdd = e.flow_factor * load.mass_flow_rate;
    const double P = e.fluid_mass > 0.0 ? e.kv * mdot * mdot / e.fluid_mass : 0.0;
    Vec3<double> g;
    for (int i = 0; i < 3; ++i) g[i] = load.gravity[i] * load.gravity_factor * mtot * l0;
    Vec3<S> F[4];
    for (int i = 0; i < 4; ++i) {
        F[i] = -hermite::load[i] * promote<S>(g);
        for (int j = 0; j < 4; ++j) {
            F[i] += (mtot * l0 * hermite::mass[i][j]) * add[j];
            F[i] += (2.0 * mdot * hermite::first[i][j]) * ad[j];
            F[i] += (mdd * hermite::first[i][j]) * a[j];
            F[i] += (P / l0 * hermite::second[i][j]) * a[j];
        }
    }
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
    if (e.rotary_inertia[0] != 0.0 || e.rotary_inertia[1] != 0.0 || e.rotary_inertia[2] != 0.0) {
        rotary(Ep, wp, alp, f + 3);
        rotary(Eq, wq, alq, f + 9);
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

template void pipe_residual<double>(const PipeElementData&, const NodeFrames&, const LoadState&,
                                    const double*, const double*, const double*, double*);

void pipe_tangent(const PipeElementData& e, const NodeFrames& ref, const LoadState& load,
                  const double* q, const double* v, const double* acc, double wK, double wC,
                  double wM, double* r, double* J) {
    if (J == nullptr || (wK == 0.0 && wC == 0.0)) {
        if (r != nullptr) pipe_residual<double>(e, ref, load, q, v, acc, r);
        if (J == nullptr) return;
        pipe_mass_matrix(e, ref, q, J);
        for (int k = 0; k < 144; ++k) J[k] *= wM;
        return;
    }
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
    *elastic = U;
    double M[144];
    pipe_mass_matrix(e, ref, q, M);
    double T = 0.0;
    for (int i = 0; i < 12; ++i)
        for (int j = 0; j < 12; ++j) T += 0.5 * v[i] * M[12 * i + j] * v[j];
    *kinetic = T;
}

}  // namespace pipeflex
