/* The planar pendulum through holosym's C interface (include/holosym.h).
 *
 * q = (x, y), H = |p|^2/2 + y, phi = x^2 + y^2 - 1, released at rest from 1 rad. The
 * program integrates 10 s with (M, N, G) = (3, 2, 4), h = 1/16, prints the state every
 * 2 s from an observer (with the dense output in the middle of that step), checks energy
 * and constraint, then feeds the interface bad input and checks each status and message.
 * It exits with status 1 when a check fails.
 *
 * Build and run: `make c-example` (the real128 library and gcc; -DHOLOSYM_REAL64 with the
 * real64 library). Output (real128):
 *
 *     t =  2.000  x = -0.3014385  y = -0.9534856  x~(t - h/2) = -0.2740968
 *     t =  4.000  x = -0.7350684  y = -0.6779929  x~(t - h/2) = -0.7458472
 *     t =  6.000  x =  0.7164068  y = -0.6976828  x~(t - h/2) =  0.7038183
 *     t =  8.000  x =  0.3440492  y = -0.9389516  x~(t - h/2) =  0.3699520
 *     t = 10.000  x = -0.8409031  y = -0.5411857  x~(t - h/2) = -0.8399689
 *     after 160 steps: |H - H0|/|H0| = 2.3e-14, |phi| = 0.0e+00
 *     checks: 9 of 9 passed
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "holosym.h"

#ifdef HOLOSYM_REAL64
#define TO_DOUBLE(x) ((double)(x))
static const double round_off = 1e-13;
#else
#include <quadmath.h>
#define TO_DOUBLE(x) ((double)(x))
static const double round_off = 1e-30;
#endif

static int hamiltonian(int n, const holosym_real *q, const holosym_real *p,
                       holosym_real *energy, void *data) {
    (void)n;
    (void)data;
    *energy = (p[0] * p[0] + p[1] * p[1]) / 2 + q[1];
    return 0;
}

static int dh_dq(int n, const holosym_real *q, const holosym_real *p, holosym_real *g,
                 void *data) {
    (void)n;
    (void)q;
    (void)p;
    (void)data;
    g[0] = 0;
    g[1] = 1;
    return 0;
}

static int dh_dp(int n, const holosym_real *q, const holosym_real *p, holosym_real *g,
                 void *data) {
    (void)n;
    (void)q;
    (void)data;
    g[0] = p[0];
    g[1] = p[1];
    return 0;
}

static int constraint(int n, int m, const holosym_real *q, holosym_real *phi, void *data) {
    (void)n;
    (void)m;
    (void)data;
    phi[0] = q[0] * q[0] + q[1] * q[1] - 1;
    return 0;
}

/* Row-major m x n: jac[l*n + i] = d phi_l / d q_i. */
static int constraint_jacobian(int n, int m, const holosym_real *q, holosym_real *jac,
                               void *data) {
    (void)n;
    (void)m;
    (void)data;
    jac[0] = 2 * q[0];
    jac[1] = 2 * q[1];
    return 0;
}

/* A potential that refuses to be evaluated beyond y > *limit (for the failure check). */
static int picky_dh_dq(int n, const holosym_real *q, const holosym_real *p, holosym_real *g,
                       void *data) {
    const holosym_real *limit = data;
    if (q[1] > *limit) return 42;
    return dh_dq(n, q, p, g, data);
}

/* Every 32nd step: the state and x~ in the middle of the step just taken. */
static int observer(holosym_integrator *integrator, int step, holosym_real t,
                    const holosym_real *q, const holosym_real *p, void *data) {
    holosym_real qd[2], pd[2], lambda[1];
    (void)p;
    (void)data;
    if (step % 32 != 0) return 0;
    if (holosym_dense_output(integrator, 0.5, qd, pd, lambda) != HOLOSYM_SUCCESS) return 1;
    printf("t = %6.3f  x = %10.7f  y = %10.7f  x~(t - h/2) = %10.7f\n", TO_DOUBLE(t),
           TO_DOUBLE(q[0]), TO_DOUBLE(q[1]), TO_DOUBLE(qd[0]));
    return 0;
}

static int passed = 0, failed = 0;

static void expect(int condition, const char *what, holosym_integrator *integrator) {
    char message[512];
    if (condition) {
        passed++;
        return;
    }
    failed++;
    holosym_message(integrator, message, (int)sizeof message);
    printf("FAILED: %s (status %d: %s)\n", what, holosym_status(integrator), message);
}

int main(void) {
    holosym_system system = {2, 1, hamiltonian, dh_dq, dh_dp, constraint, constraint_jacobian,
                             NULL};
    holosym_real q[2], p[2] = {0, 0}, q0[2], energy0, energy, phi[1], h = 1.0 / 16;
    holosym_real q_before[2], p_before[2], lambda[1], limit = -0.9;
    char message[512];
    int steps_done = 0, status;
    holosym_integrator *integrator, *broken;

#ifdef HOLOSYM_REAL64
    q[0] = sin(1.0);
    q[1] = -cos(1.0);
#else
    q[0] = sinq(1.0Q);
    q[1] = -cosq(1.0Q);
#endif
    memcpy(q0, q, sizeof q);
    hamiltonian(2, q, p, &energy0, NULL);

    integrator = holosym_create(&system, 3, 2, 4);
    if (holosym_status(integrator) != HOLOSYM_SUCCESS) {
        holosym_message(integrator, message, (int)sizeof message);
        printf("create failed: %s\n", message);
        return 1;
    }
    status = holosym_integrate(integrator, q, p, h, 160, observer, NULL, &steps_done);
    if (status != HOLOSYM_SUCCESS) {
        holosym_message(integrator, message, (int)sizeof message);
        printf("integrate failed after %d steps: %s\n", steps_done, message);
        return 1;
    }
    hamiltonian(2, q, p, &energy, NULL);
    constraint(2, 1, q, phi, NULL);
    printf("after %d steps: |H - H0|/|H0| = %.1e, |phi| = %.1e\n", steps_done,
           fabs(TO_DOUBLE((energy - energy0) / energy0)), fabs(TO_DOUBLE(phi[0])));
    expect(steps_done == 160, "160 steps", integrator);
    expect(fabs(TO_DOUBLE((energy - energy0) / energy0)) < 1e-8, "energy error", integrator);
    expect(fabs(TO_DOUBLE(phi[0])) < round_off, "constraint at round-off", integrator);

    /* Bad input: status, message, arrays unchanged. */
    memcpy(q_before, q, sizeof q);
    memcpy(p_before, p, sizeof p);
    status = holosym_step(integrator, q, p, -1);
    expect(status == HOLOSYM_INVALID_STEP_SIZE && memcmp(q, q_before, sizeof q) == 0 &&
               memcmp(p, p_before, sizeof p) == 0,
           "negative step size rejected, state unchanged", integrator);
    holosym_message(integrator, message, (int)sizeof message);
    expect(strstr(message, "step size") != NULL, "message names the step size", integrator);
    expect(holosym_dense_output(integrator, 2, q, p, lambda) == HOLOSYM_INVALID_ARGUMENT,
           "tau = 2 rejected", integrator);

    system.dh_dq = NULL;
    broken = holosym_create(&system, 3, 2, 4);
    expect(holosym_status(broken) == HOLOSYM_INVALID_ARGUMENT &&
               holosym_step(broken, q, p, h) == HOLOSYM_NOT_INITIALIZED,
           "NULL callback rejected", broken);
    holosym_destroy(broken);

    system.dh_dq = picky_dh_dq;
    system.data = &limit;
    broken = holosym_create(&system, 3, 2, 4);
    memcpy(q, q0, sizeof q);
    p[0] = p[1] = 0;
    status = holosym_integrate(broken, q, p, h, 160, NULL, NULL, &steps_done);
    holosym_message(broken, message, (int)sizeof message);
    expect(status == HOLOSYM_OUTSIDE_DOMAIN && strstr(message, "dh_dq returned 42") != NULL,
           "a failing callback is reported by name", broken);
    holosym_destroy(broken);

    expect(holosym_create(NULL, 3, 2, 4) == NULL, "NULL system gives NULL", integrator);
    printf("checks: %d of %d passed\n", passed, passed + failed);
    holosym_destroy(integrator);
    return failed == 0 ? 0 : 1;
}
