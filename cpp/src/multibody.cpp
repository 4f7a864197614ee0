#include "pipeflex/multibody/multibody.hpp"
#include "pipeflex/core/format.hpp"
#include "pipeflex/core/interrupt.hpp"
#include "pipeflex/solvers/sparse_lu.hpp"

#include <Eigen/LU>
#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>
#include <stdexcept>

namespace pipeflex {

namespace {

// Sparse LU of the iteration matrix [S, s C_q^T; s C_q, 0] on a fixed block pattern:
// S couples only bodies that share a joint, and a joint's rows touch only its bodies.
// For a chain of bodies this is far cheaper than a dense LU (ordering computed once).
class IterationMatrixLU {
   public:
    IterationMatrixLU(const std::vector<int>& offsets, const std::vector<int>& rows,
                      const std::vector<MbJoint>& joints) {
        const int nb = static_cast<int>(offsets.size()) - 1, n = offsets.back(), nc = rows.back();
        n_ = n;
        std::vector<char> coupled(static_cast<size_t>(nb) * nb, 0);
        for (int b = 0; b < nb; ++b) coupled[b * nb + b] = 1;
        for (const MbJoint& j : joints)
            if (j.body_b >= 0) coupled[j.body_a * nb + j.body_b] = coupled[j.body_b * nb + j.body_a] = 1;
        std::vector<int> pr, pc;
        auto block = [&](int r0, int nr, int c0, int ncol) {
            for (int c = c0; c < c0 + ncol; ++c)
                for (int r = r0; r < r0 + nr; ++r) {
                    pr.push_back(r);
                    pc.push_back(c);
                }
        };
        for (int a = 0; a < nb; ++a)
            for (int b = 0; b < nb; ++b)
                if (coupled[a * nb + b])
                    block(offsets[a], offsets[a + 1] - offsets[a], offsets[b], offsets[b + 1] - offsets[b]);
        for (size_t k = 0; k < joints.size(); ++k) {
            for (int body : {joints[k].body_a, joints[k].body_b}) {
                if (body < 0) continue;
                const int o = offsets[body], nbody = offsets[body + 1] - o, r0 = n + rows[k], nr = rows[k + 1] - rows[k];
                block(r0, nr, o, nbody);
                block(o, nbody, r0, nr);
            }
        }
        lu_.analyze(n + nc, pr, pc);
    }

    // False if the matrix is singular.
    bool factorize(const MatX& S, const MatX& J, double scale) {
        FixedPatternLU::Matrix& A = lu_.matrix();
        for (Eigen::Index c = 0; c < A.outerSize(); ++c)
            for (FixedPatternLU::Matrix::InnerIterator it(A, c); it; ++it) {
                const Eigen::Index r = it.row();
                it.valueRef() = r < n_ ? (c < n_ ? S(r, c) : scale * J(c - n_, r)) : (c < n_ ? scale * J(r - n_, c) : 0.0);
            }
        return lu_.factorize();
    }

    void solve(const VecX& rhs, VecX& x) { lu_.solve(rhs, x); }

   private:
    Eigen::Index n_ = 0;
    FixedPatternLU lu_;
};

}  // namespace

int MbJoint::rows() const {
    switch (kind) {
        case JointKind::rigid: return 6;
        case JointKind::hinge: return 5;
        case JointKind::spherical: return 3;
        case JointKind::roller: return 1;
    }
    return 0;
}

int MultibodySystemCore::add_body(MbBody body) {
    check_ffrf_body(body.data);
    const Eigen::Index m = body.data.M.rows() - 6;
    if (body.s.size() < 2) throw std::invalid_argument("add_body: a body needs at least 2 nodes (s)");
    if (body.basis.cols() != m || body.basis.rows() != 6 * static_cast<Eigen::Index>(body.s.size()))
        throw std::invalid_argument("add_body: basis must be 6 n_nodes x m with m = (size of M) - 6");
    length_scale_ = std::max(length_scale_ * (bodies_.empty() ? 0.0 : 1.0), body.s.back() - body.s.front());
    offsets_.push_back(offsets_.back() + 6 + static_cast<int>(m));
    n_ = offsets_.back();
    bodies_.push_back(std::move(body));
    return n_bodies() - 1;
}

void MultibodySystemCore::add_joint(const MbJoint& j) {
    auto check = [&](int b, int nd) {
        if (b < 0 || b >= n_bodies() || nd < 0 || nd >= static_cast<int>(bodies_[b].s.size()))
            throw std::invalid_argument("add_joint: no node " + std::to_string(nd) + " on body " + std::to_string(b));
    };
    check(j.body_a, j.node_a);
    if (j.body_b >= 0) check(j.body_b, j.node_b);
    joints_.push_back(j);
    rows_.push_back(rows_.back() + j.rows());
    nc_ = rows_.back();
}

void MultibodySystemCore::add_load(const MbLoad& l) {
    if (l.body < 0 || l.body >= n_bodies() || l.node < 0 || l.node >= static_cast<int>(bodies_[l.body].s.size()))
        throw std::invalid_argument("add_load: no such body node");
    loads_.push_back(l);
}

void MultibodySystemCore::finalize() {
    n_ = offsets_.back();
    nc_ = rows_.back();
}

void MultibodySystemCore::check_state(const MbState& s) const {
    const int nb = n_bodies();
    if (static_cast<int>(s.r.size()) != nb || static_cast<int>(s.R.size()) != nb)
        throw std::invalid_argument("state: r and R must hold one frame per body (" + std::to_string(nb) + "), got " +
                                    std::to_string(s.r.size()) + " and " + std::to_string(s.R.size()));
    if (s.eta.size() != n_ || s.v.size() != n_ || s.a.size() != n_ || s.lam.size() != nc_)
        throw std::invalid_argument("state: eta, v and a must have " + std::to_string(n_) +
                                    " entries (n_coordinates) and lam " + std::to_string(nc_) + " (n_constraints)");
    bool finite = std::isfinite(s.t) && s.eta.allFinite() && s.v.allFinite() && s.a.allFinite() && s.lam.allFinite();
    for (int j = 0; j < nb; ++j) finite = finite && s.r[j].allFinite() && s.R[j].allFinite();
    if (!finite) throw std::invalid_argument("state: all its numbers must be finite");
}

void MultibodySystemCore::node(const MbState& s, int body, int nd, Vec3d& p, Mat3d& A, MatX* Jp, MatX* Ja) const {
    if (body < 0 || body >= n_bodies() || nd < 0 || nd >= n_nodes(body))
        throw std::invalid_argument("no node " + std::to_string(nd) + " on body " + std::to_string(body));
    if (s.eta.size() != n_ || static_cast<int>(s.r.size()) != n_bodies() || static_cast<int>(s.R.size()) != n_bodies())
        throw std::invalid_argument("state: eta must have n_coordinates = " + std::to_string(n_) +
                                    " entries and r, R one frame per body");
    const MbBody& b = bodies_[body];
    const Eigen::Index m = b.basis.cols();
    const int o = offsets_[body];
    const auto eta = s.eta.segment(o + 6, m);
    const auto Pu = b.basis.middleRows(6 * nd, 3);
    const auto Pt = b.basis.middleRows(6 * nd + 3, 3);
    const Mat3d& R = s.R[body];
    const Vec3d y = R * (Vec3d(b.s[nd], 0.0, 0.0) + Pu * eta);
    const Vec3d th = Pt * eta;
    p = s.r[body] + y;
    A = R * rotation_exp(th);
    if (Jp) {
        Jp->setZero(3, 6 + m);
        Jp->leftCols(3).setIdentity();
        Jp->middleCols(3, 3) = -skew(y);
        Jp->rightCols(m) = R * Pu;
    }
    if (Ja) {
        Ja->setZero(3, 6 + m);
        Ja->middleCols(3, 3).setIdentity();
        Ja->rightCols(m) = R * rotation_jacobian(th) * Pt;
    }
}

void MultibodySystemCore::increment(MbState& s, const VecX& dq) const {
    if (dq.size() != n_ || s.eta.size() != n_ || static_cast<int>(s.r.size()) != n_bodies() ||
        static_cast<int>(s.R.size()) != n_bodies())
        throw std::invalid_argument("increment: dq and the state's eta must have n_coordinates = " +
                                    std::to_string(n_) + " entries, got " + std::to_string(dq.size()) + " and " +
                                    std::to_string(s.eta.size()));
    for (int j = 0; j < n_bodies(); ++j) {
        const int o = offsets_[j], m = offsets_[j + 1] - o - 6;
        s.r[j] += dq.segment<3>(o);
        s.R[j] = rotation_exp(dq.segment<3>(o + 3)) * s.R[j];
        s.eta.segment(o + 6, m) += dq.segment(o + 6, m);
    }
}

void MultibodySystemCore::joint_equations(const MbState& s, const MbJoint& j, Eigen::Ref<VecX> c,
                                          Eigen::Ref<MatX> Ja, Eigen::Ref<MatX> Jb, MbJointWork& w) const {
    Vec3d pa, pb;
    Mat3d Aa, Ab;
    MatX &Jpa = w.Jpa, &Jaa = w.Jaa, &Jpb = w.Jpb, &Jab = w.Jab;
    node(s, j.body_a, j.node_a, pa, Aa, &Jpa, &Jaa);
    const bool ground = j.body_b < 0;
    if (ground) {
        pb = j.p_ground;
        Ab = j.A_ground;
    } else {
        node(s, j.body_b, j.node_b, pb, Ab, &Jpb, &Jab);
    }
    Ja.setZero();
    if (!ground) Jb.setZero();
    if (j.kind == JointKind::roller) {
        c(0) = j.direction.dot(pa - j.p0);
        Ja.row(0) = j.direction.transpose() * Jpa;
        return;
    }
    c.head<3>() = pa - pb;
    Ja.topRows(3) = Jpa;
    if (!ground) Jb.topRows(3) = -Jpb;
    if (j.kind == JointKind::rigid) {
        const Mat3d D = Aa.transpose() * Ab * j.C0.transpose();
        c.segment<3>(3) = vee_skew(D);
        Mat3d JD;
        for (int k = 0; k < 3; ++k) JD.col(k) = vee_skew(skew(Vec3d::Unit(k)) * D);
        JD = JD * Aa.transpose();
        Ja.middleRows(3, 3) = -JD * Jaa;
        if (!ground) Jb.middleRows(3, 3) = JD * Jab;
    } else if (j.kind == JointKind::hinge) {
        const Vec3d axb = Ab * j.axis_b;
        for (int k = 0; k < 2; ++k) {
            const Vec3d ea = Aa * j.perp_a[k];
            c(3 + k) = ea.dot(axb);
            Ja.row(3 + k) = ea.cross(axb).transpose() * Jaa;
            if (!ground) Jb.row(3 + k) = axb.cross(ea).transpose() * Jab;
        }
    }
}

double MultibodySystemCore::junction_pressure(int body, double mdot) const {
    const MbBody& b = bodies_[body];
    return b.fluid_mass > 0.0 ? b.flow_factor * b.flow_factor * mdot * mdot / b.fluid_mass : 0.0;
}

bool MultibodySystemCore::joint_forces(const MbState& s, const MbJoint& j, double mdot, double load_factor,
                                       MbJointWork& w) const {
    if (!j.actuated && !j.junction) return false;
    Vec3d p;
    Mat3d Aa, Ab;
    MatX &Jpa = w.Jpa, &Jaa = w.Jaa, &Jpb = w.Jpb, &Jab = w.Jab;
    VecX &fa = w.fa, &fb = w.fb;
    node(s, j.body_a, j.node_a, p, Aa, &Jpa, &Jaa);
    const bool ground = j.body_b < 0;
    if (!ground) node(s, j.body_b, j.node_b, p, Ab, &Jpb, &Jab);
    else Ab = j.A_ground;
    fa.setZero(Jpa.cols());
    fb.setZero(ground ? 0 : Jpb.cols());
    if (j.actuated) {
        const Vec3d T = load_factor * j.torque.at(s.t) * (Ab * j.axis_b);
        fa += Jaa.transpose() * T;
        if (!ground) fb -= Jab.transpose() * T;
    }
    if (j.junction && !ground) {
        auto along_flow = [&](int body, const Mat3d& A) -> Vec3d {
            return (bodies_[body].flow_factor >= 0.0 ? 1.0 : -1.0) * Vec3d(A.col(0));
        };
        fa += Jpa.transpose() * (j.upstream * junction_pressure(j.body_a, mdot) * along_flow(j.body_a, Aa));
        fb -= Jpb.transpose() * (j.upstream * junction_pressure(j.body_b, mdot) * along_flow(j.body_b, Ab));
    }
    return true;
}

void MultibodySystemCore::body_columns(MbState& st, int body,
                                      const std::function<void(int col, double h, double sign)>& fn) const {
    const int o = offsets_[body], n = offsets_[body + 1] - o;
    // Generalised forces of joints, loads and torques do not depend on the frame
    // position r (only on R and eta): start at the rotation columns.
    for (int col = 3; col < n; ++col) {
        const double h = 1e-7;
        const Mat3d R0 = st.R[body];
        const double e0 = st.eta(o + col);
        for (double sign : {1.0, -1.0}) {
            const double d = sign * h;
            if (col < 6) st.R[body] = rotation_exp(d * Vec3d::Unit(col - 3)) * R0;
            else st.eta(o + col) += d;
            fn(col, h, sign);
            st.R[body] = R0;
            st.eta(o + col) = e0;
        }
    }
}

void MultibodySystemCore::geometric_stiffness(const MbState& s, double mdot, double load_factor, MatX& S,
                                              double w) const {
    MbState st = s;
    // joint reactions C_q^T lambda at fixed lambda
    for (size_t k = 0; k < joints_.size(); ++k) {
        const MbJoint& j = joints_[k];
        const int nr = j.rows();
        const VecX lam = s.lam.segment(rows_[k], nr);
        if (lam.isZero(0.0)) continue;
        const int na = offsets_[j.body_a + 1] - offsets_[j.body_a];
        const int nb = j.body_b < 0 ? 0 : offsets_[j.body_b + 1] - offsets_[j.body_b];
        VecX c(nr);
        MatX Ja(nr, na), Jb(nr, nb);
        MbJointWork jw;
        for (int body : {j.body_a, j.body_b}) {
            if (body < 0) continue;
            body_columns(st, body, [&](int col, double h, double sign) {
                joint_equations(st, j, c, Ja, Jb, jw);
                const double f = sign * w / (2 * h);
                S.block(offsets_[j.body_a], offsets_[body] + col, na, 1) += f * (Ja.transpose() * lam);
                if (nb) S.block(offsets_[j.body_b], offsets_[body] + col, nb, 1) += f * (Jb.transpose() * lam);
            });
        }
    }
    // driving torques turn with the hinge axis, junction forces with the pipe
    for (const MbJoint& j : joints_) {
        if (!j.actuated && !j.junction) continue;
        MbJointWork jw;
        const VecX &fa = jw.fa, &fb = jw.fb;
        const int oa = offsets_[j.body_a], na = offsets_[j.body_a + 1] - oa;
        for (int body : {j.body_a, j.body_b}) {
            if (body < 0) continue;
            body_columns(st, body, [&](int col, double h, double sign) {
                joint_forces(st, j, mdot, load_factor, jw);
                const double f = -sign * w / (2 * h);
                S.block(oa, offsets_[body] + col, na, 1) += f * fa;
                if (fb.size()) S.block(offsets_[j.body_b], offsets_[body] + col, fb.size(), 1) += f * fb;
            });
        }
    }
    // dead nodal loads: -(Jp^T f + Ja^T m) turns with the node
    MatX Jp, Ja;
    Vec3d p;
    Mat3d A;
    for (const MbLoad& l : loads_) {
        Vec3d fo, mo;
        for (int i = 0; i < 3; ++i) {
            fo[i] = load_factor * l.force[i].at(s.t);
            mo[i] = load_factor * l.moment[i].at(s.t);
        }
        if (fo.isZero(0.0) && mo.isZero(0.0)) continue;
        const int o = offsets_[l.body], n = offsets_[l.body + 1] - o;
        body_columns(st, l.body, [&](int col, double h, double sign) {
            node(st, l.body, l.node, p, A, &Jp, &Ja);
            S.block(o, o + col, n, 1) -= sign * w / (2 * h) * (Jp.transpose() * fo + Ja.transpose() * mo);
        });
    }
}

void MultibodySystemCore::evaluate(const MbState& s, double mdot, double mdot_rate, double load_factor,
                                   double gravity_factor, double wK, double wC, double wM, bool with_tangent,
                                   MbEvaluation& out) const {
    if (s.eta.size() != n_ || s.v.size() != n_ || s.a.size() != n_ || s.lam.size() != nc_ ||
        static_cast<int>(s.r.size()) != n_bodies() || static_cast<int>(s.R.size()) != n_bodies())
        check_state(s);  // throws, naming the sizes
    out.F.setZero(n_);
    out.c.setZero(nc_);
    out.J.setZero(nc_, n_);
    if (with_tangent) out.S.setZero(n_, n_);
    MatX dummy(0, 0);
    out.work.resize(bodies_.size());
    out.motion.resize(bodies_.size());
    for (int j = 0; j < n_bodies(); ++j) {
        poll_interrupt();
        const MbBody& b = bodies_[j];
        const int o = offsets_[j], n = offsets_[j + 1] - o, m = n - 6;
        FfrfBodyMotion& mo = out.motion[j];
        mo.gravity = gravity_factor * gravity_;
        mo.R = s.R[j];
        mo.omega = s.v.segment<3>(o + 3);
        mo.a = s.a.segment(o, n);
        mo.eta = s.eta.segment(o + 6, m);
        mo.eta_dot = s.v.segment(o + 6, m);
        const double f = b.fluid_mass > 0.0 ? b.flow_factor / b.fluid_mass : 0.0;
        mo.sdot = f * mdot;
        mo.sddot = f * mdot_rate;
        if (with_tangent)
            ffrf_body_forces(b.data, mo, wK, wC, wM, out.work[j], out.F.segment(o, n), out.S.block(o, o, n, n), true);
        else
            ffrf_body_forces(b.data, mo, wK, wC, wM, out.work[j], out.F.segment(o, n), dummy, false);
    }
    MatX Jp, Ja;
    Vec3d p;
    Mat3d A;
    for (const MbLoad& l : loads_) {
        node(s, l.body, l.node, p, A, &Jp, &Ja);
        Vec3d fo, mo2;
        for (int i = 0; i < 3; ++i) {
            fo[i] = l.force[i].at(s.t);
            mo2[i] = l.moment[i].at(s.t);
        }
        const int o = offsets_[l.body];
        out.F.segment(o, Jp.cols()) -= load_factor * (Jp.transpose() * fo + Ja.transpose() * mo2);
    }
    out.joint_work.resize(joints_.size());
    for (size_t k = 0; k < joints_.size(); ++k) {
        const MbJoint& j = joints_[k];
        MbJointWork& w = out.joint_work[k];
        const int r0 = rows_[k], nr = j.rows();
        const int oa = offsets_[j.body_a], na = offsets_[j.body_a + 1] - oa;
        const int ob = j.body_b < 0 ? 0 : offsets_[j.body_b], nb = j.body_b < 0 ? 0 : offsets_[j.body_b + 1] - ob;
        w.Ja.resize(nr, na);
        w.Jb.resize(nr, nb);
        joint_equations(s, j, out.c.segment(r0, nr), w.Ja, w.Jb, w);
        out.J.block(r0, oa, nr, na) += w.Ja;
        if (nb) out.J.block(r0, ob, nr, nb) += w.Jb;
        if (joint_forces(s, j, mdot, load_factor, w)) {
            out.F.segment(oa, na) -= w.fa;
            if (nb) out.F.segment(ob, nb) -= w.fb;
        }
    }
    out.F.noalias() += out.J.transpose() * s.lam;
    if (with_tangent && wK != 0.0) geometric_stiffness(s, mdot, load_factor, out.S, wK);
}

MbOutput MultibodySystemCore::integrate(MbState& s, const TimeTable& mass_flow, double t_end,
                                        const std::vector<long>& out_steps, const MbOptions& opt) const {
    check_state(s);
    if (!std::isfinite(t_end) || !(t_end > s.t))
        throw std::invalid_argument("t_end = " + fmt(t_end) + " s must be finite and after the state's time " +
                                    fmt(s.t) + " s");
    if (!std::isfinite(opt.step) || !(opt.step > 0.0)) throw std::invalid_argument("step must be > 0 and finite");
    if (!(opt.rho_inf >= 0.0 && opt.rho_inf < 1.0)) throw std::invalid_argument("rho_inf must be in [0, 1)");
    if (!(opt.tol > 0.0)) throw std::invalid_argument("tol must be > 0");
    if (opt.max_newton < 1 || opt.refresh < 1) throw std::invalid_argument("max_newton and refresh must be >= 1");
    const double steps_needed = std::ceil((t_end - s.t) / opt.step - 1e-9);
    if (steps_needed > static_cast<double>(opt.max_steps))
        throw std::invalid_argument("step = " + fmt(opt.step) + " s gives " + fmt(steps_needed) + " steps to t_end = " +
                                    fmt(t_end) + " s; max_steps = " + std::to_string(opt.max_steps) +
                                    " (raise step or max_steps, or shorten the run)");
    for (size_t k = 0; k < out_steps.size(); ++k)
        if (out_steps[k] < 0 || out_steps[k] > static_cast<long>(std::max(1.0, steps_needed)) ||
            (k > 0 && out_steps[k] <= out_steps[k - 1]))
            throw std::invalid_argument("out_steps must be increasing step numbers in [0, n_steps]");
    const double rho = opt.rho_inf;
    const double am = (2 * rho - 1) / (rho + 1), af = rho / (rho + 1);
    const double gamma = 0.5 + af - am, beta = 0.25 * (gamma + 0.5) * (gamma + 0.5);
    const double t0 = s.t;
    const long n_steps = std::max(1L, static_cast<long>(std::ceil((t_end - t0) / opt.step - 1e-9)));
    const double h = (t_end - t0) / static_cast<double>(n_steps);
    const double bp = (1 - am) / ((1 - af) * beta * h * h), gp = gamma / (beta * h);
    const double L = length_scale_;
    MbOutput out;
    MbEvaluation ev;
    auto save = [&](const MbState& st) {
        out.t.push_back(st.t);
        out.states.push_back(st);
        out.drift.push_back((ev.J * st.v).cwiseAbs().maxCoeff());
    };

    // consistent initial acceleration and multipliers (minimum-norm least squares)
    evaluate(s, mass_flow.at(t0), mass_flow.rate(t0), 1.0, 1.0, 0.0, 0.0, 1.0, true, ev);
    {
        MatX A = MatX::Zero(n_ + nc_, n_ + nc_);
        A.topLeftCorner(n_, n_) = ev.S;
        A.topRightCorner(n_, nc_) = ev.J.transpose();
        A.bottomLeftCorner(nc_, n_) = ev.J;
        VecX rhs = VecX::Zero(n_ + nc_);
        rhs.head(n_) = -(ev.F - ev.J.transpose() * s.lam - ev.S * s.a);
        const VecX x = A.completeOrthogonalDecomposition().solve(rhs);
        s.a = x.head(n_);
        s.lam = x.tail(nc_);
    }
    VecX acc = s.a;
    size_t next_out = 0;
    if (next_out < out_steps.size() && out_steps[next_out] == 0) {
        save(s);
        ++next_out;
    }
    IterationMatrixLU lu(offsets_, rows_, joints_);
    bool have_lu = false;
    double scale = 1.0;
    VecX rhs(n_ + nc_), x(n_ + nc_), dx(n_);
    for (long n = 1; n <= n_steps; ++n) {
        poll_interrupt();
        const double t = t0 + static_cast<double>(n) * h;
        const VecX acc_new = (af * s.a - am * acc) / (1 - am);
        const VecX dq = h * s.v + h * h * ((0.5 - beta) * acc + beta * acc_new);
        s.v += h * ((1 - gamma) * acc + gamma * acc_new);
        s.a.setZero();
        s.t = t;
        increment(s, dq);
        const double mdot = mass_flow.at(t), mrate = mass_flow.rate(t);
        double size = 0.0;
        bool singular = false;
        int done = 0;  // iterations of the last Newton attempt
        // Newton on the corrections; full = re-evaluate the iteration matrix every iteration.
        auto newton = [&](bool full, int max_it) {
            bool fresh = false, stale_stall = false;
            double last = INFINITY;
            done = 0;
            for (int it = 0; it < max_it; ++it) {
                poll_interrupt();
                const bool refresh = full || !have_lu || it >= opt.refresh || stale_stall;
                fresh = fresh || refresh;
                evaluate(s, mdot, mrate, 1.0, 1.0, 1.0, gp, bp, refresh, ev);
                if (refresh) {
                    scale = ev.S.cwiseAbs().maxCoeff();
                    have_lu = lu.factorize(ev.S, ev.J, scale);
                    ++out.factorizations;
                    singular = !have_lu;
                    if (singular) return false;
                }
                rhs.head(n_) = -ev.F;
                rhs.tail(nc_) = -scale * ev.c;
                lu.solve(rhs, x);
                if (!x.allFinite()) return false;
                dx = x.head(n_);
                increment(s, dx);
                s.v += gp * dx;
                s.a += bp * dx;
                s.lam += scale * x.tail(nc_);
                ++out.iterations;
                ++done;
                size = dx.cwiseAbs().maxCoeff();
                // Converged; or stalled at round-off near the tolerance with a matrix
                // evaluated in this step (a stall with an older matrix is slow
                // modified-Newton convergence: re-evaluate the matrix instead).
                const bool stalled = size >= 0.5 * last && size <= 10 * opt.tol * L;
                if (size <= opt.tol * L || (stalled && fresh)) return true;
                if (size > L) return false;  // diverging
                stale_stall = size >= 0.5 * last;
                last = size;
            }
            return false;
        };
        const MbState predicted = s;
        if (!newton(false, opt.max_newton)) {
            // the kept matrix may be too far off: retry the step with full Newton
            s = predicted;
            ++out.retries;
            if (!newton(true, 2 * opt.max_newton)) {
                std::ostringstream msg;
                if (singular)
                    msg << "singular iteration matrix at t = " << t << " s (h = " << h
                        << " s): the joints lock a motion twice or leave a body's mass matrix singular; ";
                msg << "Newton did not converge at t = " << t << " s (h = " << h << " s) after " << done
                    << " full Newton iterations (last increment " << size << ", residual "
                    << ev.F.cwiseAbs().maxCoeff() << " N, constraint violation " << ev.c.cwiseAbs().maxCoeff()
                    << " m): reduce the step";
                ConvergenceError::Where where;
                where.time = t;
                where.iteration = done;
                where.residual = ev.F.cwiseAbs().maxCoeff();
                where.mass_flow = mdot;
                if (singular) throw SingularMatrixError(msg.str(), where);
                throw ConvergenceError(msg.str(), where);
            }
        }
        acc = acc_new + (1 - af) / (1 - am) * s.a;
        ++out.steps;
        if (next_out < out_steps.size() && out_steps[next_out] == n) {
            save(s);
            ++next_out;
        }
    }
    return out;
}

}  // namespace pipeflex
