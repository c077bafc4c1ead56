// SPDX-License-Identifier: MIT
/*
 * avatargw-ikbench - solves every row of a benchmark file and judges each
 * solve by forward kinematics, as ../shared/bench/README.md describes.
 *
 *   avatargw-ikbench --targets FILE [--mode reset|warm] [--dims S,A,F,H]
 *       [--limits FILE] [--solver dq|matrix|newton-dq|newton-matrix]
 *       [--solutions OUT.csv] [--quiet]
 *
 * The last line printed is one JSON object.
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdint.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ik/ik.h"
#include "lib/benchfile.h"

#define DEG2RAD 0.017453292519943295

static void usage(FILE *f)
{
	fprintf(f, "usage: avatargw-ikbench --targets FILE [--mode reset|warm] [--dims S,A,F,H]\n"
		   "       [--limits FILE] [--solver dq|matrix|newton-dq|newton-matrix]\n"
		   "       [--solutions OUT.csv] [--quiet] [--iteration-cost]\n"
		   "--limits FILE: 8 lines 'lo hi' in degrees (J1..J8); '#' starts a comment\n");
}

/*
 * The cost of one Newton iteration alone (kinematics, Jacobian, error twist
 * and the least-squares step) at the generating postures of the file, each
 * against the next row's target: the median of 21 passes, in ns.
 */
static int iteration_cost(const struct arm *arm, const struct ik_kin *kin, const struct bench_row *rows, size_t n)
{
	double pass_ns[21], sink = 0;
	size_t i, m = n < 2000 ? n : 2000;
	int p;

	for (p = 0; p < 21; p++) {
		double t0 = bench_now_ns();

		for (i = 0; i + 1 < m; i++) {
			struct ik_target t;
			struct ik_err err;
			struct vec3 pp = { rows[i + 1].p[0], rows[i + 1].p[1], rows[i + 1].p[2] };
			struct quat r = { rows[i + 1].r[0], rows[i + 1].r[1], rows[i + 1].r[2], rows[i + 1].r[3] };
			double J[6][ARM_DOF], V[6], x[ARM_DOF];

			ik_target_set(&t, &pp, &r);
			kin->eval(arm, rows[i].q, &t, J, V, &err);
			ik_lsq_step((const double(*)[ARM_DOF])J, V, NULL, x);
			sink += x[0] + err.pos;
		}
		pass_ns[p] = (bench_now_ns() - t0) / (double)(m - 1);
	}
	qsort(pass_ns, 21, sizeof(pass_ns[0]), bench_cmp_double);
	printf("{\"kinematics\":\"%s\",\"iteration_ns\":%.1f,\"check\":%.3g}\n", kin->name, pass_ns[10], sink);
	return 0;
}

int main(int argc, char **argv)
{
	static const struct option longopts[] = {
		{ "targets", required_argument, NULL, 't' },  { "mode", required_argument, NULL, 'm' },
		{ "dims", required_argument, NULL, 'd' },     { "limits", required_argument, NULL, 'l' },
		{ "solver", required_argument, NULL, 's' },   { "solutions", required_argument, NULL, 'o' },
		{ "quiet", no_argument, NULL, 'q' },	      { "help", no_argument, NULL, 'h' },
		{ "iteration-cost", no_argument, NULL, 'i' }, { NULL, 0, NULL, 0 },
	};
	const char *targets = NULL, *mode = "reset", *solver = "dq", *solutions = NULL, *limits = NULL;
	struct arm_dims dims = { 0.18, 0.30, 0.26, 0.08 };
	struct arm_limits lim;
	struct arm arm;
	struct ik_opts opts;
	const struct ik_kin *kin;
	struct bench_row *rows;
	size_t n, i, strict = 0, loose = 0, inlim = 0, jumps = 0, reached = 0;
	double *us, *ev, iters = 0, evals = 0, prev[ARM_DOF] = { 0 }, (*sol)[ARM_DOF];
	bool warm, newton, quiet = false, iter_cost = false;
	int c;

	arm_default_limits(&lim);
	while ((c = getopt_long(argc, argv, "t:m:d:l:s:o:qhi", longopts, NULL)) != -1) {
		switch (c) {
		case 't':
			targets = optarg;
			break;
		case 'm':
			mode = optarg;
			break;
		case 'd':
			if (sscanf(optarg, "%lf,%lf,%lf,%lf", &dims.shoulder, &dims.arm, &dims.forearm, &dims.hand) !=
				    4 ||
			    dims.shoulder < 0 || dims.arm <= 0 || dims.forearm <= 0 || dims.hand < 0) {
				fprintf(stderr,
					"avatargw-ikbench: --dims S,A,F,H: four lengths in metres, A and F > 0\n");
				return 2;
			}
			break;
		case 'l':
			limits = optarg;
			break;
		case 's':
			solver = optarg;
			break;
		case 'o':
			solutions = optarg;
			break;
		case 'q':
			quiet = true;
			break;
		case 'i':
			iter_cost = true;
			break;
		case 'h':
			usage(stdout);
			return 0;
		default:
			usage(stderr);
			return 2;
		}
	}
	if (!targets || optind != argc) {
		usage(stderr);
		return 2;
	}
	if (strcmp(mode, "reset") && strcmp(mode, "warm")) {
		fprintf(stderr, "avatargw-ikbench: --mode reset|warm\n");
		return 2;
	}
	warm = !strcmp(mode, "warm");
	newton = !strncmp(solver, "newton-", 7);
	if (!strcmp(solver, "dq") || !strcmp(solver, "newton-dq")) {
		kin = &ik_kin_dq;
	} else if (!strcmp(solver, "matrix") || !strcmp(solver, "newton-matrix")) {
		kin = &ik_kin_mat;
	} else {
		fprintf(stderr, "avatargw-ikbench: --solver dq|matrix|newton-dq|newton-matrix\n");
		return 2;
	}
	if (limits && bench_load_limits("avatargw-ikbench", limits, &lim))
		return 1;
	if (bench_load_rows("avatargw-ikbench", targets, SIZE_MAX, &rows, &n))
		return 1;
	if (n == 0) {
		fprintf(stderr, "avatargw-ikbench: %s: no rows\n", targets);
		return 1;
	}
	arm_init(&arm, ARM_RIGHT, &dims, &lim);
	ik_default_opts(&opts);
	if (newton) {
		opts.max_step = 0; /* the paper's plain step */
		opts.max_iter = 100;
	}
	if (iter_cost)
		return iteration_cost(&arm, kin, rows, n);
	us = calloc(n, sizeof(*us));
	ev = calloc(n, sizeof(*ev));
	sol = calloc(n, sizeof(*sol));
	if (!us || !ev || !sol)
		return 1;

	for (int pass = 0; pass < 2; pass++) {
		/* pass 0 warms caches and branch predictors on the first rows; pass 1 is measured */
		size_t lim_n = pass == 0 ? (n < 500 ? n : 500) : n;

		memset(prev, 0, sizeof(prev));
		for (i = 0; i < lim_n; i++) {
			struct ik_target t;
			struct ik_result res;
			struct vec3 p = { rows[i].p[0], rows[i].p[1], rows[i].p[2] };
			struct quat r = { rows[i].r[0], rows[i].r[1], rows[i].r[2], rows[i].r[3] };
			double q[ARM_DOF], zero[ARM_DOF] = { 0 }, t0, t1;

			t0 = bench_now_ns();
			ik_target_set(&t, &p, &r);
			if (newton)
				ik_newton(&arm, kin, &t, warm ? prev : zero, &opts, q, &res);
			else
				ik_solve(&arm, kin, &t, warm && i > 0 ? prev : NULL, &opts, q, &res);
			t1 = bench_now_ns();
			memcpy(prev, q, sizeof(prev));
			if (pass == 0)
				continue;
			us[i] = (t1 - t0) / 1e3;
			memcpy(sol[i], q, sizeof(q));
			iters += res.iters;
			evals += res.evals;
			ev[i] = res.evals;
			if (res.flags & IK_REACHED)
				reached++;
		}
	}

	for (i = 0; i < n; i++) {
		struct dq fk;
		struct vec3 pc;
		struct quat rt = { rows[i].r[0], rows[i].r[1], rows[i].r[2], rows[i].r[3] };
		double ep, er;
		bool in = true;
		int j;

		arm_fk(&arm, sol[i], &fk);
		dq_translation(&fk, &pc);
		ep = sqrt((pc.x - rows[i].p[0]) * (pc.x - rows[i].p[0]) +
			  (pc.y - rows[i].p[1]) * (pc.y - rows[i].p[1]) +
			  (pc.z - rows[i].p[2]) * (pc.z - rows[i].p[2]));
		quat_normalize(&rt, &rt);
		er = quat_angle_between(&fk.r, &rt) / DEG2RAD;
		if (ep < 1e-4 && er < 0.01)
			strict++;
		if (ep < 1e-3 && er < 0.1)
			loose++;
		for (j = 0; j < ARM_DOF; j++) {
			double a = bench_wrap_deg(sol[i][j] / DEG2RAD);

			if (!(a >= lim.lo[j] / DEG2RAD - 1e-9 && a <= lim.hi[j] / DEG2RAD + 1e-9))
				in = false;
		}
		if (in)
			inlim++;
		if (i > 0) {
			for (j = 0; j < ARM_DOF; j++)
				if (fabs(bench_wrap_deg((sol[i][j] - sol[i - 1][j]) / DEG2RAD)) > 10.0)
					break;
			if (j < ARM_DOF)
				jumps++;
		}
	}

	if (solutions) {
		FILE *f = fopen(solutions, "w");

		if (!f) {
			fprintf(stderr, "avatargw-ikbench: %s: %s\n", solutions, strerror(errno));
			return 1;
		}
		fprintf(f, "row,q1,q2,q3,q4,q5,q6,q7,q8\n");
		for (i = 0; i < n; i++) {
			fprintf(f, "%zu", i);
			for (int j = 0; j < ARM_DOF; j++)
				fprintf(f, ",%.17g", sol[i][j]);
			fprintf(f, "\n");
		}
		if (fclose(f)) {
			fprintf(stderr, "avatargw-ikbench: %s: %s\n", solutions, strerror(errno));
			return 1;
		}
	}

	{
		double *sorted = malloc(n * sizeof(*sorted)), med, p99, max;

		if (!sorted)
			return 1;
		memcpy(sorted, us, n * sizeof(*sorted));
		qsort(sorted, n, sizeof(*sorted), bench_cmp_double);
		med = sorted[n / 2];
		p99 = sorted[(size_t)((n - 1) * 0.99)];
		max = sorted[n - 1];
		if (!quiet) {
			printf("targets      %s\n", targets);
			printf("solver       %s (%s kinematics), mode %s, scalar %s\n",
			       newton ? "paper Newton" : "avatargw", kin->name, mode, SC_NAME);
			printf("dims         S=%.4g A=%.4g F=%.4g H=%.4g m\n", dims.shoulder, dims.arm, dims.forearm,
			       dims.hand);
			printf("rows         %zu\n", n);
			printf("strict       %.4f %%  (< 0.1 mm, < 0.01 deg)\n", 100.0 * strict / n);
			printf("loose        %.4f %%  (< 1 mm, < 0.1 deg)\n", 100.0 * loose / n);
			printf("in limits    %.4f %%\n", 100.0 * inlim / n);
			printf("jumps        %zu  (> 10 deg between consecutive rows)\n", jumps);
			printf("reached      %.4f %% (solver's own flag)\n", 100.0 * reached / n);
			printf("iterations   %.3f mean Newton, %.2f mean closed-form postures\n", iters / n, evals / n);
			printf("time         median %.3f us, p99 %.3f us, max %.3f us\n", med, p99, max);
			qsort(ev, n, sizeof(*ev), bench_cmp_double);
			printf("postures     p50 %.0f, p90 %.0f, p99 %.0f, max %.0f closed-form postures per solve\n",
			       ev[n / 2], ev[(size_t)((n - 1) * 0.9)], ev[(size_t)((n - 1) * 0.99)], ev[n - 1]);
		}
		printf("{\"solver\":\"%s\",\"mode\":\"%s\",\"n\":%zu,\"strict\":%.6f,\"loose\":%.6f,\"in_limits\":%.6f,"
		       "\"jumps\":%zu,\"iters_mean\":%.4f,\"median_us\":%.4f,\"p99_us\":%.4f,\"max_us\":%.4f}\n",
		       solver, mode, n, (double)strict / n, (double)loose / n, (double)inlim / n, jumps, iters / n, med,
		       p99, max);
		free(sorted);
	}
	free(rows);
	free(us);
	free(ev);
	free(sol);
	return 0;
}
