/* SPDX-License-Identifier: MIT */
/*
 * channels.h - what the network sources (vrpn_in.c, dtrack.c) share about
 * their numbered sensors: channel (or body) N is sensor N, named "N"
 * unless "sensor.N = NAME" names it; "buttons.N" and "analog.N" give a
 * channel a device's inputs (vrpn). The keys arrive as written
 * (struct cfg_per, config.h); these helpers read and check them.
 */
#ifndef AGW_CHANNELS_H
#define AGW_CHANNELS_H

#include "config/config.h"

#include <ctype.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CHAN_MAX 16	     /* channels (vrpn) or body ids (dtrack) taken at most */
#define CHAN_MAX_FLYSTICKS 4 /* dtrack Flysticks taken at most */

/*
 * The number after a per-key's dot ("sensor.3" -> 3; with fly, "sensor.f1" -> 1 and *is_fly), or -1
 * when it is no number (or an f-number where fly is not allowed).
 */
static inline int chan_index(const char *key, bool fly, bool *is_fly)
{
	const char *d = strchr(key, '.');
	char *end;
	long n;

	if (!d)
		return -1;
	d++;
	*is_fly = fly && *d == 'f';
	if (*is_fly)
		d++;
	if (!isdigit((unsigned char)*d))
		return -1;
	n = strtol(d, &end, 10);
	return *end || n > 1000 ? -1 : (int)n;
}

/* the value of the per-key called key, or NULL */
static inline const char *chan_value(const struct cfg_per *per, int n, const char *key)
{
	for (int i = 0; i < n; i++)
		if (per[i].key[0] && !strcmp(per[i].key, key))
			return per[i].value;
	return NULL;
}

/* a sensor name as config.c takes them: 1-31 of A-Z a-z 0-9 _ - . */
static inline bool chan_valid_name(const char *s)
{
	size_t n = strlen(s);

	if (!n || n >= CFG_NAME_MAX)
		return false;
	for (; *s; s++)
		if (!isalnum((unsigned char)*s) && *s != '_' && *s != '-' && *s != '.')
			return false;
	return true;
}

/* "FIRST [COUNT]" (COUNT 1 to cap, default cap); false when not */
static inline bool chan_range(const char *v, int cap, int out[2])
{
	char *end;
	long first = strtol(v, &end, 10), count = cap;

	if (end == v || first < 0 || first > 4095)
		return false;
	while (*end == ' ' || *end == '\t')
		end++;
	if (*end) {
		char *e2;

		count = strtol(end, &e2, 10);
		while (*e2 == ' ' || *e2 == '\t')
			e2++;
		if (e2 == end || *e2)
			return false;
	}
	if (count < 1 || count > cap)
		return false;
	out[0] = (int)first;
	out[1] = (int)count;
	return true;
}

/*
 * The per-keys of one kind (sensor.N: cap 0; buttons.N, analog.N: cap = the most COUNT may be) name
 * channels 0 .. sensors-1 (and, flysticks >= 0, fN for Flysticks 0 .. flysticks-1), names are names and
 * ranges are ranges; and no two of the source's sensors share a name. 0, or -1 with err and *key to blame.
 */
int chan_check(const struct cfg_source *cfg, const struct cfg_per *per, int n, int sensors, int flysticks, int cap,
	       const char **key, char *err, size_t errlen);

#endif /* AGW_CHANNELS_H */
