// SPDX-License-Identifier: MIT
/* benchfile.c - benchmark rows, joint limits and small helpers of the IK tools (benchfile.h) */
#include "benchfile.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define DEG2RAD 0.017453292519943295

int bench_load_rows(const char *tool, const char *path, size_t max, struct bench_row **out, size_t *n)
{
	FILE *f = fopen(path, "r");
	char line[1024];
	size_t cap = 0, len = 0, lineno = 0;
	struct bench_row *rows = NULL;

	if (!f) {
		fprintf(stderr, "%s: %s: %s\n", tool, path, strerror(errno));
		return -1;
	}
	while (len < max && fgets(line, sizeof(line), f)) {
		double v[15];
		char *s = line, *end;
		int k;

		lineno++;
		if (lineno == 1 && strncmp(line, "q1,", 3) == 0)
			continue;
		for (k = 0; k < 15; k++) {
			v[k] = strtod(s, &end);
			if (end == s)
				break;
			s = end;
			if (*s == ',')
				s++;
		}
		if (k != 15) {
			fprintf(stderr, "%s: %s:%zu: expected 15 numbers\n", tool, path, lineno);
			goto fail;
		}
		if (len == cap) {
			struct bench_row *nr;

			cap = cap ? 2 * cap : 1024;
			nr = realloc(rows, cap * sizeof(*rows));
			if (!nr) {
				fprintf(stderr, "%s: %s: out of memory\n", tool, path);
				goto fail;
			}
			rows = nr;
		}
		memcpy(rows[len].q, v, sizeof(rows[len].q));
		memcpy(rows[len].p, v + 8, sizeof(rows[len].p));
		memcpy(rows[len].r, v + 11, sizeof(rows[len].r));
		len++;
	}
	fclose(f);
	*out = rows;
	*n = len;
	return 0;
fail:
	fclose(f);
	free(rows);
	return -1;
}

int bench_load_limits(const char *tool, const char *path, struct arm_limits *lim)
{
	FILE *f = fopen(path, "r");
	char line[256];
	int j = 0, lineno = 0;

	if (!f) {
		fprintf(stderr, "%s: %s: %s\n", tool, path, strerror(errno));
		return -1;
	}
	while (j < ARM_DOF && fgets(line, sizeof(line), f)) {
		double lo, hi;

		lineno++;
		line[strcspn(line, "#")] = 0;
		if (strspn(line, " \t\r\n") == strlen(line))
			continue;
		if (sscanf(line, "%lf %lf", &lo, &hi) != 2 || lo > hi || lo < -180 || hi > 180) {
			fprintf(stderr, "%s: %s:%d: expected 'lo hi' in degrees, lo <= hi, in [-180, 180]\n", tool,
				path, lineno);
			fclose(f);
			return -1;
		}
		lim->lo[j] = lo * DEG2RAD;
		lim->hi[j] = hi * DEG2RAD;
		j++;
	}
	fclose(f);
	if (j != ARM_DOF) {
		fprintf(stderr, "%s: %s: %d joints, expected %d\n", tool, path, j, ARM_DOF);
		return -1;
	}
	return 0;
}

double bench_now_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return ts.tv_sec * 1e9 + ts.tv_nsec;
}

int bench_cmp_double(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;

	return x < y ? -1 : x > y;
}

double bench_wrap_deg(double a)
{
	a = fmod(a + 180.0, 360.0);
	if (a < 0)
		a += 360.0;
	return a - 180.0;
}
