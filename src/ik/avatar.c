// SPDX-License-Identifier: MIT
/*
 * avatar.c - the chest from the head, both arms toward the hands.
 * See ik/avatar.h; what each model choice buys is measured in
 * docs/FIDELITY.md.
 */
#include "ik/avatar.h"

#include "ik_private.h"

void avatar_default_limits(struct arm_limits *out)
{
	arm_default_limits(out);
	out->lo[1] = SC_C(-2.9670597283903604); /* -170 degrees: an arm over the head, the shoulder blade turned */
	/* J7 turns the hand about its x axis, across the palm: deviation, -30..30 degrees */
	out->lo[6] = SC_C(-0.5235987755982988);
	out->hi[6] = SC_C(0.5235987755982988);
	/* J8 about its z axis, the thumb's: flexion (+) and extension (-), -80..80 degrees */
	out->lo[7] = SC_C(-1.3962634015954636);
	out->hi[7] = SC_C(1.3962634015954636);
}

void avatar_init(struct avatar *av, const struct arm_dims *dims, const struct vec3 *head_offset,
		 const struct arm_limits *lim)
{
	av->body.dims = *dims;
	av->body.head_offset = *head_offset;
	av->body.model = AVATAR_MODEL_DEFAULT;
	av->body.rest_pronation = SC_C(-0.5235987755982988); /* -30 degrees: cos and sin below exactly */
	av->rest6_c = SC_C(0.8660254037844387);
	av->rest6_s = SC_C(-0.5);
	if (lim)
		av->body.lim = *lim;
	else
		avatar_default_limits(&av->body.lim);
	arm_init(&av->arm[ARM_RIGHT], ARM_RIGHT, dims, &av->body.lim);
	arm_init(&av->arm[ARM_LEFT], ARM_LEFT, dims, &av->body.lim);
}

void avatar_set_left_arm(struct avatar *av, sc_t arm, sc_t forearm, sc_t hand)
{
	struct arm_dims d = { av->body.dims.shoulder, arm, forearm, hand };

	arm_init(&av->arm[ARM_LEFT], ARM_LEFT, &d, &av->body.lim);
}

void avatar_set_rest_pronation(struct avatar *av, sc_t j6)
{
	av->body.rest_pronation = j6;
	sc_sincos(j6, &av->rest6_s, &av->rest6_c);
}

sc_t avatar_head_yaw(const struct quat *head)
{
	/* the twist of q about z is (w, 0, 0, z) normalised: yaw = 2 atan2(z, w) */
	sc_t w = head->w, z = head->z;

	if (sc_abs(w) + sc_abs(z) < SC_C(1e-6))
		return 0;
	if (w < 0) {
		w = -w;
		z = -z;
	}
	return 2 * sc_atan2(z, w);
}

/*
 * The heading of the line from the left to the right hand, as a unit
 * vector (*hx, *hy), and how far to trust it as the chest's: hands at
 * least 30 cm apart sideways count fully from 50 cm on, and a line more
 * than 60 degrees off the head's heading (cy, sy) is not the chest's (one
 * arm reaching out, the hands crossed). Returns the weight in [0, 1].
 */
#define COS45 SC_C(0.7071067811865476)
#define COS60 SC_C(0.5)

static sc_t hands_heading(const struct dq *lhand, const struct dq *rhand, sc_t cy, sc_t sy, sc_t *hx, sc_t *hy)
{
	struct vec3 l, r;
	sc_t dx, dy, sep, k, wgt;

	if (!lhand || !rhand || !dq_is_finite(lhand) || !dq_is_finite(rhand))
		return 0;
	dq_translation(lhand, &l);
	dq_translation(rhand, &r);
	dx = r.x - l.x;
	dy = r.y - l.y;
	sep = sc_sqrt(sc_mul(dx, dx) + sc_mul(dy, dy));
	if (!(sep > SC_C(0.3)))
		return 0;
	k = sc_div(SC_C(1), sep);
	*hx = sc_mul(dx, k);
	*hy = sc_mul(dy, k);
	wgt = sc_min(sc_div(sep - SC_C(0.3), SC_C(0.2)), SC_C(1));
	/*
	 * fading out from 45 to 60 degrees off the head's heading (linearly in
	 * the cosine: no angle computed): no jump of the chest when it crosses
	 */
	return sc_mul(wgt,
		      sc_clamp(sc_div(sc_mul(*hx, cy) + sc_mul(*hy, sy) - COS60, COS45 - COS60), SC_C(0), SC_C(1)));
}

/*
 * AVATAR_NECK: the head sensor's offset from the chest, bent by half of the
 * head's tilt. A nod or a bow is shared between the joint of the head on the
 * neck and the neck itself; the neck's share turns the offset about the
 * chest origin. u is the head's up axis in the chest frame (yawed, upright),
 * v the unit vector halfway between the chest's up axis ez and u, and the
 * offset turns by the least rotation from ez to v, half the angle from ez to
 * u: R x = x + c x x + c x (c x x) / (1 + v.z), c = ez x v (no angle
 * computed; 1 + v.z >= 1 while the head is less than upside down). A head
 * upside down (u = -ez) has no halfway vector: the offset stays unbent.
 */
static void neck_offset(const struct vec3 *off, const struct quat *yaw, const struct quat *head, struct vec3 *out)
{
	const struct vec3 ez = { 0, 0, SC_C(1) };
	struct quat yc, rel;
	struct vec3 u, v, c, cx, ccx;
	sc_t n, k;

	quat_conj(yaw, &yc);
	quat_mul(&yc, head, &rel);
	quat_rotate(&rel, &ez, &u);
	v = (struct vec3){ u.x, u.y, u.z + SC_C(1) };
	n = v3_norm(&v);
	if (!(n > SC_C(1e-3))) {
		*out = *off;
		return;
	}
	k = sc_div(SC_C(1), n);
	v = (struct vec3){ sc_mul(v.x, k), sc_mul(v.y, k), sc_mul(v.z, k) };
	c = (struct vec3){ -v.y, v.x, 0 };
	v3_cross(&c, off, &cx);
	v3_cross(&c, &cx, &ccx);
	k = sc_div(SC_C(1), SC_C(1) + v.z);
	*out = (struct vec3){ off->x + cx.x + sc_mul(ccx.x, k), off->y + cx.y + sc_mul(ccx.y, k),
			      off->z + cx.z + sc_mul(ccx.z, k) };
}

/*
 * AVATAR_YAW_REACH: a hand held forward turns the trunk toward it (the
 * shoulder goes with the arm: a right hand forward turns the chest to the
 * left). Each hand's forward reach from the chain origin the head places,
 * in arm lengths (A + F + H, at most 2), counts as much as the hand is
 * raised: not at all hanging (a length below the shoulders), fully from
 * the shoulders' height up. The chest turns by REACH_TURN times the right
 * hand's share minus the left's, about world z: 36.4 degrees per arm length,
 * fitted on CMU motion alone (docs/FIDELITY.md). (cy, sy) is the head's
 * heading; returns the turn in radians.
 */
#define REACH_TURN SC_C(0.6353)

static sc_t reach_share(const struct dq *hand, const struct arm_dims *d, const struct vec3 *hp, const struct vec3 *ho,
			sc_t cy, sc_t sy)
{
	struct vec3 p;
	sc_t len = d->arm + d->forearm + d->hand, fwd, up;

	if (!hand || !dq_is_finite(hand) || !(len > SC_C(0.05)))
		return 0;
	dq_translation(hand, &p);
	/* the hand from the chain origin, head - Rz(yaw) head_offset, along the yawed y and z */
	fwd = sc_mul(p.x - hp->x, -sy) + sc_mul(p.y - hp->y, cy) + ho->y;
	if (!(fwd > 0))
		return 0;
	/* bounded before the divisions: a sensor far off saturates nothing in fixed point */
	fwd = sc_min(fwd, 2 * len);
	up = sc_clamp(p.z - hp->z + ho->z, -len, SC_C(0));
	return sc_mul(sc_div(fwd, len), SC_C(1) + sc_div(up, len));
}

/*
 * The half-angle rotation about z of the heading (cy, sy) = (cos y, sin y),
 * a unit vector: (1 + cy, sy) over its norm while |y| <= 90 degrees, beyond
 * that (|sy|, 1 - cy) with sy's sign on the second (the same direction),
 * each norm at least sqrt 2. The first form alone leaves 1 + cy without
 * bits near y = 180 degrees in fixed point: a rotation far from unit, 1 / n
 * saturated, the chest a metre off (test_fixq, the clip turned around).
 */
static void heading_half(sc_t cy, sc_t sy, sc_t *w, sc_t *z)
{
	sc_t k;

	if (cy >= 0) {
		k = sc_div(SC_C(1), sc_sqrt(2 * (SC_C(1) + cy)));
		*w = sc_mul(SC_C(1) + cy, k);
		*z = sc_mul(sy, k);
	} else {
		k = sc_div(SC_C(1), sc_sqrt(2 * (SC_C(1) - cy)));
		*w = sc_mul(sc_abs(sy), k);
		*z = sc_mul(sy < 0 ? cy - SC_C(1) : SC_C(1) - cy, k);
	}
}

/*
 * The chest's heading without an angle until the last: the head's twist
 * about z, (w, z) normalised, is the half-angle rotation itself; the hands'
 * heading is averaged in as unit vectors, and the mean's half-angle
 * rotation is (1 + cos, sin) normalised. One atan2, for *yaw.
 */
/*
 * AVATAR_BOW_HEAD: a head pitched forward by more than the neck takes
 * (30 degrees, looking down at the hands) is a bow at the waist: the trunk
 * pitches by the rest (at most 60 degrees) about the head sensor. The
 * head's pitch is its forward axis's fall below the yawed chest's horizon:
 * sin p = -f.z, cos p = |f.xy| (no angle computed; a head pitched past the
 * vertical counts as pitched less). Writes the chest's rotation r Rx(-q);
 * false if the head pitches less.
 */
#define HEAD_BOW_COS SC_C(0.8660254037844387) /* the neck's share: 30 degrees */
#define HEAD_BOW_SIN SC_C(0.5)

static bool head_bow(const struct quat *r, const struct quat *head, struct quat *rb)
{
	const struct vec3 ey = { 0, SC_C(1), 0 };
	struct quat rc, rel, px;
	struct vec3 f;
	sc_t sp, cp, sq, cq, ch;

	quat_conj(r, &rc);
	quat_mul(&rc, head, &rel);
	quat_rotate(&rel, &ey, &f);
	sp = -f.z;
	cp = sc_sqrt(sc_mul(f.x, f.x) + sc_mul(f.y, f.y));
	sq = sc_mul(sp, HEAD_BOW_COS) - sc_mul(cp, HEAD_BOW_SIN);
	if (!(sq > 0))
		return false;
	cq = sc_mul(cp, HEAD_BOW_COS) + sc_mul(sp, HEAD_BOW_SIN);
	/* the half angle: cos = sqrt((1 + cos q) / 2), sin = sin q / (2 cos) */
	ch = sc_sqrt(sc_mul(SC_C(0.5), SC_C(1) + cq));
	px = (struct quat){ ch, -sc_div(sq, 2 * ch), 0, 0 };
	quat_mul(r, &px, rb);
	return true;
}

static bool chest_place(const struct avatar *av, unsigned model, const struct dq *head, const struct dq *lhand,
			const struct dq *rhand, struct dq *chest, sc_t *yaw)
{
	struct quat r, hr, rb;
	struct vec3 hp, off, o, bent;
	sc_t w, z, n, cy, sy, hx = 0, hy = 0, wt;
	bool turned = false;

	if (!dq_is_finite(head) || !quat_normalize(&head->r, &r)) {
		dq_identity(chest);
		*yaw = 0;
		return false;
	}
	hr = r;
	w = r.w;
	z = r.z;
	if (w < 0) {
		w = -w;
		z = -z;
	}
	if (sc_abs(w) + sc_abs(z) < SC_C(1e-6)) {
		w = SC_C(1); /* upside down: no yaw */
		z = 0;
	} else {
		n = sc_div(SC_C(1), sc_sqrt(sc_mul(w, w) + sc_mul(z, z)));
		w = sc_mul(w, n);
		z = sc_mul(z, n);
	}
	cy = sc_mul(w, w) - sc_mul(z, z);
	sy = 2 * sc_mul(w, z);
	dq_translation(head, &hp);
	if (model & AVATAR_YAW_REACH) {
		sc_t a = sc_mul(
			     REACH_TURN,
			     reach_share(rhand, &av->arm[ARM_RIGHT].dims, &hp, &av->body.head_offset, cy, sy) -
				     reach_share(lhand, &av->arm[ARM_LEFT].dims, &hp, &av->body.head_offset, cy, sy)),
		     s, c, x;

		if (a != 0) {
			sc_sincos(a, &s, &c);
			x = sc_mul(cy, c) - sc_mul(sy, s);
			sy = sc_mul(sy, c) + sc_mul(cy, s);
			cy = x;
			turned = true;
		}
	}
	if ((model & AVATAR_YAW_HANDS) && (wt = hands_heading(lhand, rhand, cy, sy, &hx, &hy)) > 0) {
		/* the weighted circular mean of the two headings */
		sc_t mx = cy + sc_mul(wt, hx), my = sy + sc_mul(wt, hy), k;

		n = sc_sqrt(sc_mul(mx, mx) + sc_mul(my, my));
		if (n > SC_C(1e-6)) {
			k = sc_div(SC_C(1), n);
			cy = sc_mul(mx, k);
			sy = sc_mul(my, k);
			turned = true;
		}
	}
	if (turned)
		heading_half(cy, sy, &w, &z);
	*yaw = 2 * sc_atan2(z, w);
	r = (struct quat){ w, 0, 0, z };
	if ((model & AVATAR_BOW_HEAD) && head_bow(&r, &hr, &rb)) {
		/* the trunk bowed about the head sensor, the neck as upright */
		quat_rotate(&rb, &av->body.head_offset, &off);
		r = rb;
	} else if (model & AVATAR_NECK) {
		neck_offset(&av->body.head_offset, &r, &hr, &bent);
		quat_rotate(&r, &bent, &off);
	} else {
		quat_rotate(&r, &av->body.head_offset, &off);
	}
	o = (struct vec3){ hp.x - off.x, hp.y - off.y, hp.z - off.z };
	dq_from_rt(&r, &o, chest);
	return true;
}

bool avatar_chest_hands(const struct avatar *av, const struct dq *head, const struct dq *lhand, const struct dq *rhand,
			struct dq *chest, sc_t *yaw)
{
	return chest_place(av, av->body.model, head, lhand, rhand, chest, yaw);
}

bool avatar_chest(const struct avatar *av, const struct dq *head, struct dq *chest, sc_t *yaw)
{
	return avatar_chest_hands(av, head, NULL, NULL, chest, yaw);
}

void avatar_arm_target(const struct dq *chest, const struct dq *hand, struct ik_target *t)
{
	struct dq ci, local;
	struct vec3 p;

	if (!dq_is_finite(hand)) {
		struct vec3 nanp = { 0, 0, 0 };
		struct quat zero = { 0, 0, 0, 0 };

		ik_target_set(t, &nanp, &zero); /* marked invalid */
		return;
	}
	dq_conj(chest, &ci);
	dq_mul(&ci, hand, &local);
	dq_translation(&local, &p);
	ik_target_set(t, &p, &local.r);
}

/* ---- the elbow the hand points at ------------------------------------------------------ */

/*
 * v scaled to length 1 (unless it is nearly zero); its length before. Short
 * vectors are divided component by component: their reciprocal length would
 * saturate in fixed point (1/n > 32 in Q5.26 below n = 1/32, the bend plane
 * of an arm straight to within 2 degrees), while each component over n is at
 * most 1.
 */
static sc_t v3_unit(struct vec3 *v)
{
	sc_t n = v3_norm(v);

	if (n > SC_C(0.0625)) {
		sc_t k = sc_div(SC_C(1), n);

		v->x = sc_mul(v->x, k);
		v->y = sc_mul(v->y, k);
		v->z = sc_mul(v->z, k);
	} else if (n > SC_EPS) {
		v->x = sc_div(v->x, n);
		v->y = sc_div(v->y, n);
		v->z = sc_div(v->z, n);
	}
	return n;
}

/*
 * One target of one arm, seen from one J1, in the right arm's frame (a left
 * arm's target mirrored: the angles are the same): the wrist centre, the
 * shoulder, and the circle the elbow can lie on about the shoulder-wrist
 * line. The elbow's place on it is an angle phi from d0 (the way down, or
 * back when the line is vertical) toward d1 = ax x d0.
 */
struct arm_goal {
	sc_t R[3][3];	    /* target orientation */
	struct vec3 w, s;   /* wrist centre, shoulder */
	struct vec3 ax;	    /* unit, shoulder -> wrist */
	struct vec3 d0, d1; /* unit, across ax */
	sc_t x, r;	    /* the circle: centre s + x ax, radius r */
	sc_t q1, s1, c1;
	/*
	 * the upper arm (x ax + r v) / A = ua ax + uv v and the forearm
	 * (w - elbow) / F = fa ax + fv v for the elbow at v on the circle, and
	 * J5's cosine and sine (the forearm on the upper arm's frame), none of
	 * which depends on the swivel; c5 = 0 when the lengths do not allow them
	 */
	sc_t ua, uv, fa, fv, c5, s5;
	bool in_reach; /* false: the wrist is beyond A + F, the circle is the straight arm's */
};

static bool goal_init(const struct arm *a, const struct ik_target *t, sc_t q1, struct arm_goal *g)
{
	const struct arm_dims *dm = &a->dims;
	struct vec3 p = t->p, hy;
	sc_t L, r2, k;
	int i, j;

	/* the target's matrix form; a left arm's mirrored (x -> -x: M R M flips row 0 and column 0) */
	for (i = 0; i < 3; i++)
		for (j = 0; j < 3; j++)
			g->R[i][j] = t->m[i][j];
	if (a->side == ARM_LEFT) {
		p.x = -p.x;
		g->R[0][1] = -g->R[0][1];
		g->R[0][2] = -g->R[0][2];
		g->R[1][0] = -g->R[1][0];
		g->R[2][0] = -g->R[2][0];
	}
	hy = (struct vec3){ g->R[0][1], g->R[1][1], g->R[2][1] };
	g->w = p;
	ik_add_scaled(&g->w, -dm->hand, &hy, &g->w);
	g->q1 = sc_clamp(q1, a->lim.lo[0], a->lim.hi[0]);
	if (g->q1 == 0) {
		g->s1 = 0;
		g->c1 = SC_C(1);
	} else {
		sc_sincos(g->q1, &g->s1, &g->c1);
	}
	g->s = (struct vec3){ sc_mul(dm->shoulder, g->c1), sc_mul(dm->shoulder, g->s1), 0 };
	g->ax = (struct vec3){ g->w.x - g->s.x, g->w.y - g->s.y, g->w.z - g->s.z };
	L = v3_unit(&g->ax);
	if (!sc_isfinite(L) || !(L > sc_abs(dm->arm - dm->forearm) + SC_C(1e-4)))
		return false;
	g->in_reach = L <= dm->arm + dm->forearm;
	if (!g->in_reach)
		L = dm->arm + dm->forearm; /* the arm straight toward the wrist */
	g->x = sc_div(sc_mul(dm->arm, dm->arm) - sc_mul(dm->forearm, dm->forearm) + sc_mul(L, L), 2 * L);
	r2 = sc_mul(dm->arm, dm->arm) - sc_mul(g->x, g->x);
	g->r = r2 > 0 ? sc_sqrt(r2) : SC_C(0);
	g->c5 = g->s5 = 0;
	if (dm->arm > 0 && dm->forearm > 0) {
		sc_t ia = a->inv_arm, iF = a->inv_forearm;

		g->ua = sc_mul(g->x, ia);
		g->uv = sc_mul(g->r, ia);
		g->fa = sc_mul(L - g->x, iF);
		g->fv = -sc_mul(g->r, iF);
		/* f . yu and f . zu for yu = uv ax - ua v, zu = -(ua ax + uv v) (goal_posture_cs) */
		g->c5 = sc_mul(g->fa, g->uv) - sc_mul(g->fv, g->ua);
		g->s5 = -(sc_mul(g->fa, g->ua) + sc_mul(g->fv, g->uv));
	}
	g->d0 = (struct vec3){ 0, 0, SC_C(-1) };
	k = v3_dot(&g->d0, &g->ax);
	ik_add_scaled(&g->d0, -k, &g->ax, &g->d0);
	if (v3_unit(&g->d0) < SC_C(0.1)) {
		g->d0 = (struct vec3){ 0, SC_C(-1), 0 };
		k = v3_dot(&g->d0, &g->ax);
		ik_add_scaled(&g->d0, -k, &g->ax, &g->d0);
		v3_unit(&g->d0);
	}
	v3_cross(&g->ax, &g->d0, &g->d1);
	return true;
}

/*
 * The wrist's cost of a swivel. With the elbow at swivel phi the forearm
 * frame (y along the forearm, x the elbow's axis) is fixed, and the hand's
 * orientation relative to it is J6..J8: pronation about the forearm (J6),
 * then about the hand's x axis, across the palm (J7: radial or ulnar
 * deviation, a narrow range), then about its z axis, the thumb's
 * (J8: flexion or extension, a wide one). A real wrist bends far in flexion
 * and extension (waving, pointing with the hand up) and little sideways,
 * and the forearm rests half pronated. The cost
 *
 *   W6 (1 - cos(J6 - MU6) cos J7) + W7 sin^2 J7 + W8 (1 - cos J7 cos J8)
 *
 * is, for small angles, (J6 - MU6)^2 / SIG6^2 + J7^2 / SIG7^2 + J8^2 / SIG8^2
 * (the weights below), and grows more slowly than that for large ones (a
 * hand frame that is not the hand's does not drag the elbow all the way).
 * Every term is a dot product of the hand's axes with vectors that are
 * linear in (cos phi, sin phi):
 *
 *   forearm f = (K ax - r v) / F, v = cos phi d0 + sin phi d1 (K = L - x)
 *   elbow axis x5 = sin phi d0 - cos phi d1,  x5 x f = -(K v + r ax) / F
 *   sin J7 = -f.Z, cos J7 cos J8 = f.Y,
 *   cos J7 (cos J6, sin J6) = ((x5 x f).Z, x5.Z)
 *
 * so the cost is k0 + k1 cos phi + k2 sin phi + k3 cos 2phi + k4 sin 2phi,
 * without one angle computed. MU6 is the body's rest pronation
 * (avatar_set_rest_pronation, -30 degrees unless set): the forearm at rest
 * a little pronated.
 */
#define W6 SC_C(3.2422778766) /* 2 / SIG6^2, SIG6 = 45 degrees about MU6 */
#define W7 SC_C(2.7194094061) /* 1 / SIG7^2 - W6 / 2 - W8 / 2, SIG7 = 25 degrees */
#define W8 SC_C(1.8237813055) /* 2 / SIG8^2, SIG8 = 60 degrees */

/* what the swivel is chosen with besides the target: MU6's cosine and sine, AVATAR_ARM_TWIST */
struct wrist_prior {
	sc_t c6, s6;
	bool twist;
};

struct trig2 {
	sc_t k[5]; /* k0 + k1 cos + k2 sin + k3 cos 2 + k4 sin 2 */
};

/* c += w (a0 + a1 cos + a2 sin)^2 */
static void trig2_add_sq(struct trig2 *c, sc_t w, sc_t a0, sc_t a1, sc_t a2)
{
	sc_t h1 = sc_mul(SC_C(0.5), sc_mul(a1, a1)), h2 = sc_mul(SC_C(0.5), sc_mul(a2, a2));

	c->k[0] += sc_mul(w, sc_mul(a0, a0) + h1 + h2);
	c->k[1] += sc_mul(w, 2 * sc_mul(a0, a1));
	c->k[2] += sc_mul(w, 2 * sc_mul(a0, a2));
	c->k[3] += sc_mul(w, h1 - h2);
	c->k[4] += sc_mul(w, sc_mul(a1, a2));
}

/* c += w (1 - cos(phi - phi0)), phi0 given by its cosine and sine */
static void trig2_add_pull(struct trig2 *c, sc_t w, sc_t c0, sc_t s0)
{
	c->k[0] += w;
	c->k[1] -= sc_mul(w, c0);
	c->k[2] -= sc_mul(w, s0);
}

static void goal_wrist_cost(const struct arm *a, const struct wrist_prior *wp, const struct arm_goal *g,
			    struct trig2 *c)
{
	const sc_t F = a->dims.forearm, r = g->r;
	struct vec3 Y = { g->R[0][1], g->R[1][1], g->R[2][1] }, Z = { g->R[0][2], g->R[1][2], g->R[2][2] };
	sc_t K = sc_sqrt(sc_max(sc_mul(F, F) - sc_mul(r, r), SC_C(0)));
	sc_t iF = sc_div(SC_C(1), F), Ki = sc_mul(K, iF), ri = sc_mul(r, iF);
	sc_t aZ = v3_dot(&g->ax, &Z), d0Z = v3_dot(&g->d0, &Z), d1Z = v3_dot(&g->d1, &Z);
	/* f.Z = z0 + z1 cos + z2 sin, f.Y = y0 + y1 cos + y2 sin, cos J7 cos(J6 - MU6) = p0 + p1 cos + p2 sin */
	sc_t z0 = sc_mul(Ki, aZ), z1 = -sc_mul(ri, d0Z), z2 = -sc_mul(ri, d1Z);
	sc_t y0 = sc_mul(Ki, v3_dot(&g->ax, &Y)), y1 = -sc_mul(ri, v3_dot(&g->d0, &Y));
	sc_t y2 = -sc_mul(ri, v3_dot(&g->d1, &Y));
	sc_t p0 = -sc_mul(wp->c6, sc_mul(ri, aZ));
	sc_t p1 = -sc_mul(wp->c6, sc_mul(Ki, d0Z)) - sc_mul(wp->s6, d1Z);
	sc_t p2 = -sc_mul(wp->c6, sc_mul(Ki, d1Z)) + sc_mul(wp->s6, d0Z);

	c->k[0] = sc_mul(W6, SC_C(1) - p0) + sc_mul(W8, SC_C(1) - y0);
	c->k[1] = -sc_mul(W6, p1) - sc_mul(W8, y1);
	c->k[2] = -sc_mul(W6, p2) - sc_mul(W8, y2);
	c->k[3] = c->k[4] = 0;
	trig2_add_sq(c, W7, z0, z1, z2);
}

#define STEP15 SC_C(0.2617993877991494)
#define STEP30 SC_C(0.5235987755982988)
#define SWIVEL_STEPS 12

/* cos and sin of k * 30 degrees, k = 0..5 (k + 6: both negated), and of 2 k * 30 degrees */
static const sc_t cos30k[6] = { SC_C(1),    SC_C(0.8660254037844387), SC_C(0.5), SC_C(0),
				SC_C(-0.5), SC_C(-0.8660254037844387) };
static const sc_t sin30k[6] = { SC_C(0),  SC_C(0.5), SC_C(0.8660254037844387), SC_C(1), SC_C(0.8660254037844387),
				SC_C(0.5) };
static const sc_t cos60k[6] = { SC_C(1), SC_C(0.5), SC_C(-0.5), SC_C(-1), SC_C(-0.5), SC_C(0.5) };
static const sc_t sin60k[6] = { SC_C(0), SC_C(0.8660254037844387),  SC_C(0.8660254037844387),
				SC_C(0), SC_C(-0.8660254037844387), SC_C(-0.8660254037844387) };

/* (c, s) turned by a (|a| <= 15 degrees; Taylor to a^5, off by under 1e-6) */
static void rot_small(sc_t a, sc_t *c, sc_t *s)
{
	sc_t a2 = sc_mul(a, a);
	sc_t ca = SC_C(1) - sc_mul(a2, SC_C(0.5) - sc_mul(a2, SC_C(1.0 / 24)));
	sc_t sa = sc_mul(a, SC_C(1) - sc_mul(a2, SC_C(1.0 / 6) - sc_mul(a2, SC_C(1.0 / 120))));
	sc_t nc = sc_mul(*c, ca) - sc_mul(*s, sa);

	*s = sc_mul(*s, ca) + sc_mul(*c, sa);
	*c = nc;
}

/*
 * The least of a trig2 over the circle: samples 30 degrees apart (every
 * cosine and sine of phi and 2 phi a constant; phi + 180 degrees shares
 * the 2 phi terms), a parabola through the lowest and its neighbours, then
 * one Newton step on the polynomial itself. Writes the angle and its
 * cosine and sine (no sine or cosine computed: the sample's turned by the
 * small steps); returns the least value.
 */
static sc_t trig2_min(const struct trig2 *c, sc_t *phi, sc_t *cpo, sc_t *spo)
{
	sc_t v[SWIVEL_STEPS], vm, vp, den, d, sp, cp, c2, s2, d1, d2, h;
	int k, kb = 0;

	for (k = 0; k < 6; k++) {
		sc_t e = c->k[0] + sc_mul(c->k[3], cos60k[k]) + sc_mul(c->k[4], sin60k[k]);
		sc_t o = sc_mul(c->k[1], cos30k[k]) + sc_mul(c->k[2], sin30k[k]);

		v[k] = e + o;
		v[k + 6] = e - o;
	}
	for (k = 1; k < SWIVEL_STEPS; k++)
		if (v[k] < v[kb])
			kb = k;
	vm = v[(kb + SWIVEL_STEPS - 1) % SWIVEL_STEPS];
	vp = v[(kb + 1) % SWIVEL_STEPS];
	den = vm - 2 * v[kb] + vp;
	d = den > SC_EPS ? sc_clamp(sc_div(vm - vp, 2 * den), SC_C(-0.5), SC_C(0.5)) : SC_C(0);
	cp = kb < 6 ? cos30k[kb] : -cos30k[kb - 6];
	sp = kb < 6 ? sin30k[kb] : -sin30k[kb - 6];
	rot_small(sc_mul(d, STEP30), &cp, &sp);
	c2 = sc_mul(cp, cp) - sc_mul(sp, sp);
	s2 = 2 * sc_mul(sp, cp);
	/* the first and second derivatives in phi */
	d1 = sc_mul(c->k[2], cp) - sc_mul(c->k[1], sp) + 2 * (sc_mul(c->k[4], c2) - sc_mul(c->k[3], s2));
	d2 = -(sc_mul(c->k[1], cp) + sc_mul(c->k[2], sp)) - 4 * (sc_mul(c->k[3], c2) + sc_mul(c->k[4], s2));
	h = d2 > SC_EPS ? sc_clamp(-sc_div(d1, d2), -STEP15, STEP15) : SC_C(0);
	*phi = sc_wrap_pi(sc_mul(sc_from_int(kb) + d, STEP30) + h);
	d2 = c->k[0] + sc_mul(c->k[1], cp) + sc_mul(c->k[2], sp) + sc_mul(c->k[3], c2) + sc_mul(c->k[4], s2) +
	     sc_mul(sc_mul(SC_C(0.5), h), d1);
	rot_small(h, &cp, &sp);
	*cpo = cp;
	*spo = sp;
	return d2;
}

/*
 * The posture with the elbow at swivel phi: J2..J5 from the elbow, J6..J8
 * what the target's orientation then asks of the wrist (of the two angle
 * triples the one inside the limits; nothing clamped). Reaches the wrist
 * centre exactly (when in reach) and the orientation exactly. Writes the
 * limit violations of J2..J5 (arm) and J6..J8 (wrist), radians; false if
 * something is not finite.
 */
static bool goal_posture_cs(const struct arm *a, const struct arm_goal *g, sc_t cp, sc_t sp, sc_t q[ARM_DOF],
			    sc_t *v_arm, sc_t *v_wrist)
{
	const struct arm_limits *lim = &a->lim;
	struct vec3 zu, yu, xu, v;
	sc_t Ru[3][3], M[3][3], Rf[3][3], N[3][3], k, s5 = g->s5, c5 = g->c5, va;
	bool in_plane = true;
	int i, j;

	/*
	 * (cp, sp) to unit length (a Newton step for 1 / |(cp, sp)|: goal_swivel's
	 * come from Taylor turns, 1e-6 off, which would leave the posture that
	 * far from exact), else the frame below is not orthonormal
	 */
	k = SC_C(1.5) - sc_mul(SC_C(0.5), sc_mul(cp, cp) + sc_mul(sp, sp));
	cp = sc_mul(cp, k);
	sp = sc_mul(sp, k);
	v = (struct vec3){ sc_mul(cp, g->d0.x) + sc_mul(sp, g->d1.x), sc_mul(cp, g->d0.y) + sc_mul(sp, g->d1.y),
			   sc_mul(cp, g->d0.z) + sc_mul(sp, g->d1.z) };
	if (c5 >= SC_C(1e-4)) {
		/*
		 * The upper arm's frame: -z along the upper arm, y across it toward
		 * the forearm (the bend plane is that of ax and v), x = y x z the
		 * elbow's axis, -(ax x v) = sin phi d0 - cos phi d1: no root, no
		 * division (ax, d0, d1 are orthonormal and x^2 + r^2 = A^2)
		 */
		zu = (struct vec3){ -(sc_mul(g->ua, g->ax.x) + sc_mul(g->uv, v.x)),
				    -(sc_mul(g->ua, g->ax.y) + sc_mul(g->uv, v.y)),
				    -(sc_mul(g->ua, g->ax.z) + sc_mul(g->uv, v.z)) };
		yu = (struct vec3){ sc_mul(g->uv, g->ax.x) - sc_mul(g->ua, v.x),
				    sc_mul(g->uv, g->ax.y) - sc_mul(g->ua, v.y),
				    sc_mul(g->uv, g->ax.z) - sc_mul(g->ua, v.z) };
		xu = (struct vec3){ sc_mul(sp, g->d0.x) - sc_mul(cp, g->d1.x),
				    sc_mul(sp, g->d0.y) - sc_mul(cp, g->d1.y),
				    sc_mul(sp, g->d0.z) - sc_mul(cp, g->d1.z) };
	} else {
		/* the arm (nearly) straight: the bend plane from the elbow's side */
		struct vec3 e = g->s, u, f;

		ik_add_scaled(&e, g->x, &g->ax, &e);
		ik_add_scaled(&e, g->r, &v, &e);
		u = (struct vec3){ e.x - g->s.x, e.y - g->s.y, e.z - g->s.z };
		f = (struct vec3){ g->w.x - e.x, g->w.y - e.y, g->w.z - e.z };
		v3_unit(&u);
		v3_unit(&f);
		zu = (struct vec3){ -u.x, -u.y, -u.z };
		/* the forearm's part across the upper arm; a straight arm bends away from the elbow's side */
		yu = f;
		k = v3_dot(&yu, &zu);
		ik_add_scaled(&yu, -k, &zu, &yu);
		if (v3_unit(&yu) < SC_C(1e-4)) {
			yu = (struct vec3){ -v.x, -v.y, -v.z };
			k = v3_dot(&yu, &zu);
			ik_add_scaled(&yu, -k, &zu, &yu);
			if (v3_unit(&yu) < SC_C(1e-6))
				return false;
			in_plane = false; /* f is (nearly) along zu, not exactly in the plane of yu and zu */
		}
		v3_cross(&yu, &zu, &xu);
		c5 = v3_dot(&f, &yu);
		s5 = v3_dot(&f, &zu);
	}
	q[0] = g->q1;
	q[4] = sc_atan2(s5, c5);
	for (i = 0; i < 3; i++) {
		Ru[i][0] = i == 0 ? xu.x : i == 1 ? xu.y : xu.z;
		Ru[i][1] = i == 0 ? yu.x : i == 1 ? yu.y : yu.z;
		Ru[i][2] = i == 0 ? zu.x : i == 1 ? zu.y : zu.z;
	}
	/* Rz(-q1) Ru = Ry(q2) Rx(q3) Rz(q4) */
	for (i = 0; i < 3; i++) {
		M[0][i] = sc_mul(g->c1, Ru[0][i]) + sc_mul(g->s1, Ru[1][i]);
		M[1][i] = sc_mul(g->c1, Ru[1][i]) - sc_mul(g->s1, Ru[0][i]);
		M[2][i] = Ru[2][i];
	}
	va = ik_euler_yxz((const sc_t(*)[3])M, lim, 1, &q[1]);
	/*
	 * the forearm frame Ru Rx(q5), then Rf^T R = Ry(q6) Rx(q7) Rz(q8); f, a
	 * unit vector in the plane of yu and zu, is (cos q5, sin q5) there
	 */
	if (!in_plane)
		sc_sincos(q[4], &s5, &c5);
	for (i = 0; i < 3; i++) {
		Rf[i][0] = Ru[i][0];
		Rf[i][1] = sc_mul(c5, Ru[i][1]) + sc_mul(s5, Ru[i][2]);
		Rf[i][2] = sc_mul(c5, Ru[i][2]) - sc_mul(s5, Ru[i][1]);
	}
	for (i = 0; i < 3; i++)
		for (j = 0; j < 3; j++)
			N[i][j] = ik_m3_tdot((const sc_t(*)[3])Rf, (const sc_t(*)[3])g->R, i, j);
	/* the violations of J2..J4 and J6..J8 as the angle triples' choice summed them */
	*v_wrist = ik_euler_yxz((const sc_t(*)[3])N, lim, 5, &q[5]);
	*v_arm = va + ik_violation(q[4], lim->lo[4], lim->hi[4]);
	for (i = 0; i < ARM_DOF; i++)
		if (!sc_isfinite(q[i]))
			return false;
	return true;
}

static bool goal_posture(const struct arm *a, const struct arm_goal *g, sc_t phi, sc_t q[ARM_DOF], sc_t *v_arm,
			 sc_t *v_wrist)
{
	sc_t sp, cp;

	sc_sincos(phi, &sp, &cp);
	return goal_posture_cs(a, g, cp, sp, q, v_arm, v_wrist);
}

#define MISFIT_RATE SC_C(0.02) /* of the running mean per frame */
/*
 * Besides the wrist: a pull of the elbow toward its natural place, down and
 * turned 30 degrees out (where people's elbows are when nothing else says),
 * as strong as holding the elbow up is tiring: raising it on its circle
 * lifts the upper arm and forearm by r sin(tilt) (1 - cos phi) (r the
 * circle's radius, tilt the shoulder-wrist line's from the vertical), so
 * the pull is W_GRAVITY r / A sin(tilt) (1 - cos(phi - natural)). A bent
 * arm reaching forward or up then keeps its elbow low, as the motion-capture
 * arms do, where the wrist's cost (with a constant pull) lifted it 10 to 20 cm to spare an
 * extension the real wrist makes (a wave, a pointing hand); a straight arm
 * or a vertical shoulder-wrist line leaves the elbow to the wrist.
 * W_GRAVITY: 4 to 8 do within 0.4 cm of each other on the mean of the 14
 * medians (docs/FIDELITY.md); a constant pull (the circle's size and tilt
 * ignored) strong enough to hold the waving elbows moved other arms'
 * medians up (measured: weights 2 to 4).
 * (A pull toward the previous frame's elbow, tried, changed the clips'
 * medians by under 0.1 cm.)
 */
#define W_GRAVITY SC_C(6)
#define COS_NATURAL SC_C(0.8660254037844387) /* -30 degrees: d1 = ax x d0 points inward for a forward reach */
#define SIN_NATURAL SC_C(-0.5)

/*
 * AVATAR_ARM_TWIST: on a nearly straight arm the swivel and the forearm's
 * pronation are one turn about the shoulder-wrist line, and the wrist's cost
 * alone puts all of it in the upper arm. The upper arm's twist is charged
 * too: a pull of the elbow's axis toward the untwisted one, the hanging
 * arm's (x, the elbow flexing forward) carried by the least rotation from
 * down to the shoulder-wrist line u. That rotation takes x to
 * (1 - uz - ux^2, -ux uy, ux (1 - uz)) / (1 - uz): the numerator is used,
 * so the pull fades as the arm points up, where the untwisted axis is
 * undefined. With the elbow's axis -(ax x v) (goal_posture_cs), the pull
 * (1 - axis . n) is (1 - cos(phi - phi_n)) with (cos, sin) phi_n =
 * (-n.d1, n.d0). Its weight is W_TWIST on a straight arm, falling to 0 as
 * the circle's radius r reaches K_TWIST of the upper arm, where the elbow's
 * place itself says the swivel. W_TWIST and K_TWIST were chosen on the CMU
 * clips alone (docs/FIDELITY.md).
 */
#define W_TWIST SC_C(6)
#define INV_K_TWIST SC_C(1.4285714285714286) /* K_TWIST = 0.7 */

static void twist_pull(const struct arm_goal *g, struct trig2 *c)
{
	const struct vec3 *u = &g->ax;
	sc_t w = SC_C(1) - sc_mul(g->uv, INV_K_TWIST), dz = SC_C(1) - u->z;
	struct vec3 n = { dz - sc_mul(u->x, u->x), -sc_mul(u->x, u->y), sc_mul(u->x, dz) };

	if (w > 0)
		trig2_add_pull(c, sc_mul(W_TWIST, w), -v3_dot(&n, &g->d1), v3_dot(&n, &g->d0));
}

/*
 * The least cost swivel of a goal: the wrist's and the natural place's
 * (and the upper arm's twist, with twist). Returns the least cost. (The cost
 * has a single local least in every frame of the motion-capture clips: an
 * elbow that leaves the truth at a wave's extremes is that least drifting,
 * not a jump between two; docs/FIDELITY.md.)
 */
static sc_t goal_swivel(const struct arm *a, const struct wrist_prior *wp, const struct arm_goal *g, sc_t *phi,
			sc_t *cp, sc_t *sp)
{
	struct trig2 c;
	/* sin(tilt): the shoulder-wrist line's horizontal part (the chest frame is upright) */
	sc_t tilt = sc_sqrt(sc_mul(g->ax.x, g->ax.x) + sc_mul(g->ax.y, g->ax.y));

	goal_wrist_cost(a, wp, g, &c);
	trig2_add_pull(&c, sc_mul(W_GRAVITY, sc_mul(tilt, sc_div(g->r, a->dims.arm))), COS_NATURAL, SIN_NATURAL);
	if (wp->twist)
		twist_pull(g, &c);
	return trig2_min(&c, phi, cp, sp);
}

/*
 * The posture to start the IK from: the elbow at the swivel of the least
 * cost (goal_swivel), J1 at 0; J6..J8 what the orientation then asks.
 * Updates the running mean of the least cost. false when the wrist centre
 * is too close to the shoulder (the solver then starts from the previous
 * posture).
 */
static bool hand_elbow_posture(const struct arm *a, const struct wrist_prior *wp, const struct ik_target *t, bool first,
			       sc_t prev_misfit, sc_t *misfit, sc_t pref[ARM_DOF])
{
	struct arm_goal g;
	sc_t va, vw, m, phi, cp, sp;

	/* J1 at mid-range: what the shoulders do beyond the chest's yaw is the solver's to find */
	if (!goal_init(a, t, SC_C(0), &g))
		return false;
	m = goal_swivel(a, wp, &g, &phi, &cp, &sp);
	if (!first && sc_isfinite(prev_misfit))
		m = prev_misfit + sc_mul(MISFIT_RATE, m - prev_misfit);
	*misfit = m;
	return goal_posture_cs(a, &g, cp, sp, pref, &va, &vw);
}

/* ---- the hand to its sensor first ---------------------------------------------------------- */

/*
 * A posture that puts the hand on its target's position with J1..J5 inside
 * their limits and the wrist as near the target's orientation as its limits
 * allow. Tries J1 at q1s[], the swivel in 15 degree steps from the hand's,
 * then narrows the best step down. Returns false if no J1 and swivel keep
 * J2..J5 inside their limits.
 */
static bool reach_first(const struct arm *a, const struct wrist_prior *wp, const struct ik_target *t, const sc_t *q1s,
			int n1, sc_t q[ARM_DOF])
{
	sc_t best_vw = SC_C(1e9), best_phi = 0, best_q1 = 0, cand[ARM_DOF], va, vw;
	bool found = false;
	int i, k;

	for (i = 0; i < n1 && !(found && best_vw == 0); i++) {
		struct arm_goal g;
		sc_t phi0, c0, s0;

		if (!goal_init(a, t, q1s[i], &g) || !g.in_reach)
			continue;
		goal_swivel(a, wp, &g, &phi0, &c0, &s0);
		for (k = 0; k < 24; k++) {
			/* 0, +1, -1, +2, ... steps from the hand's swivel */
			sc_t phi = phi0 + sc_mul(SC_C((k + 1) / 2 * (k & 1 ? 1 : -1)), STEP15);

			if (!goal_posture(a, &g, phi, cand, &va, &vw) || va > 0 || !(vw < best_vw))
				continue;
			best_vw = vw;
			best_phi = phi;
			best_q1 = g.q1;
			found = true;
			ik_q_copy(q, cand);
		}
	}
	if (!found)
		return false;
	if (best_vw > 0) {
		/* narrow down around the best step, where the violation is smooth in phi */
		struct arm_goal g;
		sc_t lo = best_phi - STEP15, hi = best_phi + STEP15;

		goal_init(a, t, best_q1, &g);
		for (k = 0; k < 24; k++) {
			sc_t m1 = lo + sc_div(hi - lo, SC_C(3)), m2 = hi - sc_div(hi - lo, SC_C(3));
			sc_t va1, vw1, va2, vw2, c2[ARM_DOF];
			bool ok1 = goal_posture(a, &g, m1, cand, &va1, &vw1) && va1 == 0;
			bool ok2 = goal_posture(a, &g, m2, c2, &va2, &vw2) && va2 == 0;

			if (ok1 && vw1 < best_vw) {
				best_vw = vw1;
				ik_q_copy(q, cand);
			}
			if (ok2 && vw2 < best_vw) {
				best_vw = vw2;
				ik_q_copy(q, c2);
			}
			if (!ok1 && !ok2)
				break;
			if (!ok2 || (ok1 && vw1 < vw2))
				hi = m2;
			else
				lo = m1;
		}
	}
	arm_clamp(a, q);
	return true;
}

/* IK_LIMITED if a joint of q is at one of its limits, as the solver flags it */
static unsigned at_limits(const struct arm *a, const sc_t q[ARM_DOF])
{
	for (int i = 0; i < ARM_DOF; i++)
		if (q[i] <= a->lim.lo[i] || q[i] >= a->lim.hi[i])
			return IK_LIMITED;
	return 0;
}

/* |hand - target| and the angle between their orientations, for a posture */
static void posture_err(const struct arm *a, const struct ik_target *t, const sc_t q[ARM_DOF], struct ik_err *err)
{
	struct dq ee;
	struct vec3 p;

	arm_fk(a, q, &ee);
	dq_translation(&ee, &p);
	p = (struct vec3){ p.x - t->p.x, p.y - t->p.y, p.z - t->p.z };
	err->pos = v3_norm(&p);
	err->rot = quat_angle_between(&ee.r, &t->r);
}

/* chests within 5 degrees of each other: the cosine of the half angle, the quaternions' dot product */
#define SAME_CHEST SC_C(0.9990482215818578)

static bool same_chest(const struct quat *a, const struct quat *b)
{
	return sc_abs(sc_mul(a->w, b->w) + sc_mul(a->x, b->x) + sc_mul(a->y, b->y) + sc_mul(a->z, b->z)) > SAME_CHEST;
}

/* closed-form postures tried per frame while tracking a target out of the limits' reach */
#define TRACK_EVALS 48

/*
 * An arm kept on its branch (avatar_arm_solve's last step): a frame whose
 * elbow moved JUMP_MARGIN more than its hand since the last frame jumped to
 * another branch of the arm; the posture near the last one is kept instead
 * when it has the hand within HOLD_POS of its sensor and the hand's
 * orientation within HOLD_ROT of what the jump gave (radians, 20 degrees).
 */
#define JUMP_MARGIN SC_C(0.10)
#define HOLD_POS SC_C(0.001)
#define HOLD_ROT SC_C(0.35)
#define HOLD_STEPS 6
#define HOLD_STEP SC_C(0.04363323129985824) /* 2.5 degrees */

/*
 * The posture with the hand on its target's position and the elbow where
 * it was (its swivel about the new shoulder-wrist line, J1 as it was), the
 * wrist as near the orientation as its limits allow; false if J2..J5 leave
 * their limits there.
 */
static bool hold_swivel(const struct arm *a, const struct ik_target *t, const sc_t pq[ARM_DOF],
			const struct arm_pose *was, sc_t q[ARM_DOF])
{
	struct arm_goal g;
	struct vec3 e;
	sc_t c, s, n, va, vw, phi;
	int k;

	if (!goal_init(a, t, pq[0], &g) || !g.in_reach)
		return false;
	e = (struct vec3){ was->elbow.x, was->elbow.y, was->elbow.z };
	if (a->side == ARM_LEFT)
		e.x = -e.x;
	e = (struct vec3){ e.x - g.s.x, e.y - g.s.y, e.z - g.s.z };
	c = v3_dot(&e, &g.d0);
	s = v3_dot(&e, &g.d1);
	n = sc_sqrt(sc_mul(c, c) + sc_mul(s, s));
	if (!(n > SC_C(1e-6)))
		return false;
	phi = sc_atan2(s, c);
	/* the swivel it had, else the nearest within HOLD_STEPS steps of 2.5 degrees that keeps J2..J5 inside */
	for (k = 0; k <= 2 * HOLD_STEPS; k++) {
		sc_t d = sc_mul(sc_from_int((k + 1) / 2 * (k & 1 ? 1 : -1)), HOLD_STEP);

		if (goal_posture(a, &g, phi + d, q, &va, &vw) && va == 0)
			break;
	}
	if (k > 2 * HOLD_STEPS)
		return false;
	arm_clamp(a, q);
	return true;
}

/* the elbow moved JUMP_MARGIN more than the hand since the previous frame (chest frame) */
static bool arm_jumped(const struct arm_pose *was, const struct arm_pose *now)
{
	struct vec3 de = { now->elbow.x - was->elbow.x, now->elbow.y - was->elbow.y, now->elbow.z - was->elbow.z };
	struct vec3 dh = { now->hand.x - was->hand.x, now->hand.y - was->hand.y, now->hand.z - was->hand.z };

	return v3_norm(&de) > v3_norm(&dh) + JUMP_MARGIN;
}

/* Newton from a posture with no closed-form search (ik_opts.max_evals = 0) */
static void newton_from(const struct arm *a, const struct ik_kin *kin, const struct ik_target *t,
			const sc_t from[ARM_DOF], const struct ik_opts *o, sc_t q[ARM_DOF], struct ik_result *r,
			struct arm_pose *s)
{
	struct ik_opts no = *o;

	no.max_evals = 0;
	ik_solve_pose(a, kin, t, from, &no, q, r, s);
}

/* another posture for the arm's result: its angles, result and segment poses; returns its flags */
static unsigned take_posture(sc_t q[ARM_DOF], struct ik_result *res, struct arm_pose *seg, const sc_t q2[ARM_DOF],
			     const struct ik_result *r2, const struct arm_pose *s2)
{
	ik_q_copy(q, q2);
	*res = *r2;
	*seg = *s2;
	return r2->flags;
}

unsigned avatar_arm_solve(const struct avatar *av, int side, const struct ik_kin *kin, const struct ik_opts *o,
			  const struct ik_target *t, const struct avatar_pose *prev, struct avatar_pose *out)
{
	const struct arm *a = &av->arm[side];
	const sc_t *pq = prev ? prev->q[side] : NULL;
	sc_t pref[ARM_DOF], base[ARM_DOF], *q = out->q[side];
	struct ik_result *res = &out->res[side];
	const sc_t *seed = pq;
	const struct ik_opts *so = o;
	struct ik_opts track;
	unsigned flags;
	const struct wrist_prior wp = { av->rest6_c, av->rest6_s, (av->body.model & AVATAR_ARM_TWIST) != 0 };

	out->hand_misfit[side] = prev ? prev->hand_misfit[side] : SC_C(0);
	if ((av->body.model & AVATAR_HAND_ELBOW) && t->valid) {
		if (!pq) {
			/* a reset: the solver's own choice is where an untrusted hand leaves the elbow */
			ik_solve(a, kin, t, NULL, o, base, res);
			pq = base;
		}
		if (hand_elbow_posture(a, &wp, t, !prev, prev ? prev->hand_misfit[side] : SC_C(0),
				       &out->hand_misfit[side], pref))
			seed = pref;
		else
			seed = pq;
	}
	if (prev && (prev->res[side].flags & IK_UNREACHABLE) && o->max_evals > TRACK_EVALS) {
		/*
		 * The last frame was already a compromise (the target out of the
		 * limits' reach): a short look for an exact posture near the seed,
		 * not the whole search again. A target out of reach stays so for
		 * many frames (a hand frame the wrist cannot take, a hand beyond
		 * the arm), and the whole search costs a hundred times an ordinary
		 * solve in each of them; this bounds such an arm's frame.
		 */
		track = *o;
		track.max_evals = TRACK_EVALS;
		so = &track;
	}
	flags = ik_solve_pose(a, kin, t, seed, so, q, res, &out->seg[side]);
	if ((av->body.model & AVATAR_REACH_FIRST) && t->valid && (flags & IK_UNREACHABLE) &&
	    res->err.pos > o->tol_pos) {
		/*
		 * No posture inside the limits has both the position and the
		 * orientation, and the solver's compromise moved the hand off
		 * its sensor: the position first, if J1..J5 can give it.
		 */
		sc_t q2[ARM_DOF], q1s[4] = { q[0], pq ? pq[0] : SC_C(0), SC_C(0), sc_mul(q[0], SC_C(0.5)) };
		struct ik_err e2;

		if (reach_first(a, &wp, t, q1s, 4, q2)) {
			posture_err(a, t, q2, &e2);
			if (e2.pos < res->err.pos) {
				ik_q_copy(q, q2);
				arm_fk_pose(a, q, &out->seg[side]);
				res->err = e2;
				res->flags = (res->flags & ~(unsigned)IK_LIMITED) | at_limits(a, q);
				flags = res->flags;
			}
		}
	}
	if ((av->body.model & AVATAR_REACH_FIRST) && prev && t->valid && (flags & IK_UNREACHABLE) &&
	    res->err.pos > HOLD_POS && same_chest(&prev->chest.r, &out->chest.r)) {
		/*
		 * Still off its sensor: the compromise Newton reaches from the
		 * last frame's posture (no search) is often nearer than the one
		 * from the seed (a raised arm against its limits, seeded outside
		 * them, can end a hand's length away); the hand's place first.
		 * Not when the chest turned (a bow tried or left): the last
		 * posture was another arm's then.
		 */
		struct ik_result r2;
		struct arm_pose s2;
		sc_t q2[ARM_DOF];

		newton_from(a, kin, t, prev->q[side], o, q2, &r2, &s2);
		if (r2.err.pos < res->err.pos)
			flags = take_posture(q, res, &out->seg[side], q2, &r2, &s2);
	}
	if ((av->body.model & AVATAR_KEEP_BRANCH) && prev && t->valid &&
	    arm_jumped(&prev->seg[side], &out->seg[side])) {
		/*
		 * The elbow left the last frame's far faster than the hand: the
		 * search found another branch of the arm, and the next frame may
		 * well go back (an arm against its limits, a body whose arms do
		 * not fit its sensors: the default body on other people's motion
		 * flickered so 22 times in the seven clips of docs/FIDELITY.md).
		 * A renderer shows that as a flicker of the arm; the branch the arm
		 * is on does better, unless it costs the hand its place or much
		 * of its orientation: Newton from the last posture (no search),
		 * or where Newton gives up the hand's place for its orientation,
		 * the hand on its place with the elbow at its last swivel.
		 */
		struct ik_result r2;
		struct arm_pose s2;
		sc_t q2[ARM_DOF];

		newton_from(a, kin, t, prev->q[side], o, q2, &r2, &s2);
		if (!(r2.err.pos <= HOLD_POS) && hold_swivel(a, t, prev->q[side], &prev->seg[side], q2)) {
			/* Newton gave up the hand's place for its orientation: the hand on its place at the elbow's
			 * swivel */
			posture_err(a, t, q2, &r2.err);
			arm_fk_pose(a, q2, &s2);
			r2.flags = IK_UNREACHABLE | at_limits(a, q2);
		}
		if (r2.err.pos <= sc_max(HOLD_POS, res->err.pos) && r2.err.rot <= res->err.rot + HOLD_ROT &&
		    !arm_jumped(&prev->seg[side], &s2))
			flags = take_posture(q, res, &out->seg[side], q2, &r2, &s2);
	}
	return flags;
}

/*
 * AVATAR_REACH_CHEST (reach_chest below): the chest's move toward hands
 * beyond reach, at most REACH_SHIFT: the trunk leans and the shoulder
 * girdle protracts that much (the head sensor is then that far from its
 * offset: the neck bends). Before the solve, so a hand that becomes
 * reachable costs one ordinary solve.
 */
#define REACH_SHIFT SC_C(0.08)

/*
 * goal_init(q1 = 0)'s in_reach, for the common case, from the hand's y axis
 * alone (the second column of its rotation): the wrist centre no farther
 * from the shoulder than the arm is long. Mirroring the left arm's target
 * would only flip x on both points, which no distance sees.
 */
static bool wrist_in_reach(const struct arm *a, const struct ik_target *t)
{
	const struct arm_dims *dm = &a->dims;
	const struct quat *r = &t->r;
	sc_t sx = a->side == ARM_LEFT ? -dm->shoulder : dm->shoulder, reach = dm->arm + dm->forearm;
	struct vec3 hy = { 2 * (sc_mul(r->x, r->y) - sc_mul(r->w, r->z)),
			   SC_C(1) - 2 * (sc_mul(r->x, r->x) + sc_mul(r->z, r->z)),
			   2 * (sc_mul(r->y, r->z) + sc_mul(r->w, r->x)) };
	struct vec3 d = { t->p.x - sc_mul(dm->hand, hy.x) - sx, t->p.y - sc_mul(dm->hand, hy.y),
			  t->p.z - sc_mul(dm->hand, hy.z) };

	/* a margin of a millimetre: near the edge the exact test decides */
	return v3_norm(&d) < reach - SC_C(0.001);
}

/*
 * The chest c0 moved by d (c0's frame) and rolled about its forward axis by
 * the angle whose sine is sr (the right shoulder down for sr > 0), both
 * arms' targets rewritten.
 */
static void chest_shift(const struct dq *c0, struct vec3 d, sc_t sr, const struct dq *const hand[2], struct dq *chest,
			struct ik_target t[2])
{
	struct vec3 dw, c;
	struct quat r = c0->r;
	int side;

	quat_rotate(&r, &d, &dw);
	dq_translation(c0, &c);
	c = (struct vec3){ c.x + dw.x, c.y + dw.y, c.z + dw.z };
	if (sr != 0) {
		/* the half angle: cos = sqrt((1 + cos) / 2), sin = sin / (2 cos(half)) */
		sc_t ch = sc_sqrt(sc_mul(SC_C(0.5), SC_C(1) + sc_sqrt(SC_C(1) - sc_mul(sr, sr))));
		struct quat ry = { ch, 0, sc_div(sr, 2 * ch), 0 }, rr;

		quat_mul(&r, &ry, &rr);
		r = rr;
	}
	dq_from_rt(&r, &c, chest);
	for (side = 0; side < 2; side++)
		avatar_arm_target(chest, hand[side], &t[side]);
}

/*
 * The least move of the shoulders that brings every hand beyond reach
 * within it: x = (d, u), d the chest's shift and u the rise of the right
 * shoulder (the left falling as much) by a roll about the forward axis, the
 * least |x| with g_i . x >= c_i for each arm i that needs it (g_i the arm's
 * shoulder-wrist line as the shoulder moves with x: (a_i, +-a_i.z), or
 * (a_i, 0) without the roll). A quadratic programme of at most two
 * constraints in four unknowns, solved by its active sets: none, each one
 * alone (if it leaves the other met), both. A lateral lean of the trunk (an
 * arm raised overhead, the other hanging: one shoulder up, one down) is the
 * last; no shift of a rigid chest gives it.
 */
#define ROLL_MAX SC_C(0.3420201433256687) /* sine of 20 degrees */

struct reach_x {
	sc_t v[4]; /* d.x, d.y, d.z, u */
};

static sc_t rx_dot(const struct reach_x *a, const struct reach_x *b)
{
	return sc_mul(a->v[0], b->v[0]) + sc_mul(a->v[1], b->v[1]) + sc_mul(a->v[2], b->v[2]) +
	       sc_mul(a->v[3], b->v[3]);
}

static void rx_scaled(const struct reach_x *g, sc_t k, struct reach_x *x)
{
	for (int i = 0; i < 4; i++)
		x->v[i] = sc_mul(k, g->v[i]);
}

static void reach_qp(const struct reach_x g[2], const sc_t c[2], const bool act[2], struct reach_x *x)
{
	sc_t gg[2], g01, det, l0, l1;
	int i;

	*x = (struct reach_x){ { 0, 0, 0, 0 } };
	if (!act[0] || !act[1]) {
		i = act[0] ? 0 : 1;
		if (act[i] && c[i] > 0)
			rx_scaled(&g[i], sc_div(c[i], rx_dot(&g[i], &g[i])), x);
		return;
	}
	gg[0] = rx_dot(&g[0], &g[0]);
	gg[1] = rx_dot(&g[1], &g[1]);
	if (!(c[0] > 0) && !(c[1] > 0))
		return;
	for (i = 0; i < 2; i++) {
		/* the one alone, if it leaves the other's met */
		if (c[i] > 0) {
			rx_scaled(&g[i], sc_div(c[i], gg[i]), x);
			if (rx_dot(&g[1 - i], x) >= c[1 - i])
				return;
		}
	}
	g01 = rx_dot(&g[0], &g[1]);
	det = sc_mul(gg[0], gg[1]) - sc_mul(g01, g01);
	if (!(det > SC_C(0.01))) {
		/* nearly one line: the arm that needs more */
		i = c[0] > c[1] ? 0 : 1;
		rx_scaled(&g[i], sc_div(c[i], gg[i]), x);
		return;
	}
	l0 = sc_div(sc_mul(gg[1], c[0]) - sc_mul(g01, c[1]), det);
	l1 = sc_div(sc_mul(gg[0], c[1]) - sc_mul(g01, c[0]), det);
	for (i = 0; i < 4; i++)
		x->v[i] = sc_mul(l0, g[0].v[i]) + sc_mul(l1, g[1].v[i]);
}

/*
 * AVATAR_REACH_CHEST: the chest moved (and, with AVATAR_REACH_ROLL, rolled)
 * by the least move that brings the hands beyond the straight arms' reach
 * within it, at most REACH_SHIFT and 20 degrees. The arms' lines change
 * with the move (and the roll is not linear): REACH_ITERS rounds, each the
 * whole move again from the chest the head placed, with every arm that
 * needed a move in an earlier round kept in it (a move for one hand must
 * not take the other's shoulder out of its reach). The linearised rounds
 * need not improve on each other (arms spread to both sides: two lines
 * nearly opposite, where the moves for either hand undo the other's), so
 * the chest kept is the round's that leaves the hands least beyond reach,
 * the last of equals. Rewrites the targets; returns whether the chest moved.
 */
#define REACH_ITERS 3
/* the hand brought 2 mm inside the straight arm's reach (1 mm: Q5.26's elbow of a straight arm 1 um off double) */
#define REACH_MARGIN SC_C(0.002)

static bool reach_chest(const struct avatar *av, const struct dq *const hand[2], struct dq *chest,
			struct ik_target t[2])
{
	const struct dq c0 = *chest;
	const bool roll = (av->body.model & AVATAR_REACH_ROLL) != 0;
	const sc_t sh = av->arm[ARM_RIGHT].dims.shoulder;
	struct reach_x x = { { 0, 0, 0, 0 } }, g[2] = { { { 0, 0, 0, 0 } }, { { 0, 0, 0, 0 } } };
	sc_t c[2] = { 0, 0 }, sr = 0, cr = SC_C(1), best = SC_C(1e9), best_sr = 0;
	struct vec3 dm = { 0, 0, 0 }, best_d = { 0, 0, 0 };
	bool act[2] = { false, false }, moved = false;
	int it, side;

	for (it = 0;; it++) {
		bool need = false;
		sc_t over = 0; /* the farthest hand beyond reach with this round's chest */

		for (side = 0; side < 2; side++) {
			const struct arm *a = &av->arm[side];
			struct arm_goal gl;
			struct vec3 ax;
			sc_t e;

			if (!t[side].valid || (!act[side] && wrist_in_reach(a, &t[side])) ||
			    !goal_init(a, &t[side], SC_C(0), &gl) || (!act[side] && gl.in_reach))
				continue;
			e = v3_norm(&(struct vec3){ gl.w.x - gl.s.x, gl.w.y - gl.s.y, gl.w.z - gl.s.z }) -
			    (a->dims.arm + a->dims.forearm) + REACH_MARGIN;
			/* the line in the chest's frame (the left arm's mirrored back), then in c0's */
			ax = (struct vec3){ side == ARM_LEFT ? -gl.ax.x : gl.ax.x, gl.ax.y, gl.ax.z };
			g[side] = (struct reach_x){ { sc_mul(cr, ax.x) + sc_mul(sr, ax.z), ax.y,
						      sc_mul(cr, ax.z) - sc_mul(sr, ax.x), 0 } };
			if (roll)
				g[side].v[3] = side == ARM_LEFT ? -g[side].v[2] : g[side].v[2];
			c[side] = e + rx_dot(&g[side], &x);
			act[side] = true;
			need |= e > 0;
			over = sc_max(over, e - REACH_MARGIN);
		}
		if (!(over > best)) {
			best = over;
			best_d = dm;
			best_sr = sr;
		}
		if (!need || it == REACH_ITERS)
			break;
		reach_qp(g, c, act, &x);
		{
			struct vec3 d = { x.v[0], x.v[1], x.v[2] };
			sc_t n = v3_norm(&d);

			if (n > REACH_SHIFT) {
				sc_t k = sc_div(REACH_SHIFT, n);

				d = (struct vec3){ sc_mul(d.x, k), sc_mul(d.y, k), sc_mul(d.z, k) };
				x.v[0] = d.x;
				x.v[1] = d.y;
				x.v[2] = d.z;
			}
			/* the right shoulder (S, 0, 0) rolled by a about y: (S cos a, 0, -S sin a), u = -S sin a */
			sr = sc_clamp(-sc_div(x.v[3], sh), -ROLL_MAX, ROLL_MAX);
			x.v[3] = -sc_mul(sr, sh);
			cr = sc_sqrt(SC_C(1) - sc_mul(sr, sr));
			chest_shift(&c0, d, sr, hand, chest, t);
			dm = d;
			moved = true;
		}
	}
	if (moved && (best_d.x != dm.x || best_d.y != dm.y || best_d.z != dm.z || best_sr != sr))
		chest_shift(&c0, best_d, best_sr, hand, chest, t);
	return moved;
}

/*
 * AVATAR_RAISE_ROLL: a shoulder rises with its arm raised above the
 * horizontal (the collar bone's elevation in the shoulder blade's upward
 * turn, about 15 degrees of a 15 cm clavicle at full elevation:
 * RAISE_RISE), by the sine of the shoulder-hand line's elevation; the
 * rigid chest carries the difference of the two rises as a roll about its
 * forward axis (one arm raised: that side up, the trunk bent away from it).
 * Their mean, a shift up, is left out: the folds of docs/FIDELITY.md chose
 * the roll and not the shift (both arms raised: 6 clips worse by a
 * centimetre).
 */
#define RAISE_RISE SC_C(0.04)

/* before the targets: the hands' places in the chest's frame from their sensors, the chest's rotation rolled */
static void raise_roll(const struct avatar *av, const struct dq *const hand[2], struct dq *chest)
{
	const sc_t sh = av->arm[ARM_RIGHT].dims.shoulder;
	sc_t e[2] = { 0, 0 }, sr, ch;
	struct quat rc, r;
	struct vec3 o;
	int side;

	quat_conj(&chest->r, &rc);
	dq_translation(chest, &o);
	for (side = 0; side < 2; side++) {
		sc_t sx = side == ARM_LEFT ? -av->arm[side].dims.shoulder : av->arm[side].dims.shoulder, n;
		struct vec3 hp, v;

		if (!hand[side] || !dq_is_finite(hand[side]))
			continue;
		dq_translation(hand[side], &hp);
		hp = (struct vec3){ hp.x - o.x, hp.y - o.y, hp.z - o.z };
		quat_rotate(&rc, &hp, &v);
		v.x -= sx;
		n = v3_norm(&v);
		if (v.z > 0 && n > SC_C(0.05))
			e[side] = sc_mul(RAISE_RISE, sc_div(v.z, n));
	}
	if (e[ARM_RIGHT] == e[ARM_LEFT])
		return;
	/*
	 * the right shoulder (S, 0, 0) rolled by a about y: (S cos a, 0, -S sin a), a rise u = -S sin a;
	 * the half angle: cos = sqrt((1 + cos) / 2), sin = sin / (2 cos(half))
	 */
	sr = -sc_div(sc_mul(SC_C(0.5), e[ARM_RIGHT] - e[ARM_LEFT]), sh);
	ch = sc_sqrt(sc_mul(SC_C(0.5), SC_C(1) + sc_sqrt(SC_C(1) - sc_mul(sr, sr))));
	quat_mul(&chest->r, &(struct quat){ ch, 0, sc_div(sr, 2 * ch), 0 }, &r);
	dq_from_rt(&r, &o, chest);
}

/*
 * AVATAR_BOW: a hand the upright chest leaves more than a millimetre off its
 * sensor (a joint limit in the way, after AVATAR_REACH_CHEST has mended the
 * arm's length) may be a bow at the waist: the trunk pitched forward carries
 * the shoulders and sweeps the arms back along it, while the head, on its
 * sensor, stays up. The chest is tried pitched forward by 15, 30 ... 75 degrees about
 * its x axis, turning with the neck and head about the head sensor
 * (origin = head - Rz Rx(pitch) B head_offset, B the neck's bend as
 * upright), both arms solved at each, in the order of how nearly each bow
 * lays the shoulder-wrist lines along the trunk (the posture a bow
 * explains; the least bow that reaches the hands leaves the arms at their
 * limits, behind an upright trunk). The first that puts both hands on
 * their sensors is kept; else the one that puts the most on, its upper
 * arms nearest along the trunk; none if none puts more on than the
 * upright chest.
 * Costs up to BOW_TRIES times both arms' solves, in the frames it runs.
 */
#define BOW_TRIES 5
/* the half angles of 15, 30, 45, 60, 75 degrees: Rx(-pitch) = (cos, -sin, 0, 0) */
static const sc_t bow_c[BOW_TRIES] = { SC_C(0.9914448613738104), SC_C(0.9659258262890683), SC_C(0.9238795325112867),
				       SC_C(0.8660254037844387), SC_C(0.7933533402912352) };
static const sc_t bow_s[BOW_TRIES] = { SC_C(0.13052619222005157), SC_C(0.25881904510252074), SC_C(0.3826834323650898),
				       SC_C(0.5), SC_C(0.6087614290087207) };

/* more than BOW_MISS: a millimetre, what the fidelity goals call a hand on its sensor */
#define BOW_MISS SC_C(0.001)

static bool hand_off(const struct ik_target t[2], const struct avatar_pose *p, int side)
{
	return t[side].valid && p->res[side].err.pos > BOW_MISS;
}

/*
 * A bow explains hands off their sensors only when they are low or behind:
 * below the shoulders of the upright chest, or behind its shoulder line
 * (the arms swept back along a trunk bowed past the horizontal). A raised
 * hand in front or overhead out of reach (a wave over the head against a
 * joint limit) is no bow.
 */
static bool bow_wanted(const struct ik_target t[2], const struct avatar_pose *p)
{
	int side, off = 0;

	for (side = 0; side < 2; side++)
		if (hand_off(t, p, side)) {
			if (!(t[side].p.z < 0) && !(t[side].p.y < 0))
				return false;
			off++;
		}
	return off > 0;
}

/*
 * How a pose does as a bow: its hands off their sensors (returned), and how
 * far its upper arms are from lying along the trunk (*lie: 0 for both
 * straight down the chest's -z, 2 at most per arm; the arms with a target).
 */
static int bow_eval(const struct ik_target t[2], const struct avatar_pose *p, sc_t *lie)
{
	int side, off = 0;

	*lie = 0;
	for (side = 0; side < 2; side++) {
		const struct arm_pose *sg = &p->seg[side];
		struct vec3 ua = { sg->elbow.x - sg->shoulder.x, sg->elbow.y - sg->shoulder.y,
				   sg->elbow.z - sg->shoulder.z };
		sc_t n = v3_norm(&ua);

		if (!t[side].valid)
			continue;
		if (n > 0)
			*lie += SC_C(1) + sc_div(ua.z, n);
		off += hand_off(t, p, side);
	}
	return off;
}

/* a chest pitched (or rolled) by more than half the least bow: its z axis's z below cos 7.5 degrees */
static bool bowed(const struct dq *chest)
{
	const struct quat *r = &chest->r;

	return 2 * (sc_mul(r->x, r->x) + sc_mul(r->y, r->y)) > SC_C(0.008555139301011035);
}

/* the chest `up` (upright) pitched forward by bow k about the head sensor */
static void bowed_chest(const struct avatar *av, const struct dq *head, const struct dq *up, int k, struct dq *chest)
{
	const struct quat px = { bow_c[k], -bow_s[k], 0, 0 };
	struct quat hr, rb;
	struct vec3 hp, bent, off, o;

	quat_mul(&up->r, &px, &rb);
	dq_translation(head, &hp);
	if ((av->body.model & AVATAR_NECK) && quat_normalize(&head->r, &hr)) {
		neck_offset(&av->body.head_offset, &up->r, &hr, &bent);
		quat_rotate(&rb, &bent, &off);
	} else {
		quat_rotate(&rb, &av->body.head_offset, &off);
	}
	o = (struct vec3){ hp.x - off.x, hp.y - off.y, hp.z - off.z };
	dq_from_rt(&rb, &o, chest);
}

/* bow_eval's lie of the shoulder-wrist lines alone, before any solve: which bows to try first */
static sc_t bow_line_cost(const struct avatar *av, const struct ik_target t[2])
{
	sc_t cost = 0;
	int side;

	for (side = 0; side < 2; side++) {
		sc_t sx = side == ARM_LEFT ? -av->arm[side].dims.shoulder : av->arm[side].dims.shoulder;
		struct vec3 l = { t[side].p.x - sx, t[side].p.y, t[side].p.z };
		sc_t n = v3_norm(&l);

		if (t[side].valid && n > 0)
			cost += SC_C(1) + sc_div(l.z, n);
	}
	return cost;
}

static unsigned bow(const struct avatar *av, const struct ik_kin *kin, const struct ik_opts *o, const struct dq *head,
		    const struct dq *const hand[2], const struct avatar_pose *prev, const struct dq *upright,
		    struct avatar_pose *out, unsigned flags)
{
	struct avatar_pose tmp;
	struct ik_target t[2];
	struct ik_opts short_o = *o;
	struct dq chest[BOW_TRIES];
	sc_t line[BOW_TRIES], best_lie = 0;
	bool tried[BOW_TRIES] = { false }, kept = false;
	const struct dq up = *upright;
	int k, n, side, best_off;

	/* each bow's solve as short as tracking a target out of reach */
	if (short_o.max_evals > TRACK_EVALS)
		short_o.max_evals = TRACK_EVALS;
	/* a bow is kept only if it puts more hands on their sensors than the upright chest */
	for (side = 0; side < 2; side++)
		avatar_arm_target(&up, hand[side], &t[side]);
	best_off = hand_off(t, out, 0) + hand_off(t, out, 1);
	for (k = 0; k < BOW_TRIES; k++) {
		bowed_chest(av, head, &up, k, &chest[k]);
		for (side = 0; side < 2; side++)
			avatar_arm_target(&chest[k], hand[side], &t[side]);
		line[k] = bow_line_cost(av, t);
	}
	/* the bows in the order of their lines; the first that puts both hands on is kept */
	for (n = 0; n < BOW_TRIES; n++) {
		unsigned f = 0;
		sc_t lie;
		int kb = -1, off;

		for (k = 0; k < BOW_TRIES; k++)
			if (!tried[k] && (kb < 0 || line[k] < line[kb]))
				kb = k;
		tried[kb] = true;
		tmp.chest = chest[kb];
		tmp.head_yaw = out->head_yaw;
		for (side = 0; side < 2; side++)
			avatar_arm_target(&tmp.chest, hand[side], &t[side]);
		/* the bowed trunk's shoulders still move toward hands beyond reach */
		if (av->body.model & AVATAR_REACH_CHEST)
			reach_chest(av, hand, &tmp.chest, t);
		for (side = 0; side < 2; side++)
			f |= avatar_arm_solve(av, side, kin, &short_o, &t[side], prev, &tmp);
		off = bow_eval(t, &tmp, &lie);
		/* fewer hands off; among bows as many, the arms nearer along the trunk */
		if (off < best_off || (kept && off == best_off && lie < best_lie)) {
			kept = true;
			best_off = off;
			best_lie = lie;
			*out = tmp;
			flags = f;
		}
		if (!off)
			break;
	}
	return flags;
}

/*
 * AVATAR_LEAN: raised hands that their arms, against their limits, leave
 * more than a millimetre off their sensors (J2 at -170 degrees: an arm over
 * the head), every hand off raised: the trunk bends as a person reaching
 * overhead does (the shoulder blade's turn, which the chain has no joint
 * for). With one such hand it bends sideways away from it, lifting that
 * shoulder and turning the arm's frame under the raised arm: the chest
 * rolled about its forward axis through its origin by 5, 10, 15, 20
 * degrees; then, and with both hands raised, it leans back: the chest
 * pitched back about the head sensor by 5, 10, 15, 20 degrees. Both arms
 * are solved at each with the short budget of a target out of reach; the
 * first that puts every hand on is kept, else the chest stays.
 */
#define LEAN_TRIES 4
/* the half angles of 5, 10, 15, 20 degrees */
static const sc_t lean_c[LEAN_TRIES] = { SC_C(0.9990482215818578), SC_C(0.9961946980917455), SC_C(0.9914448613738104),
					 SC_C(0.984807753012208) };
static const sc_t lean_s[LEAN_TRIES] = { SC_C(0.043619387365336), SC_C(0.08715574274765817), SC_C(0.13052619222005157),
					 SC_C(0.17364817766693033) };

/* the side of the one raised hand off, 2 for both, -1 if none or a hand off is low */
static int lean_wanted(const struct ik_target t[2], const struct avatar_pose *p)
{
	int side, raised = -1;

	for (side = 0; side < 2; side++)
		if (hand_off(t, p, side)) {
			if (!(t[side].p.z > 0))
				return -1;
			raised = raised < 0 ? side : 2;
		}
	return raised;
}

static unsigned lean(const struct avatar *av, const struct ik_kin *kin, const struct ik_opts *o, const struct dq *head,
		     const struct dq *const hand[2], const struct avatar_pose *prev, int raised,
		     struct avatar_pose *out, unsigned flags)
{
	struct avatar_pose tmp;
	struct ik_target t[2];
	struct ik_opts short_o = *o;
	struct vec3 hp, hc, c;
	struct dq ci;
	int k, side;

	if (short_o.max_evals > TRACK_EVALS)
		short_o.max_evals = TRACK_EVALS;
	/* the head sensor in the chest's frame: where a pitch turns the chest about */
	dq_translation(head, &hp);
	dq_conj(&out->chest, &ci);
	dq_transform_point(&ci, &hp, &hc);
	for (k = raised == 2 ? LEAN_TRIES : 0; k < 2 * LEAN_TRIES; k++) {
		const int j = k % LEAN_TRIES;
		/* the raised arm's shoulder up: about +y for the left arm, -y for the right (x toward the right) */
		const struct quat rq =
			k < LEAN_TRIES ? (struct quat){ lean_c[j], 0, raised == ARM_LEFT ? lean_s[j] : -lean_s[j], 0 }
				       : (struct quat){ lean_c[j], lean_s[j], 0, 0 };
		struct quat r;
		unsigned f = 0;

		quat_mul(&out->chest.r, &rq, &r);
		if (k < LEAN_TRIES) {
			dq_translation(&out->chest, &c);
		} else {
			quat_rotate(&r, &hc, &c);
			c = (struct vec3){ hp.x - c.x, hp.y - c.y, hp.z - c.z };
		}
		dq_from_rt(&r, &c, &tmp.chest);
		tmp.head_yaw = out->head_yaw;
		for (side = 0; side < 2; side++) {
			avatar_arm_target(&tmp.chest, hand[side], &t[side]);
			f |= avatar_arm_solve(av, side, kin, &short_o, &t[side], prev, &tmp);
		}
		if (!hand_off(t, &tmp, 0) && !hand_off(t, &tmp, 1)) {
			*out = tmp;
			return f;
		}
	}
	return flags;
}

unsigned avatar_solve(const struct avatar *av, const struct ik_kin *kin, const struct ik_opts *o, const struct dq *head,
		      const struct dq *lhand, const struct dq *rhand, const struct avatar_pose *prev,
		      struct avatar_pose *out)
{
	const struct dq *hand[2] = { rhand, lhand };
	const struct ik_opts *o1 = o;
	struct ik_opts short_o;
	struct ik_target t[2];
	unsigned flags = 0;
	int side;

	if (!avatar_chest_hands(av, head, lhand, rhand, &out->chest, &out->head_yaw)) {
		/* no head: keep the previous frame, flagged */
		for (side = 0; side < 2; side++) {
			int i;

			for (i = 0; i < ARM_DOF; i++)
				out->q[side][i] = prev ? prev->q[side][i] : SC_C(0);
			if (!prev)
				ik_rest_posture(&av->arm[side], out->q[side]);
			if (prev)
				out->seg[side] = prev->seg[side];
			else
				arm_fk_pose(&av->arm[side], out->q[side], &out->seg[side]);
			out->res[side] = (struct ik_result){ IK_BAD_TARGET, 0, 0, { 0, 0 } };
			out->hand_misfit[side] = prev ? prev->hand_misfit[side] : SC_C(0);
		}
		if (prev)
			out->chest = prev->chest;
		return IK_BAD_TARGET;
	}
	if (av->body.model & AVATAR_RAISE_ROLL)
		raise_roll(av, hand, &out->chest);
	for (side = 0; side < 2; side++)
		avatar_arm_target(&out->chest, hand[side], &t[side]);
	if (av->body.model & AVATAR_REACH_CHEST)
		reach_chest(av, hand, &out->chest, t);
	if ((av->body.model & AVATAR_BOW) && prev && bowed(&prev->chest) && o->max_evals > TRACK_EVALS) {
		/* out of a bow the upright chest is likely still short: its search as short as the bow's */
		short_o = *o;
		short_o.max_evals = TRACK_EVALS;
		o1 = &short_o;
	}
	for (side = 0; side < 2; side++)
		flags |= avatar_arm_solve(av, side, kin, o1, &t[side], prev, out);
	if (av->body.model & AVATAR_LEAN) {
		int raised = lean_wanted(t, out);

		if (raised >= 0)
			flags = lean(av, kin, o, head, hand, prev, raised, out, flags);
	}
	if ((av->body.model & AVATAR_BOW) && bow_wanted(t, out)) {
		struct dq up;
		sc_t y;

		/* the bows are tried from the upright chest the head places (not bowed by it, not shifted or rolled) */
		chest_place(av, av->body.model & ~(unsigned)AVATAR_BOW_HEAD, head, lhand, rhand, &up, &y);
		flags = bow(av, kin, o, head, hand, prev, &up, out, flags);
	}
	return flags;
}
