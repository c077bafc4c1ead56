// SPDX-License-Identifier: MIT
/*
 * swivel.c - the arm's redundancy in closed form.
 *
 * J6..J8 turn about axes through one point (the wrist centre), so the wrist
 * centre w = p - R (0, H, 0) depends on J1..J5 alone. For a given J1 the
 * shoulder s is fixed, the elbow angle follows from |w - s| (law of cosines)
 * and the elbow lies on a circle about the shoulder-wrist line: its angle on
 * that circle is the swivel. Given (J1, swivel) every joint follows in closed
 * form: the upper-arm frame from the elbow position and the bend plane,
 * J2..J4 from it (Y-X-Z angles), J6..J8 from the remaining rotation (Y-X-Z).
 * The posture reaches the target exactly; what is left is to choose
 * (J1, swivel) inside the joint limits and close to a preferred posture.
 *
 * All work is in the right arm's frame: a left-arm target is mirrored first
 * (the left chain is the mirror image, with the same angles).
 */
#include "ik/ik.h"
#include "ik_private.h"

/* out = p + k u (p NULL: k u), or p - k u with sub (the product is rounded, then negated) */
static void v3_madd(const struct vec3 *p, sc_t k, const struct vec3 *u, bool sub, struct vec3 *out)
{
	int i;

	for (i = 0; i < 3; i++) {
		sc_t m = sc_mul(k, SC_CV(u)[i]);

		if (sub)
			m = -m;
		SC_V(out)[i] = p ? SC_CV(p)[i] + m : m;
	}
}

/*
 * (c, s) turned by the angle whose cosine and sine are ct, st (back: by its
 * negative): c ct - s st, s ct + c st, or c ct + s st, s ct - c st
 */
static inline void turn(sc_t *c, sc_t *s, sc_t ct, sc_t st, bool back)
{
	sc_t c0 = *c;

	*c = back ? sc_mul_add(c0, ct, *s, st) : sc_mul_sub(c0, ct, *s, st);
	*s = back ? sc_mul_sub(*s, ct, c0, st) : sc_mul_add(*s, ct, c0, st);
}

static sc_t v3_normalize(struct vec3 *v)
{
	sc_t n = v3_norm(v);

	if (n > SC_EPS) {
		sc_recip_t k = sc_recip(n);

		v->x = sc_mul_recip(v->x, k);
		v->y = sc_mul_recip(v->y, k);
		v->z = sc_mul_recip(v->z, k);
	}
	return n;
}

/*
 * The same limit test without atan2, for the scans: the angle of the unit
 * vector (c, s) against joint j's limits through sin(theta - lo) and
 * sin(hi - theta). Returns 0 inside, else 1 - cos of the angle to the nearer
 * limit (monotonic in that angle, which is all the search needs to rank)
 * plus SC_EPS, so that every joint outside adds at least SC_EPS. (c, s) is a
 * unit vector only up to rounding, the more so after euler_fast's division
 * by cos b, and near a limit the cosine can round above 1 (in Q5.26 1 - cos
 * is under one unit up to 2e-4 rad out): 1 - cos is clamped at 0 before
 * SC_EPS is added, or a negative term would let the sample count as inside
 * or cancel another joint's violation in euler_fast's sum.
 */
static sc_t arc_violation(const struct arm *a, int j, sc_t c, sc_t s)
{
	const sc_t *cs = a->lim_cs[j];
	sc_t slo = sc_mul_sub(cs[0], s, cs[1], c);
	sc_t shi = sc_mul_sub(c, cs[3], s, cs[2]);
	sc_t near; /* cos of the angle to the nearer limit */
	bool in;

	if (a->lim.hi[j] - a->lim.lo[j] <= SC_PI)
		in = slo >= 0 && shi >= 0;
	else
		in = slo >= 0 || shi >= 0;
	if (in)
		return 0;
	near = sc_max(sc_mul_add(c, cs[0], s, cs[1]), sc_mul_add(c, cs[2], s, cs[3]));
	return sc_max(SC_C(1) - near, SC_C(0)) + SC_EPS;
}

/*
 * euler_yxz's verdict alone, cheaply: 0 if one branch of the Y-X-Z angles
 * of m lies inside the limits [i0, i0+2], else a positive ranking value.
 */
static sc_t euler_fast(const sc_t m[3][3], const struct arm *a, int i0)
{
	sc_t sb = -m[1][2], cb = sc_sqrt(SC_C(1) - sc_mul(sb, sb)), best = SC_BIG;
	sc_recip_t inv;
	int k;

	for (k = 0; k < 2 && best > 0; k++) {
		sc_t sg = k ? SC_C(-1) : SC_C(1), v;

		v = arc_violation(a, i0 + 1, sc_mul(sg, cb), sb);
		if (v >= best)
			continue;
		if (cb < SC_C(1e-6)) {
			/* gimbal lock: the outer two angles only add; the exact path decides */
			best = v;
			continue;
		}
		/* (m22, m02) / cos b and (m11, m10) / cos b are cos and sin of the outer angles */
		inv = sc_recip(sc_mul(sg, cb));
		v += arc_violation(a, i0, sc_mul_recip(m[2][2], inv), sc_mul_recip(m[0][2], inv));
		if (v >= best)
			continue;
		v += arc_violation(a, i0 + 2, sc_mul_recip(m[1][1], inv), sc_mul_recip(m[1][0], inv));
		best = sc_min(best, v);
	}
	return best;
}

/* what stays fixed while the swivel moves: one target, one J1 */
struct swivel_ctx {
	const struct arm *a;
	sc_t rt1[3][3];	    /* target rotation in the J1 frame */
	struct vec3 u;	    /* shoulder -> wrist centre, J1 frame */
	struct vec3 uh;	    /* u / |u| */
	struct vec3 n1, n2; /* basis of the swivel circle's plane */
	struct vec3 c;	    /* centre of the circle (from the shoulder) */
	sc_t r;		    /* radius of the circle */
	sc_t q1, q5, s5, c5;
	sc_t inv_a;  /* 1 / A */
	sc_t viol15; /* limit violation of J1 and J5 */
};

/* Sets up the circle for one J1; false if the wrist is out of reach there. */
static bool ctx_init(struct swivel_ctx *x, const struct arm *a, const struct vec3 *w, const sc_t rt[3][3], sc_t q1)
{
	sc_t A = a->dims.arm, F = a->dims.forearm, S = a->dims.shoulder;
	sc_t s1, c1, d, d2, ca, sa, sq5, AA, FF;
	struct vec3 dw, g;
	int j;

	x->a = a;
	x->q1 = q1;
	x->inv_a = sc_div(SC_C(1), A);
	sc_sincos(q1, &s1, &c1);
	dw = (struct vec3){ w->x - sc_mul(S, c1), w->y - sc_mul(S, s1), w->z };
	/* Rz(-q1) applied to dw (j = 3) and to rt's columns */
	x->u = dw;
	turn(&x->u.x, &x->u.y, c1, s1, true);
	for (j = 0; j < 3; j++) {
		x->rt1[0][j] = rt[0][j];
		x->rt1[1][j] = rt[1][j];
		x->rt1[2][j] = rt[2][j];
		turn(&x->rt1[0][j], &x->rt1[1][j], c1, s1, true);
	}
	d2 = v3_dot(&x->u, &x->u);
	d = sc_sqrt(d2);
	if (d < SC_C(1e-6))
		return false;
	AA = sc_mul(A, A);
	FF = sc_mul(F, F);
	/* |u|^2 = A^2 + F^2 - 2 A F sin q5 */
	sq5 = sc_div(AA + FF - d2, 2 * sc_mul(A, F));
	if (sq5 > SC_C(1) || sq5 < SC_C(-1))
		return false;
	x->q5 = sc_asin(sq5);
	x->s5 = sq5;
	x->c5 = sc_sqrt(SC_C(1) - sc_mul(sq5, sq5));
	x->viol15 = ik_violation(q1, a->lim.lo[0], a->lim.hi[0]) + ik_violation(x->q5, a->lim.lo[4], a->lim.hi[4]);
	x->uh = x->u;
	v3_normalize(&x->uh);
	/* angle at the shoulder between the upper arm and u */
	ca = sc_div(AA + d2 - FF, 2 * sc_mul(A, d));
	ca = sc_clamp(ca, SC_C(-1), SC_C(1));
	sa = sc_sqrt(SC_C(1) - sc_mul(ca, ca));
	v3_madd(NULL, sc_mul(A, ca), &x->uh, false, &x->c);
	x->r = sc_mul(A, sa);
	/* n1: "down" projected on the plane (forward when u is vertical) */
	g = sc_abs(x->uh.z) < SC_C(0.9) ? (struct vec3){ 0, 0, SC_C(-1) } : (struct vec3){ 0, SC_C(1), 0 };
	v3_madd(&g, v3_dot(&g, &x->uh), &x->uh, true, &x->n1);
	v3_normalize(&x->n1);
	v3_cross(&x->uh, &x->n1, &x->n2);
	return true;
}

/*
 * The swivel angle whose bend plane is closest to an elbow axis x4 (J1
 * frame); with x4 NULL the one that points the forearm as close as possible
 * along the hand (the wrist nearest neutral).
 */
static sc_t ctx_swivel(const struct swivel_ctx *x, const struct vec3 *x4)
{
	struct vec3 n;
	sc_t d1, d2;

	if (x4) {
		/* the elbow sits at n = u^ x x4 from the shoulder-wrist line */
		v3_cross(&x->uh, x4, &n);
	} else {
		/* forearm = (w - c - r n) / F: closest to the hand's y axis h when n is along -h */
		n = (struct vec3){ x->rt1[0][1], x->rt1[1][1], x->rt1[2][1] };
	}
	d2 = v3_dot(&n, &x->n2);
	d1 = v3_dot(&n, &x->n1);
	return x4 ? sc_atan2(d2, d1) : sc_atan2(-d2, -d1);
}

/* added to the violation when the upper arm is already outside its limits */
#define UPPER_PENALTY SC_C(4)

/*
 * The posture at the swivel whose cosine and sine are cp, sp; returns its
 * limit violation (0: inside). With
 * full false the wrist is skipped when the upper arm is already outside its
 * limits (the result is then only a bound, and q[5..7] are not written).
 */
static sc_t ctx_eval_cs(const struct swivel_ctx *x, sc_t cp, sc_t sp, sc_t q[ARM_DOF], bool full)
{
	const struct arm *a = x->a;
	sc_t R[3][3], R15[3][3], M[3][3], v;
	int i;
	struct vec3 n, e, x4, y4, z4;

	/* (the compact build's loops would cost the host's inner loop a third more time) */
#if IK_COMPACT
	for (i = 0; i < 3; i++)
		SC_V(&n)[i] = sc_mul_add(cp, SC_CV(&x->n1)[i], sp, SC_CV(&x->n2)[i]);
	v3_madd(&x->c, x->r, &n, false, &e);
#else
	n.x = sc_mul(cp, x->n1.x) + sc_mul(sp, x->n2.x);
	n.y = sc_mul(cp, x->n1.y) + sc_mul(sp, x->n2.y);
	n.z = sc_mul(cp, x->n1.z) + sc_mul(sp, x->n2.z);
	e.x = x->c.x + sc_mul(x->r, n.x);
	e.y = x->c.y + sc_mul(x->r, n.y);
	e.z = x->c.z + sc_mul(x->r, n.z);
#endif
	/*
	 * Upper-arm frame: -z along the upper arm, x the elbow axis. |e| = A,
	 * and n, u^ are orthonormal, so z4 and x4 = n x u^ are unit vectors and
	 * orthogonal (z4 lies in the plane of u^ and n) up to rounding.
	 */
#if IK_COMPACT
	v3_madd(NULL, x->inv_a, &e, true, &z4);
	v3_cross(&n, &x->uh, &x4);
	v3_cross(&z4, &x4, &y4);
	for (i = 0; i < 3; i++) {
		R[i][0] = SC_V(&x4)[i];
		R[i][1] = SC_V(&y4)[i];
		R[i][2] = SC_V(&z4)[i];
	}
#else
	z4 = (struct vec3){ -sc_mul(e.x, x->inv_a), -sc_mul(e.y, x->inv_a), -sc_mul(e.z, x->inv_a) };
	v3_cross(&n, &x->uh, &x4);
	v3_cross(&z4, &x4, &y4);
	R[0][0] = x4.x, R[0][1] = y4.x, R[0][2] = z4.x;
	R[1][0] = x4.y, R[1][1] = y4.y, R[1][2] = z4.y;
	R[2][0] = x4.z, R[2][1] = y4.z, R[2][2] = z4.z;
#endif
	q[0] = x->q1;
	q[4] = x->q5;
	if (!full) {
		v = euler_fast((const sc_t(*)[3])R, a, 1);
		if (v > 0)
			return v + x->viol15 + UPPER_PENALTY;
	} else {
		v = ik_euler_yxz((const sc_t(*)[3])R, &a->lim, 1, &q[1]);
	}
	/*
	 * The wrist turns M = R15^T Rt with R15 = R Rx(q5) (J1 frame). Rx only
	 * mixes columns 1 and 2; of M only the five entries the Y-X-Z angles
	 * read are needed.
	 */
	for (i = 0; i < 3; i++) {
		R15[i][0] = R[i][0];
#if IK_COMPACT
		R15[i][1] = R[i][1];
		R15[i][2] = R[i][2];
		turn(&R15[i][1], &R15[i][2], x->c5, x->s5, true);
#else
		R15[i][1] = sc_mul(x->c5, R[i][1]) + sc_mul(x->s5, R[i][2]);
		R15[i][2] = sc_mul(x->c5, R[i][2]) - sc_mul(x->s5, R[i][1]);
#endif
	}
	M[0][0] = M[0][1] = M[2][0] = M[2][1] = 0;
#if IK_COMPACT
	for (i = 0; i < 5; i++) {
		static const unsigned char rc[5] = { 0x02, 0x10, 0x11, 0x12, 0x22 }; /* row << 4 | column */
		int r = rc[i] >> 4, c = rc[i] & 3;

		M[r][c] = ik_m3_tdot((const sc_t(*)[3])R15, (const sc_t(*)[3])x->rt1, r, c);
	}
#else
	M[0][2] = ik_m3_tdot((const sc_t(*)[3])R15, (const sc_t(*)[3])x->rt1, 0, 2);
	M[1][0] = ik_m3_tdot((const sc_t(*)[3])R15, (const sc_t(*)[3])x->rt1, 1, 0);
	M[1][1] = ik_m3_tdot((const sc_t(*)[3])R15, (const sc_t(*)[3])x->rt1, 1, 1);
	M[1][2] = ik_m3_tdot((const sc_t(*)[3])R15, (const sc_t(*)[3])x->rt1, 1, 2);
	M[2][2] = ik_m3_tdot((const sc_t(*)[3])R15, (const sc_t(*)[3])x->rt1, 2, 2);
#endif
	if (!full) {
		v = euler_fast((const sc_t(*)[3])M, a, 5);
		if (v > 0)
			return v + x->viol15;
		/* inside: now the angles themselves */
		ik_euler_yxz((const sc_t(*)[3])R, &a->lim, 1, &q[1]);
		ik_euler_yxz((const sc_t(*)[3])M, &a->lim, 5, &q[5]);
		return x->viol15;
	}
	v += ik_euler_yxz((const sc_t(*)[3])M, &a->lim, 5, &q[5]);
	return v + x->viol15;
}

struct search {
	const struct ik_opts *o;
	int evals;
	sc_t best_v; /* least violation seen, and its posture: the fallback */
	sc_t best_q[ARM_DOF];
	sc_t best_q1, best_phi;
};

static sc_t search_eval_cs(struct search *s, const struct swivel_ctx *x, sc_t phi, sc_t cp, sc_t sp, sc_t q[ARM_DOF],
			   bool full)
{
	sc_t v;

	if (s->evals >= s->o->max_evals)
		return SC_BIG; /* budget spent: nothing more is feasible */
	v = ctx_eval_cs(x, cp, sp, q, full);

	s->evals++;
	if (v < s->best_v) {
		s->best_v = v;
		s->best_q1 = x->q1;
		s->best_phi = phi;
		/*
		 * a bound (full false, outside the limits) left J2..J4 and J6..J8
		 * unwritten: the fallback posture is evaluated whole (it was the
		 * caller's uninitialised or stale entries: results that changed
		 * from run to run)
		 */
		if (!full && v > 0)
			ctx_eval_cs(x, cp, sp, s->best_q, true);
		else
			ik_q_copy(s->best_q, q);
	}
	return v;
}

static sc_t search_eval(struct search *s, const struct swivel_ctx *x, sc_t phi, sc_t q[ARM_DOF], bool full)
{
	sc_t sp, cp;

	sc_sincos(phi, &sp, &cp);
	return search_eval_cs(s, x, phi, cp, sp, q, full);
}

/*
 * Least violation on [lo, hi] by golden section (the violation is a sum of
 * hinges of smooth functions of the swivel); stops as soon as it reaches 0.
 */
static bool ctx_refine(struct search *s, const struct swivel_ctx *x, sc_t lo, sc_t hi, sc_t q[ARM_DOF])
{
	const sc_t g = SC_C(0.38196601125010515);
	sc_t m1 = lo + sc_mul(g, hi - lo), m2 = hi - sc_mul(g, hi - lo), t[ARM_DOF];
	sc_t v1 = search_eval(s, x, m1, q, true), v2;
	int it;

	if (v1 == 0)
		return true;
	v2 = search_eval(s, x, m2, t, true);
	for (it = 0; it < 12; it++) {
		if (v2 == 0) {
			ik_q_copy(q, t);
			return true;
		}
		if (v1 <= v2) {
			hi = m2;
			m2 = m1, v2 = v1;
			m1 = lo + sc_mul(g, hi - lo);
			v1 = search_eval(s, x, m1, t, true);
			if (v1 == 0) {
				ik_q_copy(q, t);
				return true;
			}
		} else {
			lo = m1;
			m1 = m2, v1 = v2;
			m2 = hi - sc_mul(g, hi - lo);
			v2 = search_eval(s, x, m2, t, true);
		}
	}
	return false;
}

/*
 * Feasible swivel closest to phi0 at this J1: phi0 itself, else the nearest
 * feasible sample on either side, refined by bisection toward phi0 (so that
 * a posture held against a limit follows the limit smoothly). If no sample
 * is feasible and refine is set, the neighbourhood of the least violating
 * one is searched.
 */
static bool ctx_search(struct search *s, const struct swivel_ctx *x, sc_t phi0, bool refine, sc_t q[ARM_DOF])
{
	int samples = s->o->swivel_samples > 2 ? s->o->swivel_samples : 2;
	sc_t step = sc_div_int(2 * SC_PI, samples), t[ARM_DOF], v, bv, bphi;
	sc_t c0, s0, cs, ss, cf, sf, cb, sb;
	int k, side, it;

	/* the samples' cosines and sines by rotation, forward (cf, sf) and back (cb, sb) */
	sc_sincos(phi0, &s0, &c0);
	sc_sincos(step, &ss, &cs);
	cf = cb = c0;
	sf = sb = s0;
	bv = search_eval_cs(s, x, phi0, c0, s0, q, false);
	if (bv == 0)
		return true;
	bphi = phi0;
	for (k = 1; 2 * k <= samples; k++) {
		turn(&cf, &sf, cs, ss, false);
		turn(&cb, &sb, cs, ss, true);
		for (side = -1; side <= 1; side += 2) {
			sc_t lo, hi = phi0 + sc_mul_int(step, side * k);

			v = search_eval_cs(s, x, hi, side < 0 ? cb : cf, side < 0 ? sb : sf, t, false);
			if (v > 0) {
				if (v < bv)
					bv = v, bphi = hi;
				continue;
			}
			ik_q_copy(q, t);
			/* feasible at hi, not at lo: move hi toward lo */
			lo = hi - sc_mul_int(step, side);
			for (it = 0; it < 8; it++) {
				sc_t mid = sc_mul(lo + hi, SC_C(0.5));

				if (search_eval(s, x, mid, t, false) > 0) {
					lo = mid;
				} else {
					hi = mid;
					ik_q_copy(q, t);
				}
			}
			return true;
		}
	}
	return refine && ctx_refine(s, x, bphi - step, bphi + step, q);
}

/* what does not change while J1 and the swivel are searched */
struct swivel_target {
	const struct arm *a;
	struct vec3 w;	 /* wrist centre, right-arm chest frame */
	sc_t rt[3][3];	 /* target rotation, right-arm chest frame */
	struct vec3 x4p; /* preferred elbow axis, J1 frame */
};

static int yaw_candidates(const struct swivel_target *st, sc_t q1p, int samples, sc_t out[], int max);

/*
 * Last resort for targets whose feasible region is narrow: a fine grid over
 * J1 and the swivel for the least violation, then a pattern search on it.
 */
static bool rescue(struct search *s, const struct swivel_target *st, sc_t q[ARM_DOF])
{
	const struct arm *a = st->a;
	struct swivel_ctx x;
	sc_t t[ARM_DOF], q1, phi, dq1, dphi, v;
	int i, j, n1 = 9, n2 = 32, round;

	sc_t q1s[24];
	int nq = yaw_candidates(st, a->lim.lo[0], n1, q1s, 24);

	s->best_v = SC_BIG;
	for (i = 0; i < nq; i++) {
		if (!ctx_init(&x, a, &st->w, (const sc_t(*)[3])st->rt, q1s[i]))
			continue;
		for (j = 0; j < n2; j++)
			search_eval(s, &x, sc_mul_int(sc_div_int(2 * SC_PI, n2), j), t, true);
	}
	if (s->best_v >= SC_BIG)
		return false;
	q1 = s->best_q1;
	phi = s->best_phi;
	v = s->best_v;
	dq1 = sc_div_int(a->lim.hi[0] - a->lim.lo[0], 2 * (n1 - 1));
	dphi = sc_div_int(SC_PI, n2);
	for (round = 0; round < 100 && v > 0 && dphi > SC_C(1e-5) && s->evals < s->o->max_evals; round++) {
		static const signed char dir[4][2] = { { 1, 0 }, { -1, 0 }, { 0, 1 }, { 0, -1 } };
		bool moved = false;
		int d;

		for (d = 0; d < 4 && !moved; d++) {
			sc_t nq1 = sc_clamp(q1 + sc_mul_int(dq1, dir[d][0]), a->lim.lo[0], a->lim.hi[0]);
			sc_t nphi = phi + sc_mul_int(dphi, dir[d][1]), nv;

			if (!ctx_init(&x, a, &st->w, (const sc_t(*)[3])st->rt, nq1))
				continue;
			nv = search_eval(s, &x, nphi, t, true);
			if (nv < v) {
				v = nv;
				q1 = nq1;
				phi = nphi;
				moved = true;
			}
		}
		if (!moved) {
			dq1 = sc_mul(dq1, SC_C(0.5));
			dphi = sc_mul(dphi, SC_C(0.5));
		}
	}
	if (v > 0)
		return false;
	ik_q_copy(q, s->best_q);
	return true;
}

/* num / den for den > 0, clamped to [-2, 2]: a cosine's bound (fixed point cannot hold every quotient) */
static sc_t ratio_2(sc_t num, sc_t den)
{
	if (num > 2 * den)
		return SC_C(2);
	if (num < -2 * den)
		return SC_C(-2);
	return sc_div(num, den);
}

/*
 * J1 values at which the wrist centre is within reach with the elbow inside
 * its limits: |w - s(q1)|^2 = |w|^2 + S^2 - 2 S rho cos(q1 - beta) must lie
 * between the squared shoulder-wrist distances of the elbow's limits. Up to
 * two intervals inside J1's limits; returns their count.
 */
static int reach_intervals(const struct swivel_target *st, sc_t lo[2], sc_t hi[2])
{
	const struct arm *a = st->a;
	sc_t A = a->dims.arm, F = a->dims.forearm, S = a->dims.shoulder;
	sc_t l1 = a->lim.lo[0], h1 = a->lim.hi[0];
	sc_t base = sc_mul_add(A, A, F, F), af2 = 2 * sc_mul(A, F);
	sc_t rho = sc_sqrt(sc_mul_add(st->w.x, st->w.x, st->w.y, st->w.y));
	sc_t k = v3_dot(&st->w, &st->w) + sc_mul(S, S), srho = 2 * sc_mul(S, rho);
	sc_t beta, d2[2], cb[2], amin, amax, cand[2][2];
	int n = 0, i;

	/* the squared shoulder-wrist distance at J5's lower limit (the largest) and upper (the smallest) */
	for (i = 0; i < 2; i++)
		d2[i] = base - sc_mul(af2, sc_sin_lim(i ? sc_min(a->lim.hi[4], SC_HALF_PI)
							: sc_max(a->lim.lo[4], -SC_HALF_PI)));
	if (!(srho > SC_C(1e-9))) {
		/* the distance does not depend on J1 */
		if (k > d2[0] || k < d2[1])
			return 0;
		lo[0] = l1;
		hi[0] = h1;
		return 1;
	}
	/* cos(q1 - beta) in [cb[0], cb[1]] */
	for (i = 0; i < 2; i++)
		cb[i] = ratio_2(k - d2[i], srho);
	if (cb[0] > SC_C(1) || cb[1] < SC_C(-1))
		return 0;
	/* |q1 - beta| in [acos(cb[1]), acos(cb[0])] */
	amin = sc_acos(sc_min(cb[1], SC_C(1)));
	amax = sc_acos(sc_max(cb[0], SC_C(-1)));
	beta = sc_atan2(st->w.y, st->w.x);
	cand[0][0] = beta + amin, cand[0][1] = beta + amax;
	cand[1][0] = beta - amax, cand[1][1] = beta - amin;
	for (i = 0; i < 2; i++) {
		/* bring the interval next to J1's range (which lies inside [-pi, pi]) */
		sc_t c0 = cand[i][0], c1 = cand[i][1];

		if (sc_mul(c0 + c1, SC_C(0.5)) > SC_PI)
			c0 -= 2 * SC_PI, c1 -= 2 * SC_PI;
		else if (sc_mul(c0 + c1, SC_C(0.5)) < -SC_PI)
			c0 += 2 * SC_PI, c1 += 2 * SC_PI;
		c0 = sc_max(c0, l1);
		c1 = sc_min(c1, h1);
		if (c0 <= c1) {
			lo[n] = c0;
			hi[n] = c1;
			n++;
		}
	}
	if (n == 2 && lo[1] < lo[0]) {
		sc_t t = lo[0];

		lo[0] = lo[1], lo[1] = t;
		t = hi[0], hi[0] = hi[1], hi[1] = t;
	}
	if (n == 2 && lo[1] <= hi[0]) {
		/* overlapping: merge */
		hi[0] = sc_max(hi[0], hi[1]);
		n = 1;
	}
	return n;
}

/*
 * J1 values to try, best first: the reachable one nearest the preferred,
 * then samples spread over the reachable intervals by distance from it.
 */
static int yaw_candidates(const struct swivel_target *st, sc_t q1p, int samples, sc_t out[], int max)
{
	sc_t lo[2], hi[2], margin = SC_C(0.01);
	int n = reach_intervals(st, lo, hi), m = 0, i, j;

	if (n == 0)
		return 0;
	/* the reachable J1 nearest q1p, a little inside the interval */
	{
		sc_t best = 0, bd = SC_BIG;

		for (i = 0; i < n; i++) {
			sc_t mg = sc_min(margin, sc_mul(hi[i] - lo[i], SC_C(0.5)));
			sc_t c = sc_clamp(q1p, lo[i] + mg, hi[i] - mg), dd = sc_abs(c - q1p);

			if (dd < bd)
				bd = dd, best = c;
		}
		out[m++] = best;
	}
	for (i = 0; i < n && m < max; i++) {
		sc_t mg = sc_min(margin, sc_mul(hi[i] - lo[i], SC_C(0.5)));
		sc_t a0 = lo[i] + mg, a1 = hi[i] - mg;

		for (j = 0; j < samples && m < max; j++) {
			out[m++] = samples > 1 ? a0 + sc_div_int(sc_mul_int(a1 - a0, j), samples - 1)
					       : sc_mul(a0 + a1, SC_C(0.5));
		}
	}
	/* insertion sort by distance from the first (keeps it first) */
	for (i = 2; i < m; i++) {
		sc_t v = out[i];

		for (j = i; j > 1 && sc_abs(out[j - 1] - out[0]) > sc_abs(v - out[0]); j--)
			out[j] = out[j - 1];
		out[j] = v;
	}
	return m;
}

bool ik_swivel_solve(const struct arm *a, const struct ik_target *t, const sc_t pref[ARM_DOF], const struct ik_opts *o,
		     sc_t q[ARM_DOF], int *evals)
{
	struct swivel_target st;
	struct swivel_ctx x;
	struct search s;
	struct dq d;
	struct vec3 p;
	sc_t H = a->dims.hand, q1p, cand[ARM_DOF], q1c[24];
	int k, nc, n1 = o->yaw_samples > 1 ? o->yaw_samples : 2;
	bool found = false;

	s.o = o;
	s.evals = 0;
	s.best_v = SC_BIG;
	s.best_q1 = s.best_phi = 0;
	ik_q_copy(s.best_q, pref);
	st.a = a;
	d = t->d;
	if (a->side == ARM_LEFT)
		arm_mirror_dq(&t->d, &d);
	dq_translation(&d, &p);
	quat_to_mat3(&d.r, st.rt);
	{
		/* the wrist centre: H back along the hand's y axis */
		struct vec3 hy = { st.rt[0][1], st.rt[1][1], st.rt[2][1] };

		v3_madd(&p, H, &hy, true, &st.w);
	}
	{
		/* the preferred elbow axis in the J1 frame: Ry(q2) Rx(q3) Rz(q4) x */
		sc_t s2, c2, s3, c3, s4, c4;

		sc_sincos(pref[1], &s2, &c2);
		sc_sincos(pref[2], &s3, &c3);
		sc_sincos(pref[3], &s4, &c4);
		st.x4p.x = sc_mul_add(c2, c4, s2, sc_mul(s3, s4));
		st.x4p.y = sc_mul(c3, s4);
		st.x4p.z = sc_mul_sub(c2, sc_mul(s3, s4), s2, c4);
	}
	q1p = sc_clamp(pref[0], a->lim.lo[0], a->lim.hi[0]);
	nc = yaw_candidates(&st, q1p, n1, q1c, (int)(sizeof(q1c) / sizeof(q1c[0])));
	for (k = 0; k < nc; k++) {
		if (!ctx_init(&x, a, &st.w, (const sc_t(*)[3])st.rt, q1c[k]))
			continue;
		if (x.viol15 > 0) {
			/* rounding at the edge of reach: only the fallback may use it */
			search_eval(&s, &x, ctx_swivel(&x, &st.x4p), cand, true);
			continue;
		}
		/* the nearest J1 is searched closely, the others coarsely first */
		/* past the first J1, start where the wrist is nearest neutral: its limits are the tightest */
		if (!ctx_search(&s, &x, ctx_swivel(&x, k == 0 ? &st.x4p : NULL), k == 0, cand))
			continue;
		found = true;
		ik_q_copy(q, cand);
		break;
	}
	if (!found && nc > 1 && ctx_init(&x, a, &st.w, (const sc_t(*)[3])st.rt, s.best_q1) && x.viol15 == 0) {
		/* around the least violating sample of the coarse scans */
		sc_t step = sc_div_int(2 * SC_PI, o->swivel_samples > 2 ? o->swivel_samples : 2);

		found = ctx_refine(&s, &x, s.best_phi - step, s.best_phi + step, q);
	}
	if (!found)
		found = rescue(&s, &st, q);
	if (!found)
		ik_q_copy(q, s.best_q);
	*evals = s.evals;
	return found;
}
