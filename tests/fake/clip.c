// SPDX-License-Identifier: MIT
/*
 * clip.c - see clip.h.
 */
#include "fake/clip.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const prefix[3] = { "head", "lhand", "rhand" };
static const char *const field[7] = { "x", "y", "z", "qw", "qx", "qy", "qz" };

int clip_load(struct clip *c, const char *path)
{
	FILE *f = fopen(path, "r");
	char line[8192], *save, *tok;
	int col_t = -1, col[3][7], cap = 0;

	memset(c, 0, sizeof(*c));
	if (!f || !fgets(line, sizeof(line), f)) {
		if (f)
			fclose(f);
		return -1;
	}
	for (int r = 0; r < 3; r++)
		for (int k = 0; k < 7; k++)
			col[r][k] = -1;
	tok = strtok_r(line, ",\r\n", &save);
	for (int i = 0; tok; tok = strtok_r(NULL, ",\r\n", &save), i++) {
		char name[64];

		if (!strcmp(tok, "t"))
			col_t = i;
		for (int r = 0; r < 3; r++)
			for (int k = 0; k < 7; k++) {
				snprintf(name, sizeof(name), "%s_%s", prefix[r], field[k]);
				if (!strcmp(tok, name))
					col[r][k] = i;
			}
	}
	while (fgets(line, sizeof(line), f)) {
		double v[128];
		int n = 0;

		for (tok = strtok_r(line, ",\r\n", &save); tok && n < 128; tok = strtok_r(NULL, ",\r\n", &save))
			v[n++] = strtod(tok, NULL);
		if (n <= col_t)
			continue;
		if (c->n == cap) {
			cap = cap ? 2 * cap : 512;
			c->t = realloc(c->t, (size_t)cap * sizeof(*c->t));
			c->pose = realloc(c->pose, (size_t)cap * sizeof(*c->pose));
		}
		c->t[c->n] = v[col_t];
		for (int r = 0; r < 3; r++) {
			struct clip_pose *p = &c->pose[c->n][r];
			double qn;

			for (int k = 0; k < 3; k++)
				p->p[k] = v[col[r][k]];
			for (int k = 0; k < 4; k++)
				p->q[k] = v[col[r][3 + k]];
			qn = sqrt(p->q[0] * p->q[0] + p->q[1] * p->q[1] + p->q[2] * p->q[2] + p->q[3] * p->q[3]);
			for (int k = 0; k < 4; k++)
				p->q[k] /= qn;
		}
		c->n++;
	}
	fclose(f);
	return c->n > 1 ? 0 : -1;
}

void clip_free(struct clip *c)
{
	free(c->t);
	free(c->pose);
	memset(c, 0, sizeof(*c));
}

static void slerp(const double a[4], const double b0[4], double u, double out[4])
{
	double b[4], d = 0, n = 0;

	for (int k = 0; k < 4; k++)
		d += a[k] * b0[k];
	for (int k = 0; k < 4; k++)
		b[k] = d < 0 ? -b0[k] : b0[k];
	d = fabs(d);
	if (d > 0.9995) {
		for (int k = 0; k < 4; k++) {
			out[k] = a[k] + u * (b[k] - a[k]);
			n += out[k] * out[k];
		}
		for (int k = 0; k < 4; k++)
			out[k] /= sqrt(n);
		return;
	}
	double th = acos(d), s = sin(th), wa = sin((1 - u) * th) / s, wb = sin(u * th) / s;

	for (int k = 0; k < 4; k++)
		out[k] = wa * a[k] + wb * b[k];
}

void clip_at(const struct clip *c, enum clip_role role, double t, struct clip_pose *out)
{
	int lo = 0, hi = c->n - 1;
	double u;

	while (lo < hi - 1) {
		int mid = (lo + hi) / 2;

		if (c->t[mid] <= t)
			lo = mid;
		else
			hi = mid;
	}
	u = c->t[hi] == c->t[lo] ? 0 : (t - c->t[lo]) / (c->t[hi] - c->t[lo]);
	u = u < 0 ? 0 : u > 1 ? 1 : u;
	for (int k = 0; k < 3; k++)
		out->p[k] = c->pose[lo][role].p[k] + u * (c->pose[hi][role].p[k] - c->pose[lo][role].p[k]);
	slerp(c->pose[lo][role].q, c->pose[hi][role].q, u, out->q);
}

void clip_to_world(const double origin[3], double yaw_deg, const struct clip_pose *local, struct clip_pose *world)
{
	double y = yaw_deg * M_PI / 180, cy = cos(y), sy = sin(y), rw = cos(y / 2), rz = sin(y / 2);
	const double *q = local->q;

	world->p[0] = origin[0] + cy * local->p[0] - sy * local->p[1];
	world->p[1] = origin[1] + sy * local->p[0] + cy * local->p[1];
	world->p[2] = origin[2] + local->p[2];
	/* (rw, 0, 0, rz) * q */
	world->q[0] = rw * q[0] - rz * q[3];
	world->q[1] = rw * q[1] - rz * q[2];
	world->q[2] = rw * q[2] + rz * q[1];
	world->q[3] = rw * q[3] + rz * q[0];
}

double clip_dist(const double a[3], const double b[3])
{
	return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

double clip_angle(const double a[4], const double b[4])
{
	/* 2 atan2(|vector part of a* b|, |scalar part|): accurate near 0, unlike acos */
	double w = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
	double x = a[0] * b[1] - a[1] * b[0] - a[2] * b[3] + a[3] * b[2];
	double yv = a[0] * b[2] + a[1] * b[3] - a[2] * b[0] - a[3] * b[1];
	double z = a[0] * b[3] - a[1] * b[2] + a[2] * b[1] - a[3] * b[0];

	return 2 * atan2(sqrt(x * x + yv * yv + z * z), fabs(w));
}
