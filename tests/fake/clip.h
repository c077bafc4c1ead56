/* SPDX-License-Identifier: MIT */
/*
 * clip.h - a motion-capture clip (the CSV of ../shared/mocap/csv) and its
 * poses between frames: positions interpolated linearly, orientations by
 * slerp, as tools/gen-captures.py does when it makes the captures.
 * Independent of the daemon's replay code: the tests hold the drivers'
 * output against it.
 */
#ifndef AGW_TEST_CLIP_H
#define AGW_TEST_CLIP_H

enum clip_role { CLIP_HEAD, CLIP_LHAND, CLIP_RHAND };

struct clip_pose {
	double p[3];
	double q[4]; /* w x y z */
};

struct clip {
	int n;
	double *t;
	struct clip_pose (*pose)[3];
};

/* 0 or -1 */
int clip_load(struct clip *c, const char *path);
void clip_free(struct clip *c);
void clip_at(const struct clip *c, enum clip_role role, double t, struct clip_pose *out);
/* a world pose into a source's frame and back: origin, yaw (degrees) as in [source] */
void clip_to_world(const double origin[3], double yaw_deg, const struct clip_pose *local, struct clip_pose *world);
/* distance between positions, angle between orientations (rad) */
double clip_dist(const double a[3], const double b[3]);
double clip_angle(const double a[4], const double b[4]);

#endif /* AGW_TEST_CLIP_H */
