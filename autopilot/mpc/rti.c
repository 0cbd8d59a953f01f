/* One real-time iteration of the unified velocity MPC in one C call (docs/mpc.md 3.8).
 *
 * The stage blocks (RK4 gap and its Jacobians, Gauss-Newton Hessian and gradient) come from the CasADi-generated
 * functions mpc_stage and mpc_terminal (mpc_rti_model.h) and are written straight into HPIPM's OCP-QP structures,
 * which HPIPM's interior-point method solves; no sparse matrix is built or converted. The measured initial state
 * is eliminated: stage 0 has no state variables, its step dx0 = x0 - w0 enters b0, r0 and the yaw row's bounds.
 * Dimensions and the yaw row come from mpc_rti_dims.h, written by autopilot/mpc_hpipm.py.
 *
 * Vectors are laid out as in autopilot/mpc.py: w = [x0 u0 x1 u1 ... xN], P column-major (NP x N+1).
 *
 * mpc_rti_iterate takes the Gauss-Newton steps of one controller tick (each a QP, w moved by its step while the
 * steps succeed); mpc_rti_start hands them to a worker thread of this object and returns, mpc_rti_wait waits
 * for them (docs/mpc.md 3.9: the solve overlapped with the autopilot's steps). The caller leaves the vectors it
 * passed alone in between.
 */
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <time.h>
#include <stdlib.h>
#include <string.h>

#include "hpipm_d_ocp_qp.h"
#include "hpipm_d_ocp_qp_dim.h"
#include "hpipm_d_ocp_qp_ipm.h"
#include "hpipm_d_ocp_qp_sol.h"
#include "mpc_rti_dims.h"
#include "mpc_rti_model.h"

#define NZ (NX + NU)
#define STAGE_WORK 64
#define BUSY (-2) /* returned while a started solve runs (it owns the workspace) */

typedef struct {
    double *w, *dw, *info;
    const double *P, *x0, *lbw, *ubw;
    double levenberg;
    int steps, status;
} rti_job;

typedef struct {
    int horizon, nbx, nbu;
    int warm_start, cold_next; /* a failed solve's solution is no start for the next one */
    int last_iterations;
    double mu0, mu0_warm;
    int idxbx[NX], idxbu[NU];
    double yaw_offset;
    struct d_ocp_qp_dim dim;
    struct d_ocp_qp qp;
    struct d_ocp_qp_sol sol;
    struct d_ocp_qp_ipm_arg arg;
    struct d_ocp_qp_ipm_ws ws;
    void *blocks[5]; /* dim, qp, sol, arg, ws memory */
    casadi_int *iw;
    casadi_real *work;
    /* the worker thread of mpc_rti_start / mpc_rti_wait, started at the first mpc_rti_start; busy from a start
     * to its wait (set and cleared by the caller's thread only) */
    int worker_started, pending, done, quit, busy;
    pthread_t worker;
    pthread_mutex_t lock;
    pthread_cond_t changed;
    rti_job job;
} mpc_rti;

static void *aligned(size_t size) {
    void *p = NULL;
    return posix_memalign(&p, 64, size + 64) == 0 ? p : NULL;
}

void mpc_rti_free(mpc_rti *s) {
    if (s == NULL) return;
    if (s->worker_started) {
        pthread_mutex_lock(&s->lock);
        s->quit = 1;
        pthread_cond_broadcast(&s->changed);
        pthread_mutex_unlock(&s->lock);
        pthread_join(s->worker, NULL);
        pthread_mutex_destroy(&s->lock);
        pthread_cond_destroy(&s->changed);
    }
    for (int i = 0; i < 5; i++) free(s->blocks[i]);
    free(s->iw);
    free(s->work);
    free(s);
}

/* mode: 0 speed_abs, 1 speed, 2 balance, 3 robust (enum hpipm_mode); ric_alg (0 classical Riccati, 1 square
 * root), pred_corr (0/1), mu0 (> 0) and residual_exit (0/1: stop on the residuals, not only on the duality
 * measure) override the mode's defaults when not negative. mu0_warm (> 0): the initial barrier parameter of a
 * warm-started solve that follows one of at most 2 iterations (docs/mpc.md 3.8). NULL if a size is out of
 * range or memory runs out. */
mpc_rti *mpc_rti_create(int horizon, int nbx, const int *idxbx, int nbu, const int *idxbu, double yaw_offset,
                        int mode, int iter_max, double tol_stat, double tol_eq, double tol_ineq, double tol_comp,
                        int warm_start, int ric_alg, int pred_corr, double mu0, int residual_exit,
                        double mu0_warm) {
    if (horizon < 1 || nbx < 0 || nbx > NX || nbu < 0 || nbu > NU) return NULL;
    casadi_int sz_arg, sz_res, sz_iw, sz_w, t_arg, t_res, t_iw, t_w;
    mpc_stage_work(&sz_arg, &sz_res, &sz_iw, &sz_w);
    mpc_terminal_work(&t_arg, &t_res, &t_iw, &t_w);
    if (sz_arg > STAGE_WORK || sz_res > STAGE_WORK || t_arg > STAGE_WORK || t_res > STAGE_WORK) return NULL;
    mpc_rti *s = calloc(1, sizeof(mpc_rti));
    if (s == NULL) return NULL;
    s->horizon = horizon;
    s->nbx = nbx;
    s->nbu = nbu;
    memcpy(s->idxbx, idxbx, sizeof(int) * (size_t)nbx);
    memcpy(s->idxbu, idxbu, sizeof(int) * (size_t)nbu);
    s->yaw_offset = yaw_offset;
    s->iw = malloc(sizeof(casadi_int) * (size_t)(1 + (sz_iw > t_iw ? sz_iw : t_iw)));
    s->work = malloc(sizeof(casadi_real) * (size_t)(1 + (sz_w > t_w ? sz_w : t_w)));
    int n = horizon;
    s->blocks[0] = aligned(d_ocp_qp_dim_memsize(n));
    if (s->iw == NULL || s->work == NULL || s->blocks[0] == NULL) goto fail;
    d_ocp_qp_dim_create(n, &s->dim, s->blocks[0]);
    for (int k = 0; k <= n; k++) {
        d_ocp_qp_dim_set_nx(k, k == 0 ? 0 : NX, &s->dim);
        d_ocp_qp_dim_set_nu(k, k == n ? 0 : NU, &s->dim);
        d_ocp_qp_dim_set_nbx(k, k == 0 ? 0 : nbx, &s->dim);
        d_ocp_qp_dim_set_nbu(k, k == n ? 0 : nbu, &s->dim);
        d_ocp_qp_dim_set_ng(k, k == n ? 0 : 1, &s->dim);
    }
    s->blocks[1] = aligned(d_ocp_qp_memsize(&s->dim));
    s->blocks[2] = aligned(d_ocp_qp_sol_memsize(&s->dim));
    s->blocks[3] = aligned(d_ocp_qp_ipm_arg_memsize(&s->dim));
    if (s->blocks[1] == NULL || s->blocks[2] == NULL || s->blocks[3] == NULL) goto fail;
    d_ocp_qp_create(&s->dim, &s->qp, s->blocks[1]);
    d_ocp_qp_sol_create(&s->dim, &s->sol, s->blocks[2]);
    d_ocp_qp_ipm_arg_create(&s->dim, &s->arg, s->blocks[3]);
    d_ocp_qp_ipm_arg_set_default((enum hpipm_mode)mode, &s->arg);
    d_ocp_qp_ipm_arg_set_iter_max(&iter_max, &s->arg);
    d_ocp_qp_ipm_arg_set_tol_stat(&tol_stat, &s->arg);
    d_ocp_qp_ipm_arg_set_tol_eq(&tol_eq, &s->arg);
    d_ocp_qp_ipm_arg_set_tol_ineq(&tol_ineq, &s->arg);
    d_ocp_qp_ipm_arg_set_tol_comp(&tol_comp, &s->arg);
    d_ocp_qp_ipm_arg_set_warm_start(&warm_start, &s->arg);
    s->warm_start = warm_start;
    s->cold_next = 1;
    if (ric_alg >= 0) d_ocp_qp_ipm_arg_set_ric_alg(&ric_alg, &s->arg);
    if (pred_corr >= 0) d_ocp_qp_ipm_arg_set_pred_corr(&pred_corr, &s->arg);
    if (mu0 > 0) d_ocp_qp_ipm_arg_set_mu0(&mu0, &s->arg);
    s->mu0 = s->arg.mu0;
    s->mu0_warm = mu0_warm;
    if (residual_exit >= 0) { /* in the absolute form, the dual of the equalities is needed for the residuals */
        d_ocp_qp_ipm_arg_set_comp_dual_sol_eq(&residual_exit, &s->arg);
        d_ocp_qp_ipm_arg_set_comp_res_exit(&residual_exit, &s->arg);
    }
    s->blocks[4] = aligned(d_ocp_qp_ipm_ws_memsize(&s->dim, &s->arg));
    if (s->blocks[4] == NULL) goto fail;
    d_ocp_qp_ipm_ws_create(&s->dim, &s->arg, &s->ws, s->blocks[4]);

    /* The structure that does not change: the yaw row's C and D, the box bounds' indices. */
    double c_row[NX] = {0}, d_row[NU] = {0};
    c_row[YAW_STATE] = -1.0;
    d_row[YAW_INPUT] = 1.0;
    for (int k = 0; k <= n; k++) {
        if (k > 0) d_ocp_qp_set_idxbx(k, s->idxbx, &s->qp);
        if (k < n) {
            d_ocp_qp_set_idxbu(k, s->idxbu, &s->qp);
            if (k > 0) d_ocp_qp_set_C(k, c_row, &s->qp);
            d_ocp_qp_set_D(k, d_row, &s->qp);
        }
    }
    return s;
fail:
    mpc_rti_free(s);
    return NULL;
}

/* Marquardt's damping H + levenberg diag(H) + 1e-6 I (autopilot/mpc.py), on an n x n column-major block. */
static void damp(double *h, int n, double levenberg) {
    for (int i = 0; i < n; i++) h[i * n + i] += levenberg * h[i * n + i] + 1e-6;
}

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void set_bounds(mpc_rti *s, int k, const double *w, const double *lbw, const double *ubw) {
    double lo[NZ], hi[NZ];
    const int base = k * NZ;
    if (k > 0) {
        for (int i = 0; i < s->nbx; i++) {
            int j = base + s->idxbx[i];
            lo[i] = lbw[j] - w[j];
            hi[i] = ubw[j] - w[j];
        }
        d_ocp_qp_set_lbx(k, lo, &s->qp);
        d_ocp_qp_set_ubx(k, hi, &s->qp);
    }
    if (k < s->horizon) {
        for (int i = 0; i < s->nbu; i++) {
            int j = base + NX + s->idxbu[i];
            lo[i] = lbw[j] - w[j];
            hi[i] = ubw[j] - w[j];
        }
        d_ocp_qp_set_lbu(k, lo, &s->qp);
        d_ocp_qp_set_ubu(k, hi, &s->qp);
    }
}

/* One RTI: the QP at the guess w, solved. Writes the step dw (same layout as w) and
 * info = [cost at w, iterations, res_stat, res_eq, res_ineq, res_comp, seconds building the QP, seconds in HPIPM];
 * returns HPIPM's status (0 = solved). */
static int solve_one(mpc_rti *s, const double *w, const double *P, const double *x0, const double *lbw,
                     const double *ubw, double levenberg, double *dw, double *info) {
    const int n = s->horizon;
    double dx0[NX], gap[NX], A[NX * NX], B[NX * NU], H[NZ * NZ], g[NZ], cost, total = 0.0;
    double Q[NX * NX], S[NU * NX], R[NU * NU], lg, ug;
    const casadi_real *arg[STAGE_WORK];
    casadi_real *res[STAGE_WORK];
    const double started = now();
    for (int i = 0; i < NX; i++) dx0[i] = x0[i] - w[i];
    for (int k = 0; k < n; k++) {
        const double *xk = w + k * NZ, *uk = xk + NX;
        arg[0] = xk;
        arg[1] = uk;
        arg[2] = w + (k + 1) * NZ;
        arg[3] = P + k * NP;
        res[0] = gap;
        res[1] = A;
        res[2] = B;
        res[3] = H;
        res[4] = g;
        res[5] = &cost;
        mpc_stage(arg, res, s->iw, s->work, 0);
        total += cost;
        damp(H, NZ, levenberg);
        for (int j = 0; j < NX; j++) {
            for (int i = 0; i < NX; i++) Q[j * NX + i] = H[j * NZ + i];
            for (int i = 0; i < NU; i++) S[j * NU + i] = H[j * NZ + NX + i];
        }
        for (int j = 0; j < NU; j++)
            for (int i = 0; i < NU; i++) R[j * NU + i] = H[(NX + j) * NZ + NX + i];
        double offset = uk[YAW_INPUT] - xk[YAW_STATE];
        lg = -s->yaw_offset - offset;
        ug = s->yaw_offset - offset;
        double *r = g + NX;
        if (k == 0) { /* dx0 is fixed: eliminated */
            for (int j = 0; j < NX; j++) {
                for (int i = 0; i < NX; i++) gap[i] += A[j * NX + i] * dx0[j];
                for (int i = 0; i < NU; i++) r[i] += S[j * NU + i] * dx0[j];
            }
            lg += dx0[YAW_STATE];
            ug += dx0[YAW_STATE];
        } else {
            d_ocp_qp_set_A(k, A, &s->qp);
            d_ocp_qp_set_Q(k, Q, &s->qp);
            d_ocp_qp_set_S(k, S, &s->qp);
            d_ocp_qp_set_q(k, g, &s->qp);
        }
        d_ocp_qp_set_B(k, B, &s->qp);
        d_ocp_qp_set_b(k, gap, &s->qp);
        d_ocp_qp_set_R(k, R, &s->qp);
        d_ocp_qp_set_r(k, r, &s->qp);
        d_ocp_qp_set_lg(k, &lg, &s->qp);
        d_ocp_qp_set_ug(k, &ug, &s->qp);
        set_bounds(s, k, w, lbw, ubw);
    }
    arg[0] = w + n * NZ;
    arg[1] = P + n * NP;
    res[0] = Q;
    res[1] = g;
    res[2] = &cost;
    mpc_terminal(arg, res, s->iw, s->work, 0);
    total += cost;
    damp(Q, NX, levenberg);
    d_ocp_qp_set_Q(n, Q, &s->qp);
    d_ocp_qp_set_q(n, g, &s->qp);
    set_bounds(s, n, w, lbw, ubw);

    const double built = now();
    int warm_start = s->cold_next ? 0 : s->warm_start;
    d_ocp_qp_ipm_arg_set_warm_start(&warm_start, &s->arg);
    /* Started from the previous plan in a steady phase, the barrier starts low: one iteration instead of two.
     * Where bounds come and go (the previous solve needed more), a low start takes many short steps. */
    double mu0 = warm_start && s->mu0_warm > 0 && s->last_iterations <= 2 ? s->mu0_warm : s->mu0;
    d_ocp_qp_ipm_arg_set_mu0(&mu0, &s->arg);
    d_ocp_qp_ipm_solve(&s->qp, &s->sol, &s->arg, &s->ws);
    info[6] = built - started;
    info[7] = now() - built;
    int status, iterations;
    d_ocp_qp_ipm_get_status(&s->ws, &status);
    d_ocp_qp_ipm_get_iter(&s->ws, &iterations);
    memcpy(dw, dx0, sizeof(dx0));
    for (int k = 0; k < n; k++) d_ocp_qp_sol_get_u(k, &s->sol, dw + k * NZ + NX);
    for (int k = 1; k <= n; k++) d_ocp_qp_sol_get_x(k, &s->sol, dw + k * NZ);
    int finite = 1;
    for (int i = 0; i < n * NZ + NX; i++) finite &= isfinite(dw[i]) != 0;
    s->cold_next = status != 0 || !finite;
    s->last_iterations = iterations;
    info[0] = total;
    info[1] = iterations;
    d_ocp_qp_ipm_get_max_res_stat(&s->ws, info + 2);
    d_ocp_qp_ipm_get_max_res_eq(&s->ws, info + 3);
    d_ocp_qp_ipm_get_max_res_ineq(&s->ws, info + 4);
    d_ocp_qp_ipm_get_max_res_comp(&s->ws, info + 5);
    return status;
}

/* The Gauss-Newton steps of one tick: `steps` QPs at the same x0, w += dw after each one that succeeded (status 0
 * and a finite step); stops at the first that did not. info as mpc_rti_solve's for the last QP, and info[8] the
 * QP iterations of all steps, info[9] the wall time of all steps (s), info[10] 1 if the last step succeeded. */
static int iterate(mpc_rti *s, double *w, const double *P, const double *x0, const double *lbw, const double *ubw,
                   double levenberg, int steps, double *dw, double *info) {
    const double started = now();
    const int n_w = s->horizon * NZ + NX;
    double iterations = 0.0;
    int status = 0, ok = 0;
    for (int step = 0; step < steps; step++) {
        status = solve_one(s, w, P, x0, lbw, ubw, levenberg, dw, info);
        iterations += info[1];
        ok = !s->cold_next; /* status 0 and a finite step */
        if (!ok) break;
        for (int i = 0; i < n_w; i++) w[i] += dw[i];
    }
    info[8] = iterations;
    info[9] = now() - started;
    info[10] = ok;
    return status;
}

/* One QP (the step in dw), and the steps of a tick (w moved), here and now; BUSY while a started solve runs. */
int mpc_rti_solve(mpc_rti *s, const double *w, const double *P, const double *x0, const double *lbw,
                  const double *ubw, double levenberg, double *dw, double *info) {
    return s->busy ? BUSY : solve_one(s, w, P, x0, lbw, ubw, levenberg, dw, info);
}

int mpc_rti_iterate(mpc_rti *s, double *w, const double *P, const double *x0, const double *lbw, const double *ubw,
                    double levenberg, int steps, double *dw, double *info) {
    return s->busy ? BUSY : iterate(s, w, P, x0, lbw, ubw, levenberg, steps, dw, info);
}

static void *work(void *arg) {
    mpc_rti *s = arg;
    pthread_mutex_lock(&s->lock);
    for (;;) {
        while (!s->pending && !s->quit) pthread_cond_wait(&s->changed, &s->lock);
        if (s->quit) break;
        s->pending = 0;
        rti_job *j = &s->job;
        pthread_mutex_unlock(&s->lock);
        int status = iterate(s, j->w, j->P, j->x0, j->lbw, j->ubw, j->levenberg, j->steps, j->dw, j->info);
        pthread_mutex_lock(&s->lock);
        j->status = status;
        s->done = 1;
        pthread_cond_broadcast(&s->changed);
    }
    pthread_mutex_unlock(&s->lock);
    return NULL;
}

/* mpc_rti_iterate on the worker thread; 0, BUSY if a started solve has not been waited for, or -1 if the thread
 * cannot be started (nothing was started then). The worker blocks every signal: they stay the caller's. */
int mpc_rti_start(mpc_rti *s, double *w, const double *P, const double *x0, const double *lbw, const double *ubw,
                  double levenberg, int steps, double *dw, double *info) {
    if (s->busy) return BUSY;
    if (!s->worker_started) {
        if (pthread_mutex_init(&s->lock, NULL) != 0) return -1;
        if (pthread_cond_init(&s->changed, NULL) != 0) {
            pthread_mutex_destroy(&s->lock);
            return -1;
        }
        sigset_t all, previous;
        sigfillset(&all);
        pthread_sigmask(SIG_SETMASK, &all, &previous);
        int failed = pthread_create(&s->worker, NULL, work, s) != 0;
        pthread_sigmask(SIG_SETMASK, &previous, NULL);
        if (failed) {
            pthread_cond_destroy(&s->changed);
            pthread_mutex_destroy(&s->lock);
            return -1;
        }
        s->worker_started = 1;
    }
    s->busy = 1;
    pthread_mutex_lock(&s->lock);
    s->job = (rti_job){w, dw, info, P, x0, lbw, ubw, levenberg, steps, 0};
    s->done = 0;
    s->pending = 1;
    pthread_cond_broadcast(&s->changed);
    pthread_mutex_unlock(&s->lock);
    return 0;
}

/* Wait for the steps mpc_rti_start handed on; their status (mpc_rti_iterate's), -1 if none was started. */
int mpc_rti_wait(mpc_rti *s) {
    if (!s->busy) return -1;
    pthread_mutex_lock(&s->lock);
    while (!s->done) pthread_cond_wait(&s->changed, &s->lock);
    s->done = 0;
    int status = s->job.status;
    pthread_mutex_unlock(&s->lock);
    s->busy = 0;
    return status;
}
