/* Shared by the two timing drivers of benchmarks/bench_codegen.py: read the
 * states file, time a batch of calls, write what was computed.  Plain C99, so
 * that the C driver and the C++ driver (which includes it in extern "C") read
 * the same inputs the same way.
 *
 * States file (text, written by benchmarks/bench_codegen.py):
 *
 *     manipdyn-bench-states 1
 *     n N
 *     count K
 *     gravity gx gy gz          (m/s^2, base frame; only Pinocchio's driver reads it)
 *     armature a_1 ... a_N      (kg m^2 on the joint side; only Pinocchio's driver reads it)
 *     then K lines: q (N, rad or m), qd (N), qdd (N), tau (N, N m or N), in %.17g
 *
 * Output (stdout), one line per round, then the medians:
 *
 *     round R inverse_dynamics NS mass_matrix NS forward_dynamics NS inverse_dynamics_derivatives NS
 *     median inverse_dynamics NS ...
 *
 * NS is nanoseconds per call: one sample is PASSES sweeps over the K states,
 * timed as one block (a clock read costs ~20 ns, too much to time single
 * calls of a few hundred ns), divided by PASSES * K.
 */
#ifndef MD_STATES_IO_H
#define MD_STATES_IO_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define MD_NOPS 5
static const char *const md_op_names[MD_NOPS] = {
    "inverse_dynamics", "mass_matrix", "forward_dynamics", "inverse_dynamics_derivatives",
    "forward_dynamics_derivatives"};

typedef struct {
    int n, count;
    double gravity[3];
    double *armature;            /* n */
    double *q, *qd, *qdd, *tau;  /* count * n each, row-major */
} md_states;

static void md_die(const char *what, const char *detail)
{
    fprintf(stderr, "error: %s%s%s\n", what, detail ? ": " : "", detail ? detail : "");
    exit(2);
}

static double *md_alloc(size_t k)
{
    double *p = (double *)calloc(k ? k : 1, sizeof(double));
    if (!p) md_die("out of memory", NULL);
    return p;
}

static void md_read_vec(FILE *f, double *x, int k, const char *path)
{
    int i;
    for (i = 0; i < k; ++i)
        if (fscanf(f, "%lf", &x[i]) != 1) md_die("truncated or malformed states file", path);
}

static md_states md_read_states(const char *path)
{
    md_states s;
    char magic[64];
    int version, i;
    FILE *f = fopen(path, "r");
    if (!f) md_die("cannot open states file", path);
    if (fscanf(f, "%63s %d", magic, &version) != 2 || strcmp(magic, "manipdyn-bench-states") != 0 || version != 1)
        md_die("not a 'manipdyn-bench-states 1' file", path);
    if (fscanf(f, " n %d count %d", &s.n, &s.count) != 2 || s.n < 1 || s.count < 1)
        md_die("expected 'n N' and 'count K' with N, K >= 1", path);
    if (fscanf(f, " gravity") != 0) md_die("expected 'gravity gx gy gz'", path);
    md_read_vec(f, s.gravity, 3, path);
    if (fscanf(f, " armature") != 0) md_die("expected 'armature a_1 ... a_n'", path);
    s.armature = md_alloc((size_t)s.n);
    md_read_vec(f, s.armature, s.n, path);
    s.q = md_alloc((size_t)s.count * s.n);
    s.qd = md_alloc((size_t)s.count * s.n);
    s.qdd = md_alloc((size_t)s.count * s.n);
    s.tau = md_alloc((size_t)s.count * s.n);
    for (i = 0; i < s.count; ++i) {
        md_read_vec(f, s.q + (size_t)i * s.n, s.n, path);
        md_read_vec(f, s.qd + (size_t)i * s.n, s.n, path);
        md_read_vec(f, s.qdd + (size_t)i * s.n, s.n, path);
        md_read_vec(f, s.tau + (size_t)i * s.n, s.n, path);
    }
    fclose(f);
    return s;
}

static double md_now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e9 + (double)t.tv_nsec;
}

static int md_cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double md_median(double *x, int k)
{
    qsort(x, (size_t)k, sizeof(double), md_cmp);
    return k % 2 ? x[k / 2] : 0.5 * (x[k / 2 - 1] + x[k / 2]);
}

static void md_write_row(FILE *f, const double *x, int k)
{
    int i;
    for (i = 0; i < k; ++i) fprintf(f, i ? " %.17g" : "%.17g", x[i]);
    fputc('\n', f);
}

/* argv: STATES ROUNDS PASSES [DUMP] (after the driver's own leading arguments) */
static void md_parse_counts(const char *rounds, const char *passes, int *r, int *p)
{
    *r = atoi(rounds);
    *p = atoi(passes);
    if (*r < 1 || *p < 1) md_die("ROUNDS and PASSES must be integers >= 1", NULL);
}

#endif
