// SPDX-License-Identifier: MIT
/*
 * ikt.c - the IK core's self-test, the same source on every target and
 * scalar type: x86-64 and aarch64 Linux, Cortex-M0, M3 and M4F under QEMU.
 * It checks the kinematics (the published checks, the Jacobian against
 * finite differences), the least-squares step, and solves a fixed set of
 * the shared benchmark targets (random targets from the rest posture, a
 * stretch of the trajectory from the previous frame, the left arm, the
 * paper's Newton), judging each solve by its own forward kinematics as
 * ../shared/bench/README.md does. It prints a hash of every solution
 * (tests/check-embedded.sh requires the Q5.26 hashes to be identical on
 * every target), the instructions per Newton iteration and per solve where
 * the platform counts them, and the stack the solver used.
 *
 * The benchmark rows come from ikt_vectors.inc, generated from the CSV
 * files (tools/embedded-vectors.sh); SC_C() turns them into constants of
 * the scalar type at compile time, so every target starts from the same
 * bits. No libc: integers are printed by hand.
 */
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ik/ik.h"
#include "ikt.h"

struct ikt_row {
	sc_t q[ARM_DOF]; /* the generating angles */
	sc_t p[3];
	sc_t r[4];
};

#define IKT_ROW(a, b, c, d, e, f, g, h, px, py, pz, qw, qx, qy, qz)                                                    \
	{ { SC_C(a), SC_C(b), SC_C(c), SC_C(d), SC_C(e), SC_C(f), SC_C(g), SC_C(h) },                                  \
	  { SC_C(px), SC_C(py), SC_C(pz) },                                                                            \
	  { SC_C(qw), SC_C(qx), SC_C(qy), SC_C(qz) } },

static const struct ikt_row random_rows[] = {
#define IKT_RANDOM IKT_ROW
#define IKT_TRAJ(...)
#include "ikt_vectors.inc"
#undef IKT_RANDOM
#undef IKT_TRAJ
};

static const struct ikt_row traj_rows[] = {
#define IKT_RANDOM(...)
#define IKT_TRAJ IKT_ROW
#include "ikt_vectors.inc"
#undef IKT_RANDOM
#undef IKT_TRAJ
};

#define N_RANDOM (sizeof(random_rows) / sizeof(random_rows[0]))
#define N_TRAJ (sizeof(traj_rows) / sizeof(traj_rows[0]))
#define N_LEFT 8
#define N_NEWTON 8

/* tolerances of the checks, per type: about 10 ulp of the kinematics */
#if SC_TYPE == SC_FIXQ
#define TOL_FK SC_C(1e-7)
#define FD_H SC_C(1e-3)
#define TOL_FD SC_C(2e-4)
#define TOL_LSQ SC_C(1e-6)
#elif SC_TYPE == SC_FLOAT
#define TOL_FK SC_C(2e-6)
#define FD_H SC_C(1e-3)
#define TOL_FD SC_C(2e-3)
#define TOL_LSQ SC_C(2e-5)
#else
#define TOL_FK SC_C(1e-12)
#define FD_H SC_C(1e-5)
#define TOL_FD SC_C(1e-6)
#define TOL_LSQ SC_C(1e-10)
#endif
#define STRICT_POS SC_C(1e-4)
#define STRICT_ROT SC_C(1.7453292519943295e-4) /* 0.01 deg */
#define JUMP SC_C(0.17453292519943295)	       /* 10 deg */

static const struct arm_dims bench_dims = { SC_C(0.18), SC_C(0.30), SC_C(0.26), SC_C(0.08) };

/* ---- output without libc ------------------------------------------------------------- */

static char line[160];
static size_t line_len;

static void put_c(char c)
{
	if (line_len + 1 < sizeof(line))
		line[line_len++] = c;
}

static void put_u(unsigned long v, unsigned base, int width)
{
	char d[24];
	int n = 0;

	do {
		unsigned digit = (unsigned)(v % base);

		d[n++] = (char)(digit < 10 ? '0' + digit : 'a' + digit - 10);
		v /= base;
	} while (v && n < (int)sizeof(d));
	while (width-- > n)
		put_c('0');
	while (n)
		put_c(d[--n]);
}

/* %s %d %ld %u %lu %x (8 digits); enough for this file */
static void out(const char *fmt, ...)
{
	va_list ap;

	va_start(ap, fmt);
	line_len = 0;
	for (; *fmt; fmt++) {
		bool lng = false;

		if (*fmt != '%') {
			put_c(*fmt);
			continue;
		}
		if (fmt[1] == 'l') {
			lng = true;
			fmt++;
		}
		switch (*++fmt) {
		case 's':
			for (const char *s = va_arg(ap, const char *); *s; s++)
				put_c(*s);
			break;
		case 'd': {
			long v = lng ? va_arg(ap, long) : va_arg(ap, int);

			if (v < 0) {
				put_c('-');
				put_u(0ul - (unsigned long)v, 10, 0);
			} else {
				put_u((unsigned long)v, 10, 0);
			}
			break;
		}
		case 'u':
			put_u(lng ? va_arg(ap, unsigned long) : va_arg(ap, unsigned), 10, 0);
			break;
		case 'x':
			put_u(lng ? va_arg(ap, unsigned long) : va_arg(ap, unsigned), 16, 8);
			break;
		default:
			put_c('?');
			break;
		}
	}
	va_end(ap);
	line[line_len] = 0;
	ikt_puts(line);
}

/* a length or angle in units of 1e-9 (nm, nrad), for printing */
static long nano(sc_t v)
{
#if SC_TYPE == SC_FIXQ
	return (long)(((int64_t)v * 1000000000 + ((int64_t)1 << 25)) >> 26);
#else
	return (long)(v * SC_C(1e9));
#endif
}

/* ---- bookkeeping ---------------------------------------------------------------------- */

static int failures;

static void check(bool ok, const char *what, long a, long b)
{
	if (ok)
		return;
	failures++;
	out("ikt: FAILED %s (%ld, %ld)", what, a, b);
}

/* FNV-1a over the bits of every solution, little-endian whatever the machine */
static uint32_t hash_word(uint32_t h, uint32_t w)
{
	int i;

	for (i = 0; i < 4; i++) {
		h ^= (w >> (8 * i)) & 0xffu;
		h *= 16777619u;
	}
	return h;
}

static uint32_t hash_q(uint32_t h, const sc_t q[ARM_DOF], unsigned flags)
{
	int i;

	for (i = 0; i < ARM_DOF; i++) {
#if SC_TYPE == SC_FIXQ
		h = hash_word(h, (uint32_t)q[i]);
#else
		union {
			sc_t v;
			uint32_t w[sizeof(sc_t) / 4];
		} u = { q[i] };

		for (size_t k = 0; k < sizeof(sc_t) / 4; k++)
			h = hash_word(h, u.w[k]);
#endif
	}
	return hash_word(h, flags);
}

#define FNV_INIT 2166136261u

struct cost {
	unsigned long n, sum, max; /* instructions */
};

static uint32_t t_start;

static void cost_begin(void)
{
	t_start = ikt_ticks();
}

static void cost_end(struct cost *c)
{
	uint32_t ticks = (ikt_ticks() - t_start) & 0xffffffu;
	unsigned long ins = (unsigned long)((uint64_t)ticks * ikt_ticks_per_k() / 1000);

	c->n++;
	c->sum += ins;
	if (ins > c->max)
		c->max = ins;
}

static void cost_print(const char *what, const struct cost *c)
{
	if (ikt_ticks_per_k() && c->n)
		out("ikt: instructions %s: mean %lu, max %lu (%lu runs)", what, c->sum / c->n, c->max, c->n);
}

static uint32_t stack_max;

static void stack_note(void)
{
	uint32_t used = ikt_stack_used();

	if (used > stack_max)
		stack_max = used;
}

static void target_of(const struct ikt_row *r, struct ik_target *t)
{
	struct vec3 p = { r->p[0], r->p[1], r->p[2] };
	struct quat q = { r->r[0], r->r[1], r->r[2], r->r[3] };

	ik_target_set(t, &p, &q);
}

/* position and rotation error of q against t, by this type's own kinematics */
static void judge(const struct arm *a, const sc_t q[ARM_DOF], const struct ik_target *t, sc_t *ep, sc_t *er)
{
	struct dq fk;
	struct vec3 p, d;

	arm_fk(a, q, &fk);
	dq_translation(&fk, &p);
	d = (struct vec3){ p.x - t->p.x, p.y - t->p.y, p.z - t->p.z };
	*ep = v3_norm(&d);
	*er = quat_angle_between(&fk.r, &t->r);
}

/* ---- the checks ----------------------------------------------------------------------- */

static void near3(const struct vec3 *p, sc_t x, sc_t y, sc_t z, const char *what)
{
	check(sc_abs(p->x - x) <= TOL_FK && sc_abs(p->y - y) <= TOL_FK && sc_abs(p->z - z) <= TOL_FK, what,
	      nano(p->x - x), nano(p->z - z));
}

static void test_fk(void)
{
	sc_t q[ARM_DOF] = { 0 };
	struct arm right, left;
	struct dq ee;
	struct vec3 p;

	arm_init(&right, ARM_RIGHT, &bench_dims, NULL);
	arm_init(&left, ARM_LEFT, &bench_dims, NULL);
	arm_fk(&right, q, &ee);
	dq_translation(&ee, &p);
	near3(&p, SC_C(0.18), SC_C(0.34), SC_C(-0.30), "fk right q = 0");
	check(sc_abs(sc_abs(ee.r.w) - SC_C(1)) <= TOL_FK, "fk q = 0 identity", nano(ee.r.w), 0);
	arm_fk(&left, q, &ee);
	dq_translation(&ee, &p);
	near3(&p, SC_C(-0.18), SC_C(0.34), SC_C(-0.30), "fk left q = 0");
	q[4] = SC_HALF_PI;
	arm_fk(&right, q, &ee);
	dq_translation(&ee, &p);
	near3(&p, SC_C(0.18), SC_C(0), SC_C(0.04), "fk right q5 = 90 deg");
	out("ikt: kinematics: published checks done");
}

/* every Jacobian column against the central difference of FK, taken as a spatial twist */
static void test_jacobian(void)
{
	struct arm a;
	sc_t worst = 0;
	int n, i, r;

	arm_init(&a, ARM_RIGHT, &bench_dims, NULL);
	for (n = 0; n < 6; n++) {
		const sc_t *q = random_rows[n].q;
		sc_t J[6][ARM_DOF];
		struct dq c, ci;

		arm_jacobian(&a, q, J, &c);
		dq_conj(&c, &ci);
		for (i = 0; i < ARM_DOF; i++) {
			sc_t qp[ARM_DOF], qm[ARM_DOF], col[6];
			struct dq fp, fm, ep, em;
			struct twist tp, tm;

			for (r = 0; r < ARM_DOF; r++)
				qp[r] = qm[r] = q[r];
			qp[i] += FD_H;
			qm[i] -= FD_H;
			arm_fk(&a, qp, &fp);
			arm_fk(&a, qm, &fm);
			dq_mul(&fp, &ci, &ep);
			dq_mul(&fm, &ci, &em);
			dq_log_twist(&ep, &tp);
			dq_log_twist(&em, &tm);
			col[0] = tp.w.x - tm.w.x;
			col[1] = tp.w.y - tm.w.y;
			col[2] = tp.w.z - tm.w.z;
			col[3] = tp.v.x - tm.v.x;
			col[4] = tp.v.y - tm.v.y;
			col[5] = tp.v.z - tm.v.z;
			for (r = 0; r < 6; r++)
				worst = sc_max(worst, sc_abs(J[r][i] - sc_div(col[r], 2 * FD_H)));
		}
	}
	check(worst <= TOL_FD, "jacobian against finite differences", nano(worst), nano(TOL_FD));
	out("ikt: jacobian: largest difference to finite differences %ld e-9", nano(worst));
}

/* the minimum-norm step solves J x = V and is no longer than the step that made V */
/*
 * The step with held joints (newton_limited's re-solves): 7 to 3 free
 * columns, so both shapes (minimum norm, and least squares with fewer free
 * joints than equations) run on every target; held joints must not move.
 * Returns the hash of the steps.
 */
static uint32_t lsq_held(const sc_t J[6][ARM_DOF], const sc_t V[6], int n)
{
	uint32_t h = FNV_INIT;
	int held, i;

	for (held = 1; held <= 5; held++) {
		bool free[ARM_DOF];
		sc_t x[ARM_DOF];
		int rank;

		for (i = 0; i < ARM_DOF; i++)
			free[i] = (i * 3 + n) % ARM_DOF >= held;
		rank = ik_lsq_step(J, V, free, x);
		check(rank <= ARM_DOF - held, "lsq held: rank", n, rank);
		for (i = 0; i < ARM_DOF; i++)
			check(free[i] || x[i] == 0, "lsq held: a held joint moves", n, i);
		h = hash_q(h, x, (unsigned)rank);
	}
	return h;
}

static uint32_t test_lsq(void)
{
	struct arm a;
	sc_t worst = 0;
	uint32_t h = FNV_INIT;
	int n, i, r;

	arm_init(&a, ARM_RIGHT, &bench_dims, NULL);
	for (n = 0; n < 16; n++) {
		sc_t J[6][ARM_DOF], V[6], x[ARM_DOF], x0[ARM_DOF];
		sc_acc_t n0 = sc_acc0(), n1 = sc_acc0();

		arm_jacobian(&a, random_rows[n].q, J, NULL);
		for (i = 0; i < ARM_DOF; i++)
			x0[i] = sc_mul_int(SC_C(0.003), (i * 7 + n * 3) % 11 - 5);
		for (r = 0; r < 6; r++) {
			sc_acc_t s = sc_acc0();

			for (i = 0; i < ARM_DOF; i++)
				s = sc_mac(s, J[r][i], x0[i]);
			V[r] = sc_acc_get(s);
		}
		check(ik_lsq_step((const sc_t(*)[ARM_DOF])J, V, NULL, x) == 6, "lsq rank", n, 0);
		for (r = 0; r < 6; r++) {
			sc_acc_t s = sc_acc0();

			for (i = 0; i < ARM_DOF; i++)
				s = sc_mac(s, J[r][i], x[i]);
			worst = sc_max(worst, sc_abs(sc_acc_get(s) - V[r]));
		}
		for (i = 0; i < ARM_DOF; i++) {
			n0 = sc_mac(n0, x0[i], x0[i]);
			n1 = sc_mac(n1, x[i], x[i]);
		}
		check(sc_acc_sqrt(n1) <= sc_acc_sqrt(n0) + TOL_LSQ, "lsq minimum norm", nano(sc_acc_sqrt(n1)),
		      nano(sc_acc_sqrt(n0)));
		h = hash_word(h, lsq_held((const sc_t(*)[ARM_DOF])J, V, n));
	}
	check(worst <= TOL_LSQ, "lsq residual", nano(worst), nano(TOL_LSQ));
	out("ikt: least squares: largest residual %ld e-9", nano(worst));
	return h;
}

/* random targets, each from the rest posture (the paper's reset) */
static uint32_t test_random(struct cost *cost, struct cost *iter)
{
	struct arm a;
	struct ik_opts o;
	uint32_t h = FNV_INIT;
	sc_t max_ep = 0, max_er = 0;
	unsigned strict = 0, inlim = 0;
	size_t i;

	arm_init(&a, ARM_RIGHT, &bench_dims, NULL);
	ik_default_opts(&o);
	for (i = 0; i < N_RANDOM; i++) {
		struct ik_target t;
		struct ik_result res;
		sc_t q[ARM_DOF], ep, er;

		target_of(&random_rows[i], &t);
		ikt_stack_paint();
		cost_begin();
		ik_solve(&a, &ik_kin_dq, &t, NULL, &o, q, &res);
		cost_end(cost);
		stack_note();
		h = hash_q(h, q, res.flags);
		judge(&a, q, &t, &ep, &er);
		if (ep < STRICT_POS && er < STRICT_ROT) {
			strict++;
			max_ep = sc_max(max_ep, ep);
			max_er = sc_max(max_er, er);
			check(res.flags & IK_REACHED, "random: reached flag", (long)i, (long)res.flags);
		}
		inlim += arm_in_limits(&a, q);
	}
	/* one Newton iteration: the kinematics at a posture against another target, and the step */
	for (i = 0; i + 1 < N_RANDOM; i++) {
		struct ik_target t;
		struct ik_err err;
		sc_t J[6][ARM_DOF], V[6], x[ARM_DOF];

		target_of(&random_rows[i + 1], &t);
		cost_begin();
		ik_kin_dq.eval(&a, random_rows[i].q, &t, J, V, &err);
		ik_lsq_step((const sc_t(*)[ARM_DOF])J, V, NULL, x);
		cost_end(iter);
	}
	out("ikt: random targets, reset: %u of %u strict, %u in limits; largest error %ld nm, %ld nrad", strict,
	    (unsigned)N_RANDOM, inlim, nano(max_ep), nano(max_er));
	/* the benchmark goal: every target but the rare sliver no search finds */
	check(strict + 1 >= N_RANDOM, "random: strict", (long)strict, (long)N_RANDOM);
	check(inlim == N_RANDOM, "random: in limits", (long)inlim, (long)N_RANDOM);
	return h;
}

/* the trajectory, each frame from the previous solution (tracking) */
static uint32_t test_trajectory(struct cost *cost)
{
	struct arm a;
	struct ik_opts o;
	uint32_t h = FNV_INIT;
	sc_t prev[ARM_DOF], max_ep = 0, max_er = 0;
	unsigned strict = 0, inlim = 0, jumps = 0;
	size_t i;
	int k;

	arm_init(&a, ARM_RIGHT, &bench_dims, NULL);
	ik_default_opts(&o);
	for (i = 0; i < N_TRAJ; i++) {
		struct ik_target t;
		struct ik_result res;
		sc_t q[ARM_DOF], ep, er;

		target_of(&traj_rows[i], &t);
		ikt_stack_paint();
		cost_begin();
		ik_solve(&a, &ik_kin_dq, &t, i ? prev : NULL, &o, q, &res);
		if (i)
			cost_end(cost);
		stack_note();
		h = hash_q(h, q, res.flags);
		judge(&a, q, &t, &ep, &er);
		if (ep < STRICT_POS && er < STRICT_ROT)
			strict++;
		max_ep = sc_max(max_ep, ep);
		max_er = sc_max(max_er, er);
		inlim += arm_in_limits(&a, q);
		for (k = 0; i && k < ARM_DOF; k++) {
			if (sc_abs(sc_wrap_pi(q[k] - prev[k])) > JUMP) {
				jumps++;
				break;
			}
		}
		for (k = 0; k < ARM_DOF; k++)
			prev[k] = q[k];
	}
	out("ikt: trajectory, warm: %u of %u strict, %u in limits, %u jumps; largest error %ld nm, %ld nrad", strict,
	    (unsigned)N_TRAJ, inlim, jumps, nano(max_ep), nano(max_er));
	check(strict == N_TRAJ, "trajectory: strict", (long)strict, (long)N_TRAJ);
	check(inlim == N_TRAJ, "trajectory: in limits", (long)inlim, (long)N_TRAJ);
	check(jumps == 0, "trajectory: jumps", (long)jumps, 0);
	return h;
}

/* the left arm solves the mirror image with the same angles (up to rounding) */
static uint32_t test_left(void)
{
	struct arm right, left;
	struct ik_opts o;
	uint32_t h = FNV_INIT;
	unsigned same = 0, i;
	int k;

	arm_init(&right, ARM_RIGHT, &bench_dims, NULL);
	arm_init(&left, ARM_LEFT, &bench_dims, NULL);
	ik_default_opts(&o);
	for (i = 0; i < N_LEFT; i++) {
		struct ik_target t, tl;
		struct ik_result rr, rl;
		struct dq m;
		struct vec3 p;
		sc_t qr[ARM_DOF], ql[ARM_DOF], ep, er, d = 0;

		target_of(&random_rows[i], &t);
		arm_mirror_dq(&t.d, &m);
		dq_translation(&m, &p);
		ik_target_set(&tl, &p, &m.r);
		ik_solve(&right, &ik_kin_dq, &t, NULL, &o, qr, &rr);
		ik_solve(&left, &ik_kin_dq, &tl, NULL, &o, ql, &rl);
		h = hash_q(h, ql, rl.flags);
		judge(&left, ql, &tl, &ep, &er);
		check(ep < STRICT_POS && er < STRICT_ROT, "left arm: strict", (long)i, nano(ep));
		check(arm_in_limits(&left, ql), "left arm: in limits", (long)i, 0);
		for (k = 0; k < ARM_DOF; k++)
			d = sc_max(d, sc_abs(qr[k] - ql[k]));
		same += d < SC_C(1e-4);
	}
	out("ikt: left arm: %u of %u mirrored solutions equal the right arm's", same, (unsigned)N_LEFT);
	check(same + 1 >= N_LEFT, "left arm: same angles", (long)same, N_LEFT);
	return h;
}

/* the paper's Newton from q = 0, without limits */
static uint32_t test_newton(struct cost *cost)
{
	struct arm a;
	struct ik_opts o;
	uint32_t h = FNV_INIT;
	unsigned reached = 0, i;
	int iters = 0;

	arm_init(&a, ARM_RIGHT, &bench_dims, NULL);
	ik_default_opts(&o);
	o.max_step = 0;
	o.max_iter = 100;
	for (i = 0; i < N_NEWTON; i++) {
		struct ik_target t;
		struct ik_result res;
		sc_t q[ARM_DOF], zero[ARM_DOF] = { 0 }, ep, er;

		target_of(&random_rows[i], &t);
		ikt_stack_paint();
		cost_begin();
		ik_newton(&a, &ik_kin_dq, &t, zero, &o, q, &res);
		cost_end(cost);
		stack_note();
		h = hash_q(h, q, res.flags);
		judge(&a, q, &t, &ep, &er);
		reached += (res.flags & IK_REACHED) && ep < STRICT_POS && er < STRICT_ROT;
		iters += res.iters;
	}
	out("ikt: paper's Newton from q = 0: %u of %u reached, %d iterations", reached, (unsigned)N_NEWTON, iters);
	check(reached == N_NEWTON, "newton: reached", (long)reached, N_NEWTON);
	return h;
}

int ikt_run(void)
{
	struct cost reset = { 0 }, warm = { 0 }, iter = { 0 }, newton = { 0 };
	uint32_t hs, hr, ht, hl, hn;

	out("ikt: IK core self-test, scalar %s, on %s", SC_NAME, ikt_platform);
	test_fk();
	test_jacobian();
	hs = test_lsq();
	hr = test_random(&reset, &iter);
	ht = test_trajectory(&warm);
	hl = test_left();
	hn = test_newton(&newton);
	out("ikt: hash random %x trajectory %x left %x newton %x lsq %x", hr, ht, hl, hn, hs);
	out("ikt: hash %s %x", SC_NAME, hash_word(hash_word(hash_word(hash_word(hr, ht), hl), hn), hs));
	cost_print("per Newton iteration (kinematics, Jacobian, error twist, least-squares step)", &iter);
	cost_print("per solve, trajectory, warm", &warm);
	cost_print("per solve, random targets, reset", &reset);
	cost_print("per solve, paper's Newton from q = 0", &newton);
	if (stack_max)
		out("ikt: stack used by ik_solve/ik_newton: %lu bytes", (unsigned long)stack_max);
	if (failures) {
		out("ikt: FAIL (%d checks failed)", failures);
		return 1;
	}
	out("ikt: PASS");
	return 0;
}
