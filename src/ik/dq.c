// SPDX-License-Identifier: MIT
/*
 * dq.c - quaternion and dual-quaternion algebra. See ik/dq.h for contracts.
 * Compiled once per scalar type.
 */
/* with SC_FIXQ_OUTLINE this file holds the one copy of the largest small algebra (dq.h) */
#define DQ_DEFINE_OUTLINE
#include "ik/dq.h"
#include "ik_private.h"

#if IK_COMPACT
/* the next two coordinates after k, cyclically */
static const unsigned char next3[5] = { 1, 2, 0, 1, 2 };

sc_t sc_mul_add(sc_t a, sc_t b, sc_t c, sc_t d)
{
	return sc_mul(a, b) + sc_mul(c, d);
}

sc_t sc_mul_sub(sc_t a, sc_t b, sc_t c, sc_t d)
{
	return sc_mul(a, b) - sc_mul(c, d);
}

sc_acc_t vn_dot_acc(const sc_t *a, const sc_t *b, int n)
{
	sc_acc_t s = sc_acc0();
	int i;

	for (i = 0; i < n; i++)
		s = sc_mac(s, a[i], b[i]);
	return s;
}

sc_t v3_dot(const struct vec3 *a, const struct vec3 *b)
{
	return sc_acc_get(vn_dot_acc(SC_CV(a), SC_CV(b), 3));
}

sc_t v3_norm(const struct vec3 *a)
{
	return sc_acc_sqrt(vn_dot_acc(SC_CV(a), SC_CV(a), 3));
}

sc_t quat_norm(const struct quat *a)
{
	return sc_acc_sqrt(vn_dot_acc(SC_CV(a), SC_CV(a), 4));
}

static sc_t quat_dot(const struct quat *a, const struct quat *b)
{
	return sc_acc_get(vn_dot_acc(SC_CV(a), SC_CV(b), 4));
}

void v3_cross(const struct vec3 *a, const struct vec3 *b, struct vec3 *out)
{
	const sc_t *u = SC_CV(a), *v = SC_CV(b);
	sc_t c[3];
	int k;

	for (k = 0; k < 3; k++) {
		int i = next3[k], j = next3[k + 1];

		c[k] = sc_acc_get(sc_msb(sc_mac(sc_acc0(), u[i], v[j]), u[j], v[i]));
	}
	out->x = c[0], out->y = c[1], out->z = c[2];
}

void quat_mul(const struct quat *a, const struct quat *b, struct quat *out)
{
	/* component i of a b sums a_j b_(i xor j); bit 4 i + j of neg: that term is subtracted */
	const unsigned neg = 0x428eu;
	const sc_t *u = SC_CV(a), *v = SC_CV(b);
	sc_t c[4];
	int i, j;

	for (i = 0; i < 4; i++) {
		sc_acc_t s = sc_acc0();

		for (j = 0; j < 4; j++)
			s = neg >> (4 * i + j) & 1u ? sc_msb(s, u[j], v[i ^ j]) : sc_mac(s, u[j], v[i ^ j]);
		c[i] = sc_acc_get(s);
	}
	out->w = c[0], out->x = c[1], out->y = c[2], out->z = c[3];
}

void quat_axis(const struct quat *q, int k, struct vec3 *out)
{
	/* with i, j the next axes: R e_k = (1 - 2 (u_i^2 + u_j^2)) e_k + 2 (u_k u_i + w u_j) e_i + 2 (u_k u_j - w u_i)
	 * e_j */
	const sc_t *u = &q->x;
	sc_t *o = SC_V(out);
	int i = next3[k], j = next3[k + 1];

	o[k] = SC_C(1) - 2 * sc_mul_add(u[i], u[i], u[j], u[j]);
	o[i] = 2 * sc_mul_add(u[k], u[i], q->w, u[j]);
	o[j] = 2 * sc_mul_sub(u[k], u[j], q->w, u[i]);
}
#else
static sc_t quat_dot(const struct quat *a, const struct quat *b)
{
	sc_acc_t s = sc_mac(sc_acc0(), a->w, b->w);

	s = sc_mac(s, a->x, b->x);
	s = sc_mac(s, a->y, b->y);
	return sc_acc_get(sc_mac(s, a->z, b->z));
}
#endif

/* a / n, n the norm of a (or of a larger vector a belongs to) */
static void quat_div_norm(const struct quat *a, sc_t n, struct quat *out)
{
	sc_recip_t k = sc_recip(n);
	int i;

	for (i = 0; i < 4; i++)
		SC_V(out)[i] = sc_mul_recip(SC_CV(a)[i], k);
}

/*
 * The four squares of a quaternion's norm must fit the accumulator. In
 * fixed point (SC_SQ_SAFE > 0) a component beyond SC_SQ_SAFE (possible only
 * in input from outside) scales the quaternion by 1/8 first: its direction
 * is all a normalisation keeps. Unit quaternions are never touched.
 */
static bool quat_tame(const struct quat *a, struct quat *out)
{
	sc_t m = 0;
	int i;

	*out = *a;
	for (i = 0; i < 4; i++)
		m = sc_max(m, sc_abs(SC_CV(a)[i]));
	if (SC_SQ_SAFE > 0 && m > SC_SQ_SAFE) {
		for (i = 0; i < 4; i++)
			SC_V(out)[i] = sc_mul(SC_CV(a)[i], SC_C(0.125));
		return true;
	}
	return false;
}

static void quat_scale(const struct quat *a, sc_t k, struct quat *out)
{
	out->w = sc_mul(a->w, k);
	out->x = sc_mul(a->x, k);
	out->y = sc_mul(a->y, k);
	out->z = sc_mul(a->z, k);
}

bool quat_normalize(const struct quat *a, struct quat *out)
{
	struct quat t;
	sc_t n;

	quat_tame(a, &t);
	n = quat_norm(&t);
	if (!sc_isfinite(n) || n < SC_EPS) {
		*out = (struct quat){ SC_C(1), 0, 0, 0 };
		return false;
	}
	quat_div_norm(&t, n, out);
	return true;
}

void quat_to_mat3(const struct quat *q, sc_t m[3][3])
{
#if IK_COMPACT
	struct vec3 c;
	int i, k;

	for (k = 0; k < 3; k++) {
		quat_axis(q, k, &c);
		for (i = 0; i < 3; i++)
			m[i][k] = SC_V(&c)[i];
	}
#else
	sc_t xx = sc_mul(q->x, q->x), yy = sc_mul(q->y, q->y), zz = sc_mul(q->z, q->z);
	sc_t xy = sc_mul(q->x, q->y), xz = sc_mul(q->x, q->z), yz = sc_mul(q->y, q->z);
	sc_t wx = sc_mul(q->w, q->x), wy = sc_mul(q->w, q->y), wz = sc_mul(q->w, q->z);

	m[0][0] = SC_C(1) - 2 * (yy + zz);
	m[0][1] = 2 * (xy - wz);
	m[0][2] = 2 * (xz + wy);
	m[1][0] = 2 * (xy + wz);
	m[1][1] = SC_C(1) - 2 * (xx + zz);
	m[1][2] = 2 * (yz - wx);
	m[2][0] = 2 * (xz - wy);
	m[2][1] = 2 * (yz + wx);
	m[2][2] = SC_C(1) - 2 * (xx + yy);
#endif
}

void quat_from_mat3(const sc_t m[3][3], struct quat *out)
{
	/* Shepperd: take the root of the largest of 4 w^2, 4 x^2, 4 y^2, 4 z^2 */
	sc_t tr = m[0][0] + m[1][1] + m[2][2];
	sc_t r, k;
	struct quat q;

	if (tr >= m[0][0] && tr >= m[1][1] && tr >= m[2][2]) {
		r = sc_sqrt(SC_C(1) + tr);
		k = sc_div(SC_C(0.5), r);
		q.w = sc_mul(r, SC_C(0.5));
		q.x = sc_mul(m[2][1] - m[1][2], k);
		q.y = sc_mul(m[0][2] - m[2][0], k);
		q.z = sc_mul(m[1][0] - m[0][1], k);
	} else if (m[0][0] >= m[1][1] && m[0][0] >= m[2][2]) {
		r = sc_sqrt(SC_C(1) + m[0][0] - m[1][1] - m[2][2]);
		k = sc_div(SC_C(0.5), r);
		q.x = sc_mul(r, SC_C(0.5));
		q.w = sc_mul(m[2][1] - m[1][2], k);
		q.y = sc_mul(m[0][1] + m[1][0], k);
		q.z = sc_mul(m[0][2] + m[2][0], k);
	} else if (m[1][1] >= m[2][2]) {
		r = sc_sqrt(SC_C(1) - m[0][0] + m[1][1] - m[2][2]);
		k = sc_div(SC_C(0.5), r);
		q.y = sc_mul(r, SC_C(0.5));
		q.w = sc_mul(m[0][2] - m[2][0], k);
		q.x = sc_mul(m[0][1] + m[1][0], k);
		q.z = sc_mul(m[1][2] + m[2][1], k);
	} else {
		r = sc_sqrt(SC_C(1) - m[0][0] - m[1][1] + m[2][2]);
		k = sc_div(SC_C(0.5), r);
		q.z = sc_mul(r, SC_C(0.5));
		q.w = sc_mul(m[1][0] - m[0][1], k);
		q.x = sc_mul(m[0][2] + m[2][0], k);
		q.y = sc_mul(m[1][2] + m[2][1], k);
	}
	if (q.w < 0)
		quat_scale(&q, SC_C(-1), &q);
	quat_normalize(&q, out);
}

sc_t quat_angle_between(const struct quat *a, const struct quat *b)
{
	struct quat ac, e;
	sc_t s;

	quat_conj(a, &ac);
	quat_mul(&ac, b, &e);
	s = sc_acc_sqrt(sc_mac(sc_mac(sc_mac(sc_acc0(), e.x, e.x), e.y, e.y), e.z, e.z));
	return 2 * sc_atan2(s, sc_abs(e.w));
}

bool dq_normalize(const struct dq *a, struct dq *out)
{
	sc_t n, rd;
	struct quat r, d;
	bool tamed;

	tamed = quat_tame(&a->r, &r);
	n = quat_norm(&r);
	if (!sc_isfinite(n) || n < SC_EPS || !dq_is_finite(a)) {
		dq_identity(out);
		return false;
	}
	if (tamed) {
		/* tamed: the dual part is scaled alike (a normalisation does not see the scale) */
		d.w = sc_mul(a->d.w, SC_C(0.125));
		d.x = sc_mul(a->d.x, SC_C(0.125));
		d.y = sc_mul(a->d.y, SC_C(0.125));
		d.z = sc_mul(a->d.z, SC_C(0.125));
	} else {
		d = a->d;
	}
	quat_div_norm(&r, n, &r);
	quat_div_norm(&d, n, &d);
	rd = quat_dot(&r, &d);
	d.w -= sc_mul(rd, r.w);
	d.x -= sc_mul(rd, r.x);
	d.y -= sc_mul(rd, r.y);
	d.z -= sc_mul(rd, r.z);
	out->r = r;
	out->d = d;
	return true;
}

void dq_from_axis_angle_t(const struct vec3 *axis, sc_t angle, const struct vec3 *t, struct dq *out)
{
	struct quat r;

	quat_from_axis_angle(axis, angle, &r);
	dq_from_rt(&r, t, out);
}

void dq_transform_line(const struct dq *a, const struct line *in, struct line *out)
{
	struct vec3 t, l, m, tl;

	dq_translation(a, &t);
	quat_rotate(&a->r, &in->l, &l);
	quat_rotate(&a->r, &in->m, &m);
	v3_cross(&t, &l, &tl);
	out->l = l;
	out->m.x = m.x + tl.x;
	out->m.y = m.y + tl.y;
	out->m.z = m.z + tl.z;
}

void dq_to_mat4(const struct dq *a, sc_t m[4][4])
{
	sc_t r[3][3];
	struct vec3 t;
	int i, j;

	quat_to_mat3(&a->r, r);
	dq_translation(a, &t);
	for (i = 0; i < 3; i++)
		for (j = 0; j < 3; j++)
			m[i][j] = r[i][j];
	m[0][3] = t.x;
	m[1][3] = t.y;
	m[2][3] = t.z;
	m[3][0] = m[3][1] = m[3][2] = 0;
	m[3][3] = SC_C(1);
}

void dq_from_mat4(const sc_t m[4][4], struct dq *out)
{
	sc_t r[3][3];
	struct quat q;
	struct vec3 t = { m[0][3], m[1][3], m[2][3] };
	int i, j;

	for (i = 0; i < 3; i++)
		for (j = 0; j < 3; j++)
			r[i][j] = m[i][j];
	quat_from_mat3((const sc_t(*)[3])r, &q);
	dq_from_rt(&q, &t, out);
}

void dq_log_twist_rt(const struct quat *r, const struct vec3 *t, struct twist *out, sc_t *half_angle)
{
	struct quat e = *r;
	struct vec3 wt, wwt;
	sc_t s, c, x, k, f, ic, g;

	if (e.w < 0) {
		/* the shortest path; t does not change with the sign of the dual quaternion */
		e.w = -e.w;
		e.x = -e.x;
		e.y = -e.y;
		e.z = -e.z;
	}
	s = sc_acc_sqrt(sc_mac(sc_mac(sc_mac(sc_acc0(), e.x, e.x), e.y, e.y), e.z, e.z));
	c = e.w;
	x = ik_half_angle(s, c, &ic, &g); /* half the rotation angle, in [0, pi/2] */
	/* 2 x / s; at small angles (2 / c) (1 - u^2/3 + u^4/5) */
	f = g != 0 ? sc_mul(2 * ic, g) : sc_div(2 * x, s);
	/* v = t - 1/2 w x t + k w x (w x t) */
	k = ik_log_k(x, s, c);
#if IK_COMPACT
	{
		int i;

		for (i = 0; i < 3; i++)
			SC_V(&out->w)[i] = sc_mul(f, SC_V(&e)[i + 1]);
		v3_cross(&out->w, t, &wt);
		v3_cross(&out->w, &wt, &wwt);
		for (i = 0; i < 3; i++)
			SC_V(&out->v)[i] = SC_CV(t)[i] - sc_mul(SC_C(0.5), SC_V(&wt)[i]) + sc_mul(k, SC_V(&wwt)[i]);
	}
#else
	/* (straight-line where speed matters: the loops cost the host's Newton step 17 %) */
	out->w.x = sc_mul(f, e.x);
	out->w.y = sc_mul(f, e.y);
	out->w.z = sc_mul(f, e.z);
	v3_cross(&out->w, t, &wt);
	v3_cross(&out->w, &wt, &wwt);
	out->v.x = t->x - sc_mul(SC_C(0.5), wt.x) + sc_mul(k, wwt.x);
	out->v.y = t->y - sc_mul(SC_C(0.5), wt.y) + sc_mul(k, wwt.y);
	out->v.z = t->z - sc_mul(SC_C(0.5), wt.z) + sc_mul(k, wwt.z);
#endif
	*half_angle = x;
}

void dq_log_twist(const struct dq *a, struct twist *out)
{
	struct vec3 t;
	sc_t x;

	dq_translation(a, &t);
	dq_log_twist_rt(&a->r, &t, out, &x);
}

void dq_exp_twist(const struct twist *tw, struct dq *out)
{
	sc_t th2 = v3_dot(&tw->w, &tw->w), th = v3_norm(&tw->w), s, c, a, b, h;
	struct vec3 wv, wwv, t;
	struct quat r;

	sc_sincos(sc_mul(th, SC_C(0.5)), &s, &c);
	/* r = (cos th/2, sin(th/2)/th w); t = v + a w x v + b w x (w x v) */
	if (th < SC_C(1e-3)) {
		h = SC_C(0.5) - sc_mul(th2, SC_C(1.0 / 48));
		a = SC_C(0.5) - sc_mul(th2, SC_C(1.0 / 24));
		b = SC_C(1.0 / 6) - sc_mul(th2, SC_C(1.0 / 120));
	} else {
		sc_t sth, cth;

		sc_sincos(th, &sth, &cth);
		h = sc_div(s, th);
		a = sc_div(SC_C(1) - cth, th2);
		b = sc_div(th - sth, sc_mul(th2, th));
	}
	r = (struct quat){ c, sc_mul(h, tw->w.x), sc_mul(h, tw->w.y), sc_mul(h, tw->w.z) };
	v3_cross(&tw->w, &tw->v, &wv);
	v3_cross(&tw->w, &wv, &wwv);
	t.x = tw->v.x + sc_mul(a, wv.x) + sc_mul(b, wwv.x);
	t.y = tw->v.y + sc_mul(a, wv.y) + sc_mul(b, wwv.y);
	t.z = tw->v.z + sc_mul(a, wv.z) + sc_mul(b, wwv.z);
	dq_from_rt(&r, &t, out);
}

void dq_log(const struct dq *a, struct screw *out)
{
	struct twist tw;
	sc_t th;

	dq_log_twist(a, &tw);
	th = v3_norm(&tw.w);
	if (th > 16 * SC_EPS) {
		sc_recip_t k = sc_recip(th);

		out->angle = sc_min(th, SC_PI);
		out->l = (struct vec3){ sc_mul_recip(tw.w.x, k), sc_mul_recip(tw.w.y, k), sc_mul_recip(tw.w.z, k) };
		out->d = v3_dot(&out->l, &tw.v);
		/* v = angle m + d l */
		out->m.x = sc_mul_recip(tw.v.x - sc_mul(out->d, out->l.x), k);
		out->m.y = sc_mul_recip(tw.v.y - sc_mul(out->d, out->l.y), k);
		out->m.z = sc_mul_recip(tw.v.z - sc_mul(out->d, out->l.z), k);
		return;
	}
	/* (almost) pure translation: the axis is the direction of travel */
	out->angle = 0;
	out->m = (struct vec3){ 0, 0, 0 };
	out->d = v3_norm(&tw.v);
	if (out->d > SC_EPS) {
		sc_recip_t k = sc_recip(out->d);

		out->l = (struct vec3){ sc_mul_recip(tw.v.x, k), sc_mul_recip(tw.v.y, k), sc_mul_recip(tw.v.z, k) };
	} else {
		out->l = (struct vec3){ SC_C(1), 0, 0 };
	}
}

void dq_exp(const struct screw *s, struct dq *out)
{
	struct twist tw;

	tw.w = (struct vec3){ sc_mul(s->angle, s->l.x), sc_mul(s->angle, s->l.y), sc_mul(s->angle, s->l.z) };
	tw.v.x = sc_mul(s->angle, s->m.x) + sc_mul(s->d, s->l.x);
	tw.v.y = sc_mul(s->angle, s->m.y) + sc_mul(s->d, s->l.y);
	tw.v.z = sc_mul(s->angle, s->m.z) + sc_mul(s->d, s->l.z);
	dq_exp_twist(&tw, out);
}

bool dq_is_finite(const struct dq *a)
{
#if SC_TYPE == SC_FIXQ
	(void)a;
	return true; /* every fixed-point value is finite */
#else
	/* x - x is 0 for a finite x and NaN for an infinity or a NaN: one test for all eight */
	const sc_t *v = SC_CV(&a->r), *u = SC_CV(&a->d);
	sc_t z = ((v[0] - v[0]) + (v[1] - v[1])) + ((v[2] - v[2]) + (v[3] - v[3])) +
		 (((u[0] - u[0]) + (u[1] - u[1])) + ((u[2] - u[2]) + (u[3] - u[3])));

	return z == 0;
#endif
}
