// SPDX-License-Identifier: MIT
/*
 * avatargw-eval - runs avatargw's avatar (the IK core: avatar_init,
 * avatar_solve) over recorded sensor poses and writes what it made of every
 * frame, for tools/eval.py to score against ground truth.
 *
 *   avatargw-eval [--dims S,A,F,H] [--left-arm A,F,H] [--head-offset X,Y,Z] [--limits FILE]
 *       [--rest-pronation DEG] [--solver dq|matrix] [--reset] [--keyframes HZ [--interp METHOD]]
 *       [--person SOURCE/PREFIX] INPUT
 *
 * INPUT is a sensor CSV in the format of ../shared/mocap/README.md (columns
 * t and head_*, lhand_*, rhand_*: x y z qw qx qy qz; other columns are
 * ignored) or a recording of the daemon (docs/RECORDING.md): the person
 * given by --person (as an avatar's person key would name it: SOURCE for a
 * replayed clip, SOURCE/pN for a simulated person), by default the sensors
 * of the first avatar of the recording. A recording becomes one row per
 * moment at which one of the person's sensors has a new sample, each sensor
 * at its newest sample.
 *
 * --keyframes HZ keeps only the samples nearest to the instants k / HZ
 * (from the first row's time) and rebuilds every row's sensor poses from
 * them with --interp linear, catmull-rom (default) or natural
 * (record/keyframe.h): the paper's low-rate storage.
 * --reset solves every frame from the rest posture (the paper's strategy)
 * instead of tracking from the previous frame.
 *
 * Output on stdout, CSV with a header line, one row per input row:
 *   frame,t            input row and its time (s)
 *   flags_r,flags_l    IK result flags per arm (ik.h)
 *   yaw                the chest's yaw about world z, degrees
 *   chest_x..chest_qz  the avatar's chest frame (chain origin), world
 *   {r,l}sh_*, {r,l}el_*, {r,l}wr_*, {r,l}hd_*  shoulder, elbow, wrist
 *                      centre and hand (end effector) positions, world, m
 *   {r,l}res           |hand - hand sensor|, m
 *   {r,l}misfit        AVATAR_HAND_ELBOW: running mean of the least swivel cost (1: one natural range)
 *   {r,l}q1..q8        joint angles, degrees
 *   head_*, lhand_*, rhand_*  the sensor poses the avatar was given
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ik/avatar.h"
#include "record/keyframe.h"
#include "lib/benchfile.h"
#include "record/recload.h"

#define RAD2DEG 57.29577951308232
#define DEG2RAD 0.017453292519943295

/* one moment: head, left hand, right hand as x y z qw qx qy qz; the true chest if the CSV has it */
struct row {
	double t;
	double s[3][7];
	double chest[7];
	bool has_chest;
};

static const char *const prefixes[3] = { "head", "lhand", "rhand" };
static const char *const fields[7] = { "x", "y", "z", "qw", "qx", "qy", "qz" };

static void usage(FILE *f)
{
	fprintf(f, "usage: avatargw-eval [--dims S,A,F,H] [--head-offset X,Y,Z] [--limits FILE]\n"
		   "       [--left-arm A,F,H] [--rest-pronation DEG] [--solver dq|matrix] [--reset] [--model MODEL]\n"
		   "       [--chest-truth X,Y,Z [--chest-part all|yaw|upright]]\n"
		   "       [--keyframes HZ [--interp linear|catmull-rom|natural]]\n"
		   "       [--person SOURCE/PREFIX] INPUT.csv|INPUT.agwrec\n"
		   "  --left-arm     the left arm's own lengths (the right's are --dims)\n"
		   "  --rest-pronation  the forearm's pronation at rest (J6, degrees; -30 unless given)\n"
		   "  --model        paper, default, or names joined by '+' (or taken away by '-'): hand-elbow,\n"
		   "                 reach-first, yaw-hands, reach-chest, neck, bow, keep-branch, reach-roll,\n"
		   "                 bow-head, lean, raise-roll, arm-twist, yaw-reach (the\n"
		   "                 avatar's choices, docs/IK.md), e.g. default-bow\n"
		   "  --chest-truth  the chest from the CSV's true chest columns (X,Y,Z: the chain origin in\n"
		   "                 the chest frame); --chest-part: all of it, its heading only, or upright\n");
}

/* ---- input: sensor CSV ---------------------------------------------------------------- */

static int push_row(struct row **rows, size_t *n, size_t *cap, const struct row *r)
{
	if (*n == *cap) {
		size_t nc = *cap ? 2 * *cap : 1024;
		struct row *nr = realloc(*rows, nc * sizeof(*nr));

		if (!nr)
			return -1;
		*rows = nr;
		*cap = nc;
	}
	(*rows)[(*n)++] = *r;
	return 0;
}

static int load_csv(const char *path, FILE *f, struct row **rows, size_t *n)
{
	char *line = NULL, *tok, *save;
	size_t lcap = 0, cap = 0, lineno = 1;
	int col[3][7], cc[7], ct = -1, i = 0, maxcol = 0;
	bool has_chest = true;

	if (getline(&line, &lcap, f) < 0) {
		fprintf(stderr, "avatargw-eval: %s: empty\n", path);
		free(line);
		return -1;
	}
	for (int r = 0; r < 3; r++)
		for (int k = 0; k < 7; k++)
			col[r][k] = -1;
	for (int k = 0; k < 7; k++)
		cc[k] = -1;
	for (tok = strtok_r(line, ",\r\n", &save); tok; tok = strtok_r(NULL, ",\r\n", &save), i++) {
		if (!strcmp(tok, "t"))
			ct = i;
		if (!strncmp(tok, "chest_", 6))
			for (int k = 0; k < 7; k++)
				if (!strcmp(tok + 6, fields[k]))
					cc[k] = i;
		for (int r = 0; r < 3; r++) {
			size_t pl = strlen(prefixes[r]);

			if (strncmp(tok, prefixes[r], pl) || tok[pl] != '_')
				continue;
			for (int k = 0; k < 7; k++)
				if (!strcmp(tok + pl + 1, fields[k]))
					col[r][k] = i;
		}
	}
	if (ct < 0) {
		fprintf(stderr, "avatargw-eval: %s: no column t\n", path);
		free(line);
		return -1;
	}
	maxcol = ct;
	for (int r = 0; r < 3; r++)
		for (int k = 0; k < 7; k++) {
			if (col[r][k] < 0) {
				fprintf(stderr, "avatargw-eval: %s: no column %s_%s\n", path, prefixes[r], fields[k]);
				free(line);
				return -1;
			}
			if (col[r][k] > maxcol)
				maxcol = col[r][k];
		}
	for (int k = 0; k < 7; k++) {
		has_chest &= cc[k] >= 0;
		if (cc[k] > maxcol)
			maxcol = cc[k];
	}
	while (getline(&line, &lcap, f) >= 0) {
		double v[256];
		char *s = line, *end;
		int c = 0;
		struct row r;

		lineno++;
		if (line[0] == '\n' || line[0] == '\r' || line[0] == '#' || !line[0])
			continue;
		while (c <= maxcol && c < 256) {
			v[c] = strtod(s, &end);
			if (end == s)
				break;
			c++;
			if (*end != ',')
				break;
			s = end + 1;
		}
		if (c <= maxcol) {
			fprintf(stderr, "avatargw-eval: %s:%zu: unreadable row\n", path, lineno);
			free(line);
			return -1;
		}
		r.t = v[ct];
		for (int j = 0; j < 3; j++)
			for (int k = 0; k < 7; k++)
				r.s[j][k] = v[col[j][k]];
		r.has_chest = has_chest;
		for (int k = 0; k < 7; k++)
			r.chest[k] = has_chest ? v[cc[k]] : 0;
		if (push_row(rows, n, &cap, &r)) {
			free(line);
			return -1;
		}
	}
	free(line);
	return 0;
}

/* ---- input: a recording ----------------------------------------------------------------- */

static int load_recording(const char *path, const char *person, struct row **rows, size_t *n)
{
	struct rec_index ix;
	char err[512], label[300];
	int sensor[3];
	bool have[3] = { false, false, false };
	struct row cur = { 0 };
	size_t cap = 0;

	if (rec_index_load(path, &ix, err, sizeof(err))) {
		fprintf(stderr, "avatargw-eval: %s\n", err);
		return -1;
	}
	if (rec_index_person(&ix, person, sensor, label, sizeof(label), err, sizeof(err))) {
		fprintf(stderr, "avatargw-eval: %s: %s\n", path, err);
		rec_index_free(&ix);
		return -1;
	}
	for (size_t d = 0; d < ix.n_damage; d++)
		fprintf(stderr, "avatargw-eval: %s: bytes %zu..%zu skipped (%s)\n", path, ix.damage[d].off,
			ix.damage[d].off + ix.damage[d].len, ix.damage[d].truncated ? "cut off" : "damaged");
	/* one row per arrival time at which one of the person's sensors has a new sample */
	for (size_t i = 0; i < ix.n_events; i++) {
		const struct rec_event *e = &ix.events[i];
		int r = -1;

		for (int k = 0; k < 3; k++)
			if ((int)e->sensor == sensor[k])
				r = k;
		if (r < 0)
			continue;
		for (int k = 0; k < 3; k++)
			cur.s[r][k] = e->p[k];
		for (int k = 0; k < 4; k++)
			cur.s[r][3 + k] = e->q[k];
		have[r] = true;
		cur.t = (double)(e->arrival_ns - ix.events[0].arrival_ns) * 1e-9;
		if (!have[0] || !have[1] || !have[2])
			continue;
		/* the samples of one poll share their arrival: one row for all of them */
		if (i + 1 < ix.n_events && ix.events[i + 1].arrival_ns == e->arrival_ns)
			continue;
		if (*n && cur.t <= (*rows)[*n - 1].t)
			continue;
		if (push_row(rows, n, &cap, &cur)) {
			rec_index_free(&ix);
			return -1;
		}
	}
	fprintf(stderr, "avatargw-eval: %s: %s (%s, %s, %s): %zu rows\n", path, label, ix.names[sensor[0]],
		ix.names[sensor[1]], ix.names[sensor[2]], *n);
	rec_index_free(&ix);
	return 0;
}

/* ---- keyframes ---------------------------------------------------------------------------- */

/* keeps the rows nearest to t0 + k / hz and rebuilds every row's sensors from them */
static int keyframe_rows(struct row *rows, size_t n, double hz, enum kf_interp m)
{
	size_t *idx = calloc(n, sizeof(*idx)), nk = 0;
	double *kt = calloc(n, sizeof(*kt));
	struct kf_pose *key = calloc(n, sizeof(*key));
	double(*d2)[3] = calloc(n, sizeof(*d2));
	double(*s)[4] = calloc(n, sizeof(*s));
	double *work = calloc(n, sizeof(*work));
	int rc = -1;

	if (!idx || !kt || !key || !d2 || !s || !work)
		goto out;
	for (size_t i = 0, k = 0; i < n; k++) {
		double want = rows[0].t + (double)k / hz;
		size_t best = i;

		if (want > rows[n - 1].t + 0.5 / hz)
			break;
		while (best + 1 < n && fabs(rows[best + 1].t - want) <= fabs(rows[best].t - want))
			best++;
		if (!nk || best != idx[nk - 1])
			idx[nk++] = best;
		i = best;
		if (want > rows[n - 1].t)
			break;
	}
	fprintf(stderr, "avatargw-eval: %zu keyframes at %g Hz (%s) for %zu rows\n", nk, hz, kf_interp_name(m), n);
	for (int j = 0; j < 3; j++) {
		struct kf_track tr = { m,
				       nk,
				       kt,
				       key,
				       m == KF_NATURAL ? d2 : NULL,
				       m != KF_LINEAR ? s : NULL,
				       m == KF_NATURAL ? work : NULL };

		for (size_t k = 0; k < nk; k++) {
			kt[k] = rows[idx[k]].t;
			memcpy(key[k].p, rows[idx[k]].s[j], 3 * sizeof(double));
			memcpy(key[k].q, rows[idx[k]].s[j] + 3, 4 * sizeof(double));
		}
		if (kf_prepare(&tr)) {
			fprintf(stderr, "avatargw-eval: keyframes of %s are not usable\n", prefixes[j]);
			goto out;
		}
		for (size_t i = 0; i < n; i++) {
			struct kf_pose o;

			kf_eval(&tr, rows[i].t, &o);
			memcpy(rows[i].s[j], o.p, 3 * sizeof(double));
			memcpy(rows[i].s[j] + 3, o.q, 4 * sizeof(double));
		}
	}
	rc = 0;
out:
	free(idx);
	free(kt);
	free(key);
	free(d2);
	free(s);
	free(work);
	return rc;
}

/* ---- the avatar ----------------------------------------------------------------------------- */

static void pose_dq(const double s[7], struct dq *out)
{
	struct quat r = { s[3], s[4], s[5], s[6] };
	struct vec3 t = { s[0], s[1], s[2] };

	if (!quat_normalize(&r, &r))
		r = (struct quat){ NAN, NAN, NAN, NAN };
	dq_from_rt(&r, &t, out);
}

static void print_header(void)
{
	static const char *const side[2] = { "r", "l" };
	static const char *const pt[4] = { "sh", "el", "wr", "hd" };

	printf("frame,t,flags_r,flags_l,yaw,chest_x,chest_y,chest_z,chest_qw,chest_qx,chest_qy,chest_qz");
	for (int s = 0; s < 2; s++) {
		for (int p = 0; p < 4; p++)
			printf(",%s%s_x,%s%s_y,%s%s_z", side[s], pt[p], side[s], pt[p], side[s], pt[p]);
		printf(",%sres,%smisfit", side[s], side[s]);
		for (int j = 1; j <= ARM_DOF; j++)
			printf(",%sq%d", side[s], j);
	}
	for (int r = 0; r < 3; r++)
		for (int k = 0; k < 7; k++)
			printf(",%s_%s", prefixes[r], fields[k]);
	putchar('\n');
}

static void world_point(const struct dq *chest, const struct vec3 *local, struct vec3 *out)
{
	dq_transform_point(chest, local, out);
}

/* hand[side]: the hand sensors, indexed ARM_RIGHT, ARM_LEFT */
static void print_frame(size_t i, const struct row *r, const struct avatar *av, const struct avatar_pose *p,
			const struct dq hand[2])
{
	static const int side_of[2] = { ARM_RIGHT, ARM_LEFT };
	struct vec3 c;

	dq_translation(&p->chest, &c);
	printf("%zu,%.6f,%u,%u,%.4f", i, r->t, p->res[ARM_RIGHT].flags, p->res[ARM_LEFT].flags, p->head_yaw * RAD2DEG);
	printf(",%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f", c.x, c.y, c.z, p->chest.r.w, p->chest.r.x, p->chest.r.y,
	       p->chest.r.z);
	for (int k = 0; k < 2; k++) {
		int s = side_of[k];
		struct arm_pose ap;
		struct vec3 w[4], hs;
		const struct vec3 *lp[4] = { &ap.shoulder, &ap.elbow, &ap.wrist, &ap.hand };

		arm_fk_pose(&av->arm[s], p->q[s], &ap);
		for (int m = 0; m < 4; m++) {
			world_point(&p->chest, lp[m], &w[m]);
			printf(",%.6f,%.6f,%.6f", w[m].x, w[m].y, w[m].z);
		}
		dq_translation(&hand[s], &hs);
		printf(",%.7f,%.3f",
		       sqrt((w[3].x - hs.x) * (w[3].x - hs.x) + (w[3].y - hs.y) * (w[3].y - hs.y) +
			    (w[3].z - hs.z) * (w[3].z - hs.z)),
		       (double)p->hand_misfit[s]);
		for (int j = 0; j < ARM_DOF; j++)
			printf(",%.4f", p->q[s][j] * RAD2DEG);
	}
	for (int j = 0; j < 3; j++)
		for (int k = 0; k < 7; k++)
			printf(",%.6f", r->s[j][k]);
	putchar('\n');
}

/*
 * A diagnosis (--chest-truth): the arms solved from the true chest of the
 * clip (its position and full orientation, the chain origin at co in it)
 * instead of the chest the avatar places from the head.
 */
enum chest_part { CHEST_ALL, CHEST_YAW, CHEST_UPRIGHT };

static void solve_true_chest(const struct avatar *av, const struct ik_kin *kin, const struct ik_opts *o,
			     const struct row *r, const double co[3], enum chest_part part, const struct dq *head,
			     const struct dq *lhand, const struct dq *rhand, const struct avatar_pose *prev,
			     struct avatar_pose *out)
{
	struct quat q = { r->chest[3], r->chest[4], r->chest[5], r->chest[6] };
	struct vec3 c = { co[0], co[1], co[2] }, rc, p;
	const struct dq *hand[2] = { rhand, lhand };

	quat_normalize(&q, &q);
	quat_rotate(&q, &c, &rc);
	p = (struct vec3){ r->chest[0] + rc.x, r->chest[1] + rc.y, r->chest[2] + rc.z };
	{
		struct vec3 x = { 1, 0, 0 }, xr;

		quat_rotate(&q, &x, &xr);
		out->head_yaw = atan2(xr.y, xr.x);
	}
	if (part != CHEST_ALL) {
		/* upright, turned to the true heading; placed from the head (yaw) or at the true origin (upright) */
		q = (struct quat){ cos(out->head_yaw / 2), 0, 0, sin(out->head_yaw / 2) };
		if (part == CHEST_YAW) {
			struct vec3 hp, off;

			dq_translation(head, &hp);
			quat_rotate(&q, &av->body.head_offset, &off);
			p = (struct vec3){ hp.x - off.x, hp.y - off.y, hp.z - off.z };
		}
	}
	dq_from_rt(&q, &p, &out->chest);
	for (int side = 0; side < 2; side++) {
		struct ik_target t;

		avatar_arm_target(&out->chest, hand[side], &t);
		avatar_arm_solve(av, side, kin, o, &t, prev, out);
	}
}

/* "paper", "default", or names joined by '+' (added) or '-' (taken away), e.g. default-bow */
static int parse_model(const char *s)
{
	static const struct {
		const char *name;
		unsigned bit;
	} names[] = { { "paper", AVATAR_PAPER },
		      { "default", AVATAR_MODEL_DEFAULT },
		      { "hand-elbow", AVATAR_HAND_ELBOW },
		      { "reach-first", AVATAR_REACH_FIRST },
		      { "yaw-hands", AVATAR_YAW_HANDS },
		      { "reach-chest", AVATAR_REACH_CHEST },
		      { "neck", AVATAR_NECK },
		      { "bow", AVATAR_BOW },
		      { "keep-branch", AVATAR_KEEP_BRANCH },
		      { "reach-roll", AVATAR_REACH_ROLL },
		      { "bow-head", AVATAR_BOW_HEAD },
		      { "lean", AVATAR_LEAN },
		      { "raise-roll", AVATAR_RAISE_ROLL },
		      { "arm-twist", AVATAR_ARM_TWIST },
		      { "yaw-reach", AVATAR_YAW_REACH } };
	unsigned m = 0;
	bool add = true;

	while (*s) {
		size_t n = 0;
		bool found = false;

		/* a name runs to the next '+', or to a '-' that starts a known name */
		for (;;) {
			n += strcspn(s + n, "+-");
			if (s[n] != '-')
				break;
			for (size_t i = 0; i < sizeof(names) / sizeof(names[0]); i++)
				if (!strncmp(s + n + 1, names[i].name, strlen(names[i].name)) &&
				    strchr("+-", s[n + 1 + strlen(names[i].name)]))
					found = true;
			if (found)
				break;
			n++;
		}
		found = false;
		for (size_t i = 0; i < sizeof(names) / sizeof(names[0]); i++)
			if (strlen(names[i].name) == n && !strncmp(s, names[i].name, n)) {
				m = add ? m | names[i].bit : m & ~names[i].bit;
				found = true;
			}
		if (!found)
			return -1;
		s += n;
		if (*s)
			add = *s++ == '+';
	}
	return (int)m;
}

static int parse_list(const char *s, double *v, int n)
{
	for (int i = 0; i < n; i++) {
		char *end;

		v[i] = strtod(s, &end);
		if (end == s || !isfinite(v[i]))
			return -1;
		s = end;
		if (i + 1 < n) {
			if (*s != ',')
				return -1;
			s++;
		}
	}
	return *s ? -1 : 0;
}

int main(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "dims", required_argument, NULL, 'd' },
		{ "head-offset", required_argument, NULL, 'o' },
		{ "limits", required_argument, NULL, 'l' },
		{ "solver", required_argument, NULL, 's' },
		{ "reset", no_argument, NULL, 'r' },
		{ "keyframes", required_argument, NULL, 'k' },
		{ "interp", required_argument, NULL, 'i' },
		{ "person", required_argument, NULL, 'p' },
		{ "chest-truth", required_argument, NULL, 'c' },
		{ "model", required_argument, NULL, 'm' },
		{ "left-arm", required_argument, NULL, 'L' },
		{ "chest-part", required_argument, NULL, 'P' },
		{ "rest-pronation", required_argument, NULL, 'R' },
		{ "help", no_argument, NULL, 'h' },
		{ NULL, 0, NULL, 0 },
	};
	double dims[4] = { 0.1732, 0.2886, 0.1955, 0.0 }, off[3] = { 0.008, -0.0386, 0.0967 }, kf_hz = 0;
	double truth[3];
	bool chest_truth = false;
	enum chest_part part = CHEST_ALL;
	int model = -1;
	double left[3], rest_pron = NAN;
	bool have_left = false;
	const char *limits = NULL, *person = NULL, *path;
	const struct ik_kin *kin = &ik_kin_dq;
	enum kf_interp interp = KF_CATMULL_ROM;
	bool reset = false;
	struct arm_limits lim;
	struct arm_dims ad;
	struct vec3 ho;
	struct avatar av;
	struct ik_opts o;
	struct avatar_pose pose[2];
	struct row *rows = NULL;
	size_t n = 0;
	unsigned char magic[8] = { 0 };
	FILE *f;
	char *end;
	int opt, rc;

	while ((opt = getopt_long(argc, argv, "h", opts, NULL)) != -1) {
		switch (opt) {
		case 'd':
			if (parse_list(optarg, dims, 4)) {
				fprintf(stderr, "avatargw-eval: --dims wants S,A,F,H in metres\n");
				return 2;
			}
			break;
		case 'o':
			if (parse_list(optarg, off, 3)) {
				fprintf(stderr, "avatargw-eval: --head-offset wants X,Y,Z in metres\n");
				return 2;
			}
			break;
		case 'l':
			limits = optarg;
			break;
		case 's':
			if (!strcmp(optarg, "dq"))
				kin = &ik_kin_dq;
			else if (!strcmp(optarg, "matrix"))
				kin = &ik_kin_mat;
			else {
				fprintf(stderr, "avatargw-eval: --solver dq or matrix\n");
				return 2;
			}
			break;
		case 'r':
			reset = true;
			break;
		case 'k':
			kf_hz = strtod(optarg, NULL);
			if (!(kf_hz > 0 && kf_hz < 1e4)) {
				fprintf(stderr, "avatargw-eval: --keyframes wants a rate in Hz\n");
				return 2;
			}
			break;
		case 'i':
			rc = kf_interp_parse(optarg);
			if (rc < 0) {
				fprintf(stderr, "avatargw-eval: --interp linear, catmull-rom or natural\n");
				return 2;
			}
			interp = (enum kf_interp)rc;
			break;
		case 'p':
			person = optarg;
			break;
		case 'L':
			if (parse_list(optarg, left, 3)) {
				fprintf(stderr, "avatargw-eval: --left-arm wants A,F,H in metres\n");
				return 2;
			}
			have_left = true;
			break;
		case 'm':
			model = parse_model(optarg);
			if (model < 0) {
				fprintf(stderr,
					"avatargw-eval: --model paper, default, or names joined by '+': "
					"hand-elbow, reach-first, yaw-hands, reach-chest, neck, bow, "
					"keep-branch, reach-roll, bow-head, lean, raise-roll, arm-twist, yaw-reach\n");
				return 2;
			}
			break;
		case 'c':
			if (parse_list(optarg, truth, 3)) {
				fprintf(stderr, "avatargw-eval: --chest-truth wants the chain origin X,Y,Z in the "
						"chest frame\n");
				return 2;
			}
			chest_truth = true;
			break;
		case 'P':
			if (!strcmp(optarg, "yaw"))
				part = CHEST_YAW;
			else if (!strcmp(optarg, "upright"))
				part = CHEST_UPRIGHT;
			else if (!strcmp(optarg, "all"))
				part = CHEST_ALL;
			else {
				fprintf(stderr, "avatargw-eval: --chest-part all, yaw or upright\n");
				return 2;
			}
			break;
		case 'R':
			rest_pron = strtod(optarg, &end);
			if (end == optarg || *end || !(fabs(rest_pron) <= 90)) {
				fprintf(stderr, "avatargw-eval: --rest-pronation wants degrees, -90 to 90\n");
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
	if (optind + 1 != argc) {
		usage(stderr);
		return 2;
	}
	path = argv[optind];
	avatar_default_limits(&lim);
	if (limits && bench_load_limits("avatargw-eval", limits, &lim))
		return 1;

	f = fopen(path, "r");
	if (!f) {
		fprintf(stderr, "avatargw-eval: %s: %s\n", path, strerror(errno));
		return 1;
	}
	rc = (int)fread(magic, 1, sizeof(magic), f);
	if (rc == (int)sizeof(magic) && recfile_is_recording(magic, sizeof(magic))) {
		fclose(f);
		rc = load_recording(path, person, &rows, &n);
	} else {
		rewind(f);
		rc = load_csv(path, f, &rows, &n);
		fclose(f);
	}
	if (rc || n < 2) {
		if (!rc)
			fprintf(stderr, "avatargw-eval: %s: fewer than 2 rows\n", path);
		free(rows);
		return 1;
	}
	if (kf_hz > 0 && keyframe_rows(rows, n, kf_hz, interp)) {
		free(rows);
		return 1;
	}

	ad = (struct arm_dims){ dims[0], dims[1], dims[2], dims[3] };
	ho = (struct vec3){ off[0], off[1], off[2] };
	avatar_init(&av, &ad, &ho, &lim);
	if (model >= 0)
		av.body.model = (unsigned)model;
	if (have_left)
		avatar_set_left_arm(&av, left[0], left[1], left[2]);
	if (!isnan(rest_pron))
		avatar_set_rest_pronation(&av, rest_pron * (M_PI / 180));
	ik_default_opts(&o);
	print_header();
	for (size_t i = 0; i < n; i++) {
		struct avatar_pose *cur = &pose[i & 1], *prev = i && !reset ? &pose[(i - 1) & 1] : NULL;
		struct dq head, hand[2];

		pose_dq(rows[i].s[0], &head);
		pose_dq(rows[i].s[1], &hand[ARM_LEFT]);
		pose_dq(rows[i].s[2], &hand[ARM_RIGHT]);
		if (chest_truth && rows[i].has_chest)
			solve_true_chest(&av, kin, &o, &rows[i], truth, part, &head, &hand[ARM_LEFT], &hand[ARM_RIGHT],
					 prev, cur);
		else
			avatar_solve(&av, kin, &o, &head, &hand[ARM_LEFT], &hand[ARM_RIGHT], prev, cur);
		print_frame(i, &rows[i], &av, cur, hand);
	}
	free(rows);
	return 0;
}
