// SPDX-License-Identifier: MIT
/*
 * test_glm.cpp - GLM (0.9.9.8, double types) as an independent oracle for the
 * dual-quaternion algebra and the chain's forward kinematics.
 *
 * GLM conventions: glm::dquat is constructed (w, x, y, z); glm::dmat4 is
 * column-major, m[col][row]; glm::rotate(m, angle, axis) = m * R and
 * glm::translate(m, t) = m * T; glm::tdualquat's product is Hamilton in
 * the same order as ours. GLM has no mat4_cast for dual quaternions: its
 * mat3x4_cast gives the 3x4 affine matrix row by row (column k of the GLM
 * value is row k of ours).
 */
#define GLM_ENABLE_EXPERIMENTAL
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtx/dual_quaternion.hpp>
#include <glm/gtx/quaternion.hpp> /* length2(quat), which mat3x4_cast needs */

#include <cmath>
#include <cstdint>
#include <cstdio>

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
/* cmocka 1.1.5 declares its C functions without extern "C" */
extern "C" {
#include <cmocka.h>
}

#include "ik/arm.h"

#include "testutil.h"

typedef glm::tdualquat<double> gdq;

static const double pi = 3.14159265358979323846;
static const double bench_dims[4] = { 0.18, 0.30, 0.26, 0.08 };

/* ---- checks ---------------------------------------------------------------- */

/* ours and GLM's hold the same eight numbers, up to the sign of the whole */
static void assert_same_dq(const struct dq *a, const gdq &g, double tol)
{
	double s = a->r.w * g.real.w + a->r.x * g.real.x + a->r.y * g.real.y + a->r.z * g.real.z < 0 ? -1 : 1;

	assert_near(a->r.w, s * g.real.w, tol);
	assert_near(a->r.x, s * g.real.x, tol);
	assert_near(a->r.y, s * g.real.y, tol);
	assert_near(a->r.z, s * g.real.z, tol);
	assert_near(a->d.w, s * g.dual.w, tol);
	assert_near(a->d.x, s * g.dual.x, tol);
	assert_near(a->d.y, s * g.dual.y, tol);
	assert_near(a->d.z, s * g.dual.z, tol);
}

/* our row-major m[row][col] against GLM's column-major g[col][row] */
static void assert_same_mat4(const double m[4][4], const glm::dmat4 &g, double tol)
{
	for (int r = 0; r < 4; r++)
		for (int c = 0; c < 4; c++)
			assert_near(m[r][c], g[c][r], tol);
}

static glm::dvec3 rnd_dvec3(double scale)
{
	return glm::dvec3(rnd_range(-scale, scale), rnd_range(-scale, scale), rnd_range(-scale, scale));
}

static glm::dvec3 rnd_unit(void)
{
	for (;;) {
		glm::dvec3 v = rnd_dvec3(1);
		double n = glm::length(v);

		if (n > 0.1 && n <= 1)
			return v / n;
	}
}

/* ---- conversions -------------------------------------------------------------- */

static struct quat to_ours(const glm::dquat &q)
{
	struct quat r = { q.w, q.x, q.y, q.z };

	return r;
}

static struct vec3 to_ours(const glm::dvec3 &v)
{
	struct vec3 r = { v.x, v.y, v.z };

	return r;
}

static gdq to_glm(const struct dq *a)
{
	return gdq(glm::dquat(a->r.w, a->r.x, a->r.y, a->r.z), glm::dquat(a->d.w, a->d.x, a->d.y, a->d.z));
}

/* a random rigid transform, built by GLM and by us from the same rotation and translation */
static void rnd_transform(struct dq *ours, gdq *theirs, glm::dquat *r, glm::dvec3 *t)
{
	*r = glm::angleAxis(rnd_range(-2 * pi, 2 * pi), rnd_unit());
	*t = rnd_dvec3(2);
	struct quat qr = to_ours(*r);
	struct vec3 qt = to_ours(*t);

	dq_from_rt(&qr, &qt, ours);
	*theirs = gdq(*r, *t);
}

/* ---- algebra ------------------------------------------------------------------ */

static void test_glm_products(void **state)
{
	(void)state;
	rng_seed(31);
	for (int n = 0; n < 2000; n++) {
		struct dq a, b, ab, ac;
		gdq ga, gb;
		glm::dquat ra, rb;
		glm::dvec3 ta, tb;

		set_ctx("transforms %d", n);
		rnd_transform(&a, &ga, &ra, &ta);
		rnd_transform(&b, &gb, &rb, &tb);
		/* construction from rotation and translation */
		assert_same_dq(&a, ga, 1e-15);
		/* products */
		dq_mul(&a, &b, &ab);
		assert_same_dq(&ab, ga * gb, 1e-15);
		/* and on our own numbers, not normalised: the product is bilinear */
		{
			struct dq x = { { rnd_range(-2, 2), rnd_range(-2, 2), rnd_range(-2, 2), rnd_range(-2, 2) },
					{ rnd_range(-2, 2), rnd_range(-2, 2), rnd_range(-2, 2), rnd_range(-2, 2) } };
			struct dq xa;

			dq_mul(&x, &a, &xa);
			assert_same_dq(&xa, to_glm(&x) * to_glm(&a), 1e-14);
		}
		/* quaternion products and rotation of vectors */
		{
			struct quat qa = to_ours(ra), qb = to_ours(rb), qab;
			glm::dquat gab = ra * rb;
			struct vec3 v = to_ours(tb), rv;
			glm::dvec3 grv = ra * tb;

			quat_mul(&qa, &qb, &qab);
			assert_near(qab.w, gab.w, 1e-15);
			assert_near(qab.x, gab.x, 1e-15);
			assert_near(qab.y, gab.y, 1e-15);
			assert_near(qab.z, gab.z, 1e-15);
			quat_rotate(&qa, &v, &rv);
			assert_near(rv.x, grv.x, 1e-14);
			assert_near(rv.y, grv.y, 1e-14);
			assert_near(rv.z, grv.z, 1e-14);
		}
		/* our conjugate is GLM's inverse for unit dual quaternions */
		dq_conj(&a, &ac);
		assert_same_dq(&ac, glm::inverse(ga), 1e-15);
		/* and a product with the inverse is GLM's identity */
		{
			struct dq t;

			dq_mul(&a, &ac, &t);
			assert_same_dq(&t, glm::dual_quat_identity<double, glm::defaultp>(), 1e-15);
		}
	}
}

static void test_glm_mat4(void **state)
{
	(void)state;
	rng_seed(32);
	for (int n = 0; n < 2000; n++) {
		struct dq a, back;
		gdq ga;
		glm::dquat r;
		glm::dvec3 t;
		double m[4][4];

		set_ctx("transform %d", n);
		rnd_transform(&a, &ga, &r, &t);
		dq_to_mat4(&a, m);
		/* GLM's matrix of the same rotation and translation */
		glm::dmat4 g = glm::translate(glm::dmat4(1.0), t) * glm::mat4_cast(r);
		assert_same_mat4(m, g, 1e-14);
		/* GLM's own dual quaternion to matrix */
		glm::dmat3x4 g34 = glm::mat3x4_cast(ga);
		for (int row = 0; row < 3; row++)
			for (int c = 0; c < 4; c++)
				assert_near(m[row][c], g34[row][c], 1e-14);
		/* and back from GLM's matrix */
		double gm[4][4];

		for (int row = 0; row < 4; row++)
			for (int c = 0; c < 4; c++)
				gm[row][c] = g[c][row];
		dq_from_mat4(gm, &back);
		assert_same_dq(&back, ga, 1e-14);
	}
}

static void test_glm_points(void **state)
{
	(void)state;
	rng_seed(33);
	for (int n = 0; n < 2000; n++) {
		struct dq a;
		gdq ga;
		glm::dquat r;
		glm::dvec3 t, p = rnd_dvec3(3);
		struct vec3 pp = to_ours(p), out;

		set_ctx("transform %d", n);
		rnd_transform(&a, &ga, &r, &t);
		dq_transform_point(&a, &pp, &out);
		glm::dvec4 g = (glm::translate(glm::dmat4(1.0), t) * glm::mat4_cast(r)) * glm::dvec4(p, 1.0);
		assert_near(out.x, g.x, 1e-14);
		assert_near(out.y, g.y, 1e-14);
		assert_near(out.z, g.z, 1e-14);
		glm::dvec3 gd = ga * p;
		assert_near(out.x, gd.x, 1e-14);
		assert_near(out.y, gd.y, 1e-14);
		assert_near(out.z, gd.z, 1e-14);
		/* composition: GLM's matrix product against our dual-quaternion product */
		{
			struct dq b, ab;
			gdq gb;
			glm::dquat rb;
			glm::dvec3 tb;

			rnd_transform(&b, &gb, &rb, &tb);
			dq_mul(&a, &b, &ab);
			dq_transform_point(&ab, &pp, &out);
			glm::dmat4 ma = glm::translate(glm::dmat4(1.0), t) * glm::mat4_cast(r);
			glm::dmat4 mb = glm::translate(glm::dmat4(1.0), tb) * glm::mat4_cast(rb);
			g = ma * mb * glm::dvec4(p, 1.0);
			assert_near(out.x, g.x, 1e-13);
			assert_near(out.y, g.y, 1e-13);
			assert_near(out.z, g.z, 1e-13);
		}
	}
}

/* ---- the chain ---------------------------------------------------------------- */

/* the benchmark README's chain as GLM matrices: M = prod Rot(axis_i, q_i) Trans(t_i) */
static glm::dmat4 glm_chain(int left, const double q[ARM_DOF])
{
	static const int axis[ARM_DOF] = { 2, 1, 0, 2, 0, 1, 0, 2 };
	const double sg = left ? -1 : 1;
	glm::dvec3 t[ARM_DOF];
	glm::dmat4 m(1.0);

	for (int i = 0; i < ARM_DOF; i++)
		t[i] = glm::dvec3(0.0);
	t[0].x = sg * bench_dims[0];
	t[3].z = -bench_dims[1];
	t[4].y = bench_dims[2];
	t[7].y = bench_dims[3];
	for (int i = 0; i < ARM_DOF; i++) {
		glm::dvec3 ax(0.0);

		ax[axis[i]] = axis[i] == 0 ? 1 : sg;
		m = glm::rotate(m, q[i], ax);
		m = glm::translate(m, t[i]);
	}
	return m;
}

/* the same chain as a product of GLM dual quaternions: x' = R (x + t) is (r, R t) */
static gdq glm_chain_dq(int left, const double q[ARM_DOF])
{
	static const int axis[ARM_DOF] = { 2, 1, 0, 2, 0, 1, 0, 2 };
	const double sg = left ? -1 : 1;
	const glm::dvec3 t[ARM_DOF] = {
		glm::dvec3(sg * bench_dims[0], 0, 0),
		glm::dvec3(0.0),
		glm::dvec3(0.0),
		glm::dvec3(0, 0, -bench_dims[1]),
		glm::dvec3(0, bench_dims[2], 0),
		glm::dvec3(0.0),
		glm::dvec3(0.0),
		glm::dvec3(0, bench_dims[3], 0),
	};
	gdq k = glm::dual_quat_identity<double, glm::defaultp>();

	for (int i = 0; i < ARM_DOF; i++) {
		glm::dvec3 ax(0.0);

		ax[axis[i]] = axis[i] == 0 ? 1 : sg;
		glm::dquat r = glm::angleAxis(q[i], ax);
		k = k * gdq(r, r * t[i]);
	}
	return k;
}

static void test_glm_chain_fk(void **state)
{
	struct arm_dims d = { bench_dims[0], bench_dims[1], bench_dims[2], bench_dims[3] };

	(void)state;
	rng_seed(34);
	for (int side = 0; side < 2; side++) {
		struct arm a;

		arm_init(&a, side ? ARM_LEFT : ARM_RIGHT, &d, NULL);
		for (int n = 0; n < 1000; n++) {
			double q[ARM_DOF], m[4][4];
			struct dq ee;

			for (int i = 0; i < ARM_DOF; i++)
				q[i] = rnd_range(-pi, pi);
			set_ctx("%s arm, posture %d", side ? "left" : "right", n);
			arm_fk(&a, q, &ee);
			dq_to_mat4(&ee, m);
			assert_same_mat4(m, glm_chain(side, q), 1e-12);
			assert_same_dq(&ee, glm_chain_dq(side, q), 1e-12);
			/* the left arm is the right one seen in the mirror x -> -x */
			if (side) {
				glm::dmat4 mirror = glm::scale(glm::dmat4(1.0), glm::dvec3(-1, 1, 1));

				assert_same_mat4(m, mirror * glm_chain(0, q) * mirror, 1e-12);
			}
		}
	}
	/* the published checks, through GLM */
	{
		double q[ARM_DOF] = { 0 };
		glm::dvec4 p;

		set_ctx("GLM chain, q = 0");
		p = glm_chain(0, q) * glm::dvec4(0, 0, 0, 1);
		assert_near(p.x, 0.18, 1e-15);
		assert_near(p.y, 0.34, 1e-15);
		assert_near(p.z, -0.30, 1e-15);
		set_ctx("GLM chain, q5 = 90 deg");
		q[4] = pi / 2;
		p = glm_chain(0, q) * glm::dvec4(0, 0, 0, 1);
		assert_near(p.x, 0.18, 1e-15);
		assert_near(p.y, 0.0, 1e-15);
		assert_near(p.z, 0.04, 1e-15);
	}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_glm_products),
		cmocka_unit_test(test_glm_mat4),
		cmocka_unit_test(test_glm_points),
		cmocka_unit_test(test_glm_chain_fk),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
