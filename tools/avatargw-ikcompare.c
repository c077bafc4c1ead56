// SPDX-License-Identifier: MIT
/*
 * avatargw-ikcompare - the IK core built for double, float and Q5.26 fixed
 * point, side by side on one benchmark file: every row is solved by each
 * build and judged the same way (../shared/bench/README.md: forward
 * kinematics, in double, of the returned angles against the target), and
 * each build's poses are held against the double build's.
 *
 *   avatargw-ikcompare --targets FILE [--mode reset|warm]
 *       [--solver dq|matrix|newton-dq|newton-matrix] [--rows N] [--quiet]
 *
 * Prints a table and, last, one JSON line per scalar type.
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ik/ik.h"
#include "lib/benchfile.h"
#include "lib/ikx.h"

#define RAD2DEG 57.29577951308232

struct backend {
	const char *name;
	unsigned (*solve)(const struct ikx_setup *o, const double p[3], const double r[4], const double *seed,
			  double q[IKX_DOF], struct ikx_result *res);
	void (*limits)(const struct ikx_setup *o, double lo[IKX_DOF], double hi[IKX_DOF]);
};

static const struct backend backends[] = {
	{ "double", ikx_solve_d, ikx_limits_d },
	{ "float", ikx_solve_f, ikx_limits_f },
	{ "Q5.26", ikx_solve_q, ikx_limits_q },
};

#define NB (sizeof(backends) / sizeof(backends[0]))

/* angle of the rotation a* b, radians; insensitive to sign and to norms off 1 */
static double rot_between(const double a[4], const double b[4])
{
	double w = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
	double x = a[0] * b[1] - a[1] * b[0] - a[2] * b[3] + a[3] * b[2];
	double y = a[0] * b[2] - a[2] * b[0] - a[3] * b[1] + a[1] * b[3];
	double z = a[0] * b[3] - a[3] * b[0] - a[1] * b[2] + a[2] * b[1];

	return 2 * atan2(sqrt(x * x + y * y + z * z), fabs(w));
}

static double dist3(const double a[3], const double b[3])
{
	return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

struct judged {
	double q[IKX_DOF]; /* returned angles */
	double fk[7];	   /* double FK of them */
	double ep, er;	   /* against the target: metres, radians */
	bool strict, in_limits;
	unsigned flags;
	int iters;
	double us;
};

/*
 * Every row through one back end; warm: each solve starts from the previous
 * solution. In-limits is judged against the limits as the back end holds
 * them (the degrees of the table rounded to its type: a float or Q5.26
 * posture held at a limit sits on that rounded value).
 */
static void run(const struct backend *be, const struct ikx_setup *setup, const struct bench_row *rows, size_t n,
		bool warm, struct judged *out)
{
	double lo[IKX_DOF], hi[IKX_DOF];
	size_t i;
	int k;

	be->limits(setup, lo, hi);
	for (i = 0; i < n; i++) {
		struct judged *j = &out[i];
		struct ikx_result ir;
		double t0 = bench_now_ns();

		be->solve(setup, rows[i].p, rows[i].r, warm && i > 0 ? out[i - 1].q : NULL, j->q, &ir);
		j->us = (bench_now_ns() - t0) / 1e3;
		j->flags = ir.flags;
		j->iters = ir.iters;
		ikx_fk_d(setup, j->q, j->fk);
		j->ep = dist3(j->fk, rows[i].p);
		j->er = rot_between(j->fk + 3, rows[i].r);
		j->strict = j->ep < 1e-4 && j->er * RAD2DEG < 0.01;
		j->in_limits = true;
		for (k = 0; k < IKX_DOF; k++) {
			double a = bench_wrap_deg(j->q[k] * RAD2DEG);

			if (!(a >= lo[k] * RAD2DEG - 1e-9 && a <= hi[k] * RAD2DEG + 1e-9))
				j->in_limits = false;
		}
	}
}

/* largest joint difference, degrees (wrapped) */
static double joint_diff(const double a[IKX_DOF], const double b[IKX_DOF])
{
	double m = 0;
	int k;

	for (k = 0; k < IKX_DOF; k++)
		m = fmax(m, fabs(bench_wrap_deg((a[k] - b[k]) * RAD2DEG)));
	return m;
}

int main(int argc, char **argv)
{
	static const struct option longopts[] = {
		{ "targets", required_argument, NULL, 't' },
		{ "mode", required_argument, NULL, 'm' },
		{ "solver", required_argument, NULL, 's' },
		{ "rows", required_argument, NULL, 'n' },
		{ "quiet", no_argument, NULL, 'q' },
		{ "help", no_argument, NULL, 'h' },
		{ NULL, 0, NULL, 0 },
	};
	const char *targets = NULL, *mode = "reset", *solver = "dq";
	struct ikx_setup setup = { .dims = { 0.18, 0.30, 0.26, 0.08 } };
	struct bench_row *rows;
	struct judged *res[NB];
	size_t n, i, b, max_rows = (size_t)-1;
	bool warm, quiet = false;
	int c;

	while ((c = getopt_long(argc, argv, "t:m:s:n:qh", longopts, NULL)) != -1) {
		switch (c) {
		case 't':
			targets = optarg;
			break;
		case 'm':
			mode = optarg;
			break;
		case 's':
			solver = optarg;
			break;
		case 'n':
			max_rows = strtoul(optarg, NULL, 10);
			break;
		case 'q':
			quiet = true;
			break;
		case 'h':
			printf("usage: avatargw-ikcompare --targets FILE [--mode reset|warm]\n"
			       "       [--solver dq|matrix|newton-dq|newton-matrix] [--rows N] [--quiet]\n");
			return 0;
		default:
			return 2;
		}
	}
	if (!targets || optind != argc || (strcmp(mode, "reset") && strcmp(mode, "warm"))) {
		fprintf(stderr,
			"usage: avatargw-ikcompare --targets FILE [--mode reset|warm] [--solver ...] [--rows N]\n");
		return 2;
	}
	warm = !strcmp(mode, "warm");
	setup.newton = !strncmp(solver, "newton-", 7);
	if (!strcmp(solver, "matrix") || !strcmp(solver, "newton-matrix")) {
		setup.matrix = 1;
	} else if (strcmp(solver, "dq") && strcmp(solver, "newton-dq")) {
		fprintf(stderr, "avatargw-ikcompare: --solver dq|matrix|newton-dq|newton-matrix\n");
		return 2;
	}
	if (bench_load_rows("avatargw-ikcompare", targets, max_rows, &rows, &n))
		return 1;
	if (n == 0) {
		fprintf(stderr, "avatargw-ikcompare: %s: no rows\n", targets);
		return 1;
	}

	for (b = 0; b < NB; b++) {
		res[b] = calloc(n, sizeof(*res[b]));
		if (!res[b])
			return 1;
		run(&backends[b], &setup, rows, n, warm, res[b]);
	}
	if (!quiet) {
		printf("%s, mode %s, solver %s, %zu rows; judged by double FK of the returned angles\n", targets, mode,
		       solver, n);
		printf("max errors and distances to the double pose: over the rows the double build solves (strict);\n"
		       "same posture: every joint within 0.01 deg of the double solution\n");
		printf("| scalar | strict %% | loose %% | in-limits %% | jumps | Newton iters | max pos err um | "
		       "max rot err deg | pos vs double um | rot vs double deg | same posture %% | median us |\n");
		printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
	}
	for (b = 0; b < NB; b++) {
		size_t jumps = 0, strict = 0, loose = 0, inlim = 0, reached = 0, same = 0, both = 0, far = 0;
		double max_ep = 0, max_er = 0, max_dp = 0, max_dr = 0, iters = 0, *us = malloc(n * sizeof(*us));

		if (!us)
			return 1;
		for (i = 0; i < n; i++) {
			struct judged *j = &res[b][i], *d = &res[0][i];

			strict += j->strict;
			loose += j->ep < 1e-3 && j->er * RAD2DEG < 0.1;
			inlim += j->in_limits;
			reached += !!(j->flags & IK_REACHED);
			iters += j->iters;
			us[i] = j->us;
			if (i > 0 && joint_diff(j->q, res[b][i - 1].q) > 10.0)
				jumps++;
			if (!d->strict)
				continue;
			/* rows the double build solves: errors, and the distance to its pose */
			both++;
			max_ep = fmax(max_ep, j->ep);
			max_er = fmax(max_er, j->er);
			max_dp = fmax(max_dp, dist3(j->fk, d->fk));
			max_dr = fmax(max_dr, rot_between(j->fk + 3, d->fk + 3));
			same += joint_diff(j->q, d->q) < 0.01;
			far += joint_diff(j->q, d->q) > 1.0;
		}
		qsort(us, n, sizeof(*us), bench_cmp_double);
		if (!quiet)
			printf("| %s | %.2f | %.2f | %.2f | %zu | %.2f | %.3g | %.3g | %.3g | %.3g | %.2f | %.2f |\n",
			       backends[b].name, 100.0 * strict / n, 100.0 * loose / n, 100.0 * inlim / n, jumps,
			       iters / n, max_ep * 1e6, max_er * RAD2DEG, max_dp * 1e6, max_dr * RAD2DEG,
			       both ? 100.0 * same / both : 0.0, us[n / 2]);
		printf("{\"scalar\":\"%s\",\"mode\":\"%s\",\"solver\":\"%s\",\"n\":%zu,\"strict\":%.6f,"
		       "\"loose\":%.6f,\"in_limits\":%.6f,\"reached\":%.6f,\"jumps\":%zu,\"iters_mean\":%.4f,"
		       "\"rows_double_solves\":%zu,\"max_pos_err_um\":%.4g,\"max_rot_err_deg\":%.4g,"
		       "\"max_pos_vs_double_um\":%.4g,\"max_rot_vs_double_deg\":%.4g,\"same_posture\":%.6f,"
		       "\"median_us\":%.3f}\n",
		       backends[b].name, mode, solver, n, (double)strict / n, (double)loose / n, (double)inlim / n,
		       (double)reached / n, jumps, iters / n, both, max_ep * 1e6, max_er * RAD2DEG, max_dp * 1e6,
		       max_dr * RAD2DEG, both ? (double)same / both : 0.0, us[n / 2]);
		free(us);
		if (getenv("IKCOMPARE_FAR"))
			fprintf(stderr, "%s: %zu rows with a joint more than 1 deg from the double solution\n",
				backends[b].name, far);
	}
	for (b = 0; b < NB; b++)
		free(res[b]);
	free(rows);
	return 0;
}
