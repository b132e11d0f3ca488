/* Computed-torque control at 1 kHz on the generated dynamics (manipdyn codegen MODEL -o DIR --prefix arm).
 * Build: cc -std=c99 -O2 -I DIR computed_torque.c DIR/arm.c -lm.  The plant is the same generated model,
 * integrated with arm_forward_dynamics (semi-implicit Euler); the law is tau = M(q) v + h(q, qd). */
#include <math.h>
#include <stdio.h>
#include "arm.h"

#define N arm_NQ

int main(void)
{
    const double dt = 1e-3, kp = 400.0, kd = 40.0;   /* 1 kHz; critically damped at 20 rad/s */
    double q[N], qd[N], qdd[N], v[N], M[N * N], h[N], tau[N], err = 0.0;
    int i, j, k;
    for (i = 0; i < N; ++i) {                                        /* start 0.2 rad off the path, */
        q[i] = 0.5 * sin((double)i) + 0.2;                           /* with the path's velocity */
        qd[i] = 0.5 * cos((double)i);
    }
    for (k = 0; k <= 3000; ++k) {                                    /* 3 s */
        double t = k * dt;
        err = 0.0;
        for (i = 0; i < N; ++i) {                                    /* desired: q_d = 0.5 sin(t + i) */
            double e = 0.5 * sin(t + i) - q[i], ed = 0.5 * cos(t + i) - qd[i];
            v[i] = -0.5 * sin(t + i) + kp * e + kd * ed;
            err = fmax(err, fabs(e));
        }
        arm_mass_matrix(q, M);
        arm_nonlinear_effects(q, qd, h);
        for (i = 0; i < N; ++i)
            for (tau[i] = h[i], j = 0; j < N; ++j) tau[i] += M[i * N + j] * v[j];
        arm_forward_dynamics(q, qd, tau, qdd);                       /* the plant */
        for (i = 0; i < N; ++i) { qd[i] += dt * qdd[i]; q[i] += dt * qd[i]; }
        if (k % 500 == 0) printf("t = %4.1f s  max |q_d - q| = %.3e rad\n", t, err);
    }
    return err < 1e-3 ? 0 : 1;
}
