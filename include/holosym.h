/* holosym: C interface (src/capi/holosym_c.F90).
 *
 * Symplectic integration of a Hamiltonian system with holonomic constraints, given by C
 * callbacks (H(q, p), dH/dq, dH/dp, phi(q) and Phi(q) = dphi/dq: holosym_create) or by the
 * text of a model file, which the library differentiates itself (holosym_model_create).
 *
 * Reals: holosym_real is __float128 in the default (real128) build of the library and
 * double when both the library and the C code are built with -DHOLOSYM_REAL64.
 * __float128 is a compiler extension: GCC documents it for i386, x86-64, IA-64, LoongArch,
 * hppa HP-UX and PowerPC GNU/Linux with VSX (older GCC there: -mfloat128); Clang accepts it
 * on x86-64 too (only GCC is tested here). libquadmath (quadmath.h, -lquadmath) prints and
 * computes with it. The Fortran side uses gfortran's c_float128 (a GNU extension of
 * ISO_C_BINDING), so the real128 library is built with gfortran.
 *
 * Every function returns a status code (also kept by the handle: holosym_status,
 * holosym_message): 0 success, < 0 invalid input, > 0 numerical failure. On failure the
 * caller's arrays are unchanged (holosym_integrate: they hold the last good step). The
 * codes are the library's table (status_code_table in src/core/holosym_status_codes.f90;
 * the test suite compares this header with it).
 *
 * Pointers: every array argument is checked (NULL: HOLOSYM_INVALID_ARGUMENT naming the
 * function and the argument); a message buffer may be NULL (nothing is copied). Handles are
 * looked up among the live ones before use: NULL, a destroyed handle or a pointer the
 * library did not return is HOLOSYM_NOT_INITIALIZED and is never read, and destroying it is
 * ignored. What no check can see: arrays shorter than n (or m), and a handle destroyed
 * while one of its calls runs (e.g. from its own observer).
 *
 * Link: -lholosym -lgfortran -lquadmath -llapack -lblas -lgomp -lm (see `make c-example`).
 */
#ifndef HOLOSYM_H
#define HOLOSYM_H

#ifdef __cplusplus
extern "C" {
#endif

#ifdef HOLOSYM_REAL64
typedef double holosym_real;
#else
typedef __float128 holosym_real;
#endif

/* Status codes (the HOLOSYM_* constants of the Fortran library). */
#define HOLOSYM_SUCCESS 0
#define HOLOSYM_INVALID_ORDER (-1)              /* M < 1, N < 0, G < 1 or G < N + 1 */
#define HOLOSYM_INVALID_DIMENSION (-2)          /* n < 1, m < 0 or m >= n */
#define HOLOSYM_SIZE_MISMATCH (-3)
#define HOLOSYM_INVALID_STEP_SIZE (-4)          /* h <= 0 or not finite */
#define HOLOSYM_INVALID_STEP_COUNT (-5)         /* steps < 0 */
#define HOLOSYM_OFF_MANIFOLD (-6)               /* start state violates phi or Phi H_p */
#define HOLOSYM_USER_ABORT (-7)                 /* the observer returned nonzero */
#define HOLOSYM_NOT_INITIALIZED (-8)            /* NULL, destroyed or foreign handle, failed
                                                   create, no step yet */
#define HOLOSYM_INVALID_ARGUMENT (-9)           /* NULL callback or array, NaN input, tau not
                                                   in [0,1] */
#define HOLOSYM_INVALID_MODEL (-10)             /* model text refused: "model:LINE:COLUMN: ..." */
#define HOLOSYM_INCONSISTENT_SYSTEM (-11)       /* callbacks disagree (e.g. Phi with phi) */
#define HOLOSYM_SINGULAR_MATRIX 1
#define HOLOSYM_NEWTON_NOT_CONVERGED 2
#define HOLOSYM_NEWTON_DIVERGED 3
#define HOLOSYM_NONFINITE_VALUE 4               /* a callback returned NaN or Inf */
#define HOLOSYM_RANK_DEFICIENT_CONSTRAINTS 5
#define HOLOSYM_STEP_TOO_LARGE 6                /* spurious root, unresolved motion, h huge */
#define HOLOSYM_STEP_TOO_SMALL 7                /* h below the resolution of the state */
#define HOLOSYM_OUTSIDE_DOMAIN 8                /* a callback returned nonzero (refused) */

/* Callbacks: return 0 on success; anything else says the point is outside the domain of
 * the system and fails the call that needed the value with HOLOSYM_OUTSIDE_DOMAIN (the
 * message names the callback and the value returned; the caller's arrays are unchanged). */
typedef int (*holosym_hamiltonian_fn)(int n, const holosym_real *q, const holosym_real *p,
                                      holosym_real *energy, void *data);
/* dH/dq or dH/dp into gradient[0..n-1]. */
typedef int (*holosym_gradient_fn)(int n, const holosym_real *q, const holosym_real *p,
                                   holosym_real *gradient, void *data);
/* phi(q) into values[0..m-1]; or Phi(q) row-major: values[l*n + i] = d phi_l / d q_i. */
typedef int (*holosym_constraint_fn)(int n, int m, const holosym_real *q, holosym_real *values,
                                     void *data);

/* The system: sizes, callbacks (none may be NULL) and the user data they receive. */
typedef struct holosym_system {
    int n; /* coordinates q and momenta p, n >= 1 */
    int m; /* constraints, 0 <= m < n */
    holosym_hamiltonian_fn hamiltonian;
    holosym_gradient_fn dh_dq;
    holosym_gradient_fn dh_dp;
    holosym_constraint_fn constraint;
    holosym_constraint_fn constraint_jacobian;
    void *data;
} holosym_system;

/* An integrator: opaque. */
typedef struct holosym_integrator holosym_integrator;

/* Called after each step of holosym_integrate with the new state; return nonzero to stop.
 * Inside it, holosym_dense_output(integrator, tau, ...) evaluates the step just taken. */
typedef int (*holosym_observer_fn)(holosym_integrator *integrator, int step, holosym_real t,
                                   const holosym_real *q, const holosym_real *p, void *data);

/* A handle for the system and the scheme (M, N, G) (e.g. 2, 1, 3: order 4). NULL only for
 * a NULL system; otherwise check holosym_status (the handle of a failed create answers
 * every call with HOLOSYM_NOT_INITIALIZED). The callbacks are kept, the struct is not. */
holosym_integrator *holosym_create(const holosym_system *system, int M, int N, int G);

/* Free the handle (NULL, a handle destroyed already and a pointer that is no handle are
 * ignored). */
void holosym_destroy(holosym_integrator *integrator);

/* The status code of the last call on the handle. */
int holosym_status(const holosym_integrator *integrator);

/* Copy the last call's message into buffer (NUL-terminated, at most size - 1 characters;
 * nothing when buffer is NULL or size < 1); returns its full length. */
int holosym_message(const holosym_integrator *integrator, char *buffer, int size);

/* One step of size h, q[n] and p[n] in place. */
int holosym_step(holosym_integrator *integrator, holosym_real *q, holosym_real *p,
                 holosym_real h);

/* steps steps of size h in place; observer and steps_done may be NULL. */
int holosym_integrate(holosym_integrator *integrator, holosym_real *q, holosym_real *p,
                      holosym_real h, int steps, holosym_observer_fn observer,
                      void *observer_data, int *steps_done);

/* q~(tau), p~(tau), lambda~(tau) of the last step, tau in [0, 1] (lambda: m values, may be
 * NULL when m = 0). */
int holosym_dense_output(const holosym_integrator *integrator, holosym_real tau,
                         holosym_real *q, holosym_real *p, holosym_real *lambda);

/* Project (q, p) onto the constraint manifold {phi = 0, Phi dH/dp = 0} in place. */
int holosym_project(holosym_integrator *integrator, holosym_real *q, holosym_real *p);

/* The system's numbers of coordinates n and constraints m (either pointer may be NULL). */
int holosym_sizes(const holosym_integrator *integrator, int *n, int *m);

/* ---- Systems from formulas (docs/models.md has the grammar) ---- */

/* A handle for the system of a model text (lines separated by '\n', NUL-terminated) and
 * the scheme (M, N, G): the library derives the gradients, second derivatives, sparsity and
 * structure itself. NULL only for a NULL text; otherwise check holosym_status:
 * HOLOSYM_INVALID_MODEL with "model:LINE:COLUMN: what is wrong" for a text refused. */
holosym_integrator *holosym_model_create(const char *model, int M, int N, int G);

/* Set a parameter of the model by name (the integrator is set up again: masses may change);
 * HOLOSYM_INVALID_ARGUMENT for an unknown name or a value that is not finite. */
int holosym_model_set_parameter(holosym_integrator *integrator, const char *name,
                                holosym_real value);

/* The value of a parameter of the model. */
int holosym_model_get_parameter(holosym_integrator *integrator, const char *name,
                                holosym_real *value);

/* The initial state the model states (q[n], p[n]), with the current parameters, velocities
 * turned into momenta and projected onto the constraint manifold when off it (the message
 * then says so). HOLOSYM_INVALID_ARGUMENT when the model states none. */
int holosym_model_initial_state(holosym_integrator *integrator, holosym_real *q,
                                holosym_real *p);

/* Number of the model's parameters (negative: a status code, e.g. not a model). */
int holosym_model_parameter_count(holosym_integrator *integrator);

/* What holosym_model_name names. */
#define HOLOSYM_NAME_PARAMETER 0
#define HOLOSYM_NAME_COORDINATE 1
#define HOLOSYM_NAME_MOMENTUM 2

/* The name of parameter, coordinate or momentum `index` (from 1) into buffer
 * (NUL-terminated, at most size - 1 characters); returns its full length, or a negative
 * status code. */
int holosym_model_name(holosym_integrator *integrator, int what, int index, char *buffer,
                       int size);


/* ---- Reals through pointers, H and phi at a state ----
 * The same calls with every real scalar passed through a pointer (for callers that cannot
 * pass a __float128 by value, e.g. Python's ctypes, which has no such type). A NULL pointer
 * is HOLOSYM_INVALID_ARGUMENT naming the function and the argument ("holosym_step_p: h is
 * NULL"); otherwise the codes and messages are those of the call without _p. */

/* The observer of holosym_integrate_p: t through a pointer. */
typedef int (*holosym_observer_p_fn)(holosym_integrator *integrator, int step,
                                     const holosym_real *t, const holosym_real *q,
                                     const holosym_real *p, void *data);

int holosym_step_p(holosym_integrator *integrator, holosym_real *q, holosym_real *p,
                   const holosym_real *h);
int holosym_integrate_p(holosym_integrator *integrator, holosym_real *q, holosym_real *p,
                        const holosym_real *h, int steps, holosym_observer_p_fn observer,
                        void *observer_data, int *steps_done);
int holosym_dense_output_p(const holosym_integrator *integrator, const holosym_real *tau,
                           holosym_real *q, holosym_real *p, holosym_real *lambda);
int holosym_model_set_parameter_p(holosym_integrator *integrator, const char *name,
                                  const holosym_real *value);

/* H(q, p) of the handle's system into *energy (HOLOSYM_NONFINITE_VALUE when it is not
 * finite: *energy unchanged). */
int holosym_energy(holosym_integrator *integrator, const holosym_real *q,
                   const holosym_real *p, holosym_real *energy);

/* The constraint values phi(q) into phi[0..m-1] (phi may be NULL when m = 0;
 * HOLOSYM_NONFINITE_VALUE when one is not finite: phi unchanged). */
int holosym_constraint(holosym_integrator *integrator, const holosym_real *q,
                       holosym_real *phi);

/* Set the integrator up for an error *tolerance (max |error| of q and p) at time *T from
 * (q, p): holosym chooses M, N, G (into orders[0..2] unless orders is NULL), the step *h,
 * the *steps to T and the Newton tolerance from a pilot (docs/accuracy.md); then
 * holosym_integrate(integrator, q, p, *h, *steps, ...). On failure the integrator keeps
 * its set-up and the outputs are unchanged. */
int holosym_plan_accuracy(holosym_integrator *integrator, const holosym_real *q,
                          const holosym_real *p, const holosym_real *tolerance,
                          const holosym_real *T, holosym_real *h, int *steps, int *orders);

/* ---- Events (docs/events.md) ---- */

/* Event function k (1..count) at (t, q, p) into *value; return 0, or non-zero where it
 * cannot be evaluated (the run then stops with HOLOSYM_NONFINITE_VALUE). */
typedef int (*holosym_event_fn)(int k, const holosym_real *t, const holosym_real *q,
                                const holosym_real *p, holosym_real *value, void *data);
/* Receives a located event: function k, direction +1 (g rose through zero) or -1, its
 * time, state and multipliers (lambda has m values; one unused value when m = 0). Return
 * non-zero to receive no further events. */
typedef int (*holosym_event_found_fn)(int k, int direction, const holosym_real *t,
                                      const holosym_real *q, const holosym_real *p,
                                      const holosym_real *lambda, void *data);

/* Directions of the crossings wanted, per event function (directions[k - 1]). */
#define HOLOSYM_EVENT_ANY 0
#define HOLOSYM_EVENT_RISING 1
#define HOLOSYM_EVENT_FALLING (-1)

/* steps steps of size *h in place as holosym_integrate, locating the zero crossings of
 * the count event functions g within each step to the accuracy of the scheme's steps;
 * directions and terminal (non-zero: a crossing ends the run at the event) hold count
 * values each, or are NULL (HOLOSYM_EVENT_ANY, not terminal). After the run the events
 * go to found (may be NULL) in time order; *stopped (may be NULL) is 1 when a terminal
 * event ended the run, q and p then hold the state at the event. Reals through pointers
 * in both builds. */
int holosym_integrate_events(holosym_integrator *integrator, holosym_real *q,
                             holosym_real *p, const holosym_real *h, int steps, int count,
                             holosym_event_fn g, const int *directions, const int *terminal,
                             holosym_event_found_fn found, void *data, int *steps_done,
                             int *stopped);

/* The Lyapunov spectrum and MEGNO of the orbit from (q, p) on the constraint manifold
 * over steps steps of *h (docs/events.md): 2(n - m) exponents, largest first, into
 * exponents, the mean MEGNO <Y> into *megno. q and p end at the state after the steps
 * taken, also on failure (exponents and megno then cover the steps before it, and are
 * untouched when no step was taken); *steps_done (may be NULL) counts them. Reals
 * through pointers in both builds. */
int holosym_lyapunov_spectrum(holosym_integrator *integrator, holosym_real *q,
                              holosym_real *p, const holosym_real *h, int steps,
                              holosym_real *exponents, holosym_real *megno,
                              int *steps_done);

/* One step of *h in place and the derivative of the step map (restricted to the
 * constraint manifold) applied to k tangent vectors at the start state
 * (docs/events.md): vector j (0-based) is (dq + j n, dp + j n), n reals each, and
 * becomes its image at the end state. HOLOSYM_OFF_MANIFOLD for a vector off the tangent
 * space (holosym_project_tangent projects it); q, p, dq, dp unchanged on failure. Reals
 * through pointers in both builds. */
int holosym_step_tangent(holosym_integrator *integrator, holosym_real *q, holosym_real *p,
                         const holosym_real *h, int k, holosym_real *dq, holosym_real *dp);

/* An orthonormal basis of the tangent space of the constraint manifold at (q, p): its
 * dimension 2(n - m) into *count (may be NULL), vector j into (dq + j n, dp + j n);
 * dq and dp hold n 2(n - m) reals each. Unchanged on failure. */
int holosym_tangent_basis(holosym_integrator *integrator, const holosym_real *q,
                          const holosym_real *p, holosym_real *dq, holosym_real *dp,
                          int *count);

/* Project k vectors (dq + j n, dp + j n) orthogonally onto the tangent space at (q, p)
 * in place; unchanged on failure. */
int holosym_project_tangent(holosym_integrator *integrator, const holosym_real *q,
                            const holosym_real *p, int k, holosym_real *dq,
                            holosym_real *dp);

#ifdef __cplusplus
}
#endif

#endif /* HOLOSYM_H */
