// SPDX-License-Identifier: MIT
/*
 * ik.c - the Newton iteration of the paper and avatargw's limit-aware solver
 * built on it. See ik/ik.h.
 */
#include "ik/ik.h"

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

	ok = quat_normalize(r, &t->r) && ok;
	t->p = ok ? *p : (struct vec3){ 0, 0, 0 };
	dq_from_rt(&t->r, &t->p, &t->d);
	dq_to_mat4(&t->d, t->m);
	t->valid = ok;
}

void ik_rest_posture(const struct arm *a, sc_t q[ARM_DOF])
{
	int i;

	for (i = 0; i < ARM_DOF; i++)
		q[i] = 0;
	arm_clamp(a, q);
}

/* the dual-quaternion backend: J from the joint screws, V = log(D C*) */
static void kin_dq_eval(const struct arm *a, const sc_t q[ARM_DOF], const struct ik_target *t, sc_t J[6][ARM_DOF],
			sc_t V[6], struct ik_err *err)
{
	struct dq c, cc, e;
	struct twist tw;
	struct vec3 pc, dp;

	arm_jacobian(a, q, J, &c);
	dq_conj(&c, &cc);
	dq_mul(&t->d, &cc, &e);
	dq_log_twist(&e, &tw);
	V[0] = tw.w.x;
	V[1] = tw.w.y;
	V[2] = tw.w.z;
	V[3] = tw.v.x;
	V[4] = tw.v.y;
	V[5] = tw.v.z;
	dq_translation(&c, &pc);
	dp = (struct vec3){ t->p.x - pc.x, t->p.y - pc.y, t->p.z - pc.z };
	err->pos = v3_norm(&dp);
	err->rot = quat_angle_between(&c.r, &t->r);
}

const struct ik_kin ik_kin_dq = {
	.name = "dq",
	.eval = kin_dq_eval,
};

/* Householder QR of the m x k matrix a (m >= k) in place; v[j] holds reflector j (rows j..m-1). */
static void house_qr(int m, int k, sc_t a[ARM_DOF][ARM_DOF], sc_t v[ARM_DOF][ARM_DOF], sc_t beta[ARM_DOF])
{
	int i, j, c;

	for (j = 0; j < k; j++) {
		sc_acc_t s = sc_acc0();
		sc_t nrm, alpha, vv;

		for (i = j; i < m; i++)
			s = sc_mac(s, a[i][j], a[i][j]);
		nrm = sc_sqrt(sc_acc_get(s));
		beta[j] = 0;
		for (i = 0; i < m; i++)
			v[j][i] = 0;
		if (nrm < SC_EPS)
			continue;
		alpha = a[j][j] > 0 ? -nrm : nrm;
		for (i = j; i < m; i++)
			v[j][i] = a[i][j];
		v[j][j] -= alpha;
		/* |v|^2 = 2 nrm (nrm + |a_jj|) */
		vv = 2 * sc_mul(nrm, nrm + sc_abs(a[j][j]));
		beta[j] = sc_div(SC_C(2), vv);
		for (c = j; c < k; c++) {
			sc_acc_t t = sc_acc0();
			sc_t f;

			for (i = j; i < m; i++)
				t = sc_mac(t, v[j][i], a[i][c]);
			f = sc_mul(beta[j], sc_acc_get(t));
			for (i = j; i < m; i++)
				a[i][c] -= sc_mul(f, v[j][i]);
		}
	}
}

/* x <- H_j x for reflector j */
static void house_apply(int m, const sc_t v[ARM_DOF], sc_t beta, sc_t x[ARM_DOF])
{
	sc_acc_t t = sc_acc0();
	sc_t f;
	int i;

	for (i = 0; i < m; i++)
		t = sc_mac(t, v[i], x[i]);
	f = sc_mul(beta, sc_acc_get(t));
	for (i = 0; i < m; i++)
		x[i] -= sc_mul(f, v[i]);
}

#define IK_RCOND SC_C(1e-6)

int ik_lsq_step(const sc_t J[6][ARM_DOF], const sc_t V[6], const bool *free, sc_t x[ARM_DOF])
{
	sc_t a[ARM_DOF][ARM_DOF], v[ARM_DOF][ARM_DOF], beta[ARM_DOF], y[ARM_DOF], rmax = 0;
	int col[ARM_DOF], n = 0, i, j, rank = 0;

	for (i = 0; i < ARM_DOF; i++) {
		x[i] = 0;
		if (!free || free[i])
			col[n++] = i;
	}
	if (n >= 6) {
		/* J_f = R^T Q^T with J_f^T = Q R; min-norm x = Q R^-T V */
		for (i = 0; i < n; i++)
			for (j = 0; j < 6; j++)
				a[i][j] = J[j][col[i]];
		house_qr(n, 6, a, v, beta);
		for (j = 0; j < 6; j++)
			rmax = sc_max(rmax, sc_abs(a[j][j]));
		for (i = 0; i < n; i++)
			y[i] = 0;
		for (j = 0; j < 6; j++) {
			sc_acc_t s = sc_acc0();

			for (i = 0; i < j; i++)
				s = sc_mac(s, a[i][j], y[i]);
			if (sc_abs(a[j][j]) <= sc_mul(IK_RCOND, rmax) || rmax == 0) {
				y[j] = 0;
				continue;
			}
			y[j] = sc_div(V[j] - sc_acc_get(s), a[j][j]);
			rank++;
		}
		for (j = 5; j >= 0; j--)
			house_apply(n, v[j], beta[j], y);
		for (i = 0; i < n; i++)
			x[col[i]] = y[i];
		return rank;
	}
	/* fewer free joints than equations: least squares, x = R^-1 Q^T V */
	for (i = 0; i < 6; i++) {
		for (j = 0; j < n; j++)
			a[i][j] = J[i][col[j]];
		y[i] = V[i];
	}
	house_qr(6, n, a, v, beta);
	for (j = 0; j < n; j++) {
		house_apply(6, v[j], beta[j], y);
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
		y[j] = sc_div(y[j] - sc_acc_get(s), a[j][j]);
		rank++;
	}
	for (j = 0; j < n; j++)
		x[col[j]] = y[j];
	return rank;
}

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

/* scales x so that no joint moves more than max_step */
static void limit_step(sc_t x[ARM_DOF], sc_t max_step)
{
	sc_t m = 0;
	int i;

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
		kin->eval(a, q, t, J, V, &res->err);
		if (err_ok(&res->err, o)) {
			res->flags |= IK_REACHED;
			break;
		}
		if (it >= o->max_iter)
			break;
		ik_lsq_step((const sc_t(*)[ARM_DOF])J, V, NULL, x);
		if (!q_finite(x))
			break;
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
static void newton_limited(const struct arm *a, const struct ik_kin *kin, const struct ik_target *t,
			   const struct ik_opts *o, sc_t center, sc_t q[ARM_DOF], struct ik_result *res)
{
	sc_t J[6][ARM_DOF], V[6], W[6], x[ARM_DOF], z[ARM_DOF];
	bool free[ARM_DOF];
	int i, j, it, round;

	for (it = 0;; it++) {
		kin->eval(a, q, t, J, V, &res->err);
		if (err_ok(&res->err, o) || it >= o->max_iter)
			break;
		for (i = 0; i < ARM_DOF; i++)
			free[i] = true;
		for (round = 0; round < 3; round++) {
			bool again = false;

			for (i = 0; i < ARM_DOF; i++) {
				/* u in [-1, 1] across the range; push back hardest near the limits */
				sc_t half = sc_mul(a->lim.hi[i] - a->lim.lo[i], SC_C(0.5));
				sc_t u = half > 0 ? sc_div(q[i] - a->lim.lo[i] - half, half) : SC_C(0);

				z[i] = free[i] && it == 0 ? -sc_mul(sc_mul(center, half), sc_mul(u, sc_mul(u, u))) : SC_C(0);
			}
			for (j = 0; j < 6; j++) {
				sc_acc_t acc = sc_acc0();

				for (i = 0; i < ARM_DOF; i++)
					acc = sc_mac(acc, J[j][i], z[i]);
				W[j] = V[j] - sc_acc_get(acc);
			}
			ik_lsq_step((const sc_t(*)[ARM_DOF])J, W, free, x);
			for (i = 0; i < ARM_DOF; i++)
				x[i] += z[i];
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

unsigned ik_solve(const struct arm *a, const struct ik_kin *kin, const struct ik_target *t, const sc_t *seed,
		  const struct ik_opts *o, sc_t q[ARM_DOF], struct ik_result *res)
{
	sc_t pref[ARM_DOF];
	int i;

	res->flags = 0;
	res->iters = 0;
	res->evals = 0;
	res->err = (struct ik_err){ 0, 0 };
	if (seed && q_finite(seed)) {
		for (i = 0; i < ARM_DOF; i++)
			pref[i] = seed[i];
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
		return res->flags;
	}
	if (seed && !(res->flags & IK_BAD_TARGET) && o->warm_iter > 0) {
		/* tracking: a few limited Newton steps from the previous posture move the arm least */
		struct ik_opts wo = *o;

		wo.max_iter = o->warm_iter;
		for (i = 0; i < ARM_DOF; i++)
			q[i] = pref[i];
		newton_limited(a, kin, t, &wo, o->center_gain, q, res);
		if (err_ok(&res->err, o))
			goto done;
	}
	if (ik_swivel_solve(a, t, pref, o, q, &res->evals))
		res->flags |= IK_ANALYTIC;
	arm_clamp(a, q);
	newton_limited(a, kin, t, o, 0, q, res);
done:
	if (err_ok(&res->err, o))
		res->flags |= IK_REACHED;
	else
		res->flags |= IK_UNREACHABLE;
	for (i = 0; i < ARM_DOF; i++)
		if (q[i] <= a->lim.lo[i] || q[i] >= a->lim.hi[i])
			res->flags |= IK_LIMITED;
	return res->flags;
}
