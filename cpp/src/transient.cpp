#include "pipeflex/solvers/transient.hpp"

#include "pipeflex/core/format.hpp"
#include "pipeflex/core/interrupt.hpp"
#include "pipeflex/solvers/element_equations.hpp"
#include "pipeflex/solvers/sparse_lu.hpp"

#include <Eigen/Dense>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseLU>
#include <ida/ida.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_linearsolver.h>
#include <sundials/sundials_matrix.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>

namespace pipeflex {

namespace {

double table_value(const TimeTable& f, double time) {
    const auto& t = f.t;
    const auto& value = f.value;
    if (t.empty()) return 0.0;
    if (time <= t.front()) return value.front();
    if (time >= t.back()) return value.back();
    const auto it = std::upper_bound(t.begin(), t.end(), time);
    const std::size_t k = static_cast<std::size_t>(it - t.begin());
    const double s = (time - t[k - 1]) / (t[k] - t[k - 1]);
    return value[k - 1] + s * (value[k] - value[k - 1]);
}

double table_rate(const TimeTable& f, double time) {
    const auto& t = f.t;
    if (t.size() < 2 || time < t.front() || time >= t.back()) return 0.0;
    const auto it = std::upper_bound(t.begin(), t.end(), time);
    const std::size_t k = static_cast<std::size_t>(it - t.begin());
    return (f.value[k] - f.value[k - 1]) / (t[k] - t[k - 1]);
}

}  // namespace

double TimeTable::at(double time) const {
    const double env = table_value(*this, time);
    return omega == 0.0 ? env : env * std::sin(omega * time + phase);
}

double TimeTable::rate(double time) const {
    const double d = table_rate(*this, time);
    if (omega == 0.0) return d;
    const double arg = omega * time + phase;
    return d * std::sin(arg) + table_value(*this, time) * omega * std::cos(arg);
}

double gravity_potential(const Model& model, const State& s, const LoadState& load) {
    double V = 0.0;
    Vec3<double> g;
    for (int i = 0; i < 3; ++i) g[i] = load.gravity[i] * load.gravity_factor;
    for (const auto& e : model.elements) e->add_gravity_potential(s, g, &V);
    for (const auto& nm : model.masses) {
        Vec3<double> x{{s.q[6 * nm.node], s.q[6 * nm.node + 1], s.q[6 * nm.node + 2]}};
        V -= nm.mass * dot(g, x);
    }
    return V;
}

namespace {

// ---------------------------------------------------------------- IDA ----------------

struct IdaData {
    ElementEquations* sys;
    Eigen::VectorXd z, v, zd, vd;
    long jacobians = 0;
    std::string error;
};

void unpack(const double* y, Eigen::VectorXd& z, Eigen::VectorXd& v, int n) {
    for (int i = 0; i < n; ++i) {
        z[i] = y[2 * i];
        v[i] = y[2 * i + 1];
    }
}

int ida_residual(sunrealtype t, N_Vector yy, N_Vector yp, N_Vector rr, void* user) {
    auto* d = static_cast<IdaData*>(user);
    ElementEquations& s = *d->sys;
    const int n = s.n;
    unpack(NV_DATA_S(yy), d->z, d->v, n);
    unpack(NV_DATA_S(yp), d->zd, d->vd, n);
    double* r = NV_DATA_S(rr);
    for (int i = 0; i < n; ++i)
        if (!std::isfinite(d->z[i]) || !std::isfinite(d->v[i])) return 1;  // recoverable
    try {
        s.set(d->z, d->v, d->vd, t);
        const Eigen::VectorXd R = s.residual(t);
        for (int i = 0; i < n; ++i) {
            r[2 * i] = d->zd[i] - d->v[i];
            r[2 * i + 1] = R[i];
            if (!std::isfinite(R[i])) return 1;
        }
    } catch (const std::exception& e) {
        d->error = e.what();
        return -1;
    }
    return 0;
}

// IDA's Newton matrix for y = (z, v) interleaved (rows 2i: z_dot - v; rows 2i+1: R),
//     J = [[cj I, -I], [K, C + cj M]],
// solved through its Schur complement on the velocity: J (dz, dv) = (b1, b2) gives
//     (K + cj C + cj^2 M) dv = cj b2 - K b1,   dz = (b1 + dv) / cj,
// one sparse LU of n unknowns on the tangent's cached pattern, K and the iteration
// matrix assembled in one pass (assemble_csc). A band LU of the 2n unknowns costs of
// the order of (2 b)^2 per unknown for the half bandwidth b of the node numbering:
// superlinear in size through the cache (measured), quadratic in b for a network
// numbered badly.
struct NewtonMatrix {
    std::shared_ptr<const TangentPattern> pattern;
    std::vector<double> K, S;
    FixedPatternLU lu;
    double cj = 0.0;
    Eigen::VectorXd b1, b2, rhs, dv;

    NewtonMatrix(const Model& model, int dense_below) : pattern(tangent_pattern(model)), lu(dense_below) {
        const int n = pattern->n;
        std::vector<int> rows(pattern->nnz()), cols(pattern->nnz());
        for (int c = 0; c < n; ++c)
            for (int k = pattern->col_ptr[c]; k < pattern->col_ptr[c + 1]; ++k) {
                rows[k] = pattern->row_index[k];
                cols[k] = c;
            }
        lu.analyze(n, rows, cols);
        const auto& A = lu.matrix();
        if (static_cast<std::size_t>(A.nonZeros()) != pattern->nnz() ||
            !std::equal(pattern->row_index.begin(), pattern->row_index.end(), A.innerIndexPtr()))
            throw std::logic_error("IDA: the LU's pattern differs from the tangent's");
        K.resize(pattern->nnz());
        S.resize(pattern->nnz());
        b1.resize(n);
        b2.resize(n);
    }
};

int ida_jacobian(sunrealtype t, sunrealtype cj, N_Vector yy, N_Vector yp, N_Vector, SUNMatrix J, void* user,
                 N_Vector, N_Vector, N_Vector) {
    auto* d = static_cast<IdaData*>(user);
    auto* nm = static_cast<NewtonMatrix*>(J->content);
    ElementEquations& s = *d->sys;
    const int n = s.n;
    ++d->jacobians;
    unpack(NV_DATA_S(yy), d->z, d->v, n);
    unpack(NV_DATA_S(yp), d->zd, d->vd, n);
    try {
        s.set(d->z, d->v, d->vd, t);
        double* values[2] = {nm->K.data(), nm->S.data()};
        assemble_csc(s.model, s.state, s.load_at(t), s.load_factor(t), {{1.0, 0.0, 0.0}, {1.0, cj, cj * cj}},
                     nullptr, values);
    } catch (const std::exception& e) {
        d->error = e.what();
        return -1;
    }
    nm->cj = cj;
    std::copy(nm->S.begin(), nm->S.end(), nm->lu.matrix().valuePtr());
    return 0;
}

SUNMatrix_ID newton_matrix_id(SUNMatrix) { return SUNMATRIX_CUSTOM; }
int newton_matrix_zero(SUNMatrix) { return 0; }  // the Jacobian overwrites every value
SUNLinearSolver_Type newton_solver_type(SUNLinearSolver) { return SUNLINEARSOLVER_DIRECT; }
SUNLinearSolver_ID newton_solver_id(SUNLinearSolver) { return SUNLINEARSOLVER_CUSTOM; }

int newton_setup(SUNLinearSolver, SUNMatrix J) {
    auto* nm = static_cast<NewtonMatrix*>(J->content);
    return nm->lu.factorize() ? SUNLS_SUCCESS : SUNLS_LUFACT_FAIL;  // singular: IDA retries a smaller step
}

int newton_solve(SUNLinearSolver, SUNMatrix J, N_Vector x, N_Vector b, sunrealtype) {
    auto* nm = static_cast<NewtonMatrix*>(J->content);
    const int n = nm->pattern->n;
    unpack(NV_DATA_S(b), nm->b1, nm->b2, n);
    const Eigen::Map<const Eigen::SparseMatrix<double>> K(n, n, static_cast<Eigen::Index>(nm->pattern->nnz()),
                                                          nm->pattern->col_ptr.data(),
                                                          nm->pattern->row_index.data(), nm->K.data());
    nm->rhs.noalias() = nm->cj * nm->b2;
    nm->rhs.noalias() -= K * nm->b1;
    nm->lu.solve(nm->rhs, nm->dv);
    double* out = NV_DATA_S(x);
    for (int i = 0; i < n; ++i) {
        out[2 * i] = (nm->b1[i] + nm->dv[i]) / nm->cj;
        out[2 * i + 1] = nm->dv[i];
    }
    return nm->dv.allFinite() ? SUNLS_SUCCESS : SUNLS_PACKAGE_FAIL_REC;
}

template <class T, void (*Free)(T)>
struct Handle {
    T p;
    ~Handle() {
        if (p) Free(p);
    }
};
void free_ida(void* p) { IDAFree(&p); }
void free_ctx(SUNContext c) { SUNContext_Free(&c); }


}  // namespace

TransientOutput integrate_ida(const Model& model, State& state, const LoadState& load, const TimeFunctions& functions,
                              const std::vector<double>& times, const TransientOptions& opt,
                              const ProgressFn& progress) {
    TransientOutput out;
    if (times.empty()) return out;
    ElementEquations sys(model, state, load, functions, opt);
    const int n = sys.n;
    double t = times.front();
    IdaData data{&sys, Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n),
                 Eigen::VectorXd::Zero(n), 0, {}};

    SUNContext ctx = nullptr;
    if (SUNContext_Create(nullptr, &ctx) != 0) throw std::runtime_error("SUNDIALS: could not create a context");
    Handle<SUNContext, free_ctx> ctx_guard{ctx};
    const int N = 2 * n;
    std::unique_ptr<_generic_N_Vector, void (*)(N_Vector)> yy(N_VNew_Serial(N, ctx), N_VDestroy);
    std::unique_ptr<_generic_N_Vector, void (*)(N_Vector)> yp(N_VNew_Serial(N, ctx), N_VDestroy);
    NewtonMatrix newton(model, kDenseLuBelow);
    std::unique_ptr<_generic_SUNMatrix, void (*)(SUNMatrix)> A(SUNMatNewEmpty(ctx), SUNMatFreeEmpty);
    std::unique_ptr<_generic_SUNLinearSolver, void (*)(SUNLinearSolver)> LS(SUNLinSolNewEmpty(ctx),
                                                                           SUNLinSolFreeEmpty);
    if (!A || !LS) throw std::runtime_error("SUNDIALS: could not create the Newton matrix and solver");
    A->content = &newton;
    A->ops->getid = newton_matrix_id;
    A->ops->zero = newton_matrix_zero;
    LS->ops->gettype = newton_solver_type;
    LS->ops->getid = newton_solver_id;
    LS->ops->setup = newton_setup;
    LS->ops->solve = newton_solve;
    void* mem = IDACreate(ctx);
    if (mem == nullptr) throw std::runtime_error("SUNDIALS: IDACreate failed");
    Handle<void*, free_ida> mem_guard{mem};

    // Consistent initial values: z = 0 at the base, v from the state, v_dot from M a = -R.
    Eigen::VectorXd v = reduce(model, state.v), a;
    sys.rebase(0.0, v, a);
    {
        Eigen::VectorXd lam;
        initial_acceleration(sys, Eigen::VectorXd::Zero(n), v, t, a, lam);
    }
    auto load_y = [&](const Eigen::VectorXd& vv, const Eigen::VectorXd& aa) {
        double* y = NV_DATA_S(yy.get());
        double* p = NV_DATA_S(yp.get());
        for (int i = 0; i < n; ++i) {
            y[2 * i] = 0.0;
            y[2 * i + 1] = vv[i];
            p[2 * i] = vv[i];
            p[2 * i + 1] = aa[i];
        }
    };
    load_y(v, a);
    auto check = [&](int flag, const char* what) {
        if (flag < 0) throw std::runtime_error(std::string("SUNDIALS: ") + what + " failed (flag " + std::to_string(flag) + ")");
    };
    check(IDAInit(mem, ida_residual, t, yy.get(), yp.get()), "IDAInit");
    check(IDASStolerances(mem, opt.rtol, opt.atol), "IDASStolerances");
    check(IDASetUserData(mem, &data), "IDASetUserData");
    check(IDASetLinearSolver(mem, LS.get(), A.get()), "IDASetLinearSolver");
    check(IDASetJacFn(mem, ida_jacobian), "IDASetJacFn");
    check(IDASetMaxNumSteps(mem, opt.max_steps), "IDASetMaxNumSteps");
    check(IDASetMaxOrd(mem, opt.max_order), "IDASetMaxOrd");
    check(IDASetStopTime(mem, times.back()), "IDASetStopTime");

    sys.set(Eigen::VectorXd::Zero(n), v, a, t);
    sys.start_work(t);
    sys.record(t, out, 0.0, 0.0);
    std::size_t next = 1;
    double prev_t = t, prev_fw = 0.0, prev_lw = 0.0;
    Eigen::VectorXd z(n);
    N_Vector dky = N_VNew_Serial(N, ctx);
    std::unique_ptr<_generic_N_Vector, void (*)(N_Vector)> dky_guard(dky, N_VDestroy);
    while (next < times.size()) {
        double tret = 0.0;
        poll_interrupt();
        // IDASetMaxNumSteps bounds the steps of one IDASolve call; this loop takes one
        // step per call, so it counts them itself
        if (out.steps >= opt.max_steps)
            throw std::invalid_argument("IDA: max_steps = " + std::to_string(opt.max_steps) + " steps reached at t = " +
                                        fmt(prev_t) + " s before t_end; raise max_steps or loosen the tolerances");
        const int flag = IDASolve(mem, times.back(), &tret, yy.get(), yp.get(), IDA_ONE_STEP);
        if (flag < 0) {
            double h = 0.0, tc = 0.0;
            IDAGetLastStep(mem, &h);
            IDAGetCurrentTime(mem, &tc);
            std::string why = data.error.empty() ? IDAGetReturnFlagName(flag) : data.error;
            ConvergenceError::Where where;
            where.time = tc;
            where.mass_flow = sys.load_at(tc).mass_flow;
            throw ConvergenceError("IDA failed at t = " + fmt(tc) + " s (last step " + fmt(h) + " s): " + why +
                                       ". The motion may diverge or the tolerances be too tight.",
                                   where);
        }
        ++out.steps;
        unpack(NV_DATA_S(yy.get()), data.z, data.v, n);
        unpack(NV_DATA_S(yp.get()), data.zd, data.vd, n);
        sys.set(data.z, data.v, data.vd, tret);
        sys.check_divergence(tret, tret - prev_t);
        sys.accumulate_work(tret);
        // outputs inside (prev_t, tret], interpolated by IDA; work linearly
        while (next < times.size() && times[next] <= tret + 1e-14 * std::max(1.0, std::abs(tret))) {
            const double to = std::min(times[next], tret);
            check(IDAGetDky(mem, to, 0, dky), "IDAGetDky");
            Eigen::VectorXd zo(n), vo(n), ao(n), dummy(n);
            unpack(NV_DATA_S(dky), zo, vo, n);
            check(IDAGetDky(mem, to, 1, dky), "IDAGetDky");
            unpack(NV_DATA_S(dky), dummy, ao, n);
            sys.set(zo, vo, ao, to);
            const double s = tret > prev_t ? (to - prev_t) / (tret - prev_t) : 1.0;
            sys.record(to, out, prev_fw + s * (sys.fluid_work - prev_fw), prev_lw + s * (sys.load_work - prev_lw));
            if (progress) progress(to);
            ++next;
        }
        prev_t = tret;
        prev_fw = sys.fluid_work;
        prev_lw = sys.load_work;
        // re-base rotations that grew large, then restart IDA from the same motion
        sys.set(data.z, data.v, data.vd, tret);
        const bool big = state.max_rotation() > opt.rebase_angle;
        if (big && next < times.size()) {
            Eigen::VectorXd vv, aa;
            out.rebases += sys.rebase(opt.rebase_angle, vv, aa);
            load_y(vv, aa);
            check(IDAReInit(mem, tret, yy.get(), yp.get()), "IDAReInit");
        }
    }
    long nni = 0;
    IDAGetNumNonlinSolvIters(mem, &nni);
    out.newton_iterations = nni;
    out.jacobians = data.jacobians;
    long nef = 0;
    IDAGetNumErrTestFails(mem, &nef);
    out.failed_steps = nef;
    long ncf = 0;
    IDAGetNumNonlinSolvConvFails(mem, &ncf);
    out.convergence_failures = ncf;
    return out;
}

// ------------------------------------------------------- generalised-alpha ------------

}  // namespace pipeflex
