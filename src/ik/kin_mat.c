// SPDX-License-Identifier: MIT
/*
 * kin_mat.c - the same kinematics with 4x4 homogeneous matrices, for the
 * comparison the paper promised: FK as a product of 4x4 joint matrices, the
 * Jacobian from the frames' rotation columns and origins, the error twist
 * from the matrix logarithm of D C^-1. Like the dual-quaternion backend, the
 * product is evaluated in its rotation-and-translation form and exploits
 * that each joint turns about a coordinate axis and moves along one: the
 * product with a joint matrix changes two columns of the rotation, and the
 * translation moves along one column.
 */
#include "ik/ik.h"
#include "ik_private.h"

/* a rotation matrix by its columns: c[k] = R e_k */
struct m3c {
	struct vec3 c[3];
};

/* a <- a cos + b sin, b <- b cos - a sin: two columns of R Rot(e_k, q) */
static inline void turn(struct vec3 *a, struct vec3 *b, sc_t s, sc_t c)
{
	struct vec3 na, nb;

	na.x = sc_mul(a->x, c) + sc_mul(b->x, s);
	na.y = sc_mul(a->y, c) + sc_mul(b->y, s);
	na.z = sc_mul(a->z, c) + sc_mul(b->z, s);
	nb.x = sc_mul(b->x, c) - sc_mul(a->x, s);
	nb.y = sc_mul(b->y, c) - sc_mul(a->y, s);
	nb.z = sc_mul(b->z, c) - sc_mul(a->z, s);
	*a = na;
	*b = nb;
}

/* R Rx: columns (c0, c c1 + s c2, c c2 - s c1); R Ry: (c c0 - s c2, c1, c c2 + s c0); R Rz: (c c0 + s c1, c c1 - s c0,
 * c2) */
static inline void rot_mx(struct m3c *r, sc_t s, sc_t c)
{
	turn(&r->c[1], &r->c[2], s, c);
}

static inline void rot_my(struct m3c *r, sc_t s, sc_t c)
{
	turn(&r->c[2], &r->c[0], s, c);
}

static inline void rot_mz(struct m3c *r, sc_t s, sc_t c)
{
	turn(&r->c[0], &r->c[1], s, c);
}

/*
 * Above pi - ROT_LOG_NEAR_PI the axis comes from the symmetric part. Fixed
 * point needs the margin wider: th / (2 sin th) must stay representable
 * (below 32, so sin th > pi / 64).
 */
#if SC_TYPE == SC_FIXQ
#define ROT_LOG_NEAR_PI SC_C(0.1)
#else
#define ROT_LOG_NEAR_PI SC_C(1e-3)
#endif

/* rotation angle and axis-times-angle of a rotation matrix */
static void rot_log(const sc_t R[3][3], struct vec3 *w, sc_t *angle)
{
	sc_t cth = sc_mul(R[0][0] + R[1][1] + R[2][2] - SC_C(1), SC_C(0.5));
	struct vec3 k = { R[2][1] - R[1][2], R[0][2] - R[2][0], R[1][0] - R[0][1] }; /* 2 sin(th) n */
	sc_t s2 = v3_norm(&k), th = sc_atan2(s2, 2 * cth), f;

	*angle = th;
	if (th < SC_C(1e-3)) {
		/* th / (2 sin th) = 1/2 (1 + th^2/6) */
		f = sc_mul(SC_C(0.5), SC_C(1) + sc_mul(sc_mul(th, th), SC_C(1.0 / 6)));
	} else if (th < SC_PI - ROT_LOG_NEAR_PI) {
		f = sc_div(th, s2);
	} else {
		/* near pi: the axis from the symmetric part, n n^T = (R + R^T - 2 c I) / (2 (1 - c)) */
		struct vec3 n;
		sc_t inv = sc_div(SC_C(1), 2 * (SC_C(1) - cth)), d2[3], h;
		int i2, m;

		for (i2 = 0; i2 < 3; i2++)
			d2[i2] = sc_mul(2 * R[i2][i2] - 2 * cth, inv);
		m = d2[0] >= d2[1] && d2[0] >= d2[2] ? 0 : (d2[1] >= d2[2] ? 1 : 2);
		h = sc_sqrt(d2[m]);
		/* off-diagonal: n_m n_j = (R_mj + R_jm) inv */
		{
			sc_t k2 = sc_div(inv, h), nn[3];

			for (i2 = 0; i2 < 3; i2++)
				nn[i2] = i2 == m ? h : sc_mul(R[m][i2] + R[i2][m], k2);
			n = (struct vec3){ nn[0], nn[1], nn[2] };
		}
		if (v3_dot(&n, &k) < 0)
			n = (struct vec3){ -n.x, -n.y, -n.z };
		*w = (struct vec3){ sc_mul(th, n.x), sc_mul(th, n.y), sc_mul(th, n.z) };
		return;
	}
	*w = (struct vec3){ sc_mul(f, k.x), sc_mul(f, k.y), sc_mul(f, k.z) };
}

/*
 * The frames T1 ... Ti (rotation R[i], origin p[i]); column i of J is the
 * axis of joint i in frame T1 ... T(i-1), i.e. sgn_i times column k_i of
 * R[i] (or of R[i+1]: turning about e_k keeps column k). With check, J and V
 * are skipped once the errors are within tolerance.
 */
static bool kin_mat(const struct arm *a, const sc_t q[ARM_DOF], const struct ik_target *t, bool check, sc_t tol_pos,
		    sc_t tol_rot, sc_t J[6][ARM_DOF], sc_t V[6], struct ik_err *err)
{
	const sc_t *sg = a->sgn;
	struct m3c R[ARM_DOF + 1];
	struct vec3 p[ARM_DOF + 1], w, tr, wt, wwt, dp;
	sc_t s[ARM_DOF], c[ARM_DOF], E[3][3], th, x, kk;
	int i, r;

	for (i = 0; i < ARM_DOF; i++) {
		sc_sincos(q[i], &s[i], &c[i]);
		s[i] = sc_mul(sg[i], s[i]);
	}
	/* J1 about z, then (S, 0, 0) */
	R[1].c[0] = (struct vec3){ c[0], s[0], 0 };
	R[1].c[1] = (struct vec3){ -s[0], c[0], 0 };
	R[1].c[2] = (struct vec3){ 0, 0, SC_C(1) };
	p[0] = (struct vec3){ 0, 0, 0 };
	ik_add_scaled(&p[0], a->trans[0].x, &R[1].c[0], &p[1]);
	/* J2 y, J3 x, J4 z then (0, 0, -A); J5 x then (0, F, 0); J6 y, J7 x, J8 z then (0, H, 0) */
	R[2] = R[1];
	rot_my(&R[2], s[1], c[1]);
	R[3] = R[2];
	rot_mx(&R[3], s[2], c[2]);
	R[4] = R[3];
	rot_mz(&R[4], s[3], c[3]);
	p[2] = p[3] = p[1];
	ik_add_scaled(&p[3], a->trans[3].z, &R[4].c[2], &p[4]);
	R[5] = R[4];
	rot_mx(&R[5], s[4], c[4]);
	ik_add_scaled(&p[4], a->trans[4].y, &R[5].c[1], &p[5]);
	R[6] = R[5];
	rot_my(&R[6], s[5], c[5]);
	R[7] = R[6];
	rot_mx(&R[7], s[6], c[6]);
	R[8] = R[7];
	rot_mz(&R[8], s[7], c[7]);
	p[6] = p[7] = p[5];
	ik_add_scaled(&p[7], a->trans[7].y, &R[8].c[1], &p[8]);
	/* E = D C^-1: rotation R_t R_c^T, translation p_t - R_e p_c */
	{
		const struct vec3 *cc = R[ARM_DOF].c;
		const sc_t C[3][3] = { { cc[0].x, cc[1].x, cc[2].x },
				       { cc[0].y, cc[1].y, cc[2].y },
				       { cc[0].z, cc[1].z, cc[2].z } };

		for (r = 0; r < 3; r++)
			for (i = 0; i < 3; i++)
				E[r][i] = sc_acc_get(
					sc_mac(sc_mac(sc_mac(sc_acc0(), t->m[r][0], C[i][0]), t->m[r][1], C[i][1]),
					       t->m[r][2], C[i][2]));
	}
	dp = (struct vec3){ t->m[0][3] - p[8].x, t->m[1][3] - p[8].y, t->m[2][3] - p[8].z };
	err->pos = v3_norm(&dp);
	rot_log((const sc_t(*)[3])E, &w, &th);
	err->rot = th;
	if (check && err->pos < tol_pos && err->rot < tol_rot)
		return true;
	tr.x = t->m[0][3] - (sc_mul(E[0][0], p[8].x) + sc_mul(E[0][1], p[8].y) + sc_mul(E[0][2], p[8].z));
	tr.y = t->m[1][3] - (sc_mul(E[1][0], p[8].x) + sc_mul(E[1][1], p[8].y) + sc_mul(E[1][2], p[8].z));
	tr.z = t->m[2][3] - (sc_mul(E[2][0], p[8].x) + sc_mul(E[2][1], p[8].y) + sc_mul(E[2][2], p[8].z));
	/* v = t - 1/2 w x t + k w x (w x t) */
	x = sc_mul(th, SC_C(0.5));
	if (x < SC_C(0.05)) {
		kk = ik_log_k(x, 0, SC_C(1)); /* the series: no sine needed */
	} else {
		sc_t sx, cx;

		sc_sincos(x, &sx, &cx);
		kk = ik_log_k(x, sx, cx);
	}
	v3_cross(&w, &tr, &wt);
	v3_cross(&w, &wt, &wwt);
	V[0] = w.x, V[1] = w.y, V[2] = w.z;
	V[3] = tr.x - sc_mul(SC_C(0.5), wt.x) + sc_mul(kk, wwt.x);
	V[4] = tr.y - sc_mul(SC_C(0.5), wt.y) + sc_mul(kk, wwt.y);
	V[5] = tr.z - sc_mul(SC_C(0.5), wt.z) + sc_mul(kk, wwt.z);
	/* the axis of J1 passes through the origin: (0, 0, sgn), no moment */
	J[0][0] = J[1][0] = 0;
	J[2][0] = sg[0];
	J[3][0] = J[4][0] = J[5][0] = 0;
	ik_jac_col(J, 1, &p[1], sg[1], &R[1].c[1]);
	ik_jac_col(J, 2, &p[2], sg[2], &R[2].c[0]);
	ik_jac_col(J, 3, &p[3], sg[3], &R[4].c[2]);
	ik_jac_col(J, 4, &p[4], sg[4], &R[5].c[0]);
	ik_jac_col(J, 5, &p[5], sg[5], &R[5].c[1]);
	ik_jac_col(J, 6, &p[6], sg[6], &R[6].c[0]);
	ik_jac_col(J, 7, &p[7], sg[7], &R[8].c[2]);
	return check && err->pos < tol_pos && err->rot < tol_rot;
}

static void kin_mat_eval(const struct arm *a, const sc_t q[ARM_DOF], const struct ik_target *t, sc_t J[6][ARM_DOF],
			 sc_t V[6], struct ik_err *err)
{
	kin_mat(a, q, t, false, 0, 0, J, V, err);
}

static bool kin_mat_eval_tol(const struct arm *a, const sc_t q[ARM_DOF], const struct ik_target *t, sc_t tol_pos,
			     sc_t tol_rot, sc_t J[6][ARM_DOF], sc_t V[6], struct ik_err *err)
{
	return kin_mat(a, q, t, true, tol_pos, tol_rot, J, V, err);
}

const struct ik_kin ik_kin_mat = {
	.name = "matrix",
	.eval = kin_mat_eval,
	.eval_tol = kin_mat_eval_tol,
};
