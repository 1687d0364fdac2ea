/* The SymPy side of the peer benchmark (benches/peers/README.md).
 *
 * Compiled by run.py together with the SymPy-generated `chain.c` (found through -I), which
 * defines NDOF and `static void eval(const double *q, const double *qd, double *M,
 * double *forcing)`: Kane's mass matrix (row-major, full) and forcing vector.
 *
 * Usage: driver <states.bin> <check> <secs> <reps>. Reads the state sequence (little-endian
 * doubles, per state q[0..NDOF] then qd[0..NDOF]) and prints, like the Rust program:
 *   check <k> <M row-major> <forcing>   for the first <check> states (%.17g);
 *   time eval <ns>                      ns per evaluation, median of <reps> repetitions of
 *                                       about <secs> seconds each. */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "chain.c"

/* The equivalent of Rust's std::hint::black_box for a pointer: the compiler must assume the
 * pointer's value and the memory behind it may be read and changed here. */
static inline double *black_box(double *p) {
    __asm__ volatile("" : "+r"(p) : : "memory");
    return p;
}

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static double *states;
static size_t n_states;
static double M[NDOF * NDOF], F[NDOF];

/* Evaluates every state once. */
static void pass(void) {
    for (size_t k = 0; k < n_states; k++) {
        double *s = black_box(states + 2 * NDOF * k);
        eval(s, black_box(s + NDOF), M, F);
        black_box(M);
        black_box(F);
    }
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    if (argc != 5) {
        fprintf(stderr, "usage: %s <states.bin> <check> <secs> <reps>\n", argv[0]);
        return 2;
    }
    size_t check = (size_t)atol(argv[2]);
    double secs = atof(argv[3]);
    int reps = atoi(argv[4]);
    if (reps <= 0 || !(secs > 0.0)) {
        fprintf(stderr, "driver: <secs> and <reps> must be positive\n");
        return 2;
    }
    FILE *f = fopen(argv[1], "rb");
    if (!f) {
        perror(argv[1]);
        return 2;
    }
    fseek(f, 0, SEEK_END);
    long bytes = ftell(f);
    fseek(f, 0, SEEK_SET);
    size_t per_state = 2 * NDOF * sizeof(double);
    if (bytes <= 0 || (size_t)bytes % per_state != 0) {
        fprintf(stderr, "%s: %ld bytes is not a whole number of states of %d links\n", argv[1],
                bytes, NDOF);
        return 2;
    }
    n_states = (size_t)bytes / per_state;
    states = malloc((size_t)bytes);
    if (!states || fread(states, 1, (size_t)bytes, f) != (size_t)bytes) {
        fprintf(stderr, "%s: read failed\n", argv[1]);
        return 2;
    }
    fclose(f);

    for (size_t k = 0; k < check && k < n_states; k++) {
        eval(states + 2 * NDOF * k, states + 2 * NDOF * k + NDOF, M, F);
        printf("check %zu", k);
        for (int i = 0; i < NDOF * NDOF; i++) printf(" %.17g", M[i]);
        for (int i = 0; i < NDOF; i++) printf(" %.17g", F[i]);
        printf("\n");
    }

    /* Warm up and calibrate the number of passes per repetition to about `secs`. */
    size_t passes = 1;
    for (;;) {
        double t = now();
        for (size_t p = 0; p < passes; p++) pass();
        double dt = now() - t;
        if (dt > 0.05) {
            passes = (size_t)(passes * secs / dt + 1.0);
            break;
        }
        passes *= 4;
    }
    double *ns = malloc((size_t)reps * sizeof(double));
    for (int r = 0; r < reps; r++) {
        double t = now();
        for (size_t p = 0; p < passes; p++) pass();
        ns[r] = (now() - t) * 1e9 / (double)(passes * n_states);
    }
    qsort(ns, (size_t)reps, sizeof(double), cmp);
    printf("time eval %.6g\n", ns[reps / 2]);
    free(ns);
    free(states);
    return 0;
}
