// SPDX-License-Identifier: MIT
/*
 * capture.c - reads captures of raw reports (see capture.h).
 */
#include "trackers/capture.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int hexval(int c)
{
	if (c >= '0' && c <= '9')
		return c - '0';
	c = tolower(c);
	return c >= 'a' && c <= 'f' ? c - 'a' + 10 : -1;
}

static int grow(struct capture *c, size_t *cap_bytes, size_t need_bytes, int *cap_rep)
{
	if (need_bytes > *cap_bytes) {
		size_t nc = *cap_bytes ? *cap_bytes : 65536;
		uint8_t *nb;

		while (nc < need_bytes)
			nc *= 2;
		nb = realloc(c->bytes, nc);
		if (!nb)
			return -1;
		c->bytes = nb;
		*cap_bytes = nc;
	}
	if (c->n == *cap_rep) {
		int nr = *cap_rep ? 2 * *cap_rep : 1024;
		struct capture_report *r = realloc(c->rep, (size_t)nr * sizeof(*r));

		if (!r)
			return -1;
		c->rep = r;
		*cap_rep = nr;
	}
	return 0;
}

int capture_parse(struct capture *c, const char *name, const char *text, char *err, size_t errlen)
{
	size_t cap_bytes = 0, used = 0;
	int cap_rep = 0, lineno = 0, untimed = 0;
	double t0 = 0;
	const char *line = text;

	memset(c, 0, sizeof(*c));
	while (*line) {
		const char *end = strchr(line, '\n'), *p = line, *stop;
		double t = -1;
		size_t len = 0;

		lineno++;
		stop = end ? end : line + strlen(line);
		while (p < stop && isspace((unsigned char)*p))
			p++;
		if (p == stop || *p == '#')
			goto next;
		/* a timestamp: the first token holds a decimal point */
		{
			const char *q = p;

			while (q < stop && !isspace((unsigned char)*q))
				q++;
			if (memchr(p, '.', (size_t)(q - p))) {
				char num[64], *e;

				if ((size_t)(q - p) >= sizeof(num))
					goto bad;
				memcpy(num, p, (size_t)(q - p));
				num[q - p] = '\0';
				t = strtod(num, &e);
				if (*e || !isfinite(t) || t < 0)
					goto bad;
				p = q;
			}
		}
		if (grow(c, &cap_bytes, used + (size_t)(stop - p) / 2 + 1, &cap_rep)) {
			snprintf(err, errlen, "%s: out of memory", name);
			goto fail;
		}
		while (p < stop) {
			int hi, lo;

			if (isspace((unsigned char)*p)) {
				p++;
				continue;
			}
			if (p + 1 >= stop || (hi = hexval(p[0])) < 0 || (lo = hexval(p[1])) < 0)
				goto bad;
			if (len == CAPTURE_MAX_REPORT) {
				snprintf(err, errlen, "%s:%d: a report longer than %d bytes", name, lineno,
					 CAPTURE_MAX_REPORT);
				goto fail;
			}
			c->bytes[used + len++] = (uint8_t)(hi << 4 | lo);
			p += 2;
		}
		if (!len)
			goto bad;
		if (t >= 0) {
			if (c->n - untimed == 0)
				t0 = t;
			t -= t0;
			if (c->n && c->rep[c->n - 1].t > t) {
				snprintf(err, errlen, "%s:%d: timestamp goes back in time", name, lineno);
				goto fail;
			}
		} else {
			untimed++;
		}
		c->rep[c->n++] = (struct capture_report){ t, (uint32_t)used, (uint16_t)len, (uint32_t)lineno };
		used += len;
	next:
		if (!end)
			break;
		line = end + 1;
	}
	if (!c->n) {
		snprintf(err, errlen, "%s: no report in the capture", name);
		goto fail;
	}
	if (untimed && untimed != c->n) {
		snprintf(err, errlen, "%s: some reports have a timestamp and others not", name);
		goto fail;
	}
	c->timed = !untimed;
	return 0;
bad:
	snprintf(err, errlen, "%s:%d: not a report (hex bytes, optionally after a timestamp in seconds)", name, lineno);
fail:
	capture_free(c);
	return -1;
}

int capture_load(struct capture *c, const char *path, char *err, size_t errlen)
{
	FILE *f = fopen(path, "r");
	char *text = NULL;
	size_t len = 0, cap = 0, got;
	int rc;

	memset(c, 0, sizeof(*c));
	if (!f) {
		snprintf(err, errlen, "capture %s: %s", path, strerror(errno));
		return -1;
	}
	do {
		if (len + 65536 + 1 > cap) {
			char *n = realloc(text, cap = cap ? 2 * cap : 262144);

			if (!n) {
				free(text);
				fclose(f);
				snprintf(err, errlen, "capture %s: out of memory", path);
				return -1;
			}
			text = n;
		}
		got = fread(text + len, 1, 65536, f);
		len += got;
	} while (got == 65536);
	fclose(f);
	text[len] = '\0';
	if (strlen(text) != len) {
		free(text);
		snprintf(err, errlen, "capture %s: not a text file (NUL byte)", path);
		return -1;
	}
	rc = capture_parse(c, path, text, err, errlen);
	free(text);
	return rc;
}

void capture_free(struct capture *c)
{
	free(c->bytes);
	free(c->rep);
	memset(c, 0, sizeof(*c));
}
