// SPDX-License-Identifier: MIT
/*
 * ik.c - the Newton iteration of the paper and avatargw's limit-aware solver
 * built on it. See ik/ik.h.
 */
#include <string.h>

#include "ik/ik.h"
#include "ik_private.h"

void ik_default_opts(struct ik_opts *o)
{
	o->max_iter = 20;
	o->tol_pos = SC_TOL_POS;
	o->tol_rot = SC_TOL_ROT;
	o->max_step = SC_C(0.5);
	o->swivel_samples = 16;
	o->max_evals = 800;
	o->yaw_samples = 7;
	o->warm_iter = 6;
	o->center_gain = SC_C(0.15);
}

void ik_target_set(struct ik_target *t, const struct vec3 *p, const struct quat *r)
{
	bool ok = sc_isfinite(p->x) && sc_isfinite(p->y) && sc_isfinite(p->z);
	struct vec3 pp = *p;

	if (SC_REACH_MAX > 0) {
		/* fixed point: a target metres beyond any reach keeps its direction only (SC_REACH_MAX) */
		struct vec3 s;
		sc_t n;
		int i;

		for (i = 0; i < 3; i++)
			SC_V(&s)[i] = sc_mul(SC_CV(p)[i], SC_C(0.25));
		n = v3_norm(&s);
		if (n > sc_mul(SC_REACH_MAX, SC_C(0.25))) {
			sc_recip_t k = sc_recip(n);

			for (i = 0; i < 3; i++)
				SC_V(&pp)[i] = sc_mul(SC_REACH_MAX, sc_mul_recip(SC_V(&s)[i], k));
		}
	}
	ok = quat_normalize(r, &t->r) && ok;
	t->p = ok ? pp : (struct vec3){ 0, 0, 0 };
	dq_from_rt(&t->r, &t->p, &t->d);
	{
		/* dq_to_mat4(&t->d) with the translation p itself (not 2 d r* again) */
		sc_t rm[3][3];
		int i, j;

		quat_to_mat3(&t->r, rm);
		for (i = 0; i < 4; i++)
			for (j = 0; j < 4; j++)
				t->m[i][j] = i < 3 ? (j < 3 ? rm[i][j] : SC_CV(&t->p)[i]) : (j < 3 ? 0 : SC_C(1));
	}
	t->valid = ok;
}

void ik_rest_posture(const struct arm *a, sc_t q[ARM_DOF])
{
	int i;

	for (i = 0; i < ARM_DOF; i++)
		q[i] = 0;
	arm_clamp(a, q);
}

/*
 * The dual-quaternion backend: J from the joint screws, V = log(D C*). The
 * chain comes as rotations and origins (ik_private.h), so the error transform
 * E = D C^-1 is formed the same way: r_e = r_t r_c*, t_e = p_t - R_e p_c.
 * The rotation error is the angle of r_e, which the logarithm computes anyway.
 * With check, J and V are skipped once the errors are within tolerance.
 */
static bool kin_dq(const struct arm *a, const sc_t q[ARM_DOF], const struct ik_target *t, bool check, sc_t tol_pos,
		   sc_t tol_rot, sc_t J[6][ARM_DOF], sc_t V[6], struct ik_err *err, struct arm_chain *chain)
{
	struct arm_chain own, *chp = chain ? chain : &own;
	struct quat rc, re;
	struct vec3 rp, te, dp;
	struct twist tw;
	sc_t half;
#if IK_COMPACT
	int i;
#endif

	arm_chain_eval(a, q, chp, NULL);
	quat_conj(&chp->r[ARM_DOF], &rc);
	quat_mul(&t->r, &rc, &re);
#if IK_COMPACT
	for (i = 0; i < 3; i++)
		SC_V(&dp)[i] = SC_CV(&t->p)[i] - SC_CV(&chp->p[ARM_DOF])[i];
#else
	/* (straight-line where speed matters: the loops cost the host's Newton step 17 %) */
	dp.x = t->p.x - chp->p[ARM_DOF].x;
	dp.y = t->p.y - chp->p[ARM_DOF].y;
	dp.z = t->p.z - chp->p[ARM_DOF].z;
#endif
	err->pos = v3_norm(&dp);
	if (check && err->pos < tol_pos && !IK_COMPACT) {
		/* the rotation error alone, as the logarithm would compute it */
		sc_t s, c = sc_abs(re.w), ic, g;

		s = sc_acc_sqrt(sc_mac(sc_mac(sc_mac(sc_acc0(), re.x, re.x), re.y, re.y), re.z, re.z));
		err->rot = 2 * ik_half_angle(s, c, &ic, &g);
		if (err->rot < tol_rot)
			return true;
	}
	quat_rotate(&re, &chp->p[ARM_DOF], &rp);
#if IK_COMPACT
	for (i = 0; i < 3; i++)
		SC_V(&te)[i] = SC_CV(&t->p)[i] - SC_V(&rp)[i];
	dq_log_twist_rt(&re, &te, &tw, &half);
	for (i = 0; i < 3; i++) {
		V[i] = SC_V(&tw.w)[i];
		V[3 + i] = SC_V(&tw.v)[i];
	}
#else
	te.x = t->p.x - rp.x;
	te.y = t->p.y - rp.y;
	te.z = t->p.z - rp.z;
	dq_log_twist_rt(&re, &te, &tw, &half);
	V[0] = tw.w.x;
	V[1] = tw.w.y;
	V[2] = tw.w.z;
	V[3] = tw.v.x;
	V[4] = tw.v.y;
	V[5] = tw.v.z;
#endif
	err->rot = 2 * half;
	/*
	 * A compact build takes the rotation error from the logarithm (the same
	 * value as the shortcut above, which it skips: the same s and c)
	 */
	if (IK_COMPACT && check && err->pos < tol_pos && err->rot < tol_rot)
		return true;
	arm_chain_jacobian(a, chp, J);
	return check && err->pos < tol_pos && err->rot < tol_rot;
}

static void kin_dq_eval(const struct arm *a, const sc_t q[ARM_DOF], const struct ik_target *t, sc_t J[6][ARM_DOF],
			sc_t V[6], struct ik_err *err)
{
	kin_dq(a, q, t, false, 0, 0, J, V, err, NULL);
}

static bool kin_dq_eval_tol(const struct arm *a, const sc_t q[ARM_DOF], const struct ik_target *t, sc_t tol_pos,
			    sc_t tol_rot, sc_t J[6][ARM_DOF], sc_t V[6], struct ik_err *err)
{
	return kin_dq(a, q, t, true, tol_pos, tol_rot, J, V, err, NULL);
}

const struct ik_kin ik_kin_dq = {
	.name = "dq",
	.eval = kin_dq_eval,
	.eval_tol = kin_dq_eval_tol,
};

#define IK_RCOND SC_C(1e-6)

/* sum of a[i] b[i] for i = j..n-1, in two interleaved partial sums (half the dependency chain) */
static inline sc_acc_t dot_from_acc(int j, const sc_t a[ARM_DOF], const sc_t b[ARM_DOF], int n)
{
#if IK_COMPACT
	/* exact sums: one loop gives the same bits */
	return vn_dot_acc(a + j, b + j, n - j);
#else
	sc_acc_t s0 = sc_acc0(), s1 = sc_acc0();
	int i;

	for (i = j; i + 1 < n; i += 2) {
		s0 = sc_mac(s0, a[i], b[i]);
		s1 = sc_mac(s1, a[i + 1], b[i + 1]);
	}
	if (i < n)
		s0 = sc_mac(s0, a[i], b[i]);
	return sc_acc_add(s0, s1);
#endif
}

static inline sc_t dot_from(int j, const sc_t a[ARM_DOF], const sc_t b[ARM_DOF], int n)
{
	return sc_acc_get(dot_from_acc(j, a, b, n));
}

/*
 * Fixed point: the coordinates of the step in the QR basis are capped at
 * +-4 (radians) so that applying the reflectors, which keep the norm (at
 * most 4 sqrt 6 = 9.8), stays inside the range; a step that large only
 * comes far from the target, and steps are scaled down (max_step,
 * SC_STEP_CAP) anyway. Floating point: no cap.
 */
static inline sc_t lsq_cap(sc_t y)
{
	if (SC_STEP_CAP > 0)
		return sc_clamp(y, SC_C(-4), SC_C(4));
	return y;
}

/*
 * lsq_cap(num / d) without the quotient itself where it is capped: past the
 * cap it may lie past Q5.26's range too (a weak pivot far from the target,
 * an arm raised against its limits), and the division would saturate first.
 * The pivots are column norms of J, under 8: 4 |d| stays inside the range.
 */
static inline sc_t lsq_div_cap(sc_t num, sc_t d)
{
	if (SC_STEP_CAP > 0 && sc_abs(num) >= sc_mul(SC_C(4), sc_abs(d)))
		return (num < 0) != (d < 0) ? SC_C(-4) : SC_C(4);
	return lsq_cap(sc_div(num, d));
}

/*
 * The minimum-norm step of an underdetermined system, J_f y = V with J_f the
 * n >= 6 free columns of J: Householder QR of J_f^T = Q R, y = Q R^-T V.
 * Column-major: a[j] is column j of J_f^T, i.e. row j of J_f, so nothing is
 * transposed. Reflector j is H_j = I - beta_j v v^T with v = (a_jj - alpha_j,
 * a[j][j+1..n-1]) stored in place of column j; R_jj = alpha_j = -sign(a_jj)
 * |a[j][j..]| is known without applying H_j to its own column, and the sums
 * below the diagonal do not wait for the square root.
 *
 * Floating point keeps v and beta = 2 / |v|^2 = 1 / (nrm (nrm + |a_jj|)).
 * Fixed point keeps the unit vector v / |v| and beta = 2 (one more square
 * root and reciprocal per column): 2 / |v|^2 is not representable when a
 * column is nearly dependent on the others, a unit reflector keeps every
 * quantity the size of J's entries.
 */
static void house_qr(int n, int p, sc_t a[6][ARM_DOF], sc_t beta[6], sc_t rd[6])
{
	int i, j, c;

	for (j = 0; j < p; j++) {
		sc_acc_t pc[6];
		sc_t ajj = a[j][j], nrm, vj;

		for (c = j + 1; c < p; c++)
			pc[c] = dot_from_acc(j + 1, a[j], a[c], n);
		nrm = sc_acc_sqrt(sc_mac(dot_from_acc(j + 1, a[j], a[j], n), ajj, ajj));
		if (nrm < SC_EPS) {
			/* nothing left in this column: no reflection, a tiny pivot */
			beta[j] = 0;
			rd[j] = ajj;
			continue;
		}
		vj = ajj > 0 ? ajj + nrm : ajj - nrm;
		rd[j] = ajj > 0 ? -nrm : nrm;
#if SC_TYPE == SC_FIXQ
		{
			/* |v|^2 = 2 nrm (nrm + |a_jj|) */
			sc_recip_t k = sc_recip(sc_acc_sqrt(sc_mac(sc_acc0(), 2 * nrm, nrm + sc_abs(ajj))));

			beta[j] = SC_C(2);
			a[j][j] = sc_mul_recip(vj, k);
			for (i = j + 1; i < n; i++)
				a[j][i] = sc_mul_recip(a[j][i], k);
			for (c = j + 1; c < p; c++) {
				/* a_c -= 2 (u . a_c) u, u . a_c = (v_j a_cj + p_c) / |v| */
				sc_t f = 2 * sc_mul_recip(sc_acc_get(sc_mac(pc[c], vj, a[c][j])), k);

				a[c][j] -= sc_mul(f, a[j][j]);
				for (i = j + 1; i < n; i++)
					a[c][i] -= sc_mul(f, a[j][i]);
			}
		}
#else
		{
			sc_t b = sc_div(SC_C(1), sc_mul(nrm, nrm + sc_abs(ajj)));

			beta[j] = b;
			a[j][j] = vj;
			for (c = j + 1; c < p; c++) {
				sc_t f = sc_mul(b, sc_acc_get(sc_mac(pc[c], vj, a[c][j])));

				a[c][j] -= sc_mul(f, vj);
				for (i = j + 1; i < n; i++)
					a[c][i] -= sc_mul(f, a[j][i]);
			}
		}
#endif
	}
}

/* y <- H_j y (reflector j of house_qr, applied to entries j..n-1) */
static void house_apply(int n, int j, const sc_t a[6][ARM_DOF], const sc_t beta[6], sc_t y[ARM_DOF])
{
	sc_t f;
	int i;

	if (beta[j] == 0)
		return;
	f = sc_mul(beta[j], dot_from(j, a[j], y, n));
	for (i = j; i < n; i++)
		y[i] -= sc_mul(f, a[j][i]);
}

/* the largest diagonal entry of R (for the pivot test of lsq_pivot) */
static sc_t lsq_rmax(int p, const sc_t rd[6])
{
	sc_t rmax = 0;
	int j;

	for (j = 0; j < p; j++)
		rmax = sc_max(rmax, sc_abs(rd[j]));
	return rmax;
}

/* num / d for a pivot d of R, 0 for a weak one (dropped: *rank is not counted) */
static sc_t lsq_pivot(sc_t num, sc_t d, sc_t rmax, int *rank)
{
	if (sc_abs(d) <= sc_mul(IK_RCOND, rmax) || rmax == 0)
		return 0;
	++*rank;
	return lsq_div_cap(num, d);
}

#if SC_TYPE == SC_FIXQ
/*
 * Fixed point: one Householder factorisation serves both shapes. With n >= 6
 * free joints the minimum-norm step: house_qr(n, 6) of J_f^T, R(i, j) =
 * a[j][i] above the diagonal and rd[j] on it, R^T y = V, x = Q y. With fewer
 * the least-squares one: house_qr(6, n) of J_f itself, R(j, i) = a[i][j],
 * R x = Q^T V. (The floating builds keep their three paths: the normal
 * equations, the same minimum-norm QR, and a tall QR of its own.)
 */
int ik_lsq_step(const sc_t J[6][ARM_DOF], const sc_t V[6], const bool *free, sc_t x[ARM_DOF])
{
	sc_t a[6][ARM_DOF], beta[6], rd[6], y[ARM_DOF], rmax;
	int col[ARM_DOF], n = 0, m, p, i, j, k, rank = 0;
	bool wide;

	for (i = 0; i < ARM_DOF; i++) {
		x[i] = 0;
		if (!free || free[i])
			col[n++] = i;
	}
	wide = n >= 6;
	m = wide ? n : 6;
	p = wide ? 6 : n;
	for (j = 0; j < 6; j++)
		for (i = 0; i < n; i++)
			*(wide ? &a[j][i] : &a[i][j]) = J[j][col[i]];
	house_qr(m, p, a, beta, rd);
	rmax = lsq_rmax(p, rd);
	for (i = 0; i < m; i++)
		y[i] = wide ? 0 : V[i];
	for (j = 0; j < p && !wide; j++)
		house_apply(6, j, (const sc_t(*)[ARM_DOF])a, beta, y);
	for (k = 0; k < p; k++) {
		/* wide: R^T y = V forward; tall: R x = Q^T V backward */
		sc_acc_t s = sc_acc0();

		j = wide ? k : p - 1 - k;
		for (i = 0; i < p; i++)
			if (wide ? i < j : i > j)
				s = sc_mac(s, wide ? a[j][i] : a[i][j], y[i]);
		y[j] = lsq_pivot((wide ? V[j] : y[j]) - sc_acc_get(s), rd[j], rmax, &rank);
	}
	for (j = 5; j >= 0 && wide; j--)
		house_apply(n, j, (const sc_t(*)[ARM_DOF])a, beta, y);
	for (i = 0; i < n; i++)
		x[col[i]] = y[i];
	return rank;
}
#else
/*
 * The minimum-norm step: after house_qr(n, 6) of J_f^T, R(i, j) = a[j][i]
 * above the diagonal and rd[j] on it: solve R^T y = V, dropping weak pivots,
 * then y <- Q y = H_0 ... H_5 y.
 */
static int lsq_min_norm(int n, sc_t a[6][ARM_DOF], const sc_t V[6], sc_t y[ARM_DOF])
{
	sc_t beta[6], rd[6], rmax;
	int i, j, rank = 0;

	house_qr(n, 6, a, beta, rd);
	rmax = lsq_rmax(6, rd);
	for (i = 0; i < n; i++)
		y[i] = 0;
	for (j = 0; j < 6; j++) {
		sc_acc_t s = sc_acc0();

		for (i = 0; i < j; i++)
			s = sc_mac(s, a[j][i], y[i]);
		y[j] = lsq_pivot(V[j] - sc_acc_get(s), rd[j], rmax, &rank);
	}
	for (j = 5; j >= 0; j--)
		house_apply(n, j, (const sc_t(*)[ARM_DOF])a, beta, y);
	return rank;
}

/*
 * Householder QR of the 6 x k matrix a (k < 6) in place; v[j] holds reflector
 * j (rows j..5), with beta[j] as in lsq_min_norm.
 */
static void house_qr_tall(int k, sc_t a[6][ARM_DOF], sc_t v[ARM_DOF][6], sc_t beta[ARM_DOF])
{
	int i, j, c;

	for (j = 0; j < k; j++) {
		sc_acc_t s = sc_acc0();
		sc_t nrm, alpha;

		for (i = j; i < 6; i++)
			s = sc_mac(s, a[i][j], a[i][j]);
		nrm = sc_acc_sqrt(s);
		beta[j] = 0;
		for (i = 0; i < 6; i++)
			v[j][i] = 0;
		if (nrm < SC_EPS)
			continue;
		alpha = a[j][j] > 0 ? -nrm : nrm;
		for (i = j; i < 6; i++)
			v[j][i] = a[i][j];
		v[j][j] -= alpha;
		beta[j] = sc_div(SC_C(2), 2 * sc_mul(nrm, nrm + sc_abs(a[j][j])));
		for (c = j; c < k; c++) {
			sc_acc_t t = sc_acc0();
			sc_t f;

			for (i = j; i < 6; i++)
				t = sc_mac(t, v[j][i], a[i][c]);
			f = sc_mul(beta[j], sc_acc_get(t));
			for (i = j; i < 6; i++)
				a[i][c] -= sc_mul(f, v[j][i]);
		}
	}
}

/* sum of a[i] b[i] over 8 entries in two interleaved partial sums */
static inline sc_t dot8(const sc_t a[ARM_DOF], const sc_t b[ARM_DOF])
{
	sc_acc_t s0 = sc_mac(sc_acc0(), a[0], b[0]), s1 = sc_mac(sc_acc0(), a[1], b[1]);

	s0 = sc_mac(s0, a[2], b[2]);
	s1 = sc_mac(s1, a[3], b[3]);
	s0 = sc_mac(s0, a[4], b[4]);
	s1 = sc_mac(s1, a[5], b[5]);
	s0 = sc_mac(s0, a[6], b[6]);
	s1 = sc_mac(s1, a[7], b[7]);
	return sc_acc_get(sc_acc_add(s0, s1));
}

/*
 * The same minimum-norm step through the normal equations, x = J^T y with
 * (J J^T) y = V by an LDL^T factorisation: the 6 pivots are the only
 * sequential part, where the QR has 6 Householder steps each waiting on a
 * square root, a division and the update of the next column (about 2.5
 * times the time). Its error grows with cond(J J^T) = cond(J)^2, so it is
 * used only when that is provably small: with lambda_max <= trace and
 * lambda_min >= det / lambda_max^5, cond(J J^T) <= trace^6 / prod(d_j), which
 * must stay below SC_NE_COND (1e10 in double: a relative error of at most
 * about 1e-6 in theory; measured, below 1e-12 on the benchmark's postures).
 * Returns false (x unspecified) when J J^T is not that well conditioned.
 */
static bool lsq_normal_eq(const sc_t J[6][ARM_DOF], const sc_t V[6], sc_t x[ARM_DOF])
{
	sc_t M[6][6], L[6][6], inv[6], z[6], y[6], tr = 0, det = SC_C(1), t2, t6;
	int i, j, k;

	IK_UNROLL
	for (i = 0; i < 6; i++)
		IK_UNROLL
	for (j = 0; j <= i; j++)
		M[i][j] = dot8(J[i], J[j]);
	/* M[i][j] (i > j) becomes W_ij = L_ij d_j */
	IK_UNROLL
	for (j = 0; j < 6; j++) {
		sc_t d = M[j][j];

		tr += d;
		IK_UNROLL
		for (k = 0; k < j; k++)
			d -= sc_mul(L[j][k], M[j][k]);
		if (!(d > 0))
			return false;
		det = sc_mul(det, d);
		inv[j] = sc_div(SC_C(1), d);
		IK_UNROLL
		for (i = j + 1; i < 6; i++) {
			sc_t w = M[i][j];

			IK_UNROLL
			for (k = 0; k < j; k++)
				w -= sc_mul(M[i][k], L[j][k]);
			M[i][j] = w;
			L[i][j] = sc_mul(w, inv[j]);
		}
	}
	/* det <= prod M_jj <= trace^6: a finite bound also rules out an overflowed det */
	t2 = sc_mul(tr, tr);
	t6 = sc_mul(sc_mul(t2, t2), t2);
	if (!(sc_isfinite(t6) && sc_mul(det, SC_NE_COND) >= t6))
		return false;
	/* L z = V, then L^T y = D^-1 z */
	IK_UNROLL
	for (i = 0; i < 6; i++) {
		sc_t s = V[i];

		IK_UNROLL
		for (k = 0; k < i; k++)
			s -= sc_mul(L[i][k], z[k]);
		z[i] = s;
	}
	IK_UNROLL
	for (i = 5; i >= 0; i--) {
		sc_t s = sc_mul(z[i], inv[i]);

		IK_UNROLL
		for (k = i + 1; k < 6; k++)
			s -= sc_mul(L[k][i], y[k]);
		y[i] = s;
	}
	IK_UNROLL
	for (k = 0; k < ARM_DOF; k++) {
		sc_acc_t s0 = sc_mac(sc_acc0(), J[0][k], y[0]), s1 = sc_mac(sc_acc0(), J[1][k], y[1]);

		s0 = sc_mac(s0, J[2][k], y[2]);
		s1 = sc_mac(s1, J[3][k], y[3]);
		s0 = sc_mac(s0, J[4][k], y[4]);
		s1 = sc_mac(s1, J[5][k], y[5]);
		x[k] = sc_acc_get(sc_acc_add(s0, s1));
	}
	return true;
}

int ik_lsq_step(const sc_t J[6][ARM_DOF], const sc_t V[6], const bool *free, sc_t x[ARM_DOF])
{
	sc_t a[6][ARM_DOF], y[ARM_DOF];
	int col[ARM_DOF], n = 0, i, j, rank = 0;

	for (i = 0; i < ARM_DOF; i++) {
		x[i] = 0;
		if (!free || free[i])
			col[n++] = i;
	}
	if (n == ARM_DOF) {
		/* well conditioned (nearly always): the normal equations; else J^T = Q R, x = Q R^-T V */
		if (SC_NE_COND > 0 && lsq_normal_eq(J, V, x))
			return 6;
		memcpy(a, J, sizeof(a));
		rank = lsq_min_norm(ARM_DOF, a, V, x);
		return rank;
	}
	if (n >= 6) {
		/* the held joints' columns zeroed add nothing to J J^T and get x = 0 */
		if (SC_NE_COND > 0) {
			for (j = 0; j < 6; j++)
				for (i = 0; i < ARM_DOF; i++)
					a[j][i] = free[i] ? J[j][i] : SC_C(0);
			if (lsq_normal_eq((const sc_t(*)[ARM_DOF])a, V, y)) {
				for (i = 0; i < ARM_DOF; i++)
					x[i] = free[i] ? y[i] : SC_C(0);
				return 6;
			}
		}
		for (j = 0; j < 6; j++)
			for (i = 0; i < n; i++)
				a[j][i] = J[j][col[i]];
		rank = lsq_min_norm(n, a, V, y);
		for (i = 0; i < n; i++)
			x[col[i]] = y[i];
		return rank;
	}
	/* fewer free joints than equations: least squares, x = R^-1 Q^T V */
	{
		sc_t v[ARM_DOF][6], beta[ARM_DOF], rmax = 0;

		for (i = 0; i < 6; i++) {
			for (j = 0; j < n; j++)
				a[i][j] = J[i][col[j]];
			y[i] = V[i];
		}
		house_qr_tall(n, a, v, beta);
		for (j = 0; j < n; j++) {
			sc_acc_t t = sc_acc0();
			sc_t f;

			for (i = 0; i < 6; i++)
				t = sc_mac(t, v[j][i], y[i]);
			f = sc_mul(beta[j], sc_acc_get(t));
			for (i = 0; i < 6; i++)
				y[i] -= sc_mul(f, v[j][i]);
			rmax = sc_max(rmax, sc_abs(a[j][j]));
		}
		for (j = n - 1; j >= 0; j--) {
			sc_acc_t s = sc_acc0();

			for (i = j + 1; i < n; i++)
				s = sc_mac(s, a[j][i], y[i]);
			if (sc_abs(a[j][j]) <= sc_mul(IK_RCOND, rmax) || rmax == 0) {
				y[j] = 0;
				continue;
			}
			y[j] = lsq_div_cap(y[j] - sc_acc_get(s), a[j][j]);
			rank++;
		}
		for (j = 0; j < n; j++)
			x[col[j]] = y[j];
	}
	return rank;
}
#endif /* SC_TYPE */

static bool q_finite(const sc_t q[ARM_DOF])
{
	int i;

	for (i = 0; i < ARM_DOF; i++)
		if (!sc_isfinite(q[i]))
			return false;
	return true;
}

static bool err_ok(const struct ik_err *e, const struct ik_opts *o)
{
	return e->pos < o->tol_pos && e->rot < o->tol_rot;
}

/*
 * The errors at q and, unless they are within tolerance (returns true), J and
 * V. With ch (not NULL) the dual-quaternion backend also leaves its chain
 * there and *ch_at sets to whether ch now holds the chain at q.
 */
static bool kin_eval(const struct ik_kin *kin, const struct arm *a, const sc_t q[ARM_DOF], const struct ik_target *t,
		     const struct ik_opts *o, sc_t J[6][ARM_DOF], sc_t V[6], struct ik_err *err, struct arm_chain *ch,
		     bool *ch_at)
{
	if (ch) {
		*ch_at = kin == &ik_kin_dq;
		if (*ch_at)
			return kin_dq(a, q, t, true, o->tol_pos, o->tol_rot, J, V, err, ch);
	}
	if (kin->eval_tol)
		return kin->eval_tol(a, q, t, o->tol_pos, o->tol_rot, J, V, err);
	kin->eval(a, q, t, J, V, err);
	return err_ok(err, o);
}

/* scales x so that no joint moves more than max_step (0: SC_STEP_CAP, which is 0, none, in floating point) */
static void limit_step(sc_t x[ARM_DOF], sc_t max_step)
{
	sc_t m = 0;
	int i;

	if (max_step <= 0)
		max_step = SC_STEP_CAP;
	if (max_step <= 0)
		return;
	for (i = 0; i < ARM_DOF; i++)
		m = sc_max(m, sc_abs(x[i]));
	if (m > max_step) {
		sc_t k = sc_div(max_step, m);

		for (i = 0; i < ARM_DOF; i++)
			x[i] = sc_mul(x[i], k);
	}
}

unsigned ik_newton(const struct arm *a, const struct ik_kin *kin, const struct ik_target *t, const sc_t seed[ARM_DOF],
		   const struct ik_opts *o, sc_t q[ARM_DOF], struct ik_result *res)
{
	sc_t J[6][ARM_DOF], V[6], x[ARM_DOF];
	int i, it;

	res->flags = 0;
	res->iters = 0;
	res->evals = 0;
	res->err = (struct ik_err){ 0, 0 };
	for (i = 0; i < ARM_DOF; i++)
		q[i] = seed[i];
	if (!q_finite(q)) {
		res->flags |= IK_BAD_TARGET;
		for (i = 0; i < ARM_DOF; i++)
			q[i] = 0;
	}
	if (!t->valid) {
		res->flags |= IK_BAD_TARGET;
		return res->flags;
	}
	for (it = 0;; it++) {
		if (kin_eval(kin, a, q, t, o, J, V, &res->err, NULL, NULL)) {
			res->flags |= IK_REACHED;
			break;
		}
		if (it >= o->max_iter)
			break;
		ik_lsq_step((const sc_t(*)[ARM_DOF])J, V, NULL, x);
		if (!q_finite(x))
			break;
		/* the paper's plain step; fixed point bounds it so that q + x stays representable */
		limit_step(x, SC_STEP_CAP);
		for (i = 0; i < ARM_DOF; i++)
			q[i] = sc_wrap_pi(q[i] + x[i]);
		res->iters++;
	}
	return res->flags;
}

/*
 * Newton with the limits: a step that would push joints past their limits
 * is re-solved with those joints held at the limit (at most 3 rounds), and
 * the posture is clamped after every step. With center > 0 the redundancy
 * drifts the free joints toward the middle of their ranges: the step is the
 * least-squares one closest to z = -center (q - mid), x = z + J+ (V - J z),
 * so that tracking does not wander into a corner of the limits.
 */
#define NEWTON_STALL SC_C(1e-4)

static void newton_limited(const struct arm *a, const struct ik_kin *kin, const struct ik_target *t,
			   const struct ik_opts *o, int max_iter, sc_t center, sc_t q[ARM_DOF], struct ik_result *res,
			   struct arm_chain *ch, bool *ch_at)
{
	sc_t J[6][ARM_DOF], V[6], W[6], x[ARM_DOF], z[ARM_DOF], e, e_prev = 0, e_prev2 = 0;
	bool free[ARM_DOF];
	int i, j, it, round;

	for (it = 0;; it++) {
		/* the first step moves the redundancy toward mid-range, the others only reach */
		bool centre = it == 0 && center != 0;

		/* every way out follows an evaluation at the final q */
		if (kin_eval(kin, a, q, t, o, J, V, &res->err, ch, ch_at) || it >= max_iter)
			break;
		/*
		 * Stalled: the error changed by under NEWTON_STALL of itself in the
		 * last step, or the steps go back and forth between two postures
		 * (the limits' clamp against the step: a target far out of reach)
		 * and this is the better of the two. A target out of the limits'
		 * reach ends here, at its compromise, instead of after max_iter
		 * steps that change nothing (a converging solve divides its error
		 * at every step and never stops here).
		 */
		e = res->err.pos + res->err.rot;
		if (it > 0 && sc_abs(e - e_prev) <= sc_mul(NEWTON_STALL, e_prev))
			break;
		if (it > 1 && e <= e_prev && sc_abs(e - e_prev2) <= sc_mul(NEWTON_STALL, e_prev2))
			break;
		e_prev2 = e_prev;
		e_prev = e;
		for (i = 0; i < ARM_DOF; i++)
			free[i] = true;
		for (round = 0; round < 3; round++) {
			bool again = false;

			if (centre) {
				for (i = 0; i < ARM_DOF; i++) {
					/* u in [-1, 1] across the range; push back hardest near the limits */
					sc_t half = sc_mul(a->lim.hi[i] - a->lim.lo[i], SC_C(0.5));
					sc_t u = half > 0 ? sc_div(q[i] - a->lim.lo[i] - half, half) : SC_C(0);

					z[i] = free[i] ? -sc_mul(sc_mul(center, half), sc_mul(u, sc_mul(u, u)))
						       : SC_C(0);
				}
				for (j = 0; j < 6; j++) {
					sc_acc_t acc = sc_acc0();

					for (i = 0; i < ARM_DOF; i++)
						acc = sc_mac(acc, J[j][i], z[i]);
					W[j] = V[j] - sc_acc_get(acc);
				}
				ik_lsq_step((const sc_t(*)[ARM_DOF])J, W, round ? free : NULL, x);
				for (i = 0; i < ARM_DOF; i++)
					x[i] += z[i];
			} else {
				ik_lsq_step((const sc_t(*)[ARM_DOF])J, V, round ? free : NULL, x);
			}
			limit_step(x, o->max_step);
			for (i = 0; i < ARM_DOF; i++) {
				sc_t n = q[i] + x[i];

				if (free[i] && ((n > a->lim.hi[i] && x[i] > 0) || (n < a->lim.lo[i] && x[i] < 0))) {
					free[i] = false;
					again = true;
				}
			}
			if (!again)
				break;
		}
		if (!q_finite(x))
			break;
		for (i = 0; i < ARM_DOF; i++)
			q[i] += x[i];
		arm_clamp(a, q);
		res->iters++;
	}
}

/*
 * The solver; with chp it also leaves its last chain there, and *ch_at
 * says whether that chain is at the returned q (ik_solve_pose).
 */
static unsigned solve(const struct arm *a, const struct ik_kin *kin, const struct ik_target *t, const sc_t *seed,
		      const struct ik_opts *o, sc_t q[ARM_DOF], struct ik_result *res, struct arm_chain *chp,
		      bool *ch_at)
{
	sc_t pref[ARM_DOF];
	int i;

	res->flags = 0;
	res->iters = 0;
	res->evals = 0;
	res->err = (struct ik_err){ 0, 0 };
	if (seed && ik_q_inside(a, seed)) {
		/* inside the limits (and finite): nothing to clamp */
		ik_q_copy(pref, seed);
	} else if (seed && q_finite(seed)) {
		ik_q_copy(pref, seed);
		arm_clamp(a, pref);
	} else {
		if (seed)
			res->flags |= IK_BAD_TARGET;
		ik_rest_posture(a, pref);
	}
	if (!t->valid) {
		for (i = 0; i < ARM_DOF; i++)
			q[i] = pref[i];
		res->flags |= IK_BAD_TARGET;
		goto out;
	}
	if (o->max_evals <= 0) {
		/* no search: Newton from the seed, within the limits, and what it reaches */
		for (i = 0; i < ARM_DOF; i++)
			q[i] = pref[i];
		newton_limited(a, kin, t, o, o->max_iter, 0, q, res, chp, ch_at);
		goto done;
	}
	if (seed && !(res->flags & IK_BAD_TARGET) && o->warm_iter > 0) {
		/* tracking: a few limited Newton steps from the previous posture move the arm least */
		ik_q_copy(q, pref);
		newton_limited(a, kin, t, o, o->warm_iter, o->center_gain, q, res, chp, ch_at);
		if (err_ok(&res->err, o))
			goto done;
	}
	if (ik_swivel_solve(a, t, pref, o, q, &res->evals))
		res->flags |= IK_ANALYTIC;
	arm_clamp(a, q);
	newton_limited(a, kin, t, o, o->max_iter, 0, q, res, chp, ch_at);
done:
	if (err_ok(&res->err, o))
		res->flags |= IK_REACHED;
	else
		res->flags |= IK_UNREACHABLE;
	for (i = 0; i < ARM_DOF; i++)
		if (q[i] <= a->lim.lo[i] || q[i] >= a->lim.hi[i])
			res->flags |= IK_LIMITED;
out:
	return res->flags;
}

unsigned ik_solve_pose(const struct arm *a, const struct ik_kin *kin, const struct ik_target *t, const sc_t *seed,
		       const struct ik_opts *o, sc_t q[ARM_DOF], struct ik_result *res, struct arm_pose *pose)
{
	struct arm_chain ch;
	bool ch_at = false;
	unsigned flags = solve(a, kin, t, seed, o, q, res, &ch, &ch_at);

	/* the solver's last evaluation was at q (newton_limited ends with one): its chain, unless another backend made
	 * it */
	if (ch_at)
		arm_chain_pose(&ch, pose);
	else
		arm_fk_pose(a, q, pose);
	return flags;
}

unsigned ik_solve(const struct arm *a, const struct ik_kin *kin, const struct ik_target *t, const sc_t *seed,
		  const struct ik_opts *o, sc_t q[ARM_DOF], struct ik_result *res)
{
	return solve(a, kin, t, seed, o, q, res, NULL, NULL);
}
