/* Timing driver for the C that `md.codegen` writes, the measured side of
 * benchmarks/bench_codegen.py.
 *
 *     cc -std=c99 -O2 -DMDPREFIX=ur5 -I DIR generated_timing.c DIR/ur5.c -lm -o t
 *     t STATES ROUNDS PASSES [DUMP]
 *
 * MDPREFIX is the prefix given to codegen (the header is DIR/MDPREFIX.h unless
 * -DMDHEADER='"file.h"' says otherwise); the functions are reached by token
 * pasting, MDPREFIX ## _inverse_dynamics and so on.  It times
 * P_inverse_dynamics, P_mass_matrix, P_forward_dynamics,
 * P_inverse_dynamics_derivatives and P_forward_dynamics_derivatives on the states of STATES (format and output:
 * states_io.h), the same file pinocchio_timing.cpp reads, with the same
 * rounds, rotation and blocks.  With DUMP, the answers for every state are
 * written there first, in the same layout as pinocchio_timing.cpp's.
 */
#define _POSIX_C_SOURCE 199309L
#include "states_io.h"

#ifndef MDPREFIX
#error "compile with -DMDPREFIX=<the prefix given to md.codegen>"
#endif
#define MD_CAT_(a, b) a##b
#define MD_CAT(a, b) MD_CAT_(a, b)
#define MD_STR_(a) #a
#define MD_STR(a) MD_STR_(a)
#ifndef MDHEADER
#define MDHEADER MD_STR(MDPREFIX.h)
#endif
#include MDHEADER

#define MD_FN(name) MD_CAT(MDPREFIX, name)
#define NQ MD_CAT(MDPREFIX, _NQ)

int main(int argc, char **argv)
{
    int rounds, passes, r, j, op, p, i;
    md_states s;
    double *out, *out2, *out3, *samples[MD_NOPS];
    volatile double sink = 0.0; /* keeps every call's result alive */
    if (argc != 4 && argc != 5) {
        fprintf(stderr, "usage: %s STATES ROUNDS PASSES [DUMP]\n", argv[0]);
        return 2;
    }
    md_parse_counts(argv[2], argv[3], &rounds, &passes);
    s = md_read_states(argv[1]);
    if (s.n != NQ) md_die("the states file's n differs from the generated header's _NQ", argv[1]);
    out = md_alloc((size_t)NQ * NQ);
    out2 = md_alloc((size_t)NQ * NQ);
    out3 = md_alloc((size_t)NQ * NQ);

    if (argc == 5) {
        FILE *f = fopen(argv[4], "w");
        if (!f) md_die("cannot write", argv[4]);
        for (i = 0; i < s.count; ++i) {
            const size_t o = (size_t)i * NQ;
            MD_FN(_inverse_dynamics)(s.q + o, s.qd + o, s.qdd + o, out);
            md_write_row(f, out, NQ);
            MD_FN(_mass_matrix)(s.q + o, out);
            md_write_row(f, out, NQ * NQ);
            MD_FN(_forward_dynamics)(s.q + o, s.qd + o, s.tau + o, out);
            md_write_row(f, out, NQ);
            MD_FN(_inverse_dynamics_derivatives)(s.q + o, s.qd + o, s.qdd + o, out, out2);
            md_write_row(f, out, NQ * NQ);
            md_write_row(f, out2, NQ * NQ);
            MD_FN(_forward_dynamics_derivatives)(s.q + o, s.qd + o, s.tau + o, out, out2, out3);
            md_write_row(f, out, NQ * NQ);
            md_write_row(f, out2, NQ * NQ);
            md_write_row(f, out3, NQ * NQ);
        }
        if (fclose(f) != 0) md_die("cannot write", argv[4]);
    }

    for (op = 0; op < MD_NOPS; ++op) samples[op] = md_alloc((size_t)rounds);
    for (r = 0; r < rounds; ++r) {
        double ns[MD_NOPS];
        printf("round %d", r);
        for (j = 0; j < MD_NOPS; ++j) {
            double acc = 0.0, t0;
            op = (r + j) % MD_NOPS;
            t0 = md_now_ns();
            for (p = 0; p < passes; ++p)
                for (i = 0; i < s.count; ++i) {
                    const size_t o = (size_t)i * NQ;
                    switch (op) {
                    case 0: MD_FN(_inverse_dynamics)(s.q + o, s.qd + o, s.qdd + o, out); break;
                    case 1: MD_FN(_mass_matrix)(s.q + o, out); break;
                    case 2: MD_FN(_forward_dynamics)(s.q + o, s.qd + o, s.tau + o, out); break;
                    case 3: MD_FN(_inverse_dynamics_derivatives)(s.q + o, s.qd + o, s.qdd + o, out, out2); break;
                    default: MD_FN(_forward_dynamics_derivatives)(s.q + o, s.qd + o, s.tau + o, out, out2, out3);
                    }
                    acc += out[0];
                }
            ns[op] = (md_now_ns() - t0) / ((double)passes * s.count);
            sink = sink + acc;
        }
        for (op = 0; op < MD_NOPS; ++op) {
            samples[op][r] = ns[op];
            printf(" %s %.3f", md_op_names[op], ns[op]);
        }
        printf("\n");
    }
    printf("median");
    for (op = 0; op < MD_NOPS; ++op) printf(" %s %.3f", md_op_names[op], md_median(samples[op], rounds));
    printf("\ninfo generated %s\n", MD_STR(MDPREFIX));
    return sink == 12345.678 ? 1 : 0; /* never: only makes the sink observable */
}
