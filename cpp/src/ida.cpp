// IDA on any system's Equations: the stabilised index-2 form and its Newton matrix
// (ida.hpp says why this form and how the matrix is solved).
#include "pipeflex/solvers/ida.hpp"

#include "pipeflex/core/format.hpp"
#include "pipeflex/core/interrupt.hpp"
#include "pipeflex/core/user_function_error.hpp"
#include "pipeflex/errors.hpp"
#include "pipeflex/solvers/sparse_lu.hpp"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <ida/ida.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_linearsolver.h>
#include <sundials/sundials_matrix.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

namespace pipeflex {

namespace {

using Vec = Eigen::VectorXd;
using SpMat = Eigen::SparseMatrix<double>;
using SpMap = Eigen::Map<const SpMat>;

// y = [z_0, v_0, z_1, v_1, ...; lambda; mu]: z and v interleaved per coordinate (the
// element model's Newton matrix keeps its band), the multipliers after them.
struct Layout {
    int n = 0, nc = 0;
    int size() const { return 2 * n + 2 * nc; }
    void unpack(const double* y, Vec& z, Vec& v, Vec* lam, Vec* mu) const {
        for (int i = 0; i < n; ++i) {
            z[i] = y[2 * i];
            v[i] = y[2 * i + 1];
        }
        if (lam != nullptr)
            for (int k = 0; k < nc; ++k) (*lam)[k] = y[2 * n + k];
        if (mu != nullptr)
            for (int k = 0; k < nc; ++k) (*mu)[k] = y[2 * n + nc + k];
    }
};

// The constraint rows' first n columns (C_q, nc x n) of an evaluate() tangent's triplets.
void constraint_jacobian(const Triplets& J, int n, int nc, SpMat& C) {
    std::vector<Eigen::Triplet<double>> t;
    for (std::size_t k = 0; k < J.values.size(); ++k)
        if (J.rows[k] >= n && J.cols[k] < n) t.emplace_back(J.rows[k] - n, J.cols[k], J.values[k]);
    C.resize(nc, n);
    C.setFromTriplets(t.begin(), t.end());
}

// The Newton matrix (ida.hpp): the velocity's KKT matrix on the tangent's kept pattern,
// C_q C_q^T, and K for the right-hand side.
struct NewtonMatrix {
    Layout lay;
    TangentCsc tangent;  // K (weight set 0) and S (1), C_q below
    int built = -1;      // tangent.builds the KKT pattern was made for
    std::vector<int> rows, cols;
    std::vector<double> values;
    FixedPatternLU lu{kDenseLuBelow};
    Eigen::SimplicialLDLT<SpMat> gram;  // C_q C_q^T
    double cj = 0.0, scale = 1.0;
    Vec b1, b2, b3, b4, u, rhs, x, dmu, delta, dz;

    void pattern() {
        const CscMatrix &top = tangent.top, &bottom = tangent.bottom;
        const int n = lay.n;
        rows.clear();
        cols.clear();
        for (int c = 0; c < n; ++c)
            for (int k = top.col_ptr[c]; k < top.col_ptr[c + 1]; ++k) {
                rows.push_back(top.row_index[k]);
                cols.push_back(c);
            }
        if (lay.nc > 0) {
            for (int c = 0; c < n; ++c)
                for (int k = bottom.col_ptr[c]; k < bottom.col_ptr[c + 1]; ++k) {
                    rows.push_back(n + bottom.row_index[k]);
                    cols.push_back(c);
                    rows.push_back(c);
                    cols.push_back(n + bottom.row_index[k]);
                }
        }
        values.assign(rows.size(), 0.0);
        built = tangent.builds;
    }
    // K (n x n) and C_q (nc x n) of the last Jacobian
    SpMap K() const {
        const CscMatrix& t = tangent.top;
        return SpMap(lay.n, lay.n, static_cast<Eigen::Index>(t.row_index.size()), t.col_ptr.data(),
                     t.row_index.data(), tangent.top_values[0].data());
    }
    SpMap C() const {
        const CscMatrix& b = tangent.bottom;
        return SpMap(lay.nc, lay.n, static_cast<Eigen::Index>(b.row_index.size()), b.col_ptr.data(),
                     b.row_index.data(), tangent.bottom_values[0].data());
    }
};

struct IdaData {
    Equations& eq;
    Layout lay;
    Vec z, v, zd, a, lam, mu, w, r, ct;
    Triplets J;
    SpMat C;
    long jacobians = 0;
    std::string error;
    std::exception_ptr user_error;  // a user function's failure, rethrown as it is
};

int ida_residual(sunrealtype t, N_Vector yy, N_Vector yp, N_Vector rr, void* user) {
    auto* d = static_cast<IdaData*>(user);
    const int n = d->lay.n, nc = d->lay.nc;
    d->lay.unpack(NV_DATA_S(yy), d->z, d->v, &d->lam, &d->mu);
    d->lay.unpack(NV_DATA_S(yp), d->zd, d->a, nullptr, nullptr);
    double* f = NV_DATA_S(rr);
    if (!d->z.allFinite() || !d->v.allFinite() || !d->lam.allFinite() || !d->mu.allFinite()) return 1;  // recoverable
    try {
        Equations& eq = d->eq;
        eq.set(d->z, d->v, d->a, d->lam, t);
        if (nc == 0) {
            eq.evaluate(0.0, 0.0, 0.0, d->r, nullptr);
            eq.chart_rates(d->v, d->w);
        } else {
            eq.evaluate(0.0, 0.0, 0.0, d->r, &d->J);
            constraint_jacobian(d->J, n, nc, d->C);
            eq.chart_rates(d->v + d->C.transpose() * d->mu, d->w);
            eq.constraint_rate(d->ct);
            d->ct += d->C * d->v;
        }
        for (int i = 0; i < n; ++i) {
            f[2 * i] = d->zd[i] - d->w[i];
            f[2 * i + 1] = d->r[i];
        }
        for (int k = 0; k < nc; ++k) {
            f[2 * n + k] = d->r[n + k];
            f[2 * n + nc + k] = d->ct[k];
        }
        if (!d->r.allFinite()) return 1;
    } catch (const std::exception& e) {
        d->error = e.what();
        if (is_user_function_error(e)) d->user_error = std::current_exception();
        return -1;
    }
    return 0;
}

int ida_jacobian(sunrealtype t, sunrealtype cj, N_Vector yy, N_Vector yp, N_Vector, SUNMatrix A, void* user, N_Vector,
                 N_Vector, N_Vector) {
    auto* d = static_cast<IdaData*>(user);
    auto* nm = static_cast<NewtonMatrix*>(A->content);
    const int nc = d->lay.nc;
    ++d->jacobians;
    d->lay.unpack(NV_DATA_S(yy), d->z, d->v, &d->lam, &d->mu);
    d->lay.unpack(NV_DATA_S(yp), d->zd, d->a, nullptr, nullptr);
    try {
        d->eq.set(d->z, d->v, d->a, d->lam, t);
        d->eq.tangents_csc({{1.0, 0.0, 0.0}, {1.0, cj, cj * cj}}, nm->tangent);
    } catch (const std::exception& e) {
        d->error = e.what();
        if (is_user_function_error(e)) d->user_error = std::current_exception();
        return -1;
    }
    if (nm->built != nm->tangent.builds) nm->pattern();
    nm->cj = cj;
    const std::vector<double>& S = nm->tangent.top_values[1];
    std::copy(S.begin(), S.end(), nm->values.begin());
    if (nc > 0) {  // the constraint rows and columns scaled to S's size, so that pivoting sees both
        double big = 0.0;
        for (const double s : S) big = std::max(big, std::abs(s));
        nm->scale = big > 0.0 ? big : 1.0;
        const std::vector<double>& Cq = nm->tangent.bottom_values[0];
        std::size_t k = S.size();
        for (const double c : Cq) {
            nm->values[k++] = nm->scale * c;
            nm->values[k++] = nm->scale * c;
        }
    }
    return 0;
}

SUNMatrix_ID newton_matrix_id(SUNMatrix) { return SUNMATRIX_CUSTOM; }
int newton_matrix_zero(SUNMatrix) { return 0; }  // the Jacobian overwrites every value
SUNLinearSolver_Type newton_solver_type(SUNLinearSolver) { return SUNLINEARSOLVER_DIRECT; }
SUNLinearSolver_ID newton_solver_id(SUNLinearSolver) { return SUNLINEARSOLVER_CUSTOM; }

int newton_setup(SUNLinearSolver, SUNMatrix A) {
    auto* nm = static_cast<NewtonMatrix*>(A->content);
    const int m = nm->lay.n + nm->lay.nc;
    // singular: IDA retries with a smaller step
    if (!nm->lu.factorize(m, nm->rows, nm->cols, nm->values)) return SUNLS_LUFACT_FAIL;
    if (nm->lay.nc > 0) {
        const SpMap C = nm->C();
        const SpMat G = C * C.transpose();
        nm->gram.compute(G);
        if (nm->gram.info() != Eigen::Success) return SUNLS_LUFACT_FAIL;
    }
    return SUNLS_SUCCESS;
}

// The Newton correction (ida.hpp): dmu from C_q C_q^T, (dv, dlambda) from the KKT matrix,
// dz = N (b1' + dv + C_q^T dmu) / cj.

int newton_solve(SUNLinearSolver LS, SUNMatrix A, N_Vector xv, N_Vector bv, sunrealtype) {
    auto* nm = static_cast<NewtonMatrix*>(A->content);
    auto* d = static_cast<IdaData*>(LS->content);
    const int n = nm->lay.n, nc = nm->lay.nc;
    nm->b1.resize(n);
    nm->b2.resize(n);
    nm->b3.resize(nc);
    nm->b4.resize(nc);
    nm->lay.unpack(NV_DATA_S(bv), nm->b1, nm->b2, &nm->b3, &nm->b4);
    try {
        d->eq.rate_increments(nm->b1, nm->u);
    } catch (const std::exception& e) {
        d->error = e.what();
        if (is_user_function_error(e)) d->user_error = std::current_exception();
        return SUNLS_PACKAGE_FAIL_UNREC;
    }
    const SpMap K = nm->K();
    if (nc > 0) {
        const SpMap C = nm->C();
        nm->dmu = nm->gram.solve(nm->cj * nm->b3 - nm->b4 - C * nm->u);
        nm->u += C.transpose() * nm->dmu;
        nm->rhs.resize(n + nc);
        nm->rhs.head(n).noalias() = nm->cj * nm->b2;
        nm->rhs.head(n).noalias() -= K * nm->u;
        nm->rhs.tail(nc) = nm->scale * nm->b4;
    } else {
        nm->rhs.noalias() = nm->cj * nm->b2;
        nm->rhs.noalias() -= K * nm->u;
    }
    nm->lu.solve(nm->rhs, nm->x);
    nm->delta = (nm->u + nm->x.head(n)) / nm->cj;
    d->eq.chart_rates(nm->delta, nm->dz);
    double* out = NV_DATA_S(xv);
    for (int i = 0; i < n; ++i) {
        out[2 * i] = nm->dz[i];
        out[2 * i + 1] = nm->x[i];
    }
    for (int k = 0; k < nc; ++k) {
        out[2 * n + k] = nm->scale * nm->x[n + k] / nm->cj;
        out[2 * n + nc + k] = nm->dmu[k];
    }
    return nm->x.allFinite() && nm->dz.allFinite() ? SUNLS_SUCCESS : SUNLS_PACKAGE_FAIL_REC;
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
using NVec = std::unique_ptr<_generic_N_Vector, void (*)(N_Vector)>;
// The absolute tolerance of the multipliers: so large that they weigh nothing in IDA's
// norms (they are out of the error test too)
constexpr double kUntestedAtol = 1e100;

// IDA's counters summed over its restarts.
struct IdaCounters {
    long newton_iterations = 0, error_test_failures = 0, convergence_failures = 0;
    void add(void* mem) {
        long nni = 0, nef = 0, ncf = 0;
        IDAGetNumNonlinSolvIters(mem, &nni);
        IDAGetNumErrTestFails(mem, &nef);
        IDAGetNumNonlinSolvConvFails(mem, &ncf);
        newton_iterations += nni;
        error_test_failures += nef;
        convergence_failures += ncf;
    }
};

// The rates projected onto C_q v + c_t = 0 (least change) at the state set with z = 0.
void project_rates(Equations& eq, const Vec& lam, double t, Vec& v) {
    const int n = eq.n_coordinates(), nc = eq.n_constraints();
    if (nc == 0) return;
    Vec r, ct;
    Triplets J;
    SpMat C;
    eq.set(Vec::Zero(n), v, Vec::Zero(n), lam, t);
    eq.evaluate(0.0, 0.0, 0.0, r, &J);
    constraint_jacobian(J, n, nc, C);
    eq.constraint_rate(ct);
    const Vec g = C * v + ct;
    if (!(g.lpNorm<Eigen::Infinity>() > 0.0)) return;
    const SpMat G = C * C.transpose();
    Eigen::SimplicialLDLT<SpMat> ldlt(G);
    if (ldlt.info() != Eigen::Success) return;  // dependent constraints: initial_acceleration says so
    v -= C.transpose() * ldlt.solve(g);
}

}  // namespace

Record integrate_ida(System& sys, const Drive& drive, const std::vector<double>& times, const ProgressFn& progress) {
    Record out;
    if (times.empty()) return out;
    const TransientOptions& opt = drive.options;
    const std::unique_ptr<Run> run = sys.start(drive, System::Mode::dynamics);
    Equations& eq = run->equations();
    eq.set_rebase_angle(opt.rebase_angle);
    Layout lay;
    lay.n = eq.n_coordinates();
    lay.nc = eq.n_constraints();
    const int n = lay.n, nc = lay.nc, N = lay.size();
    double t = times.front();
    IdaData data{eq, lay, Vec::Zero(n), Vec::Zero(n), Vec::Zero(n), Vec::Zero(n), Vec::Zero(nc), Vec::Zero(nc),
                 Vec(), Vec(), Vec(), Triplets(), SpMat(), 0, {}, nullptr};

    SUNContext ctx = nullptr;
    if (SUNContext_Create(nullptr, &ctx) != 0) throw std::runtime_error("SUNDIALS: could not create a context");
    Handle<SUNContext, free_ctx> ctx_guard{ctx};
    NVec yy(N_VNew_Serial(N, ctx), N_VDestroy), yp(N_VNew_Serial(N, ctx), N_VDestroy);
    NVec dky(N_VNew_Serial(N, ctx), N_VDestroy), id(N_VNew_Serial(N, ctx), N_VDestroy);
    NewtonMatrix newton;
    newton.lay = lay;
    std::unique_ptr<_generic_SUNMatrix, void (*)(SUNMatrix)> A(SUNMatNewEmpty(ctx), SUNMatFreeEmpty);
    std::unique_ptr<_generic_SUNLinearSolver, void (*)(SUNLinearSolver)> LS(SUNLinSolNewEmpty(ctx),
                                                                           SUNLinSolFreeEmpty);
    if (!A || !LS) throw std::runtime_error("SUNDIALS: could not create the Newton matrix and solver");
    A->content = &newton;
    A->ops->getid = newton_matrix_id;
    A->ops->zero = newton_matrix_zero;
    LS->content = &data;
    LS->ops->gettype = newton_solver_type;
    LS->ops->getid = newton_solver_id;
    LS->ops->setup = newton_setup;
    LS->ops->solve = newton_solve;
    void* mem = IDACreate(ctx);
    if (mem == nullptr) throw std::runtime_error("SUNDIALS: IDACreate failed");
    Handle<void*, free_ida> mem_guard{mem};

    // Consistent initial values at the chart's base (z = 0): the rates on the velocity
    // constraint, the accelerations and multipliers from [M, C_q^T; C_q, 0], mu = 0.
    Vec v = run->v, a, lam = run->lam;
    if (lam.size() != nc) lam = Vec::Zero(nc);
    project_rates(eq, lam, t, v);
    initial_acceleration(eq, Vec::Zero(n), v, t, a, lam);
    auto load_y = [&](const Vec& vv, const Vec& aa, const Vec& ll) {
        double* y = NV_DATA_S(yy.get());
        double* p = NV_DATA_S(yp.get());
        Vec zd;
        eq.set(Vec::Zero(n), vv, aa, ll, t);
        eq.chart_rates(vv, zd);
        for (int i = 0; i < n; ++i) {
            y[2 * i] = 0.0;
            y[2 * i + 1] = vv[i];
            p[2 * i] = zd[i];
            p[2 * i + 1] = aa[i];
        }
        for (int k = 0; k < 2 * nc; ++k) {
            y[2 * n + k] = k < nc ? ll[k] : 0.0;
            p[2 * n + k] = 0.0;
        }
    };
    load_y(v, a, lam);
    auto check = [&](int flag, const char* what) {
        if (flag < 0)
            throw std::runtime_error(std::string("SUNDIALS: ") + what + " failed (flag " + std::to_string(flag) + ")");
    };
    check(IDAInit(mem, ida_residual, t, yy.get(), yp.get()), "IDAInit");
    check(IDASStolerances(mem, opt.rtol, opt.atol), "IDASStolerances");
    check(IDASetUserData(mem, &data), "IDASetUserData");
    check(IDASetLinearSolver(mem, LS.get(), A.get()), "IDASetLinearSolver");
    check(IDASetJacFn(mem, ida_jacobian), "IDASetJacFn");
    check(IDASetMaxNumSteps(mem, opt.max_steps), "IDASetMaxNumSteps");
    check(IDASetMaxOrd(mem, opt.max_order), "IDASetMaxOrd");
    check(IDASetStopTime(mem, times.back()), "IDASetStopTime");
    if (nc > 0) {  // the multipliers are algebraic: out of the error test
        double* p = NV_DATA_S(id.get());
        for (int k = 0; k < N; ++k) p[k] = k < 2 * n ? 1.0 : 0.0;
        check(IDASetId(mem, id.get()), "IDASetId");
        check(IDASetSuppressAlg(mem, SUNTRUE), "IDASetSuppressAlg");
        // ...and out of Newton's convergence test (IDA's WRMS norm of the corrections): a
        // step's corrections of lambda and mu carry the constraints' round-off times c_j
        // (1e-16 m at c_j = 1e10 1/s: 1e-6 in mu), which no tolerance on them would pass;
        // the positions and velocities they balance are tested
        NVec atol(N_VNew_Serial(N, ctx), N_VDestroy);
        double* w = NV_DATA_S(atol.get());
        for (int k = 0; k < N; ++k) w[k] = k < 2 * n ? opt.atol : kUntestedAtol;
        check(IDASVtolerances(mem, opt.rtol, atol.get()), "IDASVtolerances");
    }

    eq.set(Vec::Zero(n), v, a, lam, t);
    run->begin(t);
    out.t.push_back(t);
    run->record(t, out);
    std::unique_ptr<SensorRecorder> sensors;
    if (drive.sensors != nullptr && !drive.sensors->empty()) {
        sensors = std::make_unique<SensorRecorder>(*run, *drive.sensors);
        sensors->step(t);
        eq.observer = sensors.get();
    }
    std::size_t next = 1;
    double prev_t = t;
    long steps = 0, rebases = 0;
    IdaCounters counters;
    Vec z(n), ad(n), mu(nc), zo(n), vo(n), ao(n), lo(nc), unused(n);
    while (next < times.size()) {
        double tret = 0.0;
        poll_interrupt();
        // IDASetMaxNumSteps bounds the steps of one IDASolve call; this loop takes one
        // step per call, so it counts them itself
        if (steps >= opt.max_steps)
            throw std::invalid_argument("IDA: max_steps = " + std::to_string(opt.max_steps) + " steps reached at t = " +
                                        fmt(prev_t) + " s before t_end; raise max_steps or loosen the tolerances");
        const int flag = IDASolve(mem, times.back(), &tret, yy.get(), yp.get(), IDA_ONE_STEP);
        if (flag < 0) {
            double h = 0.0, tc = 0.0;
            IDAGetLastStep(mem, &h);
            IDAGetCurrentTime(mem, &tc);
            if (data.user_error) std::rethrow_exception(data.user_error);
            const std::string why = data.error.empty() ? IDAGetReturnFlagName(flag) : data.error;
            ConvergenceError::Where where;
            where.time = tc;
            where.mass_flow = eq.mass_flow(tc);
            throw ConvergenceError("IDA failed at t = " + fmt(tc) + " s (last step " + fmt(h) + " s): " + why +
                                       ". The motion may diverge or the tolerances be too tight.",
                                   where);
        }
        ++steps;
        lay.unpack(NV_DATA_S(yy.get()), z, v, &lam, &mu);
        lay.unpack(NV_DATA_S(yp.get()), unused, a, nullptr, nullptr);
        eq.set(z, v, a, lam, tret);
        eq.accept(tret, tret - prev_t);  // divergence; the work (linear within the step for outputs)
        // outputs inside (prev_t, tret], interpolated by IDA
        while (next < times.size() && times[next] <= tret + 1e-14 * std::max(1.0, std::abs(tret))) {
            const double to = std::min(times[next], tret);
            check(IDAGetDky(mem, to, 0, dky.get()), "IDAGetDky");
            lay.unpack(NV_DATA_S(dky.get()), zo, vo, &lo, nullptr);
            check(IDAGetDky(mem, to, 1, dky.get()), "IDAGetDky");
            lay.unpack(NV_DATA_S(dky.get()), unused, ao, nullptr, nullptr);
            eq.set(zo, vo, ao, lo, to);
            out.t.push_back(to);
            run->record(to, out);
            if (progress) progress(to);
            ++next;
        }
        prev_t = tret;
        // re-base frames that turned far, then restart IDA from the same motion
        eq.set(z, v, a, lam, tret);
        if (eq.observer != nullptr) {  // sensors at the step's end; a terminal crossing ends the run here
            try {
                eq.observer->step(tret);
            } catch (const TerminalEvent&) {
                if (out.t.back() < tret) {
                    out.t.push_back(tret);
                    run->record(tret, out);
                }
                break;
            }
        }
        if (eq.chart_rotation() > opt.rebase_angle && next < times.size()) {
            rebases += std::max(eq.rebase(v, a), 1);
            counters.add(mem);  // IDAReInit zeroes IDA's counters
            t = tret;
            load_y(v, a, lam);
            check(IDAReInit(mem, tret, yy.get(), yp.get()), "IDAReInit");
        }
    }
    run->finish();
    counters.add(mem);
    out.counters = {{"steps", steps},
                    {"newton_iterations", counters.newton_iterations},
                    {"jacobians", data.jacobians},
                    {"rebases", rebases},
                    {"failed_steps", counters.error_test_failures},
                    {"convergence_failures", counters.convergence_failures}};
    return out;
}

}  // namespace pipeflex
