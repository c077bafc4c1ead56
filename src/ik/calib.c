// SPDX-License-Identifier: MIT
/*
 * calib.c - body dimensions from sensor readings in known poses: the paper's
 * heuristic and our least-squares fit over several poses. See ik/calib.h.
 * Compiled once per scalar type.
 */
#include "ik/calib.h"

/*
 * Unknowns of calib_poses(), in this order. The lateral offset of the head
 * sensor is not one of them: it is eliminated per reading (see obs_eqs()).
 */
enum {
	U_S,	/* Shoulder */
	U_A,	/* Arm */
	U_L,	/* Forearm + Hand: straight arms cannot tell them apart */
	U_NECK, /* head sensor height above the chain origin */
	U_HF,	/* head sensor offset along chest y */
	U_N
};

/*
 * Where the right-hand sensor is in each pose, relative to the chain origin,
 * as coefficients of S, A and L = F + H (see enum calib_pose):
 * x = S + cx (A + L), y = ya A + yl L, z = za A + zl L.
 */
struct pose_coef {
	signed char cx, ya, yl, za, zl;
};

static const struct pose_coef pose_coef[CALIB_NPOSES] = {
	[CALIB_POSE_INITIAL] = { 0, 0, 1, -1, 0 },
	[CALIB_POSE_DOWN] = { 0, 0, 0, -1, -1 },
	[CALIB_POSE_FORWARD] = { 0, 1, 1, 0, 0 },
	[CALIB_POSE_SIDE] = { 1, 0, 0, 0, 0 },
};

/* shortest length we call a body segment, and least sensor separations */
#define MIN_LEN SC_C(0.001)
#define MIN_PAPER_SEP SC_C(0.01)
#define MIN_HANDS_SEP SC_C(0.05)
/* a pivot of the normal equations below this fraction of the largest diagonal means rank deficiency */
#define PIVOT_TOL SC_C(1e-4)

static bool v3_finite(const struct vec3 *v)
{
	return sc_isfinite(v->x) && sc_isfinite(v->y) && sc_isfinite(v->z);
}

static void v3_sub(const struct vec3 *a, const struct vec3 *b, struct vec3 *out)
{
	out->x = a->x - b->x;
	out->y = a->y - b->y;
	out->z = a->z - b->z;
}

static bool len_ok(sc_t l)
{
	return sc_isfinite(l) && l >= MIN_LEN && l <= CALIB_MAX_LEN;
}

static int fail(struct calib_body *out, int err)
{
	if (out)
		*out = (struct calib_body){ .dims = { 0, 0, 0, 0 }, .head_offset = { 0, 0, 0 }, .rms = 0 };
	return err;
}

bool calib_heading(const struct quat *q, struct vec3 *right)
{
	static const struct vec3 ex = { SC_C(1), 0, 0 };
	struct quat u;
	struct vec3 x;
	sc_t h;

	if (!right)
		return false;
	*right = ex;
	if (!q || !sc_isfinite(q->w) || !sc_isfinite(q->x) || !sc_isfinite(q->y) || !sc_isfinite(q->z))
		return false;
	if (!quat_normalize(q, &u))
		return false;
	quat_rotate(&u, &ex, &x);
	/* |horizontal part| < sin(~6 deg): x is too close to vertical to define a heading */
	h = sc_sqrt(sc_acc_get(sc_mac(sc_mac(sc_acc0(), x.x, x.x), x.y, x.y)));
	if (!(h >= SC_C(0.1)))
		return false;
	right->x = sc_div(x.x, h);
	right->y = sc_div(x.y, h);
	right->z = 0;
	return true;
}

int calib_paper(const struct vec3 *head, const struct vec3 *rhand, const struct quat *head_q, enum calib_hand mode,
		struct calib_body *out)
{
	struct vec3 d;
	sc_t dx, dy, dz;

	if (!out)
		return CALIB_EINVAL;
	if (!head || !rhand || !v3_finite(head) || !v3_finite(rhand))
		return fail(out, CALIB_EINVAL);
	if (head_q &&
	    (!sc_isfinite(head_q->w) || !sc_isfinite(head_q->x) || !sc_isfinite(head_q->y) || !sc_isfinite(head_q->z)))
		return fail(out, CALIB_EINVAL);
	if (mode != CALIB_HAND_RATIO && mode != CALIB_HAND_WRIST)
		return fail(out, CALIB_EINVAL);
	v3_sub(rhand, head, &d);
	if (!v3_finite(&d))
		return fail(out, CALIB_ERANGE);
	if (!(v3_norm(&d) >= MIN_PAPER_SEP))
		return fail(out, CALIB_EDEGENERATE);
	if (head_q) {
		struct vec3 r;

		if (!calib_heading(head_q, &r))
			return fail(out, CALIB_EDEGENERATE);
		/* components along the head's right and forward (-r.y, r.x) */
		dx = sc_acc_get(sc_mac(sc_mac(sc_acc0(), d.x, r.x), d.y, r.y));
		dy = sc_acc_get(sc_mac(sc_msb(sc_acc0(), d.x, r.y), d.y, r.x));
	} else {
		dx = d.x;
		dy = d.y;
	}
	dz = d.z;

	out->dims.shoulder = sc_abs(dx);
	out->dims.arm = sc_mul(sc_abs(dz), SC_C(0.5));
	if (mode == CALIB_HAND_RATIO) {
		out->dims.forearm = sc_mul(sc_abs(dy), SC_C(0.7));
		out->dims.hand = sc_mul(sc_abs(dy), SC_C(0.3));
	} else {
		out->dims.forearm = sc_abs(dy);
		out->dims.hand = 0;
	}
	out->head_offset = (struct vec3){ 0, 0, out->dims.arm };
	out->rms = 0;
	if (!len_ok(out->dims.shoulder) || !len_ok(out->dims.arm) || !len_ok(out->dims.forearm))
		return fail(out, CALIB_ERANGE);
	return CALIB_OK;
}

/*
 * The six equations of one reading: rows over the unknowns U_*, measured
 * values (hand - head in the reading's upright frame, r right, l left) and
 * the head's lateral offset c of this reading.
 *
 * The heading of a reading comes from its two hands, so a hand that is a
 * little ahead of the other turns the frame and shifts both hands sideways
 * by the angle times their forward distance: with arms forward, 2 mm of
 * noise over a 20 cm shoulder width moves them 6 mm. A lateral offset per
 * reading takes that up; it is eliminated by using the half difference
 * (r.x - l.x) / 2 = S + cx (A + L) for both x equations, and
 * c = -(r.x + l.x) / 2 is the offset. The y and z equations are one per hand.
 */
static void obs_eqs(const struct pose_coef *pc, const struct vec3 *r, const struct vec3 *l, sc_t row[6][U_N],
		    sc_t val[6], sc_t *c)
{
	sc_t hx = sc_mul(r->x - l->x, SC_C(0.5));
	int k, j;

	for (k = 0; k < 6; k++)
		for (j = 0; j < U_N; j++)
			row[k][j] = 0;
	for (k = 0; k < 2; k++) {
		row[k][U_S] = SC_C(1);
		row[k][U_A] = SC_C(pc->cx);
		row[k][U_L] = SC_C(pc->cx);
		val[k] = hx;
		row[2 + k][U_A] = SC_C(pc->ya);
		row[2 + k][U_L] = SC_C(pc->yl);
		row[2 + k][U_HF] = SC_C(-1);
		row[4 + k][U_A] = SC_C(pc->za);
		row[4 + k][U_L] = SC_C(pc->zl);
		row[4 + k][U_NECK] = SC_C(-1);
	}
	val[2] = r->y;
	val[3] = l->y;
	val[4] = r->z;
	val[5] = l->z;
	*c = -sc_mul(r->x + l->x, SC_C(0.5));
}

/* hand - head of one reading in its upright frame (x from the left to the right hand) */
static int obs_local(const struct calib_obs *o, struct vec3 *r, struct vec3 *l)
{
	struct vec3 d, ex, dr, dl;
	sc_t h;

	v3_sub(&o->rhand, &o->lhand, &d);
	h = sc_sqrt(sc_acc_get(sc_mac(sc_mac(sc_acc0(), d.x, d.x), d.y, d.y)));
	if (!sc_isfinite(h))
		return CALIB_ERANGE;
	if (!(h >= MIN_HANDS_SEP))
		return CALIB_EDEGENERATE;
	ex.x = sc_div(d.x, h);
	ex.y = sc_div(d.y, h);
	ex.z = 0;
	v3_sub(&o->rhand, &o->head, &dr);
	v3_sub(&o->lhand, &o->head, &dl);
	/* x along ex, y along (-ex.y, ex.x), z up */
	r->x = sc_acc_get(sc_mac(sc_mac(sc_acc0(), dr.x, ex.x), dr.y, ex.y));
	r->y = sc_acc_get(sc_mac(sc_msb(sc_acc0(), dr.x, ex.y), dr.y, ex.x));
	r->z = dr.z;
	l->x = sc_acc_get(sc_mac(sc_mac(sc_acc0(), dl.x, ex.x), dl.y, ex.y));
	l->y = sc_acc_get(sc_mac(sc_msb(sc_acc0(), dl.x, ex.y), dl.y, ex.x));
	l->z = dl.z;
	if (!v3_finite(r) || !v3_finite(l))
		return CALIB_ERANGE;
	return CALIB_OK;
}

/*
 * Solves the symmetric positive semi-definite system N u = b in place by
 * Cholesky (N's lower triangle becomes the factor). Returns false if a pivot
 * is below PIVOT_TOL times the largest diagonal: some combination of the
 * unknowns is not observed.
 */
static bool chol_solve(sc_t N[U_N][U_N], sc_t b[U_N], sc_t u[U_N])
{
	sc_t dmax = 0;
	int i, j, k;

	for (i = 0; i < U_N; i++)
		dmax = sc_max(dmax, N[i][i]);
	if (!(dmax > 0))
		return false;
	for (j = 0; j < U_N; j++) {
		sc_acc_t s = sc_acc0();
		sc_t p;

		for (k = 0; k < j; k++)
			s = sc_mac(s, N[j][k], N[j][k]);
		p = N[j][j] - sc_acc_get(s);
		if (!(p > sc_mul(PIVOT_TOL, dmax)))
			return false;
		N[j][j] = sc_sqrt(p);
		for (i = j + 1; i < U_N; i++) {
			s = sc_acc0();
			for (k = 0; k < j; k++)
				s = sc_mac(s, N[i][k], N[j][k]);
			N[i][j] = sc_div(N[i][j] - sc_acc_get(s), N[j][j]);
		}
	}
	/* L y = b, then L^T u = y */
	for (i = 0; i < U_N; i++) {
		sc_acc_t s = sc_acc0();

		for (k = 0; k < i; k++)
			s = sc_mac(s, N[i][k], u[k]);
		u[i] = sc_div(b[i] - sc_acc_get(s), N[i][i]);
	}
	for (i = U_N - 1; i >= 0; i--) {
		sc_acc_t s = sc_acc0();

		for (k = i + 1; k < U_N; k++)
			s = sc_mac(s, N[k][i], u[k]);
		u[i] = sc_div(u[i] - sc_acc_get(s), N[i][i]);
	}
	return true;
}

int calib_poses(const struct calib_obs *obs, size_t n, sc_t hand, struct calib_body *out)
{
	sc_t N[U_N][U_N] = { { 0 } }, b[U_N] = { 0 }, u[U_N];
	sc_t csum = 0;
	sc_acc_t ss = sc_acc0();
	size_t i;
	int j, k, m, err;

	if (!out)
		return CALIB_EINVAL;
	if (!obs || n == 0 || !sc_isfinite(hand) || hand < 0)
		return fail(out, CALIB_EINVAL);
	for (i = 0; i < n; i++) {
		const struct calib_obs *o = &obs[i];

		if ((unsigned)o->pose >= CALIB_NPOSES || !v3_finite(&o->head) || !v3_finite(&o->lhand) ||
		    !v3_finite(&o->rhand))
			return fail(out, CALIB_EINVAL);
	}

	/* normal equations: N = sum row row^T, b = sum row val */
	for (i = 0; i < n; i++) {
		struct vec3 r, l;
		sc_t row[6][U_N], val[6], c;

		err = obs_local(&obs[i], &r, &l);
		if (err)
			return fail(out, err);
		obs_eqs(&pose_coef[obs[i].pose], &r, &l, row, val, &c);
		csum += c;
		for (k = 0; k < 6; k++)
			for (j = 0; j < U_N; j++) {
				if (row[k][j] == 0)
					continue;
				b[j] += sc_mul(row[k][j], val[k]);
				for (m = 0; m < U_N; m++)
					N[j][m] += sc_mul(row[k][j], row[k][m]);
			}
	}
	if (!chol_solve(N, b, u))
		return fail(out, CALIB_EUNDERDET);
	for (j = 0; j < U_N; j++)
		if (!sc_isfinite(u[j]))
			return fail(out, CALIB_ERANGE);

	out->dims.shoulder = u[U_S];
	out->dims.arm = u[U_A];
	out->dims.forearm = u[U_L] - hand;
	out->dims.hand = hand;
	out->head_offset.x = sc_div(csum, SC_C(n));
	out->head_offset.y = u[U_HF];
	out->head_offset.z = u[U_NECK];
	if (!len_ok(out->dims.shoulder) || !len_ok(out->dims.arm) || !len_ok(out->dims.forearm) ||
	    !len_ok(out->head_offset.z) || !(sc_abs(out->head_offset.x) <= CALIB_MAX_LEN) ||
	    !(sc_abs(out->head_offset.y) <= CALIB_MAX_LEN))
		return fail(out, CALIB_ERANGE);

	/* residual: a second pass, exact rather than from the normal equations */
	for (i = 0; i < n; i++) {
		struct vec3 r, l;
		sc_t row[6][U_N], val[6], c;

		obs_local(&obs[i], &r, &l);
		obs_eqs(&pose_coef[obs[i].pose], &r, &l, row, val, &c);
		for (k = 0; k < 6; k++) {
			sc_acc_t e = sc_acc0();
			sc_t res;

			for (j = 0; j < U_N; j++)
				e = sc_mac(e, row[k][j], u[j]);
			res = sc_acc_get(e) - val[k];
			ss = sc_mac(ss, res, res);
		}
	}
	out->rms = sc_sqrt(sc_div(sc_acc_get(ss), SC_C(6 * n)));
	return CALIB_OK;
}

const char *calib_strerror(int err)
{
	switch (err) {
	case CALIB_OK:
		return "success";
	case CALIB_EINVAL:
		return "invalid input (NULL, NaN or inf, negative hand length, no reading)";
	case CALIB_EDEGENERATE:
		return "degenerate readings (coincident sensors or no heading)";
	case CALIB_EUNDERDET:
		return "the poses given do not determine every dimension";
	case CALIB_ERANGE:
		return "a dimension came out of range (wrong pose or swapped sensors?)";
	default:
		return "unknown calibration error";
	}
}
