// SPDX-License-Identifier: MIT
/*
 * kin_mat.c - the same kinematics with 4x4 homogeneous matrices, for the
 * comparison the paper promised: FK as a product of 4x4 joint matrices, the
 * Jacobian from the frames' rotation columns and origins, the error twist
 * from the matrix logarithm of D C^-1.
 */
#include "ik/ik.h"
#include "ik_private.h"

typedef sc_t m4[4][4];

static void m4_mul(const m4 a, const m4 b, m4 out)
{
	int i, j;

	for (i = 0; i < 4; i++)
		for (j = 0; j < 4; j++) {
			sc_acc_t s = sc_mac(sc_acc0(), a[i][0], b[0][j]);

			s = sc_mac(s, a[i][1], b[1][j]);
			s = sc_mac(s, a[i][2], b[2][j]);
			out[i][j] = sc_acc_get(sc_mac(s, a[i][3], b[3][j]));
		}
}

/* Rot(axis, q) Trans(t) as a matrix: [R, R t; 0 0 0 1] */
static void joint_m4(const struct arm *a, int i, sc_t q, m4 out)
{
	const struct vec3 *ax = &a->axis[i], *t = &a->trans[i];
	sc_t s, c, R[3][3] = { { 0 } };
	int r;

	sc_sincos(q, &s, &c);
	/* axis is +-e_k: Rodrigues with a unit basis vector */
	if (ax->x != 0) {
		sc_t sg = ax->x;

		R[0][0] = SC_C(1);
		R[1][1] = c, R[1][2] = -sc_mul(sg, s);
		R[2][1] = sc_mul(sg, s), R[2][2] = c;
	} else if (ax->y != 0) {
		sc_t sg = ax->y;

		R[1][1] = SC_C(1);
		R[0][0] = c, R[0][2] = sc_mul(sg, s);
		R[2][0] = -sc_mul(sg, s), R[2][2] = c;
	} else {
		sc_t sg = ax->z;

		R[2][2] = SC_C(1);
		R[0][0] = c, R[0][1] = -sc_mul(sg, s);
		R[1][0] = sc_mul(sg, s), R[1][1] = c;
	}
	for (r = 0; r < 3; r++) {
		out[r][0] = R[r][0];
		out[r][1] = R[r][1];
		out[r][2] = R[r][2];
		out[r][3] = sc_mul(R[r][0], t->x) + sc_mul(R[r][1], t->y) + sc_mul(R[r][2], t->z);
		out[3][r] = 0;
	}
	out[3][3] = SC_C(1);
}

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
	} else if (th < SC_PI - SC_C(1e-3)) {
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

static void kin_mat_eval(const struct arm *a, const sc_t q[ARM_DOF], const struct ik_target *t, sc_t J[6][ARM_DOF],
			 sc_t V[6], struct ik_err *err)
{
	m4 k[2], ji, e;
	sc_t R[3][3];
	struct vec3 w, tr, wt, wwt, dp;
	sc_t th, x, s, c, kk;
	int i, r, cur = 0;

	/* k = T1 ... Ti; column i of J is the axis of joint i in frame T1 ... T(i-1) */
	for (r = 0; r < 4; r++)
		for (i = 0; i < 4; i++)
			k[0][r][i] = r == i ? SC_C(1) : SC_C(0);
	for (i = 0; i < ARM_DOF; i++) {
		const struct vec3 *ax = &a->axis[i];
		struct vec3 l, p = { k[cur][0][3], k[cur][1][3], k[cur][2][3] }, m;

		l.x = sc_mul(k[cur][0][0], ax->x) + sc_mul(k[cur][0][1], ax->y) + sc_mul(k[cur][0][2], ax->z);
		l.y = sc_mul(k[cur][1][0], ax->x) + sc_mul(k[cur][1][1], ax->y) + sc_mul(k[cur][1][2], ax->z);
		l.z = sc_mul(k[cur][2][0], ax->x) + sc_mul(k[cur][2][1], ax->y) + sc_mul(k[cur][2][2], ax->z);
		v3_cross(&p, &l, &m);
		J[0][i] = l.x, J[1][i] = l.y, J[2][i] = l.z;
		J[3][i] = m.x, J[4][i] = m.y, J[5][i] = m.z;
		joint_m4(a, i, q[i], ji);
		m4_mul((const sc_t(*)[4])k[cur], (const sc_t(*)[4])ji, k[1 - cur]);
		cur = 1 - cur;
	}
	/* E = D C^-1, C^-1 = [R^T, -R^T t] */
	{
		m4 ci;
		const sc_t(*C)[4] = (const sc_t(*)[4])k[cur];

		for (r = 0; r < 3; r++) {
			for (i = 0; i < 3; i++)
				ci[r][i] = C[i][r];
			ci[r][3] = -(sc_mul(C[0][r], C[0][3]) + sc_mul(C[1][r], C[1][3]) + sc_mul(C[2][r], C[2][3]));
			ci[3][r] = 0;
		}
		ci[3][3] = SC_C(1);
		m4_mul((const sc_t(*)[4])t->m, (const sc_t(*)[4])ci, e);
		dp = (struct vec3){ t->m[0][3] - C[0][3], t->m[1][3] - C[1][3], t->m[2][3] - C[2][3] };
	}
	for (r = 0; r < 3; r++)
		for (i = 0; i < 3; i++)
			R[r][i] = e[r][i];
	rot_log((const sc_t(*)[3])R, &w, &th);
	/* v = t - 1/2 w x t + k w x (w x t) */
	tr = (struct vec3){ e[0][3], e[1][3], e[2][3] };
	x = sc_mul(th, SC_C(0.5));
	sc_sincos(x, &s, &c);
	kk = ik_log_k(x, s, c);
	v3_cross(&w, &tr, &wt);
	v3_cross(&w, &wt, &wwt);
	V[0] = w.x, V[1] = w.y, V[2] = w.z;
	V[3] = tr.x - sc_mul(SC_C(0.5), wt.x) + sc_mul(kk, wwt.x);
	V[4] = tr.y - sc_mul(SC_C(0.5), wt.y) + sc_mul(kk, wwt.y);
	V[5] = tr.z - sc_mul(SC_C(0.5), wt.z) + sc_mul(kk, wwt.z);
	err->pos = v3_norm(&dp);
	err->rot = th;
}

const struct ik_kin ik_kin_mat = {
	.name = "matrix",
	.eval = kin_mat_eval,
};
