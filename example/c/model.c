/* A system from a model file through holosym's C interface (include/holosym.h): no
 * callbacks, the library reads the formulas and derives the rest.
 *
 * Reads example/models/fourbar.hsm (or the file named on the command line), integrates 10 s
 * with (M, N, G) = (4, 3, 5), h = 1/32, from the model's initial state, prints the crank
 * joint's position and the energy error, sets a parameter and starts again, then checks
 * that a broken model text is refused with its line and column. It exits with status 1
 * when a check fails.
 *
 * Build and run: `make c-example`. Output (real128):
 *
 *     fourbar: n = 4, m = 3, parameters a b c d m1 m2 g theta omega
 *     start: the initial velocities are not tangent to the constraints (|Ph ...
 *     t = 10: xb = 0.9933017  yb = -0.1155501  |H - H0|/|H0| = 3.6e-15
 *     omega = 3: xb = 0.9922186  yb = -0.1245084
 *     refused: model:3:20: unknown name 'z'
 *     checks: 5 of 5 passed
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "holosym.h"

static int checks = 0, passed = 0;

static void check(int condition, const char *what) {
    ++checks;
    if (condition)
        ++passed;
    else
        printf("FAILED: %s\n", what);
}

/* The whole file as a NUL-terminated string (NULL when it cannot be read). */
static char *read_file(const char *path) {
    FILE *file = fopen(path, "rb");
    if (!file) return NULL;
    fseek(file, 0, SEEK_END);
    long size = ftell(file);
    rewind(file);
    char *text = malloc(size + 1);
    if (text && fread(text, 1, size, file) != (size_t)size) {
        free(text);
        text = NULL;
    }
    if (text) text[size] = '\0';
    fclose(file);
    return text;
}

/* H of the four-bar with its default parameters (unit masses and gravity), for the energy
 * error. */
static double fourbar_energy(const holosym_real *q, const holosym_real *p) {
    double kinetic = 0;
    for (int i = 0; i < 4; ++i) kinetic += (double)p[i] * (double)p[i] / 2;
    return kinetic + (double)q[1] + (double)q[3];
}

int main(int argc, char **argv) {
    const char *path = argc > 1 ? argv[1] : "example/models/fourbar.hsm";
    char *text = read_file(path);
    if (!text) {
        printf("cannot read %s\n", path);
        return 1;
    }
    holosym_integrator *integrator = holosym_model_create(text, 4, 3, 5);
    free(text);
    char message[512];
    if (holosym_status(integrator) != HOLOSYM_SUCCESS) {
        holosym_message(integrator, message, sizeof message);
        printf("%s: %s\n", path, message);
        holosym_destroy(integrator);
        return 1;
    }
    int n = 0, m = 0;
    holosym_sizes(integrator, &n, &m);
    printf("fourbar: n = %d, m = %d, parameters", n, m);
    char name[64];
    for (int k = 1; k <= holosym_model_parameter_count(integrator); ++k) {
        holosym_model_name(integrator, HOLOSYM_NAME_PARAMETER, k, name, sizeof name);
        printf(" %s", name);
    }
    printf("\n");

    holosym_real q[4], p[4];
    check(holosym_model_initial_state(integrator, q, p) == HOLOSYM_SUCCESS, "initial state");
    holosym_message(integrator, message, sizeof message);
    printf("start: %.62s ...\n", message);
    double h0 = fourbar_energy(q, p);
    int done = 0;
    int code = holosym_integrate(integrator, q, p, (holosym_real)1 / 32, 320, NULL, NULL,
                                 &done);
    check(code == HOLOSYM_SUCCESS && done == 320, "320 steps");
    double error = fabs(fourbar_energy(q, p) / h0 - 1);
    printf("t = 10: xb = %.7f  yb = %.7f  |H - H0|/|H0| = %.1e\n", (double)q[0], (double)q[1],
           error);
    check(error < 1e-12, "energy error below 1e-12");

    check(holosym_model_set_parameter(integrator, "omega", 3) == HOLOSYM_SUCCESS, "omega = 3");
    holosym_model_initial_state(integrator, q, p);
    holosym_integrate(integrator, q, p, (holosym_real)1 / 32, 320, NULL, NULL, &done);
    printf("omega = 3: xb = %.7f  yb = %.7f\n", (double)q[0], (double)q[1]);
    holosym_destroy(integrator);

    integrator = holosym_model_create("coordinates x y\nmomenta px py\nhamiltonian px^2 + z\n",
                                      2, 1, 3);
    holosym_message(integrator, message, sizeof message);
    check(holosym_status(integrator) == HOLOSYM_INVALID_MODEL &&
              strstr(message, "model:3:20: unknown name 'z'") != NULL,
          "a broken model is refused with its position");
    printf("refused: %s\n", message);
    holosym_destroy(integrator);

    printf("checks: %d of %d passed\n", passed, checks);
    return passed == checks ? 0 : 1;
}
