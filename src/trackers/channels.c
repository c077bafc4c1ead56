// SPDX-License-Identifier: MIT
/*
 * channels.c - the checks of the network sources' per-channel keys (see
 * channels.h).
 */
#include "trackers/channels.h"

/* the per-channel keys: channels the source takes, names that are names, inputs that are ranges */
int chan_check(const struct cfg_source *cfg, const struct cfg_per *per, int n, int sensors, int flysticks, int cap,
	       const char **key, char *err, size_t errlen)
{
	for (int i = 0; i < n; i++) {
		bool fly = false;
		int ch, r[2];

		if (!per[i].key[0])
			continue;
		*key = per[i].key;
		ch = chan_index(per[i].key, flysticks >= 0, &fly);
		if (ch < 0 || ch >= (fly ? flysticks : sensors)) {
			if (fly)
				snprintf(err, errlen, "the source takes Flysticks f0 to f%d (flysticks = %d)",
					 flysticks - 1, flysticks);
			else
				snprintf(err, errlen, "the source takes channels 0 to %d (sensors = %d)", sensors - 1,
					 sensors);
			return -1;
		}
		if (!cap && !chan_valid_name(per[i].value)) {
			snprintf(err, errlen, "'%s' is not a valid sensor name (1-%d of A-Z a-z 0-9 _ - .)",
				 per[i].value, CFG_NAME_MAX - 1);
			return -1;
		}
		if (cap && !chan_range(per[i].value, cap, r)) {
			snprintf(err, errlen, "'%s' is not FIRST [COUNT] (FIRST 0 to 4095, COUNT 1 to %d)",
				 per[i].value, cap);
			return -1;
		}
	}
	{
		const struct cfg_type *d = cfg_source_type(cfg->driver);
		int ns = d->sensor_count(cfg);
		char a[CFG_NAME_MAX * 2], b[CFG_NAME_MAX * 2];

		for (int i = 0; i < ns; i++)
			for (int j = 0; j < i; j++) {
				d->sensor_name(cfg, i, a, sizeof(a));
				d->sensor_name(cfg, j, b, sizeof(b));
				if (!strcmp(a, b)) {
					*key = NULL;
					snprintf(err, errlen, "two sensors are named '%s' (sensor.N)", a);
					return -1;
				}
			}
	}
	return 0;
}
