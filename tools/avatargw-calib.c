// SPDX-License-Identifier: MIT
/*
 * avatargw-calib - runs the body-dimension calibrations (ik/calib.h) on one
 * mocap clip in the format of ../shared/mocap/README.md and prints what each
 * method estimates. tools/calib_eval.py turns the output of all clips into
 * docs/CALIBRATION.md.
 *
 *   avatargw-calib [--trials N] [--rounds R] [--pose-deg D] [--noise-mm M] [--seed S] CLIP.csv
 *
 * The clips hold no calibration poses, so the readings are made as follows
 * (the condition column says which):
 *   canonical  the clip's own skeleton, upright: shoulders and head sensor at
 *              their median chest-frame positions, each arm with its own
 *              upper-arm and forearm length (all from the ground-truth
 *              columns), arms placed exactly in the standard poses.
 *   frames     per trial three random frames of the clip, one per pose: the
 *              real chest, shoulders (clavicle motion included) and head
 *              sensor of that frame, arms placed exactly in the pose relative
 *              to gravity and the chest's heading.
 *   noisy      as frames, every arm segment off its pose direction by a
 *              Gaussian angle (--pose-deg per axis) and every sensor
 *              coordinate by Gaussian noise (--noise-mm).
 * With --rounds R the frames and noisy conditions take the three poses R
 * times round per trial (3 R readings, each from its own frame and with its
 * own noise), as `avatargw-ctl calibrate` asks (twice by default); the
 * paper's methods use the first reading.
 *   closest    the real sensor readings of the frames whose ground-truth arm
 *              posture is closest to each pose (info = the mean angle between
 *              the true arm segments and the pose's, degrees).
 * The hand sensors sit at the wrist (H = 0) as in the clips.
 *
 * Methods: paper (the paper's ratios, axes = the chest heading, as if the
 * world were aligned with the person), paper-wrist (Forearm = |dy|, Hand = 0,
 * same axes), paper-wrist-headyaw (the same with the axes turned by the head
 * sensor's heading, what a tracker without an aligned world gives), and
 * poses (calib_poses() on initial + down + forward readings).
 *
 * Output: '#' comment lines (the ground truth derived from the clip, the
 * frames chosen), then CSV with the header
 *   condition,method,trial,rc,S,neck,A,F,H,head_right,head_fwd,rms,info
 * one row per estimate; rc is 0 or a CALIB_E* code (then the values are 0).
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ik/calib.h"

#define PI 3.14159265358979323846
#define DEG2RAD 0.017453292519943295
#define RAD2DEG 57.29577951308232

/* ---- the clip --------------------------------------------------------------------- */

struct frame {
	double head[3], head_q[4];
	double lhand[3], rhand[3];
	double chest[3], chest_q[4];
	double sh[2][3], el[2][3], wr[2][3]; /* ground truth, [0] right, [1] left */
};

struct col {
	const char *name;
	size_t off; /* offset of the double in struct frame */
};

/* clang-format off */
#define COL3(n, f) { n "_x", offsetof(struct frame, f[0]) }, { n "_y", offsetof(struct frame, f[1]) }, \
		{ n "_z", offsetof(struct frame, f[2]) }
#define COLQ(n, f) { n "_qw", offsetof(struct frame, f[0]) }, { n "_qx", offsetof(struct frame, f[1]) }, \
		{ n "_qy", offsetof(struct frame, f[2]) }, { n "_qz", offsetof(struct frame, f[3]) }

static const struct col cols[] = {
	COL3("head", head), COLQ("head", head_q), COL3("lhand", lhand), COL3("rhand", rhand),
	COL3("chest", chest), COLQ("chest", chest_q),
	COL3("rshoulder", sh[0]), COL3("relbow", el[0]), COL3("rwrist", wr[0]),
	COL3("lshoulder", sh[1]), COL3("lelbow", el[1]), COL3("lwrist", wr[1]),
};
/* clang-format on */

#define NCOLS (sizeof(cols) / sizeof(cols[0]))

static char *next_field(char **s)
{
	char *f = *s, *c;

	if (!f)
		return NULL;
	c = strchr(f, ',');
	if (c) {
		*c = 0;
		*s = c + 1;
	} else {
		f[strcspn(f, "\r\n")] = 0;
		*s = NULL;
	}
	return f;
}

static int load_clip(const char *path, struct frame **out, size_t *n)
{
	FILE *f = fopen(path, "r");
	char *line = NULL, *s, *fld;
	size_t cap = 0, len = 0, lineno = 1, k;
	int idx[NCOLS], ncol = 0, c;
	struct frame *fr = NULL;

	if (!f) {
		fprintf(stderr, "avatargw-calib: %s: %s\n", path, strerror(errno));
		return -1;
	}
	if (getline(&line, &cap, f) < 0) {
		fprintf(stderr, "avatargw-calib: %s: empty file\n", path);
		goto fail;
	}
	for (k = 0; k < NCOLS; k++)
		idx[k] = -1;
	for (s = line; (fld = next_field(&s)); ncol++)
		for (k = 0; k < NCOLS; k++)
			if (strcmp(fld, cols[k].name) == 0)
				idx[k] = ncol;
	for (k = 0; k < NCOLS; k++)
		if (idx[k] < 0) {
			fprintf(stderr, "avatargw-calib: %s: no column %s\n", path, cols[k].name);
			goto fail;
		}
	while (getline(&line, &cap, f) >= 0) {
		double v[128];
		struct frame *t;

		lineno++;
		if (line[0] == '\n' || line[0] == 0)
			continue;
		for (s = line, c = 0; (fld = next_field(&s)); c++) {
			char *end;

			if (c >= 128 || c >= ncol)
				break;
			v[c] = strtod(fld, &end);
			if (end == fld) {
				fprintf(stderr, "avatargw-calib: %s:%zu: field %d is not a number\n", path, lineno,
					c + 1);
				goto fail;
			}
		}
		if (c < ncol) {
			fprintf(stderr, "avatargw-calib: %s:%zu: %d fields, want %d\n", path, lineno, c, ncol);
			goto fail;
		}
		if (len == *n) {
			size_t ncap = *n ? 2 * *n : 1024;

			t = realloc(fr, ncap * sizeof(*fr));
			if (!t) {
				fprintf(stderr, "avatargw-calib: out of memory\n");
				goto fail;
			}
			fr = t;
			*n = ncap;
		}
		for (k = 0; k < NCOLS; k++)
			*(double *)((char *)&fr[len] + cols[k].off) = v[idx[k]];
		len++;
	}
	if (len < 3) {
		fprintf(stderr, "avatargw-calib: %s: %zu frames, need at least 3\n", path, len);
		goto fail;
	}
	free(line);
	fclose(f);
	*out = fr;
	*n = len;
	return 0;
fail:
	free(line);
	free(fr);
	fclose(f);
	return -1;
}

/* ---- small geometry ---------------------------------------------------------------- */

static void sub3(const double a[3], const double b[3], double o[3])
{
	o[0] = a[0] - b[0];
	o[1] = a[1] - b[1];
	o[2] = a[2] - b[2];
}

static double dot3(const double a[3], const double b[3])
{
	return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static double norm3(const double a[3])
{
	return sqrt(dot3(a, a));
}

static void normalize3(double a[3])
{
	double n = norm3(a);

	a[0] /= n;
	a[1] /= n;
	a[2] /= n;
}

/* v' = q v q*, q = (w, x, y, z) unit */
static void qrot(const double q[4], const double v[3], double o[3])
{
	double w = q[0], x = q[1], y = q[2], z = q[3];
	double tx = 2 * (y * v[2] - z * v[1]), ty = 2 * (z * v[0] - x * v[2]), tz = 2 * (x * v[1] - y * v[0]);

	o[0] = v[0] + w * tx + (y * tz - z * ty);
	o[1] = v[1] + w * ty + (z * tx - x * tz);
	o[2] = v[2] + w * tz + (x * ty - y * tx);
}

static void qconj(const double q[4], double o[4])
{
	o[0] = q[0];
	o[1] = -q[1];
	o[2] = -q[2];
	o[3] = -q[3];
}

static double angle3(const double a[3], const double b[3])
{
	double c = dot3(a, b) / (norm3(a) * norm3(b));

	return acos(c > 1 ? 1 : c < -1 ? -1 : c);
}

static struct vec3 v3(const double a[3])
{
	return (struct vec3){ a[0], a[1], a[2] };
}

/* the upright frame of the chest: x its horizontal right, y forward, z up */
struct heading {
	double x[3], y[3], z[3];
};

static void chest_heading(const struct frame *f, struct heading *h)
{
	static const double ex[3] = { 1, 0, 0 };

	qrot(f->chest_q, ex, h->x);
	h->x[2] = 0;
	normalize3(h->x);
	h->y[0] = -h->x[1];
	h->y[1] = h->x[0];
	h->y[2] = 0;
	h->z[0] = h->z[1] = 0;
	h->z[2] = 1;
}

/* a yaw-only quaternion whose x axis is h->x: the paper's "world aligned with the person" */
static struct quat heading_quat(const struct heading *h)
{
	double a = atan2(h->x[1], h->x[0]);

	return (struct quat){ cos(a / 2), 0, 0, sin(a / 2) };
}

/* ---- random numbers ------------------------------------------------------------------ */

static uint64_t rng = 0x2545f4914f6cdd1dull;

static double rnd(void)
{
	rng ^= rng << 13;
	rng ^= rng >> 7;
	rng ^= rng << 17;
	return ((double)(rng >> 11) + 0.5) * (1.0 / 9007199254740992.0);
}

static double gauss(void)
{
	return sqrt(-2 * log(rnd())) * cos(2 * PI * rnd());
}

static size_t rnd_index(size_t n)
{
	size_t k = (size_t)(rnd() * (double)n);

	return k < n ? k : n - 1;
}

/* ---- the poses -------------------------------------------------------------------------- */

/* upper-arm and forearm directions of a pose in a heading frame; side 0 right, 1 left */
static void pose_dirs(enum calib_pose p, int side, const struct heading *h, double u1[3], double u2[3])
{
	const double down[3] = { 0, 0, -1 };
	double sx = side ? -1 : 1;
	int k;

	for (k = 0; k < 3; k++) {
		switch (p) {
		case CALIB_POSE_INITIAL:
			u1[k] = down[k];
			u2[k] = h->y[k];
			break;
		case CALIB_POSE_DOWN:
			u1[k] = u2[k] = down[k];
			break;
		case CALIB_POSE_FORWARD:
			u1[k] = u2[k] = h->y[k];
			break;
		case CALIB_POSE_SIDE:
			u1[k] = u2[k] = sx * h->x[k];
			break;
		}
	}
}

/* turns the unit vector u by a random angle of sd sigma (radians) per tangent axis */
static void perturb(double u[3], double sigma)
{
	double g[3] = { gauss() * sigma, gauss() * sigma, gauss() * sigma };
	double d = dot3(g, u);
	int k;

	if (sigma <= 0)
		return;
	for (k = 0; k < 3; k++)
		u[k] += g[k] - d * u[k];
	normalize3(u);
}

/* the body of one person as the truth columns give it */
struct skel {
	double A[2], F[2]; /* per side */
	double sh_c[2][3]; /* shoulders in the chest frame, medians */
	double head_c[3];  /* head sensor in the chest frame, median */
};

struct noise {
	double pose_rad;
	double sensor_m;
};

/*
 * A reading in pose p of a body whose shoulders are at sh[side] and head at
 * head (world), arms posed in the heading frame h.
 */
static void synth_obs(enum calib_pose p, const struct skel *sk, const double sh[2][3], const double head[3],
		      const struct heading *h, const struct noise *nz, struct calib_obs *o)
{
	double hand[2][3], hd[3];
	int s, k;

	for (s = 0; s < 2; s++) {
		double u1[3], u2[3];

		pose_dirs(p, s, h, u1, u2);
		perturb(u1, nz->pose_rad);
		perturb(u2, nz->pose_rad);
		for (k = 0; k < 3; k++)
			hand[s][k] = sh[s][k] + sk->A[s] * u1[k] + sk->F[s] * u2[k] + nz->sensor_m * gauss();
	}
	for (k = 0; k < 3; k++)
		hd[k] = head[k] + nz->sensor_m * gauss();
	o->pose = p;
	o->head = v3(hd);
	o->rhand = v3(hand[0]);
	o->lhand = v3(hand[1]);
}

/* ---- output ----------------------------------------------------------------------------- */

static void print_est(const char *cond, const char *method, int trial, int rc, const struct calib_body *b, double info)
{
	printf("%s,%s,%d,%d,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.3f\n", cond, method, trial, rc, b->dims.shoulder,
	       b->head_offset.z, b->dims.arm, b->dims.forearm, b->dims.hand, b->head_offset.x, b->head_offset.y, b->rms,
	       info);
}

static const enum calib_pose poses3[3] = { CALIB_POSE_INITIAL, CALIB_POSE_DOWN, CALIB_POSE_FORWARD };
#define MAX_ROUNDS 10

/*
 * All methods on three readings (initial, down, forward). head_q: the head
 * sensor orientation at the initial reading; h: the chest heading then.
 */
static void run_methods(const char *cond, int trial, const struct calib_obs *o, size_t n_obs, const struct heading *h,
			const double head_q[4], double info)
{
	struct quat hq = heading_quat(h), sq = { head_q[0], head_q[1], head_q[2], head_q[3] };
	struct calib_body b;
	int rc;

	rc = calib_paper(&o[0].head, &o[0].rhand, &hq, CALIB_HAND_RATIO, &b);
	print_est(cond, "paper", trial, rc, &b, info);
	rc = calib_paper(&o[0].head, &o[0].rhand, &hq, CALIB_HAND_WRIST, &b);
	print_est(cond, "paper-wrist", trial, rc, &b, info);
	rc = calib_paper(&o[0].head, &o[0].rhand, &sq, CALIB_HAND_WRIST, &b);
	print_est(cond, "paper-wrist-headyaw", trial, rc, &b, info);
	rc = calib_poses(o, n_obs, 0, &b);
	print_est(cond, "poses", trial, rc, &b, info);
}

static int cmp_double(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;

	return x < y ? -1 : x > y;
}

static double median(double *v, size_t n)
{
	qsort(v, n, sizeof(*v), cmp_double);
	return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* the skeleton from the ground-truth columns */
static int make_skel(const struct frame *fr, size_t n, struct skel *sk)
{
	double *v = malloc(n * sizeof(*v));
	size_t i;
	int s, k;

	if (!v)
		return -1;
	for (s = 0; s < 2; s++) {
		for (i = 0; i < n; i++) {
			double d[3];

			sub3(fr[i].el[s], fr[i].sh[s], d);
			v[i] = norm3(d);
		}
		sk->A[s] = median(v, n);
		for (i = 0; i < n; i++) {
			double d[3];

			sub3(fr[i].wr[s], fr[i].el[s], d);
			v[i] = norm3(d);
		}
		sk->F[s] = median(v, n);
	}
	/* positions in the chest frame: R^T (p - chest) */
	for (s = 0; s < 3; s++) {
		for (k = 0; k < 3; k++) {
			for (i = 0; i < n; i++) {
				const double *p = s < 2 ? fr[i].sh[s] : fr[i].head;
				double d[3], qc[4], c[3];

				sub3(p, fr[i].chest, d);
				qconj(fr[i].chest_q, qc);
				qrot(qc, d, c);
				v[i] = c[k];
			}
			if (s < 2)
				sk->sh_c[s][k] = median(v, n);
			else
				sk->head_c[k] = median(v, n);
		}
	}
	free(v);
	return 0;
}

/* mean angle between frame f's true arm segments and pose p's, degrees; both arms or the right only */
static double pose_dev(const struct frame *f, enum calib_pose p, int arms)
{
	struct heading h;
	double dev = 0;
	int s;

	chest_heading(f, &h);
	for (s = 0; s < arms; s++) {
		double u1[3], u2[3], a[3], b[3];

		pose_dirs(p, s, &h, u1, u2);
		sub3(f->el[s], f->sh[s], a);
		sub3(f->wr[s], f->el[s], b);
		dev += angle3(a, u1) + angle3(b, u2);
	}
	return dev * RAD2DEG / (2 * arms);
}

static size_t closest_frame(const struct frame *fr, size_t n, enum calib_pose p, int arms, double *dev)
{
	size_t i, best = 0;

	*dev = INFINITY;
	for (i = 0; i < n; i++) {
		double d = pose_dev(&fr[i], p, arms);

		if (d < *dev) {
			*dev = d;
			best = i;
		}
	}
	return best;
}

static void usage(FILE *f)
{
	fprintf(f, "usage: avatargw-calib [--trials N] [--rounds R] [--pose-deg D] [--noise-mm M] [--seed S] CLIP.csv\n"
		   "  --trials N     trials of the frames and noisy conditions (default 200)\n"
		   "  --rounds R     frames, noisy: times round the three poses per trial (default 1)\n"
		   "  --pose-deg D   noisy: sd of each arm segment's direction per axis, degrees (default 5)\n"
		   "  --noise-mm M   noisy: sd of each sensor coordinate, millimetres (default 2)\n"
		   "  --seed S       random seed (default 1)\n");
}

int main(int argc, char **argv)
{
	static const struct option longopts[] = {
		{ "trials", required_argument, NULL, 't' },
		{ "pose-deg", required_argument, NULL, 'p' },
		{ "noise-mm", required_argument, NULL, 'n' },
		{ "seed", required_argument, NULL, 's' },
		{ "rounds", required_argument, NULL, 'r' },
		{ "help", no_argument, NULL, 'h' },
		{ NULL, 0, NULL, 0 },
	};
	struct noise none = { 0, 0 }, noisy = { 5 * DEG2RAD, 0.002 };
	struct frame *fr = NULL;
	struct skel sk;
	size_t n = 0;
	long trials = 200, rounds = 1;
	unsigned long long seed = 1;
	int c, t, s, k;

	while ((c = getopt_long(argc, argv, "t:r:p:n:s:h", longopts, NULL)) != -1) {
		char *end;

		switch (c) {
		case 't':
			trials = strtol(optarg, &end, 10);
			if (*end || trials < 1 || trials > 1000000) {
				fprintf(stderr, "avatargw-calib: bad --trials %s\n", optarg);
				return 2;
			}
			break;
		case 'r':
			rounds = strtol(optarg, &end, 10);
			if (*end || rounds < 1 || rounds > MAX_ROUNDS) {
				fprintf(stderr, "avatargw-calib: bad --rounds %s (1 to %d)\n", optarg, MAX_ROUNDS);
				return 2;
			}
			break;
		case 'p':
			noisy.pose_rad = strtod(optarg, &end) * DEG2RAD;
			if (*end || !(noisy.pose_rad >= 0) || noisy.pose_rad > 1) {
				fprintf(stderr, "avatargw-calib: bad --pose-deg %s\n", optarg);
				return 2;
			}
			break;
		case 'n':
			noisy.sensor_m = strtod(optarg, &end) * 1e-3;
			if (*end || !(noisy.sensor_m >= 0) || noisy.sensor_m > 1) {
				fprintf(stderr, "avatargw-calib: bad --noise-mm %s\n", optarg);
				return 2;
			}
			break;
		case 's':
			seed = strtoull(optarg, &end, 10);
			if (*end) {
				fprintf(stderr, "avatargw-calib: bad --seed %s\n", optarg);
				return 2;
			}
			break;
		case 'h':
			usage(stdout);
			return 0;
		default:
			usage(stderr);
			return 2;
		}
	}
	if (optind != argc - 1) {
		usage(stderr);
		return 2;
	}
	rng ^= seed * 0x9e3779b97f4a7c15ull;
	if (!rng)
		rng = 1;
	if (load_clip(argv[optind], &fr, &n) < 0)
		return 1;
	if (make_skel(fr, n, &sk) < 0) {
		fprintf(stderr, "avatargw-calib: out of memory\n");
		free(fr);
		return 1;
	}

	printf("# clip %s: %zu frames\n", argv[optind], n);
	printf("# truth from the ground-truth columns: upper arm R %.4f L %.4f, forearm R %.4f L %.4f\n", sk.A[0],
	       sk.A[1], sk.F[0], sk.F[1]);
	printf("# chest frame medians: rshoulder %.4f %.4f %.4f, lshoulder %.4f %.4f %.4f, head sensor %.4f %.4f "
	       "%.4f\n",
	       sk.sh_c[0][0], sk.sh_c[0][1], sk.sh_c[0][2], sk.sh_c[1][0], sk.sh_c[1][1], sk.sh_c[1][2], sk.head_c[0],
	       sk.head_c[1], sk.head_c[2]);
	{
		double *yaw = malloc(n * sizeof(*yaw));
		size_t i;

		if (yaw) {
			for (i = 0; i < n; i++) {
				static const double ex[3] = { 1, 0, 0 };
				double hx[3], cx[3], d;

				qrot(fr[i].head_q, ex, hx);
				qrot(fr[i].chest_q, ex, cx);
				d = atan2(hx[1], hx[0]) - atan2(cx[1], cx[0]);
				yaw[i] = atan2(sin(d), cos(d)) * RAD2DEG;
			}
			printf("# head heading relative to the chest: median %.1f deg\n", median(yaw, n));
			free(yaw);
		}
	}
	printf("# noisy: pose sd %.2f deg per axis, sensor sd %.2f mm; trials %ld, rounds %ld, seed %llu\n",
	       noisy.pose_rad * RAD2DEG, noisy.sensor_m * 1e3, trials, rounds, seed);
	printf("condition,method,trial,rc,S,neck,A,F,H,head_right,head_fwd,rms,info\n");

	/* canonical: the median skeleton, chest frame = world, upright */
	{
		static const double q_id[4] = { 1, 0, 0, 0 };
		struct frame f0;
		struct heading h;
		struct calib_obs o[3];

		memset(&f0, 0, sizeof(f0));
		memcpy(f0.chest_q, q_id, sizeof(q_id));
		chest_heading(&f0, &h);
		for (k = 0; k < 3; k++)
			synth_obs(poses3[k], &sk, sk.sh_c, sk.head_c, &h, &none, &o[k]);
		run_methods("canonical", 0, o, 3, &h, q_id, 0);
	}

	/* frames and noisy: the real trunk and head of three random frames */
	for (s = 0; s < 2; s++) {
		const char *cond = s ? "noisy" : "frames";

		for (t = 0; t < trials; t++) {
			struct calib_obs o[3 * MAX_ROUNDS];
			struct heading h0;
			size_t f0 = 0;

			for (k = 0; k < 3 * rounds; k++) {
				size_t fi = rnd_index(n);
				struct heading h;

				chest_heading(&fr[fi], &h);
				synth_obs(poses3[k % 3], &sk, fr[fi].sh, fr[fi].head, &h, s ? &noisy : &none, &o[k]);
				if (k == 0) {
					f0 = fi;
					h0 = h;
				}
			}
			run_methods(cond, t, o, 3 * (size_t)rounds, &h0, fr[f0].head_q, 0);
		}
	}

	/* closest: the real sensors at the frames nearest to the poses */
	{
		struct calib_obs o[3];
		struct heading h;
		struct calib_body b;
		struct quat hq, sq;
		double dev, devs = 0;
		size_t fi;
		int rc;

		fi = closest_frame(fr, n, CALIB_POSE_INITIAL, 1, &dev);
		printf("# closest to initial, right arm: frame %zu, %.1f deg off\n", fi, dev);
		chest_heading(&fr[fi], &h);
		hq = heading_quat(&h);
		sq = (struct quat){ fr[fi].head_q[0], fr[fi].head_q[1], fr[fi].head_q[2], fr[fi].head_q[3] };
		o[0].head = v3(fr[fi].head);
		o[0].rhand = v3(fr[fi].rhand);
		rc = calib_paper(&o[0].head, &o[0].rhand, &hq, CALIB_HAND_RATIO, &b);
		print_est("closest", "paper", 0, rc, &b, dev);
		rc = calib_paper(&o[0].head, &o[0].rhand, &hq, CALIB_HAND_WRIST, &b);
		print_est("closest", "paper-wrist", 0, rc, &b, dev);
		rc = calib_paper(&o[0].head, &o[0].rhand, &sq, CALIB_HAND_WRIST, &b);
		print_est("closest", "paper-wrist-headyaw", 0, rc, &b, dev);
		for (k = 0; k < 3; k++) {
			fi = closest_frame(fr, n, poses3[k], 2, &dev);
			printf("# closest to pose %d, both arms: frame %zu, %.1f deg off\n", poses3[k], fi, dev);
			devs += dev;
			o[k].pose = poses3[k];
			o[k].head = v3(fr[fi].head);
			o[k].lhand = v3(fr[fi].lhand);
			o[k].rhand = v3(fr[fi].rhand);
		}
		rc = calib_poses(o, 3, 0, &b);
		print_est("closest", "poses", 0, rc, &b, devs / 3);
	}

	free(fr);
	return 0;
}
