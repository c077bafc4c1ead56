/* SPDX-License-Identifier: MIT */
/*
 * keyframe.h - a sensor's motion rebuilt from samples kept at a low rate:
 * the paper's proposal (Luciano & Banerjee 2000, section 7) of storing the
 * tracked poses "at a certain time interval, for example one second" and
 * interpolating "spline for the positions and squad quaternion interpolation
 * for the orientations" (Dam, Koch and Lillholm 1998).
 *
 * A track is n keyframes (time, position, orientation) of one sensor at
 * strictly increasing times. kf_prepare() derives what the interpolation
 * needs; kf_eval() gives the pose at any time (held at the first or last
 * keyframe outside their span). Methods:
 *
 *   KF_LINEAR       positions on straight lines, orientations by slerp (the
 *                   baseline: continuous, but velocity jumps at every key)
 *   KF_CATMULL_ROM  positions: cubic Hermite segments whose tangents are the
 *                   central differences (p[i+1] - p[i-1]) / (t[i+1] - t[i-1])
 *                   (Catmull-Rom for uneven spacing; one-sided at the ends);
 *                   local: a segment needs its two neighbouring keys only.
 *                   Orientations by squad.
 *   KF_NATURAL      positions: the natural cubic spline through every key
 *                   (continuous second derivative, zero at both ends; a
 *                   global tridiagonal solve). Orientations by squad.
 *
 * Squad (Shoemake): between keys q[i] and q[i+1] at h in [0, 1],
 * slerp(slerp(q[i], q[i+1], h), slerp(s[i], s[i+1], h), 2h(1 - h)), with
 * the inner points s[i] = q[i] exp(-(log(q[i]* q[i+1]) + log(q[i]* q[i-1])) / 4)
 * (s = q at the first and last key). It assumes evenly spaced keys, which a
 * fixed keyframe rate gives.
 *
 * Positions in any unit, quaternions (w, x, y, z) Hamilton, any norm (made
 * unit and sign-continuous by kf_prepare). Pure functions over caller
 * memory: no allocation, no I/O.
 */
#ifndef AGW_KEYFRAME_H
#define AGW_KEYFRAME_H

#include <stdbool.h>
#include <stddef.h>

enum kf_interp {
	KF_LINEAR = 0,
	KF_CATMULL_ROM = 1,
	KF_NATURAL = 2,
};

struct kf_pose {
	double p[3];
	double q[4]; /* w, x, y, z */
};

struct kf_track {
	enum kf_interp interp;
	size_t n;
	const double *t;     /* n times, strictly increasing */
	struct kf_pose *key; /* n keys; kf_prepare normalises and aligns the quaternions in place */
	double (*d2)[3];     /* n: second derivatives of the natural spline (KF_NATURAL only, else NULL) */
	double (*s)[4];	     /* n: squad inner points (KF_CATMULL_ROM and KF_NATURAL, else NULL) */
	double *work;	     /* n scratch doubles (KF_NATURAL only, else NULL) */
};

/*
 * Checks the track and derives d2 and s. Returns 0, or -1 if n == 0, a
 * buffer the method needs is NULL, a time does not increase or a number is
 * not finite, or a quaternion is zero.
 */
int kf_prepare(struct kf_track *tr);
/* the pose at time t: out->q is a unit quaternion */
void kf_eval(const struct kf_track *tr, double t, struct kf_pose *out);
/* index i of the segment holding t: t[i] <= t < t[i+1] (0 before, n - 2 after; 0 if n < 2); hint: a guess or 0 */
size_t kf_segment(const double *times, size_t n, double t, size_t hint);
/* "linear", "catmull-rom", "natural"; NULL if unknown */
const char *kf_interp_name(enum kf_interp m);
/* the method of a name, or -1 */
int kf_interp_parse(const char *name);

/* the quaternion helpers, exposed for the tests: unit quaternions (w, x, y, z) */
void kf_slerp(const double a[4], const double b[4], double h, double out[4]);
void kf_squad(const double q0[4], const double q1[4], const double s0[4], const double s1[4], double h, double out[4]);

#endif /* AGW_KEYFRAME_H */
