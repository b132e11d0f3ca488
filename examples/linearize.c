/* The discrete linearisation of one control period, for MPC and iLQR, on the generated dynamics
 * (manipdyn codegen MODEL -o DIR --prefix arm).  Build: cc -std=c99 -O2 -I DIR linearize.c DIR/arm.c -lm.
 *
 * About a state x* = (q, qd) and a torque tau*, the deviations obey dx' = A dx + B dtau with
 *     A = [[0, I], [dqdd/dq, dqdd/dqd]],   B = [[0], [dqdd/dtau]] = [[0], [M^-1]]   (continuous),
 * from arm_forward_dynamics_derivatives (rotors, coupling and the friction law included).  Holding
 * tau constant over the period dt (zero-order hold), x[k+1] - x* = Ad (x[k] - x*) + Bd (tau[k] - tau*) with
 *     [[Ad, Bd], [0, I]] = exp([[A, B], [0, 0]] dt),
 * the exponential by scaling and squaring of an 18-term Taylor series (as manipdyn's md.linearize does).
 *
 * Usage: linearize [DT Q1..Qn QD1..QDn TAU1..TAUn]   (SI units: s, rad or m, rad/s or m/s, N m or N)
 * Without arguments: dt = 1 ms, q = 0.3 rad (or m) on every joint, qd = 0, tau = the gravity torque.
 * Prints "A" and the 2n rows of Ad, then "B" and the 2n rows of Bd, in full precision.  Exit 0, or 2 on
 * bad arguments, or 1 when the exponential is not finite (a step far too long for the arm's modes). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include "arm.h"

#define N arm_NQ
#define NX (2 * N)          /* state size */
#define NE (3 * N)          /* the block matrix [[A, B], [0, 0]] */
#define TAYLOR_TERMS 18     /* with ||X||_1 <= 1/2 the first neglected term is below 2e-23 */

static void matmul(const double *X, const double *Y, double *Z)    /* Z = X Y, NE x NE, row-major */
{
    int i, j, k;
    for (i = 0; i < NE; ++i)
        for (j = 0; j < NE; ++j) {
            double s = 0.0;
            for (k = 0; k < NE; ++k) s += X[i * NE + k] * Y[k * NE + j];
            Z[i * NE + j] = s;
        }
}

/* E = exp(M) of the NE x NE matrix M (scaling and squaring); returns 0 when the result is not finite. */
static int expm(const double *M, double *E)
{
    double X[NE * NE], T[NE * NE];
    double norm = 0.0;
    int i, j, k, s = 0;
    for (j = 0; j < NE; ++j) {                                      /* the 1-norm: largest column sum */
        double c = 0.0;
        for (i = 0; i < NE; ++i) c += fabs(M[i * NE + j]);
        norm = fmax(norm, c);
    }
    if (norm > 0.5) s = (int)ceil(log2(norm / 0.5));
    for (i = 0; i < NE * NE; ++i) X[i] = ldexp(M[i], -s);
    for (i = 0; i < NE * NE; ++i) E[i] = X[i] / TAYLOR_TERMS;         /* Horner: E = I + X E / k */
    for (i = 0; i < NE; ++i) E[i * NE + i] += 1.0;
    for (k = TAYLOR_TERMS - 1; k >= 1; --k) {
        matmul(X, E, T);
        for (i = 0; i < NE * NE; ++i) E[i] = T[i] / k;
        for (i = 0; i < NE; ++i) E[i * NE + i] += 1.0;
    }
    for (k = 0; k < s; ++k) {                                      /* square s times */
        matmul(E, E, T);
        for (i = 0; i < NE * NE; ++i) E[i] = T[i];
    }
    for (i = 0; i < NE * NE; ++i)
        if (!isfinite(E[i])) return 0;
    return 1;
}

int main(int argc, char **argv)
{
    double M[NE * NE], E[NE * NE];
    double q[N], qd[N], tau[N], dq[N * N], dqd[N * N], dtau[N * N], dt = 1e-3;
    int i, j;
    if (argc == 1) {
        for (i = 0; i < N; ++i) { q[i] = 0.3; qd[i] = 0.0; }
        arm_gravity(q, tau);                                         /* hold the arm still */
    } else if (argc == 2 + 3 * N) {
        char *end;
        for (i = 1; i < argc; ++i) {
            double x = strtod(argv[i], &end);
            if (*end != '\0' || end == argv[i] || !isfinite(x)) {
                fprintf(stderr, "linearize: argument %d (%s) is not a finite number\n", i, argv[i]);
                return 2;
            }
            if (i == 1) dt = x;
            else if (i < 2 + N) q[i - 2] = x;
            else if (i < 2 + 2 * N) qd[i - 2 - N] = x;
            else tau[i - 2 - 2 * N] = x;
        }
        if (dt <= 0.0) { fprintf(stderr, "linearize: DT must be a positive time step in seconds\n"); return 2; }
    } else {
        fprintf(stderr, "usage: linearize [DT Q1..Q%d QD1..QD%d TAU1..TAU%d]\n", N, N, N);
        return 2;
    }
    arm_forward_dynamics_derivatives(q, qd, tau, dq, dqd, dtau);
    for (i = 0; i < NE * NE; ++i) M[i] = 0.0;                       /* [[A, B], [0, 0]] dt */
    for (i = 0; i < N; ++i) {
        M[i * NE + N + i] = dt;                                      /* d q' / d qd = I */
        for (j = 0; j < N; ++j) {
            M[(N + i) * NE + j] = dt * dq[i * N + j];
            M[(N + i) * NE + N + j] = dt * dqd[i * N + j];
            M[(N + i) * NE + NX + j] = dt * dtau[i * N + j];
        }
    }
    if (!expm(M, E)) { fprintf(stderr, "linearize: exp(A dt) is not finite: dt = %g s is too long\n", dt); return 1; }
    printf("A\n");
    for (i = 0; i < NX; ++i)
        for (j = 0; j < NX; ++j) printf("%.17g%c", E[i * NE + j], j + 1 < NX ? ' ' : '\n');
    printf("B\n");
    for (i = 0; i < NX; ++i)
        for (j = 0; j < N; ++j) printf("%.17g%c", E[i * NE + NX + j], j + 1 < N ? ' ' : '\n');
    return 0;
}
