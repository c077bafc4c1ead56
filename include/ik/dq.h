/* SPDX-License-Identifier: MIT */
/*
 * dq.h - vectors, quaternions and unit dual quaternions (rigid transforms).
 *
 * Conventions (the same everywhere in avatargw):
 *   - quaternions are Hamilton, scalar first: q = w + xi + yj + zk; a unit
 *     quaternion maps body vectors into the parent frame: v' = q v q*;
 *   - a unit dual quaternion Q = r + eps d stands for x' = R x + t with
 *     r the rotation and d = 1/2 t r (the paper's eq. 1 and its dual part);
 *   - products compose like 4x4 matrices: dq_mul(A, B) applies B first, in
 *     A's frame (base-first; the paper writes the reverse);
 *   - 4x4 matrices are row-major m[row][col], acting on column vectors;
 *   - lengths in metres, angles in radians.
 * Every function is pure: inputs first, result last, no allocation; results
 * may alias inputs unless a function says otherwise.
 */
#ifndef IK_DQ_H
#define IK_DQ_H

#include "ik/scalar.h"

#ifdef __cplusplus
extern "C" {
#endif

struct vec3 {
	sc_t x, y, z;
};

struct quat {
	sc_t w, x, y, z;
};

struct dq {
	struct quat r; /* rotation */
	struct quat d; /* dual part: 1/2 t r */
};

/* A screw (Chasles): rotation angle about a line and translation along it. */
struct screw {
	struct vec3 l; /* unit direction of the axis */
	struct vec3 m; /* moment of the axis: p x l for any point p on it */
	sc_t angle;    /* rotation about l, radians, in [0, pi] */
	sc_t d;	       /* translation along l, metres */
};

/* A twist: angular and linear velocity (the paper's V = {av, lv}). */
struct twist {
	struct vec3 w; /* angle times axis */
	struct vec3 v; /* linear part: velocity of the point at the origin */
};

/* A Pluecker line: unit direction and moment. */
struct line {
	struct vec3 l;
	struct vec3 m;
};

#define v3_dot SCN(v3_dot)
#define v3_cross SCN(v3_cross)
#define v3_norm SCN(v3_norm)
#define quat_mul SCN(quat_mul)
#define quat_conj SCN(quat_conj)
#define quat_norm SCN(quat_norm)
#define quat_normalize SCN(quat_normalize)
#define quat_rotate SCN(quat_rotate)
#define quat_from_axis_angle SCN(quat_from_axis_angle)
#define quat_to_mat3 SCN(quat_to_mat3)
#define quat_from_mat3 SCN(quat_from_mat3)
#define quat_angle_between SCN(quat_angle_between)
#define dq_identity SCN(dq_identity)
#define dq_mul SCN(dq_mul)
#define dq_conj SCN(dq_conj)
#define dq_normalize SCN(dq_normalize)
#define dq_from_rt SCN(dq_from_rt)
#define dq_from_axis_angle_t SCN(dq_from_axis_angle_t)
#define dq_translation SCN(dq_translation)
#define dq_transform_point SCN(dq_transform_point)
#define dq_transform_line SCN(dq_transform_line)
#define dq_to_mat4 SCN(dq_to_mat4)
#define dq_from_mat4 SCN(dq_from_mat4)
#define dq_log SCN(dq_log)
#define dq_exp SCN(dq_exp)
#define dq_log_twist SCN(dq_log_twist)
#define dq_exp_twist SCN(dq_exp_twist)
#define dq_is_finite SCN(dq_is_finite)

/*
 * The small algebra is static inline: every product in the kinematics would
 * otherwise be a call. The larger functions (normalisation, conversions,
 * logarithms) are in dq.c.
 *
 * Where every product is a call anyway (fixed point on a core without a
 * 64-bit multiply, SC_FIXQ_OUTLINE: Cortex-M0), the two largest, v3_cross
 * and quat_mul, are one function each in dq.c (which defines
 * DQ_DEFINE_OUTLINE) instead of a copy in every file: 0.8 kB less code.
 */
/*
 * IK_COMPACT: the core written as loops over tables instead of straight-line
 * code where that is all that differs (axes, components, columns), for
 * size-optimised fixed-point builds (-Os: the microcontroller images, where
 * much of the solver's code would otherwise be unrolled vector algebra).
 * Fixed point accumulates exactly and rounds where the straight-line form
 * does, so both forms give the same bits (the embedded self-test compares
 * them: its Cortex-M images are compact, the host's are not). The floating
 * builds and -O2 keep the straight-line code, which the host's speed relies
 * on. IK_COMPACT=0 or 1 overrides the choice (a compact floating build
 * works, but sums some products in another order: not the same bits). A
 * compact build also has v3_cross and quat_mul out of line (in dq.c).
 */
#ifndef IK_COMPACT
#if SC_TYPE == SC_FIXQ && defined(__OPTIMIZE_SIZE__)
#define IK_COMPACT 1
#else
#define IK_COMPACT 0
#endif
#endif

#if SC_TYPE == SC_FIXQ && (SC_FIXQ_OUTLINE || IK_COMPACT)
#define DQ_OUTLINE 1
#else
#define DQ_OUTLINE 0
#endif

/* the components of a vec3 (x, y, z) or a quat (w, x, y, z) as an array */
#define SC_V(v) ((sc_t *)(v))
#define SC_CV(v) ((const sc_t *)(v))

/*
 * DQ_INL: the small functions below are static inline, or in a compact
 * build one out-of-line copy each in dq.c (DQ_PROTO: this file gives only
 * their prototypes).
 */
#if IK_COMPACT
#define DQ_INL
#else
#define DQ_INL static inline
#endif
#if IK_COMPACT && !defined(DQ_DEFINE_OUTLINE)
#define DQ_PROTO 1
#else
#define DQ_PROTO 0
#endif

/* a b + c d and a b - c d, each product rounded (one call instead of two in a compact build) */
#if IK_COMPACT
#define sc_mul_add SCN(sc_mul_add)
#define sc_mul_sub SCN(sc_mul_sub)
sc_t sc_mul_add(sc_t a, sc_t b, sc_t c, sc_t d);
sc_t sc_mul_sub(sc_t a, sc_t b, sc_t c, sc_t d);
#else
static inline sc_t sc_mul_add(sc_t a, sc_t b, sc_t c, sc_t d)
{
	return sc_mul(a, b) + sc_mul(c, d);
}

static inline sc_t sc_mul_sub(sc_t a, sc_t b, sc_t c, sc_t d)
{
	return sc_mul(a, b) - sc_mul(c, d);
}
#endif

#if IK_COMPACT
#define vn_dot_acc SCN(vn_dot_acc)
#define quat_axis SCN(quat_axis)
/* the sum of a[i] b[i], i < n, unrounded */
sc_acc_t vn_dot_acc(const sc_t *a, const sc_t *b, int n);
/* column k (0: x, 1: y, 2: z) of the rotation matrix of q, R e_k, as quat_to_mat3 computes it */
void quat_axis(const struct quat *q, int k, struct vec3 *out);
/* loops, in dq.c */
sc_t v3_dot(const struct vec3 *a, const struct vec3 *b);
sc_t v3_norm(const struct vec3 *a);
#else
static inline sc_t v3_dot(const struct vec3 *a, const struct vec3 *b)
{
	sc_acc_t s = sc_acc0();

	s = sc_mac(s, a->x, b->x);
	s = sc_mac(s, a->y, b->y);
	s = sc_mac(s, a->z, b->z);
	return sc_acc_get(s);
}

static inline sc_t v3_norm(const struct vec3 *a)
{
	return sc_acc_sqrt(sc_mac(sc_mac(sc_mac(sc_acc0(), a->x, a->x), a->y, a->y), a->z, a->z));
}
#endif

#if DQ_OUTLINE
#define DQ_SMALL
#else
#define DQ_SMALL static inline
#endif
#if (DQ_OUTLINE && !defined(DQ_DEFINE_OUTLINE)) || IK_COMPACT
/* one copy in dq.c (a compact build's: loops) */
void v3_cross(const struct vec3 *a, const struct vec3 *b, struct vec3 *out);
/* out = a b (Hamilton) */
void quat_mul(const struct quat *a, const struct quat *b, struct quat *out);
#else
DQ_SMALL void v3_cross(const struct vec3 *a, const struct vec3 *b, struct vec3 *out)
{
	struct vec3 c;

	c.x = sc_acc_get(sc_msb(sc_mac(sc_acc0(), a->y, b->z), a->z, b->y));
	c.y = sc_acc_get(sc_msb(sc_mac(sc_acc0(), a->z, b->x), a->x, b->z));
	c.z = sc_acc_get(sc_msb(sc_mac(sc_acc0(), a->x, b->y), a->y, b->x));
	*out = c;
}

/* out = a b (Hamilton) */
DQ_SMALL void quat_mul(const struct quat *a, const struct quat *b, struct quat *out)
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
#endif

static inline void quat_conj(const struct quat *a, struct quat *out)
{
	out->w = a->w;
	out->x = -a->x;
	out->y = -a->y;
	out->z = -a->z;
}

#if IK_COMPACT
sc_t quat_norm(const struct quat *a);
#else
static inline sc_t quat_norm(const struct quat *a)
{
	sc_acc_t s = sc_mac(sc_acc0(), a->w, a->w);

	s = sc_mac(s, a->x, a->x);
	s = sc_mac(s, a->y, a->y);
	return sc_acc_sqrt(sc_mac(s, a->z, a->z));
}
#endif

/* Returns false (and writes the identity) if |a| is zero or not finite. */
bool quat_normalize(const struct quat *a, struct quat *out);

/* out = q v q*, q a unit quaternion */
DQ_INL void quat_rotate(const struct quat *q, const struct vec3 *v, struct vec3 *out)
#if DQ_PROTO
	;
#else
{
	/* v' = v + 2w (u x v) + 2 u x (u x v), u the vector part */
	struct vec3 u, c, cc;

	u.x = q->x;
	u.y = q->y;
	u.z = q->z;
	v3_cross(&u, v, &c);
	c.x += c.x;
	c.y += c.y;
	c.z += c.z;
	v3_cross(&u, &c, &cc);
	out->x = v->x + sc_mul(q->w, c.x) + cc.x;
	out->y = v->y + sc_mul(q->w, c.y) + cc.y;
	out->z = v->z + sc_mul(q->w, c.z) + cc.z;
}
#endif

/* axis must be a unit vector */
static inline void quat_from_axis_angle(const struct vec3 *axis, sc_t angle, struct quat *out)
{
	sc_t s, c;

	sc_sincos(sc_mul(angle, SC_C(0.5)), &s, &c);
	out->w = c;
	out->x = sc_mul(axis->x, s);
	out->y = sc_mul(axis->y, s);
	out->z = sc_mul(axis->z, s);
}

/* rotation matrix m[row][col] of a unit quaternion, and back (out has w >= 0) */
void quat_to_mat3(const struct quat *q, sc_t m[3][3]);
void quat_from_mat3(const sc_t m[3][3], struct quat *out);
/* angle in [0, pi] of the rotation a* b, sign-insensitive */
sc_t quat_angle_between(const struct quat *a, const struct quat *b);

static inline void dq_identity(struct dq *out)
{
	out->r.w = SC_C(1);
	out->r.x = out->r.y = out->r.z = 0;
	out->d.w = out->d.x = out->d.y = out->d.z = 0;
}

/* out = a b: b first, then a. out must not alias a or b. */
static inline void dq_mul(const struct dq *a, const struct dq *b, struct dq *out)
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

/* quaternion conjugate of both parts: the inverse of a unit dual quaternion */
static inline void dq_conj(const struct dq *a, struct dq *out)
{
	quat_conj(&a->r, &out->r);
	quat_conj(&a->d, &out->d);
}

/*
 * Makes a unit dual quaternion: r <- r/|r|, d <- d/|r|, then removes the
 * part of d along r so that r.d = 0. Returns false (identity written) for a
 * zero or non-finite real part.
 */
bool dq_normalize(const struct dq *a, struct dq *out);

/* x' = R x + t from a unit rotation r and a translation t */
DQ_INL void dq_from_rt(const struct quat *r, const struct vec3 *t, struct dq *out)
#if DQ_PROTO
	;
#else
{
	/* d = (0, h) r with h = t / 2: quat_mul's sums without its products by the zero (the same values) */
	struct quat rr = *r;
	sc_t hx = sc_mul(t->x, SC_C(0.5)), hy = sc_mul(t->y, SC_C(0.5)), hz = sc_mul(t->z, SC_C(0.5));

	out->d.w = sc_acc_get(sc_msb(sc_msb(sc_msb(sc_acc0(), hx, rr.x), hy, rr.y), hz, rr.z));
	out->d.x = sc_acc_get(sc_msb(sc_mac(sc_mac(sc_acc0(), hx, rr.w), hy, rr.z), hz, rr.y));
	out->d.y = sc_acc_get(sc_mac(sc_mac(sc_msb(sc_acc0(), hx, rr.z), hy, rr.w), hz, rr.x));
	out->d.z = sc_acc_get(sc_mac(sc_msb(sc_mac(sc_acc0(), hx, rr.y), hy, rr.x), hz, rr.w));
	out->r = rr;
}
#endif

/* the paper's Q(R, theta, T): rotation about the unit axis, then translation t in the parent frame */
void dq_from_axis_angle_t(const struct vec3 *axis, sc_t angle, const struct vec3 *t, struct dq *out);

DQ_INL void dq_translation(const struct dq *a, struct vec3 *out)
#if DQ_PROTO
	;
#else
{
	/* t = 2 d r* */
	struct quat rc, t;

	quat_conj(&a->r, &rc);
	quat_mul(&a->d, &rc, &t);
	out->x = 2 * t.x;
	out->y = 2 * t.y;
	out->z = 2 * t.z;
}
#endif

static inline void dq_transform_point(const struct dq *a, const struct vec3 *p, struct vec3 *out)
{
	struct vec3 t, rp;

	dq_translation(a, &t);
	quat_rotate(&a->r, p, &rp);
	out->x = rp.x + t.x;
	out->y = rp.y + t.y;
	out->z = rp.z + t.z;
}

/* the line moved by the transform: l' = R l, m' = R m + t x R l */
void dq_transform_line(const struct dq *a, const struct line *in, struct line *out);
void dq_to_mat4(const struct dq *a, sc_t m[4][4]);
/* m must hold a rotation and a translation (last row 0 0 0 1 ignored) */
void dq_from_mat4(const sc_t m[4][4], struct dq *out);
/*
 * Screw logarithm of a unit dual quaternion (the paper's section 5.2). For a
 * pure translation the axis is the direction of travel and the moment is zero;
 * for the identity the axis is x. The shortest path is taken (angle <= pi).
 */
void dq_log(const struct dq *a, struct screw *out);
void dq_exp(const struct screw *s, struct dq *out);
/*
 * Twist (angle times axis, linear velocity of the origin) whose exponential
 * is a; the paper's V = {theta R, t R + theta M}. Stable near zero angle and
 * for pure translations; shortest path.
 */
void dq_log_twist(const struct dq *a, struct twist *out);
void dq_exp_twist(const struct twist *tw, struct dq *out);
bool dq_is_finite(const struct dq *a);

#ifdef __cplusplus
}
#endif

#endif /* IK_DQ_H */
