/* SPDX-License-Identifier: MIT */
/*
 * benchfile.h - what the IK benchmark tools share: the rows of a benchmark
 * file of ../shared/bench (15 numbers a line: the generating angles q1..q8,
 * the target's position and its quaternion w x y z; an optional "q1,..."
 * header), a joint-limits file (8 lines "lo hi" in degrees, '#' starts a
 * comment), and small helpers for timing and reporting. Errors are printed
 * with the calling tool's name and file:line.
 */
#ifndef AGW_TOOLS_BENCHFILE_H
#define AGW_TOOLS_BENCHFILE_H

#include <stddef.h>

#include "ik/arm.h"

struct bench_row {
	double q[ARM_DOF]; /* generating angles, radians */
	double p[3];	   /* target position, metres */
	double r[4];	   /* target orientation, w x y z */
};

/* at most max rows (SIZE_MAX: all) into a malloc'ed *out; 0, or -1 after printing why */
int bench_load_rows(const char *tool, const char *path, size_t max, struct bench_row **out, size_t *n);
/* the 8 joints' limits into lim (radians); 0, or -1 after printing why */
int bench_load_limits(const char *tool, const char *path, struct arm_limits *lim);
double bench_now_ns(void);
/* qsort's comparison of doubles */
int bench_cmp_double(const void *a, const void *b);
/* an angle in degrees into [-180, 180) */
double bench_wrap_deg(double a);

#endif /* AGW_TOOLS_BENCHFILE_H */
