// SPDX-License-Identifier: MIT
/*
 * test_arm.c - the 8-DOF chain: forward kinematics against the benchmark's
 * published checks, against an independent 3x3-matrix chain and against
 * the benchmark's targets; the Jacobian against finite differences; the
 * matrix and dual-quaternion backends against each other; mirroring; limits;
 * and the float build against the double one.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ik/ik.h"

#include "lib/benchfile.h"
#include "testutil.h"

#define PI 3.14159265358979323846
#define DEG (PI / 180)

/* the benchmark's dimensions: S, A, F, H */
static const double bench_dims[4] = { 0.18, 0.30, 0.26, 0.08 };

/* tests/lib/agree.c, built once per scalar type */
void agree_fk_d(int left, const double dims[4], const double q[ARM_DOF], double out[7]);
void agree_fk_f(int left, const double dims[4], const double q[ARM_DOF], double out[7]);

/* ---- checks ---------------------------------------------------------------- */

#define assert_ctx(cond)                                                                                               \
	do {                                                                                                           \
		if (!(cond))                                                                                           \
			fail_msg("%s: %s is false", ctx, #cond);                                                       \
	} while (0)

/* same transform: equal up to the sign of the whole dual quaternion */
static void assert_dq_same(const struct dq *a, const struct dq *b, double tol)
{
	double s = a->r.w * b->r.w + a->r.x * b->r.x + a->r.y * b->r.y + a->r.z * b->r.z, k = s < 0 ? -1 : 1;

	assert_near(a->r.w, k * b->r.w, tol);
	assert_near(a->r.x, k * b->r.x, tol);
	assert_near(a->r.y, k * b->r.y, tol);
	assert_near(a->r.z, k * b->r.z, tol);
	assert_near(a->d.w, k * b->d.w, tol);
	assert_near(a->d.x, k * b->d.x, tol);
	assert_near(a->d.y, k * b->d.y, tol);
	assert_near(a->d.z, k * b->d.z, tol);
}

static void rnd_posture(double q[ARM_DOF])
{
	int i;

	for (i = 0; i < ARM_DOF; i++)
		q[i] = rnd_range(-PI, PI);
}

/* ---- the chain written out with 3x3 matrices ----------------------------------- */

struct ref_joint {
	double axis[3];
	double t[3];
};

/*
 * The benchmark README's table: axes z y x z x y x z; translations (S,0,0)
 * after J1, (0,0,-A) after J4, (0,F,0) after J5, (0,H,0) after J8. The left
 * arm is the mirror image: S -> -S and the y and z axes reversed.
 */
static void ref_chain(int left, const double dims[4], struct ref_joint j[ARM_DOF])
{
	static const int axis[ARM_DOF] = { 2, 1, 0, 2, 0, 1, 0, 2 };
	double sg = left ? -1 : 1;
	int i, k;

	for (i = 0; i < ARM_DOF; i++) {
		for (k = 0; k < 3; k++)
			j[i].axis[k] = j[i].t[k] = 0;
		j[i].axis[axis[i]] = axis[i] == 0 ? 1 : sg;
	}
	j[0].t[0] = sg * dims[0];
	j[3].t[2] = -dims[1];
	j[4].t[1] = dims[2];
	j[7].t[1] = dims[3];
}

/* Rodrigues: R = I + sin(th) K + (1 - cos(th)) K^2 */
static void ref_rot(const double n[3], double th, double R[3][3])
{
	double K[3][3] = { { 0, -n[2], n[1] }, { n[2], 0, -n[0] }, { -n[1], n[0], 0 } };
	double s = sin(th), c1 = 1 - cos(th);
	int i, j, k;

	for (i = 0; i < 3; i++)
		for (j = 0; j < 3; j++) {
			double k2 = 0;

			for (k = 0; k < 3; k++)
				k2 += K[i][k] * K[k][j];
			R[i][j] = (i == j) + s * K[i][j] + c1 * k2;
		}
}

static void ref_mm(const double A[3][3], const double B[3][3], double C[3][3])
{
	double T[3][3];
	int i, j;

	for (i = 0; i < 3; i++)
		for (j = 0; j < 3; j++)
			T[i][j] = A[i][0] * B[0][j] + A[i][1] * B[1][j] + A[i][2] * B[2][j];
	for (i = 0; i < 3; i++)
		for (j = 0; j < 3; j++)
			C[i][j] = T[i][j];
}

static void ref_mv(const double A[3][3], const double v[3], double out[3])
{
	int i;

	for (i = 0; i < 3; i++)
		out[i] = A[i][0] * v[0] + A[i][1] * v[1] + A[i][2] * v[2];
}

/*
 * Frames along the chain: R[i], p[i] after joints 1..i (R[0] = I, p[0] = 0).
 * Joint i rotates about its local axis, then translates in the rotated frame.
 */
static void ref_fk(int left, const double dims[4], const double q[ARM_DOF], double R[ARM_DOF + 1][3][3],
		   double p[ARM_DOF + 1][3])
{
	struct ref_joint j[ARM_DOF];
	int i, k;

	ref_chain(left, dims, j);
	for (i = 0; i < 3; i++) {
		for (k = 0; k < 3; k++)
			R[0][i][k] = i == k;
		p[0][i] = 0;
	}
	for (i = 0; i < ARM_DOF; i++) {
		double Ri[3][3], dp[3];

		ref_rot(j[i].axis, q[i], Ri);
		ref_mm((const double(*)[3])R[i], (const double(*)[3])Ri, R[i + 1]);
		ref_mv((const double(*)[3])R[i + 1], j[i].t, dp);
		for (k = 0; k < 3; k++)
			p[i + 1][k] = p[i][k] + dp[k];
	}
}

/* rotation matrix of a unit quaternion and the translation 2 d r* of a dual quaternion */
static void ref_dq_to_rp(const struct dq *a, double R[3][3], double p[3])
{
	double w = a->r.w, x = a->r.x, y = a->r.y, z = a->r.z;
	double dw = a->d.w, dx = a->d.x, dy = a->d.y, dz = a->d.z;

	R[0][0] = w * w + x * x - y * y - z * z;
	R[0][1] = 2 * (x * y - w * z);
	R[0][2] = 2 * (x * z + w * y);
	R[1][0] = 2 * (x * y + w * z);
	R[1][1] = w * w - x * x + y * y - z * z;
	R[1][2] = 2 * (y * z - w * x);
	R[2][0] = 2 * (x * z - w * y);
	R[2][1] = 2 * (y * z + w * x);
	R[2][2] = w * w - x * x - y * y + z * z;
	/* (d)(r*) vector part, r* = (w, -x, -y, -z) */
	p[0] = 2 * (-dw * x + dx * w - dy * z + dz * y);
	p[1] = 2 * (-dw * y + dy * w - dz * x + dx * z);
	p[2] = 2 * (-dw * z + dz * w - dx * y + dy * x);
}

static void make_arm(struct arm *a, int left, const double dims[4])
{
	struct arm_dims d = { dims[0], dims[1], dims[2], dims[3] };

	arm_init(a, left ? ARM_LEFT : ARM_RIGHT, &d, NULL);
}

/* ---- forward kinematics ----------------------------------------------------------- */

static void test_fk_published_checks(void **state)
{
	double q[ARM_DOF] = { 0 };
	struct arm right, left;
	struct dq ee;
	struct vec3 p;

	(void)state;
	make_arm(&right, 0, bench_dims);
	make_arm(&left, 1, bench_dims);

	set_ctx("right arm, q = 0");
	arm_fk(&right, q, &ee);
	dq_translation(&ee, &p);
	assert_v3_near(p, ((struct vec3){ 0.18, 0.34, -0.30 }), 1e-15);
	assert_near(fabs(ee.r.w), 1, 1e-15);
	assert_near(ee.r.x, 0, 1e-15);
	assert_near(ee.r.y, 0, 1e-15);
	assert_near(ee.r.z, 0, 1e-15);

	set_ctx("left arm, q = 0");
	arm_fk(&left, q, &ee);
	dq_translation(&ee, &p);
	assert_v3_near(p, ((struct vec3){ -0.18, 0.34, -0.30 }), 1e-15);
	assert_near(fabs(ee.r.w), 1, 1e-15);

	set_ctx("right arm, q5 = +90 deg");
	q[4] = PI / 2;
	arm_fk(&right, q, &ee);
	dq_translation(&ee, &p);
	assert_v3_near(p, ((struct vec3){ 0.18, 0, 0.04 }), 1e-15);

	set_ctx("left arm, q5 = +90 deg");
	arm_fk(&left, q, &ee);
	dq_translation(&ee, &p);
	assert_v3_near(p, ((struct vec3){ -0.18, 0, 0.04 }), 1e-15);
}

static void test_fk_vs_matrix_chain(void **state)
{
	int n, side;

	(void)state;
	rng_seed(21);
	for (side = 0; side < 2; side++) {
		struct arm a;

		make_arm(&a, side, bench_dims);
		for (n = 0; n < 1000; n++) {
			double q[ARM_DOF], R[ARM_DOF + 1][3][3], p[ARM_DOF + 1][3], dims[4], Rg[3][3], pg[3];
			struct dq ee, k[ARM_DOF + 1];
			int i, r, c;

			rnd_posture(q);
			set_ctx("%s arm, posture %d", side ? "left" : "right", n);
			ref_fk(side, bench_dims, q, R, p);
			arm_fk(&a, q, &ee);
			assert_near(ee.r.w * ee.r.w + ee.r.x * ee.r.x + ee.r.y * ee.r.y + ee.r.z * ee.r.z, 1, 1e-14);
			ref_dq_to_rp(&ee, Rg, pg);
			for (r = 0; r < 3; r++) {
				assert_near(pg[r], p[ARM_DOF][r], 1e-12);
				for (c = 0; c < 3; c++)
					assert_near(Rg[r][c], R[ARM_DOF][r][c], 1e-12);
			}
			/* every intermediate frame too */
			arm_fk_frames(&a, q, k);
			for (i = 0; i <= ARM_DOF; i++) {
				ref_dq_to_rp(&k[i], Rg, pg);
				for (r = 0; r < 3; r++) {
					assert_near(pg[r], p[i][r], 1e-12);
					for (c = 0; c < 3; c++)
						assert_near(Rg[r][c], R[i][r][c], 1e-12);
				}
			}
			assert_dq_same(&k[ARM_DOF], &ee, 0);

			/* other dimensions: the chain scales with them */
			for (i = 0; i < 4; i++)
				dims[i] = rnd_range(0.05, 0.5);
			set_ctx("%s arm, posture %d, dims %g %g %g %g", side ? "left" : "right", n, dims[0], dims[1],
				dims[2], dims[3]);
			{
				struct arm b;

				make_arm(&b, side, dims);
				ref_fk(side, dims, q, R, p);
				arm_fk(&b, q, &ee);
				ref_dq_to_rp(&ee, Rg, pg);
				for (r = 0; r < 3; r++)
					assert_near(pg[r], p[ARM_DOF][r], 1e-12);
			}
		}
	}
}

static struct vec3 sub(struct vec3 a, struct vec3 b)
{
	return (struct vec3){ a.x - b.x, a.y - b.y, a.z - b.z };
}

static double len(struct vec3 a)
{
	return sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
}

static void test_fk_pose(void **state)
{
	int n, side;

	(void)state;
	rng_seed(22);
	for (side = 0; side < 2; side++) {
		struct arm a;

		make_arm(&a, side, bench_dims);
		for (n = 0; n < 500; n++) {
			double q[ARM_DOF], R[ARM_DOF + 1][3][3], p[ARM_DOF + 1][3], s;
			struct vec3 upper, fore, hand, v;
			struct arm_pose pose;
			struct dq ee;

			rnd_posture(q);
			set_ctx("%s arm, posture %d", side ? "left" : "right", n);
			ref_fk(side, bench_dims, q, R, p);
			arm_fk_pose(&a, q, &pose);
			/* shoulder after J1, elbow after J4, wrist after J5, hand after J8 */
			assert_v3_near(pose.shoulder, ((struct vec3){ p[1][0], p[1][1], p[1][2] }), 1e-14);
			assert_v3_near(pose.elbow, ((struct vec3){ p[4][0], p[4][1], p[4][2] }), 1e-14);
			assert_v3_near(pose.wrist, ((struct vec3){ p[5][0], p[5][1], p[5][2] }), 1e-14);
			assert_v3_near(pose.hand, ((struct vec3){ p[8][0], p[8][1], p[8][2] }), 1e-14);
			/* segment lengths are kept whatever the posture */
			upper = sub(pose.elbow, pose.shoulder);
			fore = sub(pose.wrist, pose.elbow);
			hand = sub(pose.hand, pose.wrist);
			assert_near(len(pose.shoulder), bench_dims[0], 1e-15);
			assert_near(len(upper), bench_dims[1], 1e-14);
			assert_near(len(fore), bench_dims[2], 1e-14);
			assert_near(len(hand), bench_dims[3], 1e-14);
			/* the upper arm runs along -z of its frame, forearm and hand along +y of theirs */
			quat_rotate(&pose.upper_arm, &(struct vec3){ 0, 0, -bench_dims[1] }, &v);
			assert_v3_near(v, upper, 1e-14);
			quat_rotate(&pose.forearm, &(struct vec3){ 0, bench_dims[2], 0 }, &v);
			assert_v3_near(v, fore, 1e-14);
			quat_rotate(&pose.hand_rot, &(struct vec3){ 0, bench_dims[3], 0 }, &v);
			assert_v3_near(v, hand, 1e-14);
			/* the hand frame is the end effector's */
			arm_fk(&a, q, &ee);
			s = ee.r.w * pose.hand_rot.w + ee.r.x * pose.hand_rot.x + ee.r.y * pose.hand_rot.y +
			    ee.r.z * pose.hand_rot.z;
			s = s < 0 ? -1 : 1;
			assert_near(pose.hand_rot.w, s * ee.r.w, 0);
			assert_near(pose.hand_rot.x, s * ee.r.x, 0);
			assert_near(pose.hand_rot.y, s * ee.r.y, 0);
			assert_near(pose.hand_rot.z, s * ee.r.z, 0);
		}
	}
}

/* the first 200 rows of the benchmark's targets: FK of the generating angles gives the target */
static void test_fk_bench_targets(void **state)
{
	const char *path = SHARED_DIR "/bench/targets.csv";
	struct bench_row *rows = NULL;
	size_t n = 0;
	struct arm a;

	(void)state;
	set_ctx("%s", path);
	assert_ctx(bench_load_rows("test_arm", path, 200, &rows, &n) == 0);
	assert_ctx(n == 200);
	make_arm(&a, 0, bench_dims);
	for (size_t i = 0; i < n; i++) {
		const struct bench_row *r = &rows[i];
		struct dq ee;
		struct vec3 pos;
		double s;

		set_ctx("%s row %zu", path, i + 1);
		arm_fk(&a, r->q, &ee);
		dq_translation(&ee, &pos);
		assert_v3_near(pos, ((struct vec3){ r->p[0], r->p[1], r->p[2] }), 1e-9);
		/* the file has qw >= 0; ours may be the other sign of the same rotation */
		s = ee.r.w * r->r[0] + ee.r.x * r->r[1] + ee.r.y * r->r[2] + ee.r.z * r->r[3] < 0 ? -1 : 1;
		assert_near(s * ee.r.w, r->r[0], 1e-9);
		assert_near(s * ee.r.x, r->r[1], 1e-9);
		assert_near(s * ee.r.y, r->r[2], 1e-9);
		assert_near(s * ee.r.z, r->r[3], 1e-9);
	}
	free(rows);
}

/* ---- the Jacobian ------------------------------------------------------------------- */

/* column i against (log(FK(q + h e_i) FK(q)^-1) - log(FK(q - h e_i) FK(q)^-1)) / 2h */
static void test_jacobian_finite_difference(void **state)
{
	const double h = 1e-5;
	int n, side;

	(void)state;
	rng_seed(23);
	for (side = 0; side < 2; side++) {
		struct arm a;

		make_arm(&a, side, bench_dims);
		for (n = 0; n < 200; n++) {
			double q[ARM_DOF], J[6][ARM_DOF], R[ARM_DOF + 1][3][3], p[ARM_DOF + 1][3];
			struct ref_joint jt[ARM_DOF];
			struct dq c, ci, ee;
			int i, r;

			rnd_posture(q);
			set_ctx("%s arm, posture %d", side ? "left" : "right", n);
			arm_jacobian(&a, q, J, &ee);
			arm_fk(&a, q, &c);
			assert_dq_same(&ee, &c, 0);
			dq_conj(&c, &ci);
			ref_fk(side, bench_dims, q, R, p);
			ref_chain(side, bench_dims, jt);
			for (i = 0; i < ARM_DOF; i++) {
				double qp[ARM_DOF], qm[ARM_DOF], col[6], l[3], m[3];
				struct dq fp, fm, ep, em;
				struct twist tp, tm;

				for (r = 0; r < ARM_DOF; r++)
					qp[r] = qm[r] = q[r];
				qp[i] += h;
				qm[i] -= h;
				arm_fk(&a, qp, &fp);
				arm_fk(&a, qm, &fm);
				dq_mul(&fp, &ci, &ep);
				dq_mul(&fm, &ci, &em);
				dq_log_twist(&ep, &tp);
				dq_log_twist(&em, &tm);
				col[0] = (tp.w.x - tm.w.x) / (2 * h);
				col[1] = (tp.w.y - tm.w.y) / (2 * h);
				col[2] = (tp.w.z - tm.w.z) / (2 * h);
				col[3] = (tp.v.x - tm.v.x) / (2 * h);
				col[4] = (tp.v.y - tm.v.y) / (2 * h);
				col[5] = (tp.v.z - tm.v.z) / (2 * h);
				set_ctx("%s arm, posture %d, column %d", side ? "left" : "right", n, i + 1);
				for (r = 0; r < 6; r++)
					assert_near(J[r][i], col[r], 1e-6);
				/* and the screw axis itself: l = R_(i-1) axis_i through p_(i-1), m = p x l */
				ref_mv((const double(*)[3])R[i], jt[i].axis, l);
				m[0] = p[i][1] * l[2] - p[i][2] * l[1];
				m[1] = p[i][2] * l[0] - p[i][0] * l[2];
				m[2] = p[i][0] * l[1] - p[i][1] * l[0];
				for (r = 0; r < 3; r++) {
					assert_near(J[r][i], l[r], 1e-12);
					assert_near(J[r + 3][i], m[r], 1e-12);
				}
			}
			/* ee may be NULL */
			arm_jacobian(&a, q, J, NULL);
		}
	}
}

/* ---- the two backends ------------------------------------------------------------ */

static double rot_angle_between(const struct quat *a, const struct quat *b)
{
	/* a* b */
	double w = a->w * b->w + a->x * b->x + a->y * b->y + a->z * b->z;
	double x = a->w * b->x - a->x * b->w - a->y * b->z + a->z * b->y;
	double y = a->w * b->y + a->x * b->z - a->y * b->w - a->z * b->x;
	double z = a->w * b->z - a->x * b->y + a->y * b->x - a->z * b->w;

	return 2 * atan2(sqrt(x * x + y * y + z * z), fabs(w));
}

static void check_backends(const struct arm *a, const double q[ARM_DOF], const struct ik_target *t, double tol_v)
{
	double Jd[6][ARM_DOF], Jm[6][ARM_DOF], Vd[6], Vm[6];
	struct ik_err ed = { -1, -1 }, em = { -1, -1 };
	struct dq c;
	struct vec3 p;
	int r, i;

	ik_kin_dq.eval(a, q, t, Jd, Vd, &ed);
	ik_kin_mat.eval(a, q, t, Jm, Vm, &em);
	for (r = 0; r < 6; r++) {
		for (i = 0; i < ARM_DOF; i++)
			assert_near(Jd[r][i], Jm[r][i], 1e-14);
		assert_near(Vd[r], Vm[r], tol_v);
	}
	/* the errors, against the truth */
	arm_fk(a, q, &c);
	dq_translation(&c, &p);
	p = (struct vec3){ t->p.x - p.x, t->p.y - p.y, t->p.z - p.z };
	assert_near(ed.pos, sqrt(p.x * p.x + p.y * p.y + p.z * p.z), 1e-14);
	assert_near(em.pos, ed.pos, 1e-14);
	assert_near(ed.rot, rot_angle_between(&c.r, &t->r), 1e-12);
	assert_near(em.rot, ed.rot, 1e-12);
	/* V is the twist of D C^-1 */
	{
		struct dq e, ci, back;
		struct twist tw = { { Vd[0], Vd[1], Vd[2] }, { Vd[3], Vd[4], Vd[5] } };

		dq_conj(&c, &ci);
		dq_mul(&t->d, &ci, &e);
		dq_exp_twist(&tw, &back);
		assert_dq_same(&back, &e, 1e-9);
	}
}

static void test_backends_agree(void **state)
{
	int n, side;

	(void)state;
	rng_seed(24);
	for (side = 0; side < 2; side++) {
		struct arm a;

		make_arm(&a, side, bench_dims);
		for (n = 0; n < 1000; n++) {
			double q[ARM_DOF], q2[ARM_DOF], ang;
			struct vec3 p = { rnd_range(-1, 1), rnd_range(-1, 1), rnd_range(-1, 1) };
			struct quat r = { rnd_range(-1, 1), rnd_range(-1, 1), rnd_range(-1, 1), rnd_range(-1, 1) };
			struct ik_target t;
			struct dq c;
			int i;

			rnd_posture(q);
			ik_target_set(&t, &p, &r);
			assert_ctx(t.valid);
			arm_fk(&a, q, &c);
			ang = rot_angle_between(&c.r, &t.r);
			set_ctx("%s arm, posture %d, random target, rotation error %.17g", side ? "left" : "right", n,
				ang);
			/* every rotation error, near pi too (the axis from the symmetric part there) */
			check_backends(&a, q, &t, 1e-10);

			/* a reachable target near the posture, and the posture itself */
			for (i = 0; i < ARM_DOF; i++)
				q2[i] = q[i] + rnd_range(-0.3, 0.3);
			arm_fk(&a, q2, &c);
			dq_translation(&c, &p);
			ik_target_set(&t, &p, &c.r);
			set_ctx("%s arm, posture %d, nearby target", side ? "left" : "right", n);
			check_backends(&a, q, &t, 1e-10);
			arm_fk(&a, q, &c);
			dq_translation(&c, &p);
			ik_target_set(&t, &p, &c.r);
			set_ctx("%s arm, posture %d, target = FK(q)", side ? "left" : "right", n);
			check_backends(&a, q, &t, 1e-12);
			{
				double J[6][ARM_DOF], V[6];
				struct ik_err e;

				ik_kin_dq.eval(&a, q, &t, J, V, &e);
				for (i = 0; i < 6; i++)
					assert_near(V[i], 0, 1e-12);
				assert_near(e.pos, 0, 1e-14);
				assert_near(e.rot, 0, 1e-14);
			}
		}
	}
}

/* ---- mirroring ------------------------------------------------------------------------ */

static void test_mirror(void **state)
{
	static const double sgn[4] = { -1, 1, 1, 1 };
	struct arm right, left;
	struct arm_pose pr, pl;
	double q[ARM_DOF] = { 0 };
	int n;

	(void)state;
	make_arm(&right, 0, bench_dims);
	make_arm(&left, 1, bench_dims);

	set_ctx("shoulders at q = 0");
	arm_fk_pose(&left, q, &pl);
	arm_fk_pose(&right, q, &pr);
	assert_v3_near(pl.shoulder, ((struct vec3){ -bench_dims[0], 0, 0 }), 0);
	assert_v3_near(pr.shoulder, ((struct vec3){ bench_dims[0], 0, 0 }), 0);

	rng_seed(25);
	for (n = 0; n < 1000; n++) {
		struct dq fr, fl, m, mm;
		double Mr[4][4], Ml[4][4];
		int r, c;

		rnd_posture(q);
		set_ctx("posture %d", n);
		arm_fk(&right, q, &fr);
		arm_fk(&left, q, &fl);
		arm_mirror_dq(&fr, &m);
		assert_dq_same(&fl, &m, 1e-14);
		/* M X M entrywise: (M X M)_rc = s_r s_c X_rc */
		dq_to_mat4(&fr, Mr);
		dq_to_mat4(&fl, Ml);
		for (r = 0; r < 4; r++)
			for (c = 0; c < 4; c++)
				assert_near(Ml[r][c], sgn[r] * sgn[c] * Mr[r][c], 1e-14);
		/* an involution */
		arm_mirror_dq(&m, &mm);
		assert_dq_same(&mm, &fr, 1e-15);
		/* every point of the left arm mirrors the right one; the shoulders sit at x = +-S with J1 = 0 */
		q[0] = 0;
		arm_fk_pose(&left, q, &pl);
		arm_fk_pose(&right, q, &pr);
		assert_v3_near(pl.shoulder, ((struct vec3){ -bench_dims[0], 0, 0 }), 0);
		assert_v3_near(pr.shoulder, ((struct vec3){ bench_dims[0], 0, 0 }), 0);
		assert_v3_near(pl.elbow, ((struct vec3){ -pr.elbow.x, pr.elbow.y, pr.elbow.z }), 1e-15);
		assert_v3_near(pl.wrist, ((struct vec3){ -pr.wrist.x, pr.wrist.y, pr.wrist.z }), 1e-15);
		assert_v3_near(pl.hand, ((struct vec3){ -pr.hand.x, pr.hand.y, pr.hand.z }), 1e-15);
	}

	/* the same angle is the same anatomical motion: abduction (q2 < 0) lifts the elbow outward */
	set_ctx("abduction by 90 deg");
	for (n = 0; n < ARM_DOF; n++)
		q[n] = 0;
	q[1] = -PI / 2;
	arm_fk_pose(&right, q, &pr);
	arm_fk_pose(&left, q, &pl);
	assert_v3_near(pr.elbow, ((struct vec3){ bench_dims[0] + bench_dims[1], 0, 0 }), 1e-15);
	assert_v3_near(pl.elbow, ((struct vec3){ -bench_dims[0] - bench_dims[1], 0, 0 }), 1e-15);
	/* and flexion (q3 > 0) brings it forward on both sides */
	set_ctx("flexion by 90 deg");
	q[1] = 0;
	q[2] = PI / 2;
	arm_fk_pose(&right, q, &pr);
	arm_fk_pose(&left, q, &pl);
	assert_v3_near(pr.elbow, ((struct vec3){ bench_dims[0], bench_dims[1], 0 }), 1e-15);
	assert_v3_near(pl.elbow, ((struct vec3){ -bench_dims[0], bench_dims[1], 0 }), 1e-15);
}

/* ---- limits ---------------------------------------------------------------------------- */

static void test_limits(void **state)
{
	/* the benchmark README's table, degrees */
	static const double lo_deg[ARM_DOF] = { -30, -90, -60, -90, -90, -90, -70, -30 };
	static const double hi_deg[ARM_DOF] = { 30, 30, 120, 90, 60, 90, 70, 30 };
	struct arm_limits lim, custom;
	struct arm a, b;
	double q[ARM_DOF], zero[ARM_DOF] = { 0 };
	int i, j, n;

	(void)state;
	set_ctx("default limits");
	arm_default_limits(&lim);
	for (i = 0; i < ARM_DOF; i++) {
		assert_near(lim.lo[i], lo_deg[i] * DEG, 1e-15);
		assert_near(lim.hi[i], hi_deg[i] * DEG, 1e-15);
	}
	make_arm(&a, 0, bench_dims);
	for (i = 0; i < ARM_DOF; i++) {
		assert_near(a.lim.lo[i], lim.lo[i], 0);
		assert_near(a.lim.hi[i], lim.hi[i], 0);
	}
	custom = lim;
	custom.lo[4] = -0.1;
	custom.hi[4] = 0.1;
	{
		struct arm_dims d = { bench_dims[0], bench_dims[1], bench_dims[2], bench_dims[3] };

		arm_init(&b, ARM_LEFT, &d, &custom);
	}
	assert_near(b.lim.lo[4], -0.1, 0);
	assert_near(b.lim.hi[4], 0.1, 0);

	set_ctx("rest posture");
	assert_ctx(arm_in_limits(&a, zero));
	ik_rest_posture(&a, q);
	for (i = 0; i < ARM_DOF; i++)
		assert_near(q[i], 0, 0);

	for (i = 0; i < ARM_DOF; i++) {
		set_ctx("joint %d", i + 1);
		/* on the limits: inside, and clamp leaves them alone */
		for (j = 0; j < ARM_DOF; j++)
			q[j] = 0;
		q[i] = lim.lo[i];
		assert_ctx(arm_in_limits(&a, q));
		assert_ctx(!arm_clamp(&a, q));
		assert_near(q[i], lim.lo[i], 0);
		q[i] = lim.hi[i];
		assert_ctx(arm_in_limits(&a, q));
		assert_ctx(!arm_clamp(&a, q));
		assert_near(q[i], lim.hi[i], 0);
		/* just outside: out, and clamped onto the limit */
		q[i] = lim.hi[i] + 1e-9;
		assert_ctx(!arm_in_limits(&a, q));
		assert_ctx(arm_clamp(&a, q));
		assert_near(q[i], lim.hi[i], 0);
		q[i] = lim.lo[i] - 1e-9;
		assert_ctx(!arm_in_limits(&a, q));
		assert_ctx(arm_clamp(&a, q));
		assert_near(q[i], lim.lo[i], 0);
		for (j = 0; j < ARM_DOF; j++)
			if (j != i)
				assert_near(q[j], 0, 0);
		/* a full turn away from an inside angle is the same posture: inside, wrapped by clamp */
		q[i] = 0.5 * (lim.lo[i] + lim.hi[i]) + 2 * PI;
		assert_ctx(arm_in_limits(&a, q));
		assert_ctx(arm_clamp(&a, q));
		assert_near(q[i], 0.5 * (lim.lo[i] + lim.hi[i]), 1e-15);
		q[i] = 0.5 * (lim.lo[i] + lim.hi[i]) - 4 * PI;
		assert_ctx(arm_in_limits(&a, q));
		assert_ctx(arm_clamp(&a, q));
		assert_near(q[i], 0.5 * (lim.lo[i] + lim.hi[i]), 1e-14);
		/* NaN and infinities: never inside; clamp writes a finite angle within the limits */
		q[i] = NAN;
		assert_ctx(!arm_in_limits(&a, q));
		assert_ctx(arm_clamp(&a, q));
		assert_ctx(isfinite(q[i]) && q[i] >= lim.lo[i] && q[i] <= lim.hi[i]);
		q[i] = INFINITY;
		assert_ctx(!arm_in_limits(&a, q));
		assert_ctx(arm_clamp(&a, q));
		assert_ctx(isfinite(q[i]) && q[i] >= lim.lo[i] && q[i] <= lim.hi[i]);
		q[i] = -INFINITY;
		assert_ctx(!arm_in_limits(&a, q));
		assert_ctx(arm_clamp(&a, q));
		assert_ctx(isfinite(q[i]) && q[i] >= lim.lo[i] && q[i] <= lim.hi[i]);
		assert_ctx(arm_in_limits(&a, q));
	}

	rng_seed(26);
	for (n = 0; n < 2000; n++) {
		double before[ARM_DOF], w;
		bool inside, moved;

		set_ctx("random posture %d", n);
		for (i = 0; i < ARM_DOF; i++)
			before[i] = q[i] = rnd_range(-3 * PI, 3 * PI);
		inside = arm_in_limits(&a, q);
		/* inside iff every angle, wrapped to [-pi, pi), lies within its limits */
		{
			bool want = true;

			for (i = 0; i < ARM_DOF; i++) {
				w = q[i] - 2 * PI * floor((q[i] + PI) / (2 * PI));
				if (w < lim.lo[i] || w > lim.hi[i])
					want = false;
			}
			assert_ctx(inside == want);
		}
		moved = arm_clamp(&a, q);
		assert_ctx(arm_in_limits(&a, q));
		assert_ctx(!arm_clamp(&a, q)); /* idempotent */
		for (i = 0; i < ARM_DOF; i++) {
			w = before[i] - 2 * PI * floor((before[i] + PI) / (2 * PI));
			assert_near(q[i], fmin(fmax(w, lim.lo[i]), lim.hi[i]), 1e-14);
		}
		/* moved unless every angle was already inside and in [-pi, pi) */
		{
			bool same = true;

			for (i = 0; i < ARM_DOF; i++)
				if (q[i] != before[i])
					same = false;
			assert_ctx(moved == !same);
		}
	}
}

/* ---- float build ----------------------------------------------------------------------- */

static void test_float_agrees(void **state)
{
	int n, side;

	(void)state;
	rng_seed(27);
	for (side = 0; side < 2; side++) {
		struct arm a;

		make_arm(&a, side, bench_dims);
		for (n = 0; n < 2000; n++) {
			double q[ARM_DOF], od[7], of[7], dp;
			struct quat rd, rf;
			struct dq ee;
			struct vec3 p;

			rnd_posture(q);
			set_ctx("%s arm, posture %d", side ? "left" : "right", n);
			agree_fk_d(side, bench_dims, q, od);
			agree_fk_f(side, bench_dims, q, of);
			/* the double helper is the double core */
			arm_fk(&a, q, &ee);
			dq_translation(&ee, &p);
			assert_near(od[0], p.x, 0);
			assert_near(od[1], p.y, 0);
			assert_near(od[2], p.z, 0);
			assert_near(od[3], ee.r.w, 0);
			dp = sqrt((od[0] - of[0]) * (od[0] - of[0]) + (od[1] - of[1]) * (od[1] - of[1]) +
				  (od[2] - of[2]) * (od[2] - of[2]));
			assert_near(dp, 0, 2e-5);
			rd = (struct quat){ od[3], od[4], od[5], od[6] };
			rf = (struct quat){ of[3], of[4], of[5], of[6] };
			assert_near(rot_angle_between(&rd, &rf), 0, 2e-5);
			assert_near(sqrt(of[3] * of[3] + of[4] * of[4] + of[5] * of[5] + of[6] * of[6]), 1, 1e-6);
		}
	}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_fk_published_checks),
		cmocka_unit_test(test_fk_vs_matrix_chain),
		cmocka_unit_test(test_fk_pose),
		cmocka_unit_test(test_fk_bench_targets),
		cmocka_unit_test(test_jacobian_finite_difference),
		cmocka_unit_test(test_backends_agree),
		cmocka_unit_test(test_mirror),
		cmocka_unit_test(test_limits),
		cmocka_unit_test(test_float_agrees),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
