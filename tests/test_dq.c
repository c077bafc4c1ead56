// SPDX-License-Identifier: MIT
/*
 * test_dq.c - quaternion and dual-quaternion algebra of the IK core (double).
 *
 * The references are written out here from first principles: Rodrigues'
 * formula for rotations, the paper's eq. 1 for the dual part, its section 5.2
 * for the screw, and a geometric screw (axis through a point, angle, slide)
 * for the logarithm. Random numbers come from a fixed-seed xorshift so every
 * run checks the same inputs.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>

#include "ik/dq.h"

#include "testutil.h"

#define PI 3.14159265358979323846

/* ---- checks ---------------------------------------------------------------- */

/* what the current loop iteration is checking, printed on failure */

#define assert_ctx(cond)                                                                                               \
	do {                                                                                                           \
		if (!(cond))                                                                                           \
			fail_msg("%s: %s is false", ctx, #cond);                                                       \
	} while (0)

#define assert_finite(x)                                                                                               \
	do {                                                                                                           \
		double g_ = (x);                                                                                       \
		if (!isfinite(g_))                                                                                     \
			fail_msg("%s: %s = %g is not finite", ctx, #x, g_);                                            \
	} while (0)

/* a and b stand for the same transform: equal up to the sign of the whole dual quaternion */
#define assert_dq_same(a, b, tol)                                                                                      \
	do {                                                                                                           \
		const struct dq *a_ = (a), *b_ = (b);                                                                  \
		double s_ = a_->r.w * b_->r.w + a_->r.x * b_->r.x + a_->r.y * b_->r.y + a_->r.z * b_->r.z;             \
		struct dq n_ = *b_;                                                                                    \
		if (s_ < 0)                                                                                            \
			dq_neg(b_, &n_);                                                                               \
		assert_quat_near(a_->r, n_.r, (tol));                                                                  \
		assert_quat_near(a_->d, n_.d, (tol));                                                                  \
	} while (0)

#define assert_dq_finite(a)                                                                                            \
	do {                                                                                                           \
		assert_finite((a).r.w);                                                                                \
		assert_finite((a).r.x);                                                                                \
		assert_finite((a).r.y);                                                                                \
		assert_finite((a).r.z);                                                                                \
		assert_finite((a).d.w);                                                                                \
		assert_finite((a).d.x);                                                                                \
		assert_finite((a).d.y);                                                                                \
		assert_finite((a).d.z);                                                                                \
	} while (0)

static struct vec3 rnd_vec(double scale)
{
	return (struct vec3){ rnd_range(-scale, scale), rnd_range(-scale, scale), rnd_range(-scale, scale) };
}

static struct vec3 rnd_unit(void)
{
	for (;;) {
		struct vec3 v = rnd_vec(1);
		double n = sqrt(v.x * v.x + v.y * v.y + v.z * v.z);

		if (n > 0.1 && n <= 1)
			return (struct vec3){ v.x / n, v.y / n, v.z / n };
	}
}

/* ---- reference math, written independently of the core --------------------- */

static struct vec3 ref_cross(struct vec3 a, struct vec3 b)
{
	return (struct vec3){ a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x };
}

static double ref_dot(struct vec3 a, struct vec3 b)
{
	return a.x * b.x + a.y * b.y + a.z * b.z;
}

static struct vec3 ref_add(struct vec3 a, struct vec3 b)
{
	return (struct vec3){ a.x + b.x, a.y + b.y, a.z + b.z };
}

static struct vec3 ref_scale(struct vec3 a, double k)
{
	return (struct vec3){ a.x * k, a.y * k, a.z * k };
}

static double ref_norm(struct vec3 a)
{
	return sqrt(ref_dot(a, a));
}

/* Rodrigues: R = I + sin(th) K + (1 - cos(th)) K^2, K the cross-product matrix of unit n */
static void ref_rot(struct vec3 n, double th, double R[3][3])
{
	double s = sin(th), c1 = 2 * sin(th / 2) * sin(th / 2);
	double K[3][3] = { { 0, -n.z, n.y }, { n.z, 0, -n.x }, { -n.y, n.x, 0 } };
	int i, j, k;

	for (i = 0; i < 3; i++)
		for (j = 0; j < 3; j++) {
			double k2 = 0;

			for (k = 0; k < 3; k++)
				k2 += K[i][k] * K[k][j];
			R[i][j] = (i == j ? 1.0 : 0.0) + s * K[i][j] + c1 * k2;
		}
}

static struct vec3 ref_mv(const double R[3][3], struct vec3 v)
{
	return (struct vec3){ R[0][0] * v.x + R[0][1] * v.y + R[0][2] * v.z,
			      R[1][0] * v.x + R[1][1] * v.y + R[1][2] * v.z,
			      R[2][0] * v.x + R[2][1] * v.y + R[2][2] * v.z };
}

/* Hamilton product from the multiplication table i^2 = j^2 = k^2 = ijk = -1 */
static struct quat ref_qmul(struct quat a, struct quat b)
{
	struct vec3 u = { a.x, a.y, a.z }, v = { b.x, b.y, b.z }, c = ref_cross(u, v);

	return (struct quat){ a.w * b.w - ref_dot(u, v), a.w * v.x + b.w * u.x + c.x, a.w * v.y + b.w * u.y + c.y,
			      a.w * v.z + b.w * u.z + c.z };
}

static struct quat ref_quat(struct vec3 n, double th)
{
	double s = sin(th / 2);

	return (struct quat){ cos(th / 2), s * n.x, s * n.y, s * n.z };
}

static void dq_neg(const struct dq *a, struct dq *out)
{
	*out = (struct dq){ { -a->r.w, -a->r.x, -a->r.y, -a->r.z }, { -a->d.w, -a->d.x, -a->d.y, -a->d.z } };
}

static double ref_qdot(struct quat a, struct quat b)
{
	return a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z;
}

static void rnd_dq(struct dq *out, double max_angle, double tscale)
{
	struct quat r = ref_quat(rnd_unit(), rnd_range(-max_angle, max_angle));
	struct vec3 t = rnd_vec(tscale);

	dq_from_rt(&r, &t, out);
}

/*
 * The screw "rotate by th about the line through p with direction n, slide d
 * along it" as a dual quaternion: R = Rot(n, th), t = (I - R) p + d n, with
 * 1 - cos written as 2 sin^2 so tiny angles lose nothing.
 */
static void ref_screw_dq(struct vec3 n, struct vec3 p, double th, double d, struct dq *out)
{
	double s = sin(th), c1 = 2 * sin(th / 2) * sin(th / 2);
	struct vec3 nxp = ref_cross(n, p), t;
	struct quat r = ref_quat(n, th);

	/* (I - R) p = c1 p - s n x p - c1 n (n.p) */
	t = ref_add(ref_add(ref_scale(p, c1), ref_scale(nxp, -s)), ref_scale(n, d - c1 * ref_dot(n, p)));
	dq_from_rt(&r, &t, out);
}

/* ---- quaternions -------------------------------------------------------------- */

static void test_quat_products(void **state)
{
	const struct quat one = { 1, 0, 0, 0 }, qi = { 0, 1, 0, 0 }, qj = { 0, 0, 1, 0 }, qk = { 0, 0, 0, 1 };
	const struct quat minus_one = { -1, 0, 0, 0 };
	struct quat t;
	int n;

	(void)state;
	set_ctx("unit table");
	quat_mul(&qi, &qj, &t);
	assert_quat_near(t, qk, 0);
	quat_mul(&qj, &qk, &t);
	assert_quat_near(t, qi, 0);
	quat_mul(&qk, &qi, &t);
	assert_quat_near(t, qj, 0);
	quat_mul(&qj, &qi, &t);
	assert_quat_near(t, ((struct quat){ 0, 0, 0, -1 }), 0);
	quat_mul(&qi, &qi, &t);
	assert_quat_near(t, minus_one, 0);
	quat_mul(&qk, &qk, &t);
	assert_quat_near(t, minus_one, 0);

	rng_seed(1);
	for (n = 0; n < 1000; n++) {
		struct quat a = { rnd_range(-2, 2), rnd_range(-2, 2), rnd_range(-2, 2), rnd_range(-2, 2) };
		struct quat b = { rnd_range(-2, 2), rnd_range(-2, 2), rnd_range(-2, 2), rnd_range(-2, 2) };
		struct quat c = { rnd_range(-2, 2), rnd_range(-2, 2), rnd_range(-2, 2), rnd_range(-2, 2) };
		struct quat ab, ab_c, bc, a_bc, ac, aac;

		set_ctx("random quaternion %d", n);
		quat_mul(&a, &b, &ab);
		assert_quat_near(ab, ref_qmul(a, b), 1e-14);
		quat_mul(&ab, &c, &ab_c);
		quat_mul(&b, &c, &bc);
		quat_mul(&a, &bc, &a_bc);
		assert_quat_near(ab_c, a_bc, 1e-13);
		quat_mul(&a, &one, &t);
		assert_quat_near(t, a, 0);
		quat_mul(&one, &a, &t);
		assert_quat_near(t, a, 0);
		/* a a* = |a|^2, |a b| = |a| |b| */
		quat_conj(&a, &ac);
		assert_quat_near(ac, ((struct quat){ a.w, -a.x, -a.y, -a.z }), 0);
		quat_mul(&a, &ac, &aac);
		assert_quat_near(aac, ((struct quat){ ref_qdot(a, a), 0, 0, 0 }), 1e-14);
		assert_near(quat_norm(&a), sqrt(ref_qdot(a, a)), 1e-15);
		assert_near(quat_norm(&ab), quat_norm(&a) * quat_norm(&b), 1e-13);
		/* the result may alias an input */
		t = a;
		quat_mul(&t, &b, &t);
		assert_quat_near(t, ab, 0);
		t = b;
		quat_mul(&a, &t, &t);
		assert_quat_near(t, ab, 0);
	}
}

static void test_quat_rotation(void **state)
{
	int n;

	(void)state;
	rng_seed(2);
	for (n = 0; n < 1000; n++) {
		struct vec3 ax = rnd_unit(), v = rnd_vec(2), got, want, ax2 = rnd_unit();
		double th = rnd_range(-2 * PI, 2 * PI), th2 = rnd_range(0, PI), R[3][3], M[3][3];
		struct quat q, q2, qq;
		int i, j;

		set_ctx("axis (%g %g %g) angle %g", ax.x, ax.y, ax.z, th);
		quat_from_axis_angle(&ax, th, &q);
		assert_quat_near(q, ref_quat(ax, th), 1e-15);
		ref_rot(ax, th, R);
		quat_rotate(&q, &v, &got);
		want = ref_mv(R, v);
		assert_v3_near(got, want, 1e-14);
		quat_to_mat3(&q, M);
		for (i = 0; i < 3; i++)
			for (j = 0; j < 3; j++)
				assert_near(M[i][j], R[i][j], 1e-15);
		/* a rotation composed after q: the angle between them is th2 whatever the signs */
		q2 = ref_quat(ax2, th2);
		quat_mul(&q, &q2, &qq);
		assert_near(quat_angle_between(&q, &qq), th2, 1e-12);
		qq = (struct quat){ -qq.w, -qq.x, -qq.y, -qq.z };
		assert_near(quat_angle_between(&q, &qq), th2, 1e-12);
		assert_near(quat_angle_between(&qq, &q), th2, 1e-12);
		assert_near(quat_angle_between(&q, &q), 0, 1e-15);
	}
}

static void test_quat_normalize(void **state)
{
	const struct quat one = { 1, 0, 0, 0 };
	struct quat bad[] = {
		{ 0, 0, 0, 0 },	  { 1e-300, 0, 0, 0 },	 { NAN, 0, 0, 0 },
		{ 1, NAN, 0, 0 }, { 0, 0, INFINITY, 0 }, { 1, 0, 0, -INFINITY },
	};
	struct quat out;
	size_t i;
	int n;

	(void)state;
	rng_seed(3);
	for (n = 0; n < 200; n++) {
		struct quat u = ref_quat(rnd_unit(), rnd_range(-PI, PI));
		double k = rnd_range(1e-3, 1e3);
		struct quat a = { u.w * k, u.x * k, u.y * k, u.z * k };

		set_ctx("scale %g", k);
		assert_ctx(quat_normalize(&a, &out));
		assert_quat_near(out, u, 1e-15);
		assert_near(quat_norm(&out), 1, 1e-15);
	}
	for (i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		set_ctx("bad quaternion %zu", i);
		out = (struct quat){ 7, 7, 7, 7 };
		assert_ctx(!quat_normalize(&bad[i], &out));
		assert_quat_near(out, one, 0);
	}
}

/* ---- dual quaternions: products and construction ----------------------------- */

static void test_dq_products(void **state)
{
	struct dq id, t;
	int n;

	(void)state;
	dq_identity(&id);
	set_ctx("identity");
	assert_quat_near(id.r, ((struct quat){ 1, 0, 0, 0 }), 0);
	assert_quat_near(id.d, ((struct quat){ 0, 0, 0, 0 }), 0);

	rng_seed(4);
	for (n = 0; n < 1000; n++) {
		struct dq a, b, c, ab, ab_c, bc, a_bc, ac, aac, caa, bcac, abc_conj;
		struct vec3 p = rnd_vec(3), p1, p2, p3;

		set_ctx("random transforms %d", n);
		rnd_dq(&a, 2 * PI, 2);
		rnd_dq(&b, 2 * PI, 2);
		rnd_dq(&c, 2 * PI, 2);
		dq_mul(&a, &b, &ab);
		/* (a b) = (ra rb) + eps (ra db + da rb) */
		assert_quat_near(ab.r, ref_qmul(a.r, b.r), 1e-15);
		{
			struct quat x = ref_qmul(a.r, b.d), y = ref_qmul(a.d, b.r);

			assert_quat_near(ab.d, ((struct quat){ x.w + y.w, x.x + y.x, x.y + y.y, x.z + y.z }), 1e-14);
		}
		dq_mul(&ab, &c, &ab_c);
		dq_mul(&b, &c, &bc);
		dq_mul(&a, &bc, &a_bc);
		assert_dq_same(&ab_c, &a_bc, 1e-14);
		dq_mul(&a, &id, &t);
		assert_dq_same(&t, &a, 0);
		dq_mul(&id, &a, &t);
		assert_dq_same(&t, &a, 0);
		/* the conjugate of a unit dual quaternion is its inverse, on both sides */
		dq_conj(&a, &ac);
		dq_mul(&a, &ac, &aac);
		assert_quat_near(aac.r, id.r, 1e-15);
		assert_quat_near(aac.d, id.d, 1e-15);
		dq_mul(&ac, &a, &caa);
		assert_quat_near(caa.r, id.r, 1e-15);
		assert_quat_near(caa.d, id.d, 1e-15);
		/* (a b)^-1 = b^-1 a^-1 */
		dq_conj(&b, &t);
		dq_mul(&t, &ac, &bcac);
		dq_conj(&ab, &abc_conj);
		assert_dq_same(&bcac, &abc_conj, 1e-15);
		/* the product of unit dual quaternions is unit */
		assert_near(quat_norm(&ab.r), 1, 1e-15);
		assert_near(ref_qdot(ab.r, ab.d), 0, 1e-15);
		/* base-first like 4x4 matrices: a b applies b first */
		dq_transform_point(&ab, &p, &p1);
		dq_transform_point(&b, &p, &p2);
		dq_transform_point(&a, &p2, &p3);
		assert_v3_near(p1, p3, 1e-14);
		/* conj is an involution and may alias */
		t = ac;
		dq_conj(&t, &t);
		assert_dq_same(&t, &a, 0);
	}
}

static void test_dq_from_rt(void **state)
{
	int n;

	(void)state;
	rng_seed(5);
	for (n = 0; n < 1000; n++) {
		struct quat r = ref_quat(rnd_unit(), rnd_range(-2 * PI, 2 * PI)), half_t;
		struct vec3 t = rnd_vec(5), back;
		struct dq a;

		set_ctx("random r, t %d", n);
		dq_from_rt(&r, &t, &a);
		assert_quat_near(a.r, r, 0);
		/* d = 1/2 t r */
		half_t = (struct quat){ 0, t.x / 2, t.y / 2, t.z / 2 };
		assert_quat_near(a.d, ref_qmul(half_t, r), 1e-15);
		assert_near(ref_qdot(a.r, a.d), 0, 1e-15);
		dq_translation(&a, &back);
		assert_v3_near(back, t, 1e-14);
	}
	{
		struct quat r = ref_quat((struct vec3){ 0, 0, 1 }, 1);
		struct vec3 z = { 0, 0, 0 }, back;
		struct dq a;

		set_ctx("no translation");
		dq_from_rt(&r, &z, &a);
		assert_quat_near(a.d, ((struct quat){ 0, 0, 0, 0 }), 0);
		dq_translation(&a, &back);
		assert_v3_near(back, z, 0);
	}
}

/*
 * The paper's eq. 1, with R = (x, y, z) the unit axis, T = (dx, dy, dz),
 * c = cos(theta/2), s = sin(theta/2), the scalar stored LAST:
 *   q1 = 1/2 (dx c + (dy z - dz y) s)
 *   q2 = 1/2 (dy c + (dz x - dx z) s)
 *   q3 = 1/2 (dz c + (dx y - dy x) s)
 *   q4 = -1/2 (x dx + y dy + z dz) s
 */
static void test_dq_axis_angle_eq1(void **state)
{
	int n;

	(void)state;
	rng_seed(6);
	for (n = 0; n < 1000; n++) {
		struct vec3 ax = rnd_unit(), T = rnd_vec(2), p = rnd_vec(2), got, want;
		double th = rnd_range(-2 * PI, 2 * PI), c = cos(th / 2), s = sin(th / 2);
		double x = ax.x, y = ax.y, z = ax.z, dx = T.x, dy = T.y, dz = T.z, R[3][3];
		double q1 = 0.5 * (dx * c + (dy * z - dz * y) * s);
		double q2 = 0.5 * (dy * c + (dz * x - dx * z) * s);
		double q3 = 0.5 * (dz * c + (dx * y - dy * x) * s);
		double q4 = -0.5 * (x * dx + y * dy + z * dz) * s;
		struct dq a;

		set_ctx("axis (%g %g %g) angle %g T (%g %g %g)", x, y, z, th, dx, dy, dz);
		dq_from_axis_angle_t(&ax, th, &T, &a);
		assert_quat_near(a.r, ((struct quat){ c, x * s, y * s, z * s }), 1e-15);
		/* ours stores the scalar first: d = (q4, q1, q2, q3) */
		assert_near(a.d.w, q4, 1e-15);
		assert_near(a.d.x, q1, 1e-15);
		assert_near(a.d.y, q2, 1e-15);
		assert_near(a.d.z, q3, 1e-15);
		/* and it means: rotate about the axis, then translate by T in the parent frame */
		ref_rot(ax, th, R);
		want = ref_add(ref_mv(R, p), T);
		dq_transform_point(&a, &p, &got);
		assert_v3_near(got, want, 1e-14);
	}
}

static void test_dq_normalize(void **state)
{
	struct dq bad[] = {
		{ { 0, 0, 0, 0 }, { 0, 1, 2, 3 } },	   { { 1e-200, 0, 0, 0 }, { 0, 0, 0, 0 } },
		{ { NAN, 0, 0, 0 }, { 0, 0, 0, 0 } },	   { { 1, 0, NAN, 0 }, { 0, 0, 0, 0 } },
		{ { 1, 0, 0, 0 }, { 0, NAN, 0, 0 } },	   { { 1, 0, 0, 0 }, { 0, 0, 0, INFINITY } },
		{ { INFINITY, 0, 0, 0 }, { 0, 0, 0, 0 } }, { { 1, 0, 0, 0 }, { -INFINITY, 0, 0, 0 } },
	};
	struct dq id, out;
	size_t i;
	int n;

	(void)state;
	dq_identity(&id);
	rng_seed(7);
	for (n = 0; n < 500; n++) {
		struct dq u, a, again;
		double k = rnd_range(0.01, 100);
		struct quat rc, tq;
		struct vec3 t;

		set_ctx("scaled unit dq %d, k %g", n, k);
		rnd_dq(&u, PI, 3);
		a = (struct dq){ { u.r.w * k, u.r.x * k, u.r.y * k, u.r.z * k },
				 { u.d.w * k, u.d.x * k, u.d.y * k, u.d.z * k } };
		assert_ctx(dq_normalize(&a, &out));
		assert_dq_same(&out, &u, 1e-14);

		/* arbitrary r and d: |r| = 1 and r.d = 0 afterwards, translation kept */
		set_ctx("arbitrary dq %d", n);
		a = (struct dq){ { rnd_range(-3, 3), rnd_range(-3, 3), rnd_range(-3, 3), rnd_range(-3, 3) },
				 { rnd_range(-3, 3), rnd_range(-3, 3), rnd_range(-3, 3), rnd_range(-3, 3) } };
		assert_ctx(dq_normalize(&a, &out));
		assert_dq_finite(out);
		assert_near(sqrt(ref_qdot(out.r, out.r)), 1, 1e-15);
		assert_near(ref_qdot(out.r, out.d), 0, 1e-14);
		k = sqrt(ref_qdot(a.r, a.r));
		assert_quat_near(out.r, ((struct quat){ a.r.w / k, a.r.x / k, a.r.y / k, a.r.z / k }), 1e-15);
		/* the part of d along r only carries the scalar of 2 d r*: the translation survives */
		rc = (struct quat){ a.r.w / k, -a.r.x / k, -a.r.y / k, -a.r.z / k };
		tq = ref_qmul((struct quat){ 2 * a.d.w / k, 2 * a.d.x / k, 2 * a.d.y / k, 2 * a.d.z / k }, rc);
		dq_translation(&out, &t);
		assert_v3_near(t, ((struct vec3){ tq.x, tq.y, tq.z }), 1e-13);
		/* idempotent, and may alias */
		again = out;
		assert_ctx(dq_normalize(&again, &again));
		assert_dq_same(&again, &out, 1e-15);
	}
	for (i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		set_ctx("bad dq %zu", i);
		out = (struct dq){ { 5, 5, 5, 5 }, { 5, 5, 5, 5 } };
		assert_ctx(!dq_normalize(&bad[i], &out));
		assert_quat_near(out.r, id.r, 0);
		assert_quat_near(out.d, id.d, 0);
	}
}

static void test_dq_is_finite(void **state)
{
	struct dq a;
	int k;

	(void)state;
	set_ctx("dq_is_finite");
	dq_identity(&a);
	assert_ctx(dq_is_finite(&a));
	for (k = 0; k < 8; k++) {
		double *v[8] = { &a.r.w, &a.r.x, &a.r.y, &a.r.z, &a.d.w, &a.d.x, &a.d.y, &a.d.z };

		dq_identity(&a);
		*v[k] = NAN;
		assert_ctx(!dq_is_finite(&a));
		*v[k] = INFINITY;
		assert_ctx(!dq_is_finite(&a));
		*v[k] = -1e300;
		assert_ctx(dq_is_finite(&a));
	}
}

/* ---- transforms of points, lines, matrices ------------------------------------ */

static void test_dq_transform_point(void **state)
{
	struct dq id;
	int n;

	(void)state;
	dq_identity(&id);
	rng_seed(8);
	for (n = 0; n < 1000; n++) {
		struct vec3 ax = rnd_unit(), t = rnd_vec(3), p = rnd_vec(3), got, want;
		double th = rnd_range(-2 * PI, 2 * PI), R[3][3];
		struct quat r = ref_quat(ax, th);
		struct dq a;

		set_ctx("axis (%g %g %g) angle %g", ax.x, ax.y, ax.z, th);
		dq_from_rt(&r, &t, &a);
		ref_rot(ax, th, R);
		want = ref_add(ref_mv(R, p), t);
		dq_transform_point(&a, &p, &got);
		assert_v3_near(got, want, 1e-14);
		/* -a is the same transform */
		dq_neg(&a, &a);
		dq_transform_point(&a, &p, &got);
		assert_v3_near(got, want, 1e-14);
		dq_transform_point(&id, &p, &got);
		assert_v3_near(got, p, 0);
		/* the origin goes to t */
		dq_transform_point(&a, &(struct vec3){ 0, 0, 0 }, &got);
		assert_v3_near(got, t, 1e-14);
	}
}

static void test_dq_transform_line(void **state)
{
	int n;

	(void)state;
	rng_seed(9);
	for (n = 0; n < 1000; n++) {
		struct vec3 ax = rnd_unit(), t = rnd_vec(3), p0 = rnd_vec(3), l = rnd_unit(), want_l;
		double th = rnd_range(-2 * PI, 2 * PI), R[3][3];
		struct quat r = ref_quat(ax, th);
		struct line in = { l, ref_cross(p0, l) }, out;
		struct dq a;
		int k;

		set_ctx("line %d", n);
		dq_from_rt(&r, &t, &a);
		dq_transform_line(&a, &in, &out);
		ref_rot(ax, th, R);
		want_l = ref_mv(R, l);
		assert_v3_near(out.l, want_l, 1e-14);
		assert_near(ref_norm(out.l), 1, 1e-15);
		assert_near(ref_dot(out.l, out.m), 0, 1e-13);
		/* every point of the line lands on the moved line: p' x l' = m' */
		for (k = -2; k <= 2; k++) {
			struct vec3 p = ref_add(p0, ref_scale(l, 1.5 * k)), pp, mm;

			dq_transform_point(&a, &p, &pp);
			mm = ref_cross(pp, out.l);
			assert_v3_near(mm, out.m, 1e-13);
		}
	}
}

static void test_dq_mat4(void **state)
{
	/* rotations close to and at 180 degrees, about coordinate and oblique axes */
	static const double near_pi[] = { 0.1, 1e-3, 1e-6, 1e-9, 0, -1e-9, -1e-6 };
	struct vec3 axes[12] = {
		{ 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 1 }, { -1, 0, 0 }, { 0, -1, 0 }, { 0, 0, -1 },
	};
	size_t i;
	int n;

	(void)state;
	rng_seed(10);
	for (i = 6; i < 12; i++)
		axes[i] = rnd_unit();
	for (n = 0; n < 1000 + 12 * 7; n++) {
		struct vec3 ax, t = rnd_vec(3);
		double th, R[3][3], m[4][4];
		struct quat r;
		struct dq a, back;
		int row, col;

		if (n < 1000) {
			ax = rnd_unit();
			th = rnd_range(-2 * PI, 2 * PI);
		} else {
			ax = axes[(n - 1000) / 7];
			th = PI - near_pi[(n - 1000) % 7];
		}
		set_ctx("axis (%g %g %g) angle pi - %g", ax.x, ax.y, ax.z, PI - th);
		r = ref_quat(ax, th);
		dq_from_rt(&r, &t, &a);
		dq_to_mat4(&a, m);
		ref_rot(ax, th, R);
		for (row = 0; row < 3; row++)
			for (col = 0; col < 3; col++)
				assert_near(m[row][col], R[row][col], 1e-15);
		assert_near(m[0][3], t.x, 1e-14);
		assert_near(m[1][3], t.y, 1e-14);
		assert_near(m[2][3], t.z, 1e-14);
		assert_near(m[3][0], 0, 0);
		assert_near(m[3][1], 0, 0);
		assert_near(m[3][2], 0, 0);
		assert_near(m[3][3], 1, 0);
		dq_from_mat4((const double(*)[4])m, &back);
		assert_ctx(back.r.w >= 0);
		assert_dq_same(&back, &a, 1e-14);
	}
}

/* which Shepperd branch a matrix takes: the largest of 4w^2, 4x^2, 4y^2, 4z^2 */
static int shepperd_branch(const double m[3][3])
{
	double v[4] = { 1 + m[0][0] + m[1][1] + m[2][2], 1 + m[0][0] - m[1][1] - m[2][2],
			1 - m[0][0] + m[1][1] - m[2][2], 1 - m[0][0] - m[1][1] + m[2][2] };
	int k, best = 0;

	for (k = 1; k < 4; k++)
		if (v[k] > v[best])
			best = k;
	return best;
}

static void test_quat_from_mat3_branches(void **state)
{
	static const char *const names[4] = { "w", "x", "y", "z" };
	int seen[4] = { 0 }, n;

	(void)state;
	rng_seed(11);
	for (n = 0; n < 4000; n++) {
		int want = n % 4, k;
		struct vec3 ax = rnd_unit();
		double th, m[3][3];
		struct quat ref, got;

		if (want == 0) {
			/* |theta| < 2pi/3: w^2 > 1/4 >= the others */
			th = rnd_range(-2 * PI / 3, 2 * PI / 3);
		} else {
			/* near 180 degrees about an axis whose component want - 1 is the largest */
			double c[3] = { ax.x, ax.y, ax.z }, tmp;
			int big = 0;

			for (k = 1; k < 3; k++)
				if (fabs(c[k]) > fabs(c[big]))
					big = k;
			tmp = c[want - 1], c[want - 1] = c[big], c[big] = tmp;
			ax = (struct vec3){ c[0], c[1], c[2] };
			th = rnd_range(0.8 * PI, 1.2 * PI);
		}
		ref_rot(ax, th, m);
		set_ctx("branch %s, axis (%g %g %g) angle %.17g", names[want], ax.x, ax.y, ax.z, th);
		if (shepperd_branch((const double(*)[3])m) != want)
			continue;
		seen[want]++;
		ref = ref_quat(ax, th);
		if (ref.w < 0)
			ref = (struct quat){ -ref.w, -ref.x, -ref.y, -ref.z };
		quat_from_mat3((const double(*)[3])m, &got);
		assert_ctx(got.w >= 0);
		assert_near(sqrt(ref_qdot(got, got)), 1, 1e-15);
		if (ref.w < 1e-12 && ref_qdot(got, ref) < 0)
			got = (struct quat){ -got.w, -got.x, -got.y, -got.z };
		assert_quat_near(got, ref, 1e-15);
	}
	for (n = 0; n < 4; n++) {
		set_ctx("branch %s", names[n]);
		assert_ctx(seen[n] > 500);
	}

	/* exactly 180 degrees about the axes and the diagonals (ties between branches) */
	{
		const double h = sqrt(0.5), t3 = sqrt(1.0 / 3);
		const struct vec3 special[] = {
			{ 1, 0, 0 },  { 0, 1, 0 },  { 0, 0, 1 },    { h, h, 0 },
			{ h, 0, -h }, { 0, -h, h }, { t3, t3, t3 }, { -t3, t3, t3 },
		};
		size_t i;

		for (i = 0; i < sizeof(special) / sizeof(special[0]); i++) {
			/* the exact matrix of a half turn: 2 n n^T - I */
			const struct vec3 a = special[i];
			double v[3] = { a.x, a.y, a.z }, m[3][3];
			struct quat got, ref = { 0, a.x, a.y, a.z };
			int r, c;

			set_ctx("half turn about (%g %g %g)", a.x, a.y, a.z);
			for (r = 0; r < 3; r++)
				for (c = 0; c < 3; c++)
					m[r][c] = 2 * v[r] * v[c] - (r == c);
			quat_from_mat3((const double(*)[3])m, &got);
			assert_ctx(got.w >= 0);
			if (ref_qdot(got, ref) < 0)
				got = (struct quat){ -got.w, -got.x, -got.y, -got.z };
			assert_quat_near(got, ref, 1e-15);
		}
	}
	{
		const double I[3][3] = { { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 1 } };
		struct quat got;

		set_ctx("identity matrix");
		quat_from_mat3(I, &got);
		assert_quat_near(got, ((struct quat){ 1, 0, 0, 0 }), 0);
	}
}

/* ---- logarithm and exponential ------------------------------------------------- */

/* accuracy of the logarithm, at every angle (series below x = 0.05 only) */
#define LOG_TOL 1e-12

/* the core's sc_atan2 is a series good to about 1e-13 rad, not libm's */
#define ATAN_TOL 2e-13

/* one ulp above the double nearest pi: the largest angle rounding can give */
#define PI_ULP 3.1415926535897936

static void check_screw_valid(const struct screw *s, double tol_m)
{
	assert_finite(s->angle);
	assert_finite(s->d);
	assert_finite(s->l.x);
	assert_finite(s->l.y);
	assert_finite(s->l.z);
	assert_finite(s->m.x);
	assert_finite(s->m.y);
	assert_finite(s->m.z);
	if (!(s->angle >= 0 && s->angle <= PI_ULP))
		fail_msg("%s: angle %.17g outside [0, pi]", ctx, s->angle);
	assert_near(ref_norm(s->l), 1, 1e-14);
	/* the moment is perpendicular to the axis */
	assert_near(ref_dot(s->l, s->m), 0, tol_m);
}

static void check_twist_finite(const struct twist *tw)
{
	assert_finite(tw->w.x);
	assert_finite(tw->w.y);
	assert_finite(tw->w.z);
	assert_finite(tw->v.x);
	assert_finite(tw->v.y);
	assert_finite(tw->v.z);
}

/* log then exp gives the transform back, both the screw and the twist form */
static void check_log_round_trip(const struct dq *a, double tol, double tol_m)
{
	struct screw s;
	struct twist tw;
	struct dq back;

	dq_log(a, &s);
	check_screw_valid(&s, tol_m);
	dq_exp(&s, &back);
	assert_dq_finite(back);
	assert_dq_same(&back, a, tol);
	dq_log_twist(a, &tw);
	check_twist_finite(&tw);
	assert_ctx(ref_norm(tw.w) <= PI_ULP);
	dq_exp_twist(&tw, &back);
	assert_dq_finite(back);
	assert_dq_same(&back, a, tol);
	/* the two forms agree: w = angle l, v = angle m + d l */
	assert_v3_near(tw.w, ref_scale(s.l, s.angle), 1e-15 * (1 + s.angle));
	assert_v3_near(tw.v, ref_add(ref_scale(s.m, s.angle), ref_scale(s.l, s.d)), 1e-12);
}

static void test_dq_log_exp_random(void **state)
{
	int n;

	(void)state;
	rng_seed(12);
	for (n = 0; n < 2000; n++) {
		struct dq a, back;
		struct twist tw, tw2;

		rnd_dq(&a, 2 * PI, 3);
		set_ctx("random transform %d, angle %.17g", n, 2 * acos(fabs(a.r.w)));
		check_log_round_trip(&a, LOG_TOL, 1e-12);

		/* exp then log gives the twist back while |w| < pi */
		tw.w = ref_scale(rnd_unit(), rnd_range(0, PI - 1e-3));
		tw.v = rnd_vec(3);
		set_ctx("random twist %d, angle %.17g", n, ref_norm(tw.w));
		dq_exp_twist(&tw, &back);
		assert_near(quat_norm(&back.r), 1, 1e-15);
		assert_near(ref_qdot(back.r, back.d), 0, 1e-14);
		dq_log_twist(&back, &tw2);
		assert_v3_near(tw2.w, tw.w, ATAN_TOL);
		assert_v3_near(tw2.v, tw.v, LOG_TOL);
	}
	/* rotations only: no translation for the coefficient to spoil */
	for (n = 0; n < 1000; n++) {
		struct quat r = ref_quat(rnd_unit(), rnd_range(-2 * PI, 2 * PI));
		struct dq a;

		set_ctx("rotation %d, angle %.17g", n, 2 * acos(fabs(r.w)));
		dq_from_rt(&r, &(struct vec3){ 0, 0, 0 }, &a);
		check_log_round_trip(&a, ATAN_TOL, 1e-15);
	}
}

/*
 * A known screw (axis n through p, angle th, slide d) and what the logarithm
 * must find: l = n, m = p x n, w = th n, v = th (p x n) + d n. Past pi the
 * shorter way round is the same line run backwards: l = -n, 2 pi - th, -d.
 */
static void check_known_screw(struct vec3 n, struct vec3 p, double th, double d, double tol_w, double tol_v,
			      double tol_m)
{
	struct screw s;
	struct twist tw;
	struct dq a;
	struct vec3 m, v;

	ref_screw_dq(n, p, th, d, &a);
	if (th > PI) {
		n = ref_scale(n, -1);
		th = 2 * PI - th;
		d = -d;
	}
	m = ref_cross(p, n);
	v = ref_add(ref_scale(m, th), ref_scale(n, d));
	dq_log_twist(&a, &tw);
	check_twist_finite(&tw);
	assert_v3_near(tw.w, ref_scale(n, th), tol_w);
	assert_v3_near(tw.v, v, tol_v);
	dq_log(&a, &s);
	check_screw_valid(&s, tol_m);
	assert_near(s.angle, th, tol_w);
	assert_v3_near(s.l, n, 1e-14);
	assert_near(s.d, d, tol_v);
	assert_v3_near(s.m, m, tol_m);
	check_log_round_trip(&a, tol_v, tol_m);
}

static void test_dq_log_tiny_angles(void **state)
{
	/* tiny angles, and both sides of the switches between series and closed forms */
	static const double angles[] = { 1e-9, 1e-6, 1e-4, 0.999e-3, 1.001e-3, 2e-11, 1e-10, 0.02, 0.4999, 0.5001 };
	size_t i;
	int n;

	(void)state;
	rng_seed(13);
	for (i = 0; i < sizeof(angles) / sizeof(angles[0]); i++) {
		double th = angles[i];

		for (n = 0; n < 200; n++) {
			struct vec3 axis = rnd_unit(), p = rnd_vec(1);
			double d = rnd_range(-1, 1);

			set_ctx("angle %g, screw %d", th, n);
			if (th < 0.01)
				/* the moment is (v - d l) / angle: its error grows like eps / angle */
				check_known_screw(axis, p, th, d, 1e-14 * th, 1e-14, 1e-14 / th);
			else
				check_known_screw(axis, p, th, d, ATAN_TOL, LOG_TOL, LOG_TOL);
		}
	}
}

static void test_dq_log_translation(void **state)
{
	struct screw s;
	struct twist tw;
	struct dq id, a, back;
	int n;

	(void)state;
	set_ctx("identity");
	dq_identity(&id);
	dq_log(&id, &s);
	check_screw_valid(&s, 0);
	assert_near(s.angle, 0, 0);
	assert_near(s.d, 0, 0);
	assert_v3_near(s.l, ((struct vec3){ 1, 0, 0 }), 0);
	assert_v3_near(s.m, ((struct vec3){ 0, 0, 0 }), 0);
	dq_log_twist(&id, &tw);
	assert_v3_near(tw.w, ((struct vec3){ 0, 0, 0 }), 0);
	assert_v3_near(tw.v, ((struct vec3){ 0, 0, 0 }), 0);
	dq_exp(&s, &back);
	assert_dq_same(&back, &id, 0);
	dq_exp_twist(&tw, &back);
	assert_dq_same(&back, &id, 0);

	rng_seed(14);
	for (n = 0; n < 1000; n++) {
		struct vec3 t = ref_scale(rnd_unit(), rnd_range(1e-6, 5)), u;
		struct quat r = { n % 3 == 1 ? -1 : 1, 0, 0, 0 };

		set_ctx("translation (%g %g %g), r.w %g", t.x, t.y, t.z, r.w);
		dq_from_rt(&r, &t, &a);
		dq_log_twist(&a, &tw);
		check_twist_finite(&tw);
		assert_v3_near(tw.w, ((struct vec3){ 0, 0, 0 }), 0);
		assert_v3_near(tw.v, t, 1e-15);
		dq_log(&a, &s);
		check_screw_valid(&s, 0);
		assert_near(s.angle, 0, 0);
		assert_near(s.d, ref_norm(t), 1e-15);
		u = ref_scale(t, 1 / ref_norm(t));
		assert_v3_near(s.l, u, 1e-15);
		assert_v3_near(s.m, ((struct vec3){ 0, 0, 0 }), 0);
		check_log_round_trip(&a, 1e-15, 0);

		if (n % 3 == 2) {
			/*
			 * a rotation of 1e-12 rad, below the screw's zero-angle
			 * threshold: the twist keeps it, the screw is the pure
			 * translation by v = t - 1/2 w x t
			 */
			struct vec3 ax = rnd_unit(), w = ref_scale(ax, 1e-12);
			struct vec3 v = ref_add(t, ref_scale(ref_cross(w, t), -0.5));

			set_ctx("translation (%g %g %g) after a rotation of 1e-12", t.x, t.y, t.z);
			r = ref_quat(ax, 1e-12);
			dq_from_rt(&r, &t, &a);
			dq_log_twist(&a, &tw);
			assert_v3_near(tw.w, w, 1e-27);
			assert_v3_near(tw.v, v, 1e-15);
			dq_log(&a, &s);
			check_screw_valid(&s, 0);
			assert_near(s.angle, 0, 0);
			assert_near(s.d, ref_norm(v), 1e-15);
			assert_v3_near(s.l, ref_scale(v, 1 / ref_norm(v)), 1e-15);
			/* the rotation dropped by the screw is all that is lost */
			dq_exp(&s, &back);
			assert_dq_same(&back, &a, 1e-12 * (1 + ref_norm(t)));
			dq_exp_twist(&tw, &back);
			assert_dq_same(&back, &a, 1e-15);
		}
	}
	/* translations below SC_EPS get the x axis: finite, and off by no more than themselves */
	set_ctx("tiny translation");
	dq_from_rt(&(struct quat){ 1, 0, 0, 0 }, &(struct vec3){ 1e-14, -1e-14, 0 }, &a);
	check_log_round_trip(&a, 1e-14, 0);
	dq_log(&a, &s);
	assert_v3_near(s.l, ((struct vec3){ 1, 0, 0 }), 0);
}

static void test_dq_log_near_pi(void **state)
{
	static const double delta[] = { 1e-2, 1e-4, 1e-6, 1e-8, 1e-12, 0, -1e-12, -1e-8, -1e-6, -1e-4, -1e-2 };
	size_t i;
	int n;

	(void)state;
	rng_seed(15);
	for (i = 0; i < sizeof(delta) / sizeof(delta[0]); i++) {
		for (n = 0; n < 200; n++) {
			struct vec3 axis = rnd_unit(), p = rnd_vec(1);
			double th = PI - delta[i], d = rnd_range(-1, 1);

			set_ctx("angle pi - %g, screw %d", delta[i], n);
			if (delta[i] != 0) {
				/* th > pi builds a rotation quaternion with w < 0: the log must flip it */
				check_known_screw(axis, p, th, d, ATAN_TOL, 1e-13, 1e-13);
			} else {
				struct dq a;
				struct screw s;

				ref_screw_dq(axis, p, th, d, &a);
				dq_log(&a, &s);
				check_screw_valid(&s, 1e-13);
				assert_near(s.angle, PI, ATAN_TOL);
				/* either direction is the shortest: compare up to the sign of l */
				if (ref_dot(s.l, axis) < 0)
					axis = ref_scale(axis, -1), d = -d;
				assert_v3_near(s.l, axis, 1e-14);
				assert_near(s.d, d, 1e-13);
				assert_v3_near(s.m, ref_cross(p, axis), 1e-13);
				check_log_round_trip(&a, 1e-13, 1e-13);
			}
		}
	}
}

/*
 * The paper's section 5.2: for a transform with unit axis R, angle theta and
 * translation T, the screw has moment M = 1/2 (T x R + cot(theta/2) (R x T) x R)
 * and slide t = R.T; the twist is V = {theta R, t R + theta M}.
 */
static void test_dq_log_paper_moment(void **state)
{
	int n;

	(void)state;
	rng_seed(16);
	for (n = 0; n < 2000; n++) {
		struct vec3 R = rnd_unit(), T = rnd_vec(2), M, V;
		double th = rnd_range(0.05, 3.0), cot = cos(th / 2) / sin(th / 2), t = ref_dot(R, T);
		/* held to rounding where the core's series is not used */
		double tol = th > 0.5 ? 1e-12 : LOG_TOL;
		struct quat r = ref_quat(R, th);
		struct screw s;
		struct twist tw;
		struct dq a, want;

		set_ctx("axis (%g %g %g) angle %.17g T (%g %g %g)", R.x, R.y, R.z, th, T.x, T.y, T.z);
		M = ref_scale(ref_add(ref_cross(T, R), ref_scale(ref_cross(ref_cross(R, T), R), cot)), 0.5);
		V = ref_add(ref_scale(R, t), ref_scale(M, th));
		dq_from_rt(&r, &T, &a);
		dq_log(&a, &s);
		check_screw_valid(&s, 1e-13);
		assert_near(s.angle, th, ATAN_TOL);
		assert_v3_near(s.l, R, 1e-15);
		assert_near(s.d, t, 1e-14);
		assert_v3_near(s.m, M, tol);
		dq_log_twist(&a, &tw);
		assert_v3_near(tw.w, ref_scale(R, th), ATAN_TOL);
		assert_v3_near(tw.v, V, tol);
		/* and exp of the paper's screw gives the transform */
		s = (struct screw){ R, M, th, t };
		dq_exp(&s, &a);
		dq_from_rt(&r, &T, &want);
		assert_dq_same(&a, &want, 1e-14);
	}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_quat_products),
		cmocka_unit_test(test_quat_rotation),
		cmocka_unit_test(test_quat_normalize),
		cmocka_unit_test(test_dq_products),
		cmocka_unit_test(test_dq_from_rt),
		cmocka_unit_test(test_dq_axis_angle_eq1),
		cmocka_unit_test(test_dq_normalize),
		cmocka_unit_test(test_dq_is_finite),
		cmocka_unit_test(test_dq_transform_point),
		cmocka_unit_test(test_dq_transform_line),
		cmocka_unit_test(test_dq_mat4),
		cmocka_unit_test(test_quat_from_mat3_branches),
		cmocka_unit_test(test_dq_log_exp_random),
		cmocka_unit_test(test_dq_log_tiny_angles),
		cmocka_unit_test(test_dq_log_translation),
		cmocka_unit_test(test_dq_log_near_pi),
		cmocka_unit_test(test_dq_log_paper_moment),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
