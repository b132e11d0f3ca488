/* ns per call of the generated functions on this machine (manipdyn codegen MODEL -o DIR --prefix arm).
 * Build: cc -std=c99 -O2 -I DIR time_calls.c DIR/arm.c -lm.  1000 states drawn before timing; each
 * function runs over all of them, 21 times; the median run is printed, per call, in CPU time (a busy
 * machine preempting the process does not count). */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "arm.h"

#define N arm_NQ
#define S 1000
#define R 21
static double q[S][N], qd[S][N], qdd[S][N], out[N * arm_NP + 3 * N * N], sink;

static double now(void) { struct timespec t; clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t); return t.tv_sec + 1e-9 * t.tv_nsec; }
static int cmp(const void *a, const void *b) { double x = *(const double *)a, y = *(const double *)b; return (x > y) - (x < y); }

#define TIME(label, call) do { double t[R]; int r, s; \
    for (r = 0; r < R; ++r) { double t0 = now(); for (s = 0; s < S; ++s) { call; sink += out[0]; } t[r] = now() - t0; } \
    qsort(t, R, sizeof t[0], cmp); printf("%-30s %8.1f ns\n", label, 1e9 * t[R / 2] / S); } while (0)

int main(void)
{
    int s, k;
    srand(1);
    for (s = 0; s < S; ++s) for (k = 0; k < N; ++k) {
        q[s][k] = 6.0 * rand() / RAND_MAX - 3.0; qd[s][k] = 4.0 * rand() / RAND_MAX - 2.0;
        qdd[s][k] = 10.0 * rand() / RAND_MAX - 5.0; }
    TIME("inverse_dynamics", arm_inverse_dynamics(q[s], qd[s], qdd[s], out));
    TIME("mass_matrix", arm_mass_matrix(q[s], out));
    TIME("gravity", arm_gravity(q[s], out));
    TIME("nonlinear_effects", arm_nonlinear_effects(q[s], qd[s], out));
    TIME("forward_dynamics", arm_forward_dynamics(q[s], qd[s], qdd[s], out));
    TIME("inverse_dynamics_derivatives", arm_inverse_dynamics_derivatives(q[s], qd[s], qdd[s], out, out + N * N));
    TIME("forward_dynamics_derivatives",
         arm_forward_dynamics_derivatives(q[s], qd[s], qdd[s], out, out + N * N, out + 2 * N * N));
    TIME("regressor", arm_regressor(q[s], qd[s], qdd[s], out));
    return sink != sink;         /* keeps the results alive */
}
