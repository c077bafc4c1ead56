// SPDX-License-Identifier: MIT
/*
 * keyframe.c - splines for positions, slerp and squad for orientations.
 * See keyframe.h.
 */
#include "record/keyframe.h"

#include "ik/dq.h"

#include <math.h>
#include <string.h>

static const char *const interp_names[] = { "linear", "catmull-rom", "natural" };

const char *kf_interp_name(enum kf_interp m)
{
	return (unsigned)m < 3 ? interp_names[m] : NULL;
}

int kf_interp_parse(const char *name)
{
	for (int i = 0; i < 3; i++)
		if (!strcmp(name, interp_names[i]))
			return i;
	return -1;
}

/* ---- quaternions (w, x, y, z) ---------------------------------------------------- */

static double qdot(const double a[4], const double b[4])
{
	return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
}

/* the IK core's product (double build), on arrays */
static void qmul(const double a[4], const double b[4], double o[4])
{
	struct quat x = { a[0], a[1], a[2], a[3] }, y = { b[0], b[1], b[2], b[3] }, r;

	quat_mul(&x, &y, &r);
	o[0] = r.w;
	o[1] = r.x;
	o[2] = r.y;
	o[3] = r.z;
}

static bool qunit(double q[4])
{
	double n = sqrt(qdot(q, q));

	if (!(n > 1e-12) || !isfinite(n))
		return false;
	for (int k = 0; k < 4; k++)
		q[k] /= n;
	return true;
}

/* log of a unit quaternion: the vector (angle / 2) * axis */
static void qlog(const double q[4], double v[3])
{
	double s = sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
	double w = q[0] > 1 ? 1 : q[0] < -1 ? -1 : q[0];
	/* atan2 keeps precision at both small and large angles; below 1e-9, the limit 1 */
	double k = s > 1e-9 ? atan2(s, w) / s : 1.0 / (w > 0 ? w : 1.0);

	v[0] = k * q[1];
	v[1] = k * q[2];
	v[2] = k * q[3];
}

static void qexp(const double v[3], double q[4])
{
	double a = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
	double k = a > 1e-9 ? sin(a) / a : 1.0 - a * a / 6.0;

	q[0] = cos(a);
	q[1] = k * v[0];
	q[2] = k * v[1];
	q[3] = k * v[2];
}

void kf_slerp(const double a[4], const double b[4], double h, double out[4])
{
	double d = qdot(a, b), bb[4], wa, wb;

	memcpy(bb, b, sizeof(bb));
	if (d < 0) {
		/* the shorter way round */
		d = -d;
		for (int k = 0; k < 4; k++)
			bb[k] = -bb[k];
	}
	if (d > 0.9999) {
		/* nearly equal: a normalised lerp is exact to 1e-13 rad here */
		wa = 1 - h;
		wb = h;
	} else {
		double th = acos(d), s = sin(th);

		wa = sin((1 - h) * th) / s;
		wb = sin(h * th) / s;
	}
	for (int k = 0; k < 4; k++)
		out[k] = wa * a[k] + wb * bb[k];
	qunit(out);
}

void kf_squad(const double q0[4], const double q1[4], const double s0[4], const double s1[4], double h, double out[4])
{
	double a[4], b[4];

	kf_slerp(q0, q1, h, a);
	kf_slerp(s0, s1, h, b);
	kf_slerp(a, b, 2 * h * (1 - h), out);
}

/* s = q exp(-(log(q* qn) + log(q* qp)) / 4) */
static void squad_inner(const double qp[4], const double q[4], const double qn[4], double s[4])
{
	double qc[4] = { q[0], -q[1], -q[2], -q[3] }, a[4], b[4], la[3], lb[3], v[3], e[4];

	qmul(qc, qn, a);
	qmul(qc, qp, b);
	qlog(a, la);
	qlog(b, lb);
	for (int k = 0; k < 3; k++)
		v[k] = -(la[k] + lb[k]) / 4;
	qexp(v, e);
	qmul(q, e, s);
	qunit(s);
}

/* ---- tracks ------------------------------------------------------------------------- */

size_t kf_segment(const double *times, size_t n, double t, size_t hint)
{
	size_t lo, hi;

	if (n < 2 || t < times[1])
		return 0;
	if (t >= times[n - 2])
		return n - 2;
	if (hint + 1 < n && times[hint] <= t && t < times[hint + 1])
		return hint;
	if (hint + 2 < n && times[hint + 1] <= t && t < times[hint + 2])
		return hint + 1;
	/* times[lo] <= t < times[hi] */
	lo = 1;
	hi = n - 2;
	while (hi - lo > 1) {
		size_t mid = lo + (hi - lo) / 2;

		if (times[mid] <= t)
			lo = mid;
		else
			hi = mid;
	}
	return lo;
}

/* the natural cubic spline's second derivatives, per coordinate (Thomas algorithm) */
static void natural_d2(struct kf_track *tr)
{
	size_t n = tr->n, i;
	double *c = tr->work;

	for (int k = 0; k < 3; k++) {
		tr->d2[0][k] = 0;
		tr->d2[n - 1][k] = 0;
	}
	if (n < 3)
		return;
	/* rows i = 1 .. n-2: h0 M[i-1] + 2 (h0 + h1) M[i] + h1 M[i+1] = r[i]; M[0] = M[n-1] = 0 */
	c[0] = 0;
	for (i = 1; i + 1 < n; i++) {
		double h0 = tr->t[i] - tr->t[i - 1], h1 = tr->t[i + 1] - tr->t[i];
		double den = 2 * (h0 + h1) - h0 * c[i - 1];

		c[i] = h1 / den;
		for (int k = 0; k < 3; k++) {
			double r = 6 * ((tr->key[i + 1].p[k] - tr->key[i].p[k]) / h1 -
					(tr->key[i].p[k] - tr->key[i - 1].p[k]) / h0);
			double prev = i > 1 ? tr->d2[i - 1][k] : 0;

			tr->d2[i][k] = (r - h0 * prev) / den;
		}
	}
	for (i = n - 2; i >= 1; i--) {
		for (int k = 0; k < 3; k++)
			tr->d2[i][k] -= c[i] * tr->d2[i + 1][k];
		if (i == 1)
			break;
	}
}

int kf_prepare(struct kf_track *tr)
{
	size_t n = tr->n, i;

	if (n == 0 || !tr->t || !tr->key || (unsigned)tr->interp > KF_NATURAL)
		return -1;
	if (tr->interp == KF_NATURAL && (!tr->d2 || !tr->work))
		return -1;
	if (tr->interp != KF_LINEAR && !tr->s)
		return -1;
	for (i = 0; i < n; i++) {
		struct kf_pose *k = &tr->key[i];

		if (!isfinite(tr->t[i]) || (i && !(tr->t[i] > tr->t[i - 1])))
			return -1;
		for (int j = 0; j < 3; j++)
			if (!isfinite(k->p[j]))
				return -1;
		if (!qunit(k->q))
			return -1;
		/* one hemisphere along the track, so that neighbours interpolate the short way */
		if (i && qdot(k->q, tr->key[i - 1].q) < 0)
			for (int j = 0; j < 4; j++)
				k->q[j] = -k->q[j];
	}
	if (tr->interp == KF_NATURAL)
		natural_d2(tr);
	if (tr->interp != KF_LINEAR)
		for (i = 0; i < n; i++) {
			if (i == 0 || i == n - 1)
				memcpy(tr->s[i], tr->key[i].q, sizeof(tr->s[i]));
			else
				squad_inner(tr->key[i - 1].q, tr->key[i].q, tr->key[i + 1].q, tr->s[i]);
		}
	return 0;
}

/* the tangent of the Catmull-Rom spline at key i */
static void cr_tangent(const struct kf_track *tr, size_t i, double m[3])
{
	size_t a = i ? i - 1 : 0, b = i + 1 < tr->n ? i + 1 : i;
	double dt = tr->t[b] - tr->t[a];

	for (int k = 0; k < 3; k++)
		m[k] = (tr->key[b].p[k] - tr->key[a].p[k]) / dt;
}

void kf_eval(const struct kf_track *tr, double t, struct kf_pose *out)
{
	size_t i;
	double t0, t1, dt, h;
	const struct kf_pose *a, *b;

	if (tr->n == 1 || t <= tr->t[0]) {
		*out = tr->key[0];
		return;
	}
	if (t >= tr->t[tr->n - 1]) {
		*out = tr->key[tr->n - 1];
		return;
	}
	i = kf_segment(tr->t, tr->n, t, 0);
	a = &tr->key[i];
	b = &tr->key[i + 1];
	t0 = tr->t[i];
	t1 = tr->t[i + 1];
	dt = t1 - t0;
	h = (t - t0) / dt;
	switch (tr->interp) {
	case KF_LINEAR:
		for (int k = 0; k < 3; k++)
			out->p[k] = a->p[k] + h * (b->p[k] - a->p[k]);
		kf_slerp(a->q, b->q, h, out->q);
		return;
	case KF_CATMULL_ROM: {
		double m0[3], m1[3], h2 = h * h, h3 = h2 * h;
		double c00 = 2 * h3 - 3 * h2 + 1, c10 = h3 - 2 * h2 + h, c01 = -2 * h3 + 3 * h2, c11 = h3 - h2;

		cr_tangent(tr, i, m0);
		cr_tangent(tr, i + 1, m1);
		for (int k = 0; k < 3; k++)
			out->p[k] = c00 * a->p[k] + c10 * dt * m0[k] + c01 * b->p[k] + c11 * dt * m1[k];
		break;
	}
	case KF_NATURAL: {
		double u = 1 - h, w = h;

		for (int k = 0; k < 3; k++)
			out->p[k] = u * a->p[k] + w * b->p[k] +
				    ((u * u * u - u) * tr->d2[i][k] + (w * w * w - w) * tr->d2[i + 1][k]) * dt * dt / 6;
		break;
	}
	}
	kf_squad(a->q, b->q, tr->s[i], tr->s[i + 1], h, out->q);
}
