// SPDX-License-Identifier: MIT
/*
 * ikx.c - the IK core of this translation unit's scalar type, with doubles
 * in and out (see ikx.h). Compiled once per type.
 */
#include <math.h>

#include "ik/avatar.h"
#include "ikx.h"

#define ikx_fk SCN(ikx_fk)
#define ikx_jacobian SCN(ikx_jacobian)
#define ikx_lsq SCN(ikx_lsq)
#define ikx_solve SCN(ikx_solve)
#define ikx_name SCN(ikx_name)
#define ikx_limits SCN(ikx_limits)
#define ikx_tolerances SCN(ikx_tolerances)
#define ikx_avatar_run SCN(ikx_avatar_run)

static void setup_arm(const struct ikx_setup *o, struct arm *a)
{
	struct arm_dims d = { sc_from_double(o->dims[0]), sc_from_double(o->dims[1]), sc_from_double(o->dims[2]),
			      sc_from_double(o->dims[3]) };
	struct arm_limits lim;
	int i;

	for (i = 0; i < ARM_DOF; i++) {
		lim.lo[i] = sc_from_double(o->lo[i]);
		lim.hi[i] = sc_from_double(o->hi[i]);
	}
	arm_init(a, o->left ? ARM_LEFT : ARM_RIGHT, &d, o->limits ? &lim : NULL);
}

const char *ikx_name(void)
{
	return SC_NAME;
}

void ikx_limits(const struct ikx_setup *o, double lo[IKX_DOF], double hi[IKX_DOF])
{
	struct arm a;
	int i;

	setup_arm(o, &a);
	for (i = 0; i < ARM_DOF; i++) {
		lo[i] = sc_to_double(a.lim.lo[i]);
		hi[i] = sc_to_double(a.lim.hi[i]);
	}
}

void ikx_fk(const struct ikx_setup *o, const double q[IKX_DOF], double out[7])
{
	struct arm a;
	struct dq ee;
	struct vec3 p;
	sc_t qs[ARM_DOF];
	int i;

	setup_arm(o, &a);
	for (i = 0; i < ARM_DOF; i++)
		qs[i] = sc_from_double(q[i]);
	arm_fk(&a, qs, &ee);
	dq_translation(&ee, &p);
	out[0] = sc_to_double(p.x);
	out[1] = sc_to_double(p.y);
	out[2] = sc_to_double(p.z);
	out[3] = sc_to_double(ee.r.w);
	out[4] = sc_to_double(ee.r.x);
	out[5] = sc_to_double(ee.r.y);
	out[6] = sc_to_double(ee.r.z);
}

void ikx_jacobian(const struct ikx_setup *o, const double q[IKX_DOF], double J[6][IKX_DOF])
{
	struct arm a;
	sc_t qs[ARM_DOF], Js[6][ARM_DOF];
	int i, r;

	setup_arm(o, &a);
	for (i = 0; i < ARM_DOF; i++)
		qs[i] = sc_from_double(q[i]);
	arm_jacobian(&a, qs, Js, NULL);
	for (r = 0; r < 6; r++)
		for (i = 0; i < ARM_DOF; i++)
			J[r][i] = sc_to_double(Js[r][i]);
}

int ikx_lsq(const double J[6][IKX_DOF], const double V[6], const bool *free, double x[IKX_DOF])
{
	sc_t Js[6][ARM_DOF], Vs[6], xs[ARM_DOF];
	int i, r, rank;

	for (r = 0; r < 6; r++) {
		for (i = 0; i < ARM_DOF; i++)
			Js[r][i] = sc_from_double(J[r][i]);
		Vs[r] = sc_from_double(V[r]);
	}
	rank = ik_lsq_step((const sc_t(*)[ARM_DOF])Js, Vs, free, xs);
	for (i = 0; i < ARM_DOF; i++)
		x[i] = sc_to_double(xs[i]);
	return rank;
}

unsigned ikx_solve(const struct ikx_setup *o, const double p[3], const double r[4], const double *seed,
		   double q[IKX_DOF], struct ikx_result *res)
{
	struct vec3 pp = { sc_from_double(p[0]), sc_from_double(p[1]), sc_from_double(p[2]) };
	struct quat rr = { sc_from_double(r[0]), sc_from_double(r[1]), sc_from_double(r[2]), sc_from_double(r[3]) };
	const struct ik_kin *kin = o->matrix ? &ik_kin_mat : &ik_kin_dq;
	struct arm a;
	struct ik_opts opts;
	struct ik_target t;
	struct ik_result ir;
	sc_t qs[ARM_DOF], ss[ARM_DOF];
	int i;

	setup_arm(o, &a);
	ik_default_opts(&opts);
	ik_target_set(&t, &pp, &rr);
	for (i = 0; i < ARM_DOF; i++)
		ss[i] = seed ? sc_from_double(seed[i]) : 0;
	if (o->newton) {
		opts.max_step = 0; /* the paper's plain step */
		opts.max_iter = 100;
		ik_newton(&a, kin, &t, ss, &opts, qs, &ir);
	} else {
		ik_solve(&a, kin, &t, seed ? ss : NULL, &opts, qs, &ir);
	}
	for (i = 0; i < ARM_DOF; i++)
		q[i] = sc_to_double(qs[i]);
	res->flags = ir.flags;
	res->iters = ir.iters;
	res->evals = ir.evals;
	res->err_pos = sc_to_double(ir.err.pos);
	res->err_rot = sc_to_double(ir.err.rot);
	return ir.flags;
}

void ikx_tolerances(double *pos, double *rot)
{
	struct ik_opts opts;

	ik_default_opts(&opts);
	*pos = sc_to_double(opts.tol_pos);
	*rot = sc_to_double(opts.tol_rot);
}

static void sensor_dq(const double s[7], struct dq *out)
{
	struct quat r = { sc_from_double(s[3]), sc_from_double(s[4]), sc_from_double(s[5]), sc_from_double(s[6]) };
	struct vec3 t = { sc_from_double(s[0]), sc_from_double(s[1]), sc_from_double(s[2]) };

	dq_from_rt(&r, &t, out);
}

static void v3_out(const struct vec3 *v, double out[3])
{
	out[0] = sc_to_double(v->x);
	out[1] = sc_to_double(v->y);
	out[2] = sc_to_double(v->z);
}

/* false if any of v[0..n-1] is not finite */
static bool all_finite(const double *v, int n)
{
	for (int i = 0; i < n; i++)
		if (!isfinite(v[i]))
			return false;
	return true;
}

void ikx_avatar_run(const struct ikx_avatar_setup *o, const struct ikx_avatar_frame *in, size_t n,
		    struct ikx_avatar_out *out)
{
	struct arm_dims d = { sc_from_double(o->dims[0]), sc_from_double(o->dims[1]), sc_from_double(o->dims[2]),
			      sc_from_double(o->dims[3]) };
	struct vec3 off = { sc_from_double(o->head_offset[0]), sc_from_double(o->head_offset[1]),
			    sc_from_double(o->head_offset[2]) };
	/* two poses in turn: this frame's and the previous one, its seed (the daemon keeps one and copies) */
	struct avatar_pose pose[2];
	struct avatar av;
	struct ik_opts opts;
	size_t i;

	avatar_init(&av, &d, &off, NULL);
	av.body.model = (av.body.model | o->options) & ~o->without;
	ik_default_opts(&opts);
	for (i = 0; i < n; i++) {
		struct avatar_pose *cur = &pose[i & 1], *prev = i ? &pose[(i - 1) & 1] : NULL;
		struct ikx_avatar_out *r = &out[i];
		struct dq head, lhand, rhand;
		struct vec3 c;
#ifdef SC_FIXQ_STATS
		unsigned long sat = sc_saturations;
#endif

		sensor_dq(in[i].head, &head);
		sensor_dq(in[i].lhand, &lhand);
		sensor_dq(in[i].rhand, &rhand);
		avatar_solve(&av, &ik_kin_dq, &opts, &head, &lhand, &rhand, prev, cur);
#ifdef SC_FIXQ_STATS
		r->saturations = sc_saturations - sat;
#else
		r->saturations = 0;
#endif
		dq_translation(&cur->chest, &c);
		v3_out(&c, r->chest);
		r->chest[3] = sc_to_double(cur->chest.r.w);
		r->chest[4] = sc_to_double(cur->chest.r.x);
		r->chest[5] = sc_to_double(cur->chest.r.y);
		r->chest[6] = sc_to_double(cur->chest.r.z);
		r->finite = all_finite(r->chest, 7);
		for (int side = 0; side < 2; side++) {
			r->flags[side] = cur->res[side].flags;
			r->err_pos[side] = sc_to_double(cur->res[side].err.pos);
			r->err_rot[side] = sc_to_double(cur->res[side].err.rot);
			for (int j = 0; j < ARM_DOF; j++)
				r->q[side][j] = sc_to_double(cur->q[side][j]);
			v3_out(&cur->seg[side].shoulder, r->shoulder[side]);
			v3_out(&cur->seg[side].elbow, r->elbow[side]);
			v3_out(&cur->seg[side].wrist, r->wrist[side]);
			v3_out(&cur->seg[side].hand, r->hand[side]);
			r->finite = r->finite && all_finite(&r->err_pos[side], 1) && all_finite(&r->err_rot[side], 1) &&
				    all_finite(r->q[side], IKX_DOF) && all_finite(r->shoulder[side], 3) &&
				    all_finite(r->elbow[side], 3) && all_finite(r->wrist[side], 3) &&
				    all_finite(r->hand[side], 3);
		}
	}
}
