// SPDX-License-Identifier: MIT
/*
 * dq.c - quaternion and dual-quaternion algebra. See ik/dq.h for contracts.
 * Compiled once per scalar type.
 */
#include "ik/dq.h"
#include "ik_private.h"

sc_t v3_dot(const struct vec3 *a, const struct vec3 *b)
{
	sc_acc_t s = sc_acc0();

	s = sc_mac(s, a->x, b->x);
	s = sc_mac(s, a->y, b->y);
	s = sc_mac(s, a->z, b->z);
	return sc_acc_get(s);
}

void v3_cross(const struct vec3 *a, const struct vec3 *b, struct vec3 *out)
{
	struct vec3 c;

	c.x = sc_acc_get(sc_msb(sc_mac(sc_acc0(), a->y, b->z), a->z, b->y));
	c.y = sc_acc_get(sc_msb(sc_mac(sc_acc0(), a->z, b->x), a->x, b->z));
	c.z = sc_acc_get(sc_msb(sc_mac(sc_acc0(), a->x, b->y), a->y, b->x));
	*out = c;
}

sc_t v3_norm(const struct vec3 *a)
{
	return sc_sqrt(v3_dot(a, a));
}

void quat_mul(const struct quat *a, const struct quat *b, struct quat *out)
{
	struct quat c;
	sc_acc_t s;

	s = sc_mac(sc_acc0(), a->w, b->w);
	s = sc_msb(s, a->x, b->x);
	s = sc_msb(s, a->y, b->y);
	c.w = sc_acc_get(sc_msb(s, a->z, b->z));
	s = sc_mac(sc_acc0(), a->w, b->x);
	s = sc_mac(s, a->x, b->w);
	s = sc_mac(s, a->y, b->z);
	c.x = sc_acc_get(sc_msb(s, a->z, b->y));
	s = sc_mac(sc_acc0(), a->w, b->y);
	s = sc_msb(s, a->x, b->z);
	s = sc_mac(s, a->y, b->w);
	c.y = sc_acc_get(sc_mac(s, a->z, b->x));
	s = sc_mac(sc_acc0(), a->w, b->z);
	s = sc_mac(s, a->x, b->y);
	s = sc_msb(s, a->y, b->x);
	c.z = sc_acc_get(sc_mac(s, a->z, b->w));
	*out = c;
}

void quat_conj(const struct quat *a, struct quat *out)
{
	out->w = a->w;
	out->x = -a->x;
	out->y = -a->y;
	out->z = -a->z;
}

static sc_t quat_dot(const struct quat *a, const struct quat *b)
{
	sc_acc_t s = sc_mac(sc_acc0(), a->w, b->w);

	s = sc_mac(s, a->x, b->x);
	s = sc_mac(s, a->y, b->y);
	return sc_acc_get(sc_mac(s, a->z, b->z));
}

sc_t quat_norm(const struct quat *a)
{
	return sc_sqrt(quat_dot(a, a));
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
	sc_t n = quat_norm(a);

	if (!sc_isfinite(n) || n < SC_EPS) {
		*out = (struct quat){ SC_C(1), 0, 0, 0 };
		return false;
	}
	quat_scale(a, sc_div(SC_C(1), n), out);
	return true;
}

void quat_rotate(const struct quat *q, const struct vec3 *v, struct vec3 *out)
{
	/* v' = v + 2w (u x v) + 2 u x (u x v), u the vector part */
	struct vec3 u = { q->x, q->y, q->z }, c, cc;

	v3_cross(&u, v, &c);
	c.x += c.x;
	c.y += c.y;
	c.z += c.z;
	v3_cross(&u, &c, &cc);
	out->x = v->x + sc_mul(q->w, c.x) + cc.x;
	out->y = v->y + sc_mul(q->w, c.y) + cc.y;
	out->z = v->z + sc_mul(q->w, c.z) + cc.z;
}

void quat_from_axis_angle(const struct vec3 *axis, sc_t angle, struct quat *out)
{
	sc_t s, c;

	sc_sincos(sc_mul(angle, SC_C(0.5)), &s, &c);
	out->w = c;
	out->x = sc_mul(axis->x, s);
	out->y = sc_mul(axis->y, s);
	out->z = sc_mul(axis->z, s);
}

void quat_to_mat3(const struct quat *q, sc_t m[3][3])
{
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
	s = sc_sqrt(sc_acc_get(sc_mac(sc_mac(sc_mac(sc_acc0(), e.x, e.x), e.y, e.y), e.z, e.z)));
	return 2 * sc_atan2(s, sc_abs(e.w));
}

void dq_identity(struct dq *out)
{
	*out = (struct dq){ { SC_C(1), 0, 0, 0 }, { 0, 0, 0, 0 } };
}

void dq_mul(const struct dq *a, const struct dq *b, struct dq *out)
{
	struct quat t1, t2;

	quat_mul(&a->r, &b->r, &out->r);
	quat_mul(&a->r, &b->d, &t1);
	quat_mul(&a->d, &b->r, &t2);
	out->d.w = t1.w + t2.w;
	out->d.x = t1.x + t2.x;
	out->d.y = t1.y + t2.y;
	out->d.z = t1.z + t2.z;
}

void dq_conj(const struct dq *a, struct dq *out)
{
	quat_conj(&a->r, &out->r);
	quat_conj(&a->d, &out->d);
}

bool dq_normalize(const struct dq *a, struct dq *out)
{
	sc_t n = quat_norm(&a->r), k, rd;
	struct quat r, d;

	if (!sc_isfinite(n) || n < SC_EPS || !dq_is_finite(a)) {
		dq_identity(out);
		return false;
	}
	k = sc_div(SC_C(1), n);
	quat_scale(&a->r, k, &r);
	quat_scale(&a->d, k, &d);
	rd = quat_dot(&r, &d);
	d.w -= sc_mul(rd, r.w);
	d.x -= sc_mul(rd, r.x);
	d.y -= sc_mul(rd, r.y);
	d.z -= sc_mul(rd, r.z);
	out->r = r;
	out->d = d;
	return true;
}

void dq_from_rt(const struct quat *r, const struct vec3 *t, struct dq *out)
{
	struct quat tq = { 0, sc_mul(t->x, SC_C(0.5)), sc_mul(t->y, SC_C(0.5)), sc_mul(t->z, SC_C(0.5)) };
	struct quat rr = *r;

	quat_mul(&tq, &rr, &out->d);
	out->r = rr;
}

void dq_from_axis_angle_t(const struct vec3 *axis, sc_t angle, const struct vec3 *t, struct dq *out)
{
	struct quat r;

	quat_from_axis_angle(axis, angle, &r);
	dq_from_rt(&r, t, out);
}

void dq_translation(const struct dq *a, struct vec3 *out)
{
	/* t = 2 d r* */
	struct quat rc, t;

	quat_conj(&a->r, &rc);
	quat_mul(&a->d, &rc, &t);
	out->x = 2 * t.x;
	out->y = 2 * t.y;
	out->z = 2 * t.z;
}

void dq_transform_point(const struct dq *a, const struct vec3 *p, struct vec3 *out)
{
	struct vec3 t, rp;

	dq_translation(a, &t);
	quat_rotate(&a->r, p, &rp);
	out->x = rp.x + t.x;
	out->y = rp.y + t.y;
	out->z = rp.z + t.z;
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

void dq_log_twist(const struct dq *a, struct twist *out)
{
	struct dq e = *a;
	struct quat rc, tq;
	struct vec3 t, wt, wwt;
	sc_t s, c, x, k, f;

	if (e.r.w < 0) {
		quat_scale(&e.r, SC_C(-1), &e.r);
		quat_scale(&e.d, SC_C(-1), &e.d);
	}
	s = sc_sqrt(sc_acc_get(sc_mac(sc_mac(sc_mac(sc_acc0(), e.r.x, e.r.x), e.r.y, e.r.y), e.r.z, e.r.z)));
	c = e.r.w;
	x = sc_atan2(s, c); /* half the rotation angle, in [0, pi/2] */
	if (s < sc_mul(SC_C(1e-3), c)) {
		/* 2 x / s = (2 / c) (1 - (s/c)^2 / 3 + (s/c)^4 / 5) */
		sc_t u = sc_div(s, c), u2 = sc_mul(u, u);

		f = sc_mul(sc_div(SC_C(2), c), SC_C(1) - sc_mul(u2, SC_C(1.0 / 3) - sc_mul(u2, SC_C(0.2))));
	} else {
		f = sc_div(2 * x, s);
	}
	out->w.x = sc_mul(f, e.r.x);
	out->w.y = sc_mul(f, e.r.y);
	out->w.z = sc_mul(f, e.r.z);
	quat_conj(&e.r, &rc);
	quat_mul(&e.d, &rc, &tq);
	t = (struct vec3){ 2 * tq.x, 2 * tq.y, 2 * tq.z };
	/* v = t - 1/2 w x t + k w x (w x t) */
	k = ik_log_k(x, s, c);
	v3_cross(&out->w, &t, &wt);
	v3_cross(&out->w, &wt, &wwt);
	out->v.x = t.x - sc_mul(SC_C(0.5), wt.x) + sc_mul(k, wwt.x);
	out->v.y = t.y - sc_mul(SC_C(0.5), wt.y) + sc_mul(k, wwt.y);
	out->v.z = t.z - sc_mul(SC_C(0.5), wt.z) + sc_mul(k, wwt.z);
}

void dq_exp_twist(const struct twist *tw, struct dq *out)
{
	sc_t th2 = v3_dot(&tw->w, &tw->w), th = sc_sqrt(th2), s, c, a, b, h;
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
		sc_t k = sc_div(SC_C(1), th);

		out->angle = sc_min(th, SC_PI);
		out->l = (struct vec3){ sc_mul(tw.w.x, k), sc_mul(tw.w.y, k), sc_mul(tw.w.z, k) };
		out->d = v3_dot(&out->l, &tw.v);
		/* v = angle m + d l */
		out->m.x = sc_mul(tw.v.x - sc_mul(out->d, out->l.x), k);
		out->m.y = sc_mul(tw.v.y - sc_mul(out->d, out->l.y), k);
		out->m.z = sc_mul(tw.v.z - sc_mul(out->d, out->l.z), k);
		return;
	}
	/* (almost) pure translation: the axis is the direction of travel */
	out->angle = 0;
	out->m = (struct vec3){ 0, 0, 0 };
	out->d = v3_norm(&tw.v);
	if (out->d > SC_EPS) {
		sc_t k = sc_div(SC_C(1), out->d);

		out->l = (struct vec3){ sc_mul(tw.v.x, k), sc_mul(tw.v.y, k), sc_mul(tw.v.z, k) };
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
	return sc_isfinite(a->r.w) && sc_isfinite(a->r.x) && sc_isfinite(a->r.y) && sc_isfinite(a->r.z) &&
	       sc_isfinite(a->d.w) && sc_isfinite(a->d.x) && sc_isfinite(a->d.y) && sc_isfinite(a->d.z);
}
